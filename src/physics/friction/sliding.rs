//! A step in which a branch slides, or may start to: the model's states and every branch
//! deflection integrated together, piece by piece between stick/slide events.
//!
//! Within a piece every group keeps its mode, so the right-hand side is smooth; it is
//! integrated by Gragg-Bulirsch-Stoer extrapolation (modified midpoint rule, polynomial
//! extrapolation in h^2) to a relative 1e-12. After each substep the groups' event values
//! are checked; where one crosses zero, the crossing time is found by regula falsi
//! (Illinois) on the length of the substep, the state is taken there, the group changes
//! mode, and integration goes on. A spring group that slides is kept on its ellipse to
//! rounding after every substep, so the ellipse is never exceeded.
//!
//! The result is a function of the states, inputs and step size only (nothing is carried
//! from one step to the next), so a restored FMU state continues bit-identically.

// Groups and branches index several arrays together (modes, events, offsets).
#![allow(clippy::needless_range_loop)]
use super::group::{GroupInput, GroupOutput};
use super::{Direction, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateSpace, StateVector};

/// The model's states, then the branch deflections by direction and branch.
const SIZE: usize = MAX_STATES + Direction::COUNT * MAX_BRANCHES;
type Vector = [f64; SIZE];

fn branch_index(direction: usize, branch: usize) -> usize {
    MAX_STATES + direction * MAX_BRANCHES + branch
}

/// Midpoint substep counts of the extrapolation rows.
const SEQUENCE: [usize; 8] = [2, 4, 6, 8, 10, 12, 14, 16];
/// Relative accuracy of each substep.
const TOLERANCE: f64 = 1e-12;
/// An event value above this has crossed; below it, rounding. An event is located where
/// its value crosses half of this, clear of the rounding noise around zero (a group that
/// starts on its limit sits at zero).
const EVENT_TOLERANCE: f64 = 1e-12;
/// A sampled event value above minus this is close enough to its limit that the limit
/// may be touched between samples; the accurate solution is then maximised there.
const NEAR_EVENT: f64 = 1e-3;
/// How often a group may change mode at one instant before its events wait for time to
/// move on (a motion exactly along the limit, where rounding decides).
const MAX_CHANGES_AT_AN_INSTANT: u32 = 3;
/// At most this many substeps and events per step (a safeguard: a step takes a handful).
const MAX_SUBSTEPS: usize = 200_000;

type Modes = [[bool; MAX_BRANCHES]; Group::COUNT];
type Events = [[f64; MAX_BRANCHES]; Group::COUNT];
/// A point inside a substep (time from its start) where group `g`, branch `i` is past
/// its event tolerance.
type Interior = (f64, usize, usize);

/// A peak past the tolerance of the parabola through event values at three equally
/// spaced samples `s = -1, 0, 1`: its position `s` and the group and branch.
fn peak_between(first: &Events, middle: &Events, last: &Events) -> Option<(f64, usize, usize)> {
    for g in 0..Group::COUNT {
        for i in 0..MAX_BRANCHES {
            let (e0, e1, e2) = (first[g][i], middle[g][i], last[g][i]);
            if !(e0.is_finite() && e1.is_finite() && e2.is_finite()) {
                continue;
            }
            let curvature = 0.5 * (e0 - 2.0 * e1 + e2);
            let slope = 0.5 * (e2 - e0);
            if curvature < 0.0 {
                let s = -slope / (2.0 * curvature);
                if s.abs() <= 1.0 && e1 - slope * slope / (4.0 * curvature) > EVENT_TOLERANCE {
                    return Some((s, g, i));
                }
            }
        }
    }
    None
}

/// The first group and branch whose event value is past the tolerance.
fn first_past_tolerance(events: &Events) -> Option<(usize, usize)> {
    (0..Group::COUNT)
        .flat_map(|g| (0..MAX_BRANCHES).map(move |i| (g, i)))
        .find(|&(g, i)| events[g][i] > EVENT_TOLERANCE)
}

/// The coupled system of one step: the model at its operating point with held or ramped
/// driving inputs, and its branches at the step's limits.
pub struct SlidingStep<'a> {
    pub system: &'a StateSpace,
    pub friction: &'a Friction,
    pub limits: Limits,
    pub inputs: DrivingVector,
    pub input_rates: DrivingVector,
}

/// Why the integration gave up (the tire is left unchanged).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotConverged;

impl<'a> SlidingStep<'a> {
    fn pack(&self, x: &StateVector, sliders: &SliderState) -> Vector {
        let mut z = [0.0; SIZE];
        z[..MAX_STATES].copy_from_slice(x.as_slice());
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element {
                for i in 0..self.friction.branches.len() {
                    z[branch_index(d, i)] = x[element.state] + sliders.offsets[d][i];
                }
            }
        }
        z
    }

    /// The model's states and the branch offsets of `z`.
    fn unpack(&self, z: &Vector, sliders: &mut SliderState) -> StateVector {
        let x = self.model_states(z);
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element {
                for i in 0..self.friction.branches.len() {
                    sliders.offsets[d][i] = z[branch_index(d, i)] - x[element.state];
                }
            }
        }
        x
    }

    /// `sum w_i v_i` over the branches of direction `d` in `values` (deflections or rates).
    fn weighted_over_branches(&self, values: &Vector, d: usize) -> f64 {
        self.friction
            .branches
            .iter()
            .enumerate()
            .map(|(i, b)| b.stiffness_fraction * values[branch_index(d, i)])
            .sum()
    }

    /// The model's states with each element's state the weighted sum of its branches.
    fn model_states(&self, z: &Vector) -> StateVector {
        let mut x = StateVector::from_column_slice(&z[..MAX_STATES]);
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element {
                x[element.state] = self.weighted_over_branches(z, d);
            }
        }
        x
    }

    /// One group's branch `i` at model rates `x_rates` (whose element rows hold the
    /// sticking rate of `U`). A direction with a zero limit is left out: its branch
    /// deflection stays at zero ([`SlidingStep::prepare`] puts it there).
    pub fn group_input(
        &self,
        group: Group,
        i: usize,
        x: &StateVector,
        x_rates: &StateVector,
        z: &Vector,
    ) -> GroupInput {
        let branch = self.friction.branches[i];
        let mut input = GroupInput::default();
        for &direction in group.directions() {
            let d = direction as usize;
            let Some(element) = self.friction.elements[d] else {
                continue;
            };
            if self.limits.0[d] <= 0.0 {
                continue;
            }
            let k = element.state;
            let relaxation = self.system.a[(k, k)];
            let b = z[branch_index(d, i)];
            input.present[d] = true;
            input.deflection[d] = b;
            // The model's rate of U with b in its own relaxation term.
            input.sticking_rate[d] = x_rates[k] + relaxation * (b - x[k]);
            input.stiffness[d] = branch.stiffness_fraction * element.stiffness;
            input.damping[d] = branch.stiffness_fraction * element.damping;
            input.limit[d] = branch.limit_fraction * self.limits.0[d];
        }
        input
    }

    fn inputs_at(&self, t: f64) -> DrivingVector {
        self.inputs + self.input_rates * t
    }

    /// Rates of every entry, and the groups' event values.
    fn rates(&self, t: f64, z: &Vector, modes: &Modes) -> (Vector, Events) {
        let x = self.model_states(z);
        let u = self.inputs_at(t);
        let mut x_rates = self.system.state_rates(&x, &u);
        let mut rates = [0.0; SIZE];
        let mut events = [[f64::NEG_INFINITY; MAX_BRANCHES]; Group::COUNT];
        for group in self.friction.groups() {
            for i in 0..self.friction.branches.len() {
                let out: GroupOutput = self
                    .group_input(group, i, &x, &x_rates, z)
                    .evaluate(modes[group as usize][i]);
                for &direction in group.directions() {
                    let d = direction as usize;
                    if self.friction.elements[d].is_some() {
                        rates[branch_index(d, i)] = out.rate[d];
                    }
                }
                events[group as usize][i] = out.event;
            }
        }
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element {
                x_rates[element.state] = self.weighted_over_branches(&rates, d);
            }
        }
        rates[..MAX_STATES].copy_from_slice(x_rates.as_slice());
        (rates, events)
    }

    fn events(&self, t: f64, z: &Vector, modes: &Modes) -> Events {
        self.rates(t, z, modes).1
    }

    /// The modified midpoint rule with `n` substeps over `[t, t + length]`. Also gives the
    /// first interior point (time from `t`, group, branch) where an event value is, or
    /// may be between samples, past the tolerance: a limit touched and left again within
    /// the substep shows there. Between samples, a parabola through three consecutive
    /// event values finds a peak the samples straddle. Also gives the sample closest to
    /// its limit (within [`NEAR_EVENT`]) and the sample spacing.
    #[allow(clippy::too_many_arguments)]
    fn midpoint(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        length: f64,
        n: usize,
        modes: &Modes,
    ) -> (Vector, Option<Interior>, Option<Interior>, f64) {
        let h = length / n as f64;
        let mut previous = *z;
        let mut current = *z;
        let mut interior = None;
        let mut closest: Option<(f64, usize, usize, f64)> = None;
        let mut recent = [*start_events, *start_events];
        for (c, r) in current.iter_mut().zip(start_rates) {
            *c += h * r;
        }
        for m in 1..n {
            let (rates, events) = self.rates(t + m as f64 * h, &current, modes);
            if interior.is_none() {
                interior = first_past_tolerance(&events).map(|(g, i)| (m as f64 * h, g, i));
            }
            if interior.is_none() && m >= 2 {
                interior = peak_between(&recent[0], &recent[1], &events)
                    .map(|(s, g, i)| ((m as f64 - 1.0 + s) * h, g, i));
            }
            for g in 0..Group::COUNT {
                for i in 0..MAX_BRANCHES {
                    let e = events[g][i];
                    if e > -NEAR_EVENT && closest.is_none_or(|(_, _, _, best)| e > best) {
                        closest = Some((m as f64 * h, g, i, e));
                    }
                }
            }
            recent = [recent[1], events];
            let mut next = previous;
            for ((nx, r), _) in next.iter_mut().zip(&rates).zip(0..) {
                *nx += 2.0 * h * r;
            }
            previous = current;
            current = next;
        }
        let (rates, _) = self.rates(t + length, &current, modes);
        let mut out = [0.0; SIZE];
        for k in 0..SIZE {
            out[k] = 0.5 * (current[k] + previous[k] + h * rates[k]);
        }
        (out, interior, closest.map(|(at, g, i, _)| (at, g, i)), h)
    }

    /// The time in `window` (clipped to the substep) at which group `g`, branch `i` has
    /// its largest event value, if that is past the tolerance: a golden-section search on
    /// the accurate solution.
    fn touches_near(
        &self,
        t: f64,
        z: &Vector,
        modes: &Modes,
        length: f64,
        window: (f64, f64),
        (g, i): (usize, usize),
    ) -> Option<f64> {
        let scale = self.deflection_scale();
        let value = |tau: f64| {
            if tau <= 0.0 {
                return self.events(t, z, modes)[g][i];
            }
            self.substep_plain(t, z, tau, modes, scale)
                .map_or(f64::NEG_INFINITY, |z_tau| {
                    self.events(t + tau, &z_tau, modes)[g][i]
                })
        };
        const GOLDEN: f64 = 0.618_033_988_749_894_9;
        let (mut lo, mut hi) = (window.0.max(0.0), window.1.min(length));
        let mut a = hi - GOLDEN * (hi - lo);
        let mut b = lo + GOLDEN * (hi - lo);
        let (mut fa, mut fb) = (value(a), value(b));
        for _ in 0..40 {
            if fa.max(fb) > EVENT_TOLERANCE {
                break;
            }
            if hi - lo <= 1e-6 * length {
                break;
            }
            if fa > fb {
                hi = b;
                b = a;
                fb = fa;
                a = hi - GOLDEN * (hi - lo);
                fa = value(a);
            } else {
                lo = a;
                a = b;
                fa = fb;
                b = lo + GOLDEN * (hi - lo);
                fb = value(b);
            }
        }
        if fa > EVENT_TOLERANCE {
            Some(a)
        } else if fb > EVENT_TOLERANCE {
            Some(b)
        } else {
            None
        }
    }

    /// The end of an extrapolated substep, without looking inside it for events.
    fn substep_plain(&self, t: f64, z: &Vector, length: f64, modes: &Modes, scale: f64) -> Option<Vector> {
        self.extrapolate(t, z, length, modes, scale, false)
            .map(|(z, _, _, _)| z)
    }

    /// An extrapolated substep, with where a limit may have been touched inside it and
    /// the spacing of the samples that found it.
    fn substep(
        &self,
        t: f64,
        z: &Vector,
        length: f64,
        modes: &Modes,
        scale: f64,
    ) -> Option<(Vector, f64, Option<Interior>, f64)> {
        self.extrapolate(t, z, length, modes, scale, true)
    }

    /// One extrapolated substep; `None` if it did not reach the tolerance. Also returns
    /// the factor by which the next substep may grow, and the first interior point where
    /// an event value was past the tolerance (from the finest midpoint sequence).
    fn extrapolate(
        &self,
        t: f64,
        z: &Vector,
        length: f64,
        modes: &Modes,
        scale: f64,
        look_inside: bool,
    ) -> Option<(Vector, f64, Option<Interior>, f64)> {
        let (start_rates, start_events) = self.rates(t, z, modes);
        let mut table = [[0.0; SIZE]; SEQUENCE.len()];
        for j in 0..SEQUENCE.len() {
            let mut row = [[0.0; SIZE]; SEQUENCE.len()];
            let (interior, closest, spacing);
            (row[0], interior, closest, spacing) =
                self.midpoint(t, z, (&start_rates, &start_events), length, SEQUENCE[j], modes);
            for k in 1..=j {
                let ratio = (SEQUENCE[j] as f64 / SEQUENCE[j - k] as f64).powi(2) - 1.0;
                for c in 0..SIZE {
                    row[k][c] = row[k - 1][c] + (row[k - 1][c] - table[k - 1][c]) / ratio;
                }
            }
            if j >= 2 {
                let error = (0..SIZE)
                    .map(|c| {
                        (row[j][c] - row[j - 1][c]).abs()
                            / (TOLERANCE * (scale + z[c].abs().max(row[j][c].abs())))
                    })
                    .fold(0.0, f64::max);
                if error <= 1.0 {
                    // Error ~ length^(2j + 1): aim at a third of the tolerance next time.
                    let growth = 0.9 * (3.0 * error).max(1e-10).powf(-1.0 / (2 * j + 1) as f64);
                    // A sample past or close to its limit: the caller maximises the
                    // accurate event value around it.
                    let interior = if look_inside { interior.or(closest) } else { None };
                    return Some((row[j], growth.clamp(0.2, 4.0), interior, spacing));
                }
            }
            table = row;
        }
        None
    }

    /// Puts each sliding spring group back on its ellipse (it drifts by rounding).
    fn hold_on_limits(&self, z: &mut Vector, modes: &Modes) {
        let x = self.model_states(z);
        for group in self.friction.groups() {
            for i in 0..self.friction.branches.len() {
                if !modes[group as usize][i] {
                    continue;
                }
                let input = self.group_input(group, i, &x, &x, z);
                if input.damped() {
                    continue;
                }
                let utilisation = input.utilisation(&input.spring_force());
                if utilisation > 0.0 {
                    let shrink = utilisation.sqrt().recip();
                    for &direction in group.directions() {
                        let d = direction as usize;
                        if input.present[d] {
                            z[branch_index(d, i)] *= shrink;
                        }
                    }
                }
            }
        }
    }

    /// The time in `(0, length]` at which `event` of group `g`, branch `i` crosses half the
    /// event tolerance.
    #[allow(clippy::too_many_arguments)]
    fn crossing(
        &self,
        t: f64,
        z: &Vector,
        length: f64,
        modes: &Modes,
        scale: f64,
        (g, i): (usize, usize),
        start: f64,
        end: f64,
    ) -> f64 {
        let level = 0.5 * EVENT_TOLERANCE;
        let (mut lo, mut hi) = (0.0, length);
        let (mut e_lo, mut e_hi) = (start.min(level) - level, end - level);
        let mut side = 0;
        for _ in 0..80 {
            if hi - lo <= 1e-14 * length.max(f64::MIN_POSITIVE) {
                break;
            }
            let mut tau = (lo * e_hi - hi * e_lo) / (e_hi - e_lo);
            if !(tau > lo && tau < hi) {
                tau = 0.5 * (lo + hi);
            }
            let Some(z_tau) = self.substep_plain(t, z, tau, modes, scale) else {
                break;
            };
            let e = self.events(t + tau, &z_tau, modes)[g][i] - level;
            // Past the crossing by less than the event tolerance itself: as close as
            // the event is defined.
            if e > 0.0 && e <= level {
                hi = tau;
                break;
            }
            if e > 0.0 {
                hi = tau;
                e_hi = e;
                if side == 1 {
                    e_lo *= 0.5;
                }
                side = 1;
            } else {
                lo = tau;
                e_lo = e;
                if side == -1 {
                    e_hi *= 0.5;
                }
                side = -1;
            }
        }
        hi
    }

    /// Integrates over `h` seconds from `x` and `sliders`; on success both hold the end
    /// of the step.
    pub fn integrate(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        let mut z = self.pack(x, sliders);
        let mut modes = sliders.sliding;
        let scale = self.deflection_scale();
        let mut t = 0.0;
        // The midpoint rule's parasitic solution grows where a substep of the finest row
        // is long against the fastest time constant; its error estimate can then miss
        // it (near an equilibrium): substeps stay below a few time constants.
        let longest = self.longest_substep();
        let mut length = h.min(0.5 * longest);
        // Mode changes per group and branch at the current instant.
        let mut changes = [[0_u32; MAX_BRANCHES]; Group::COUNT];
        for _ in 0..MAX_SUBSTEPS {
            if t >= h {
                break;
            }
            length = length.min(h - t).min(longest);
            let Some((mut z_end, growth, interior, spacing)) = self.substep(t, &z, length, &modes, scale)
            else {
                length *= 0.25;
                if length <= 1e-15 * h {
                    return Err(NotConverged);
                }
                continue;
            };
            let start_events = self.events(t, &z, &modes);
            let mut end_events = self.events(t + length, &z_end, &modes);
            // A limit touched and left again inside the substep: end the substep at the
            // sample past the tolerance, if an accurate solution confirms it there.
            if first_past_tolerance(&end_events).is_none()
                && let Some((sample, g, i)) = interior
                && start_events[g][i] <= EVENT_TOLERANCE
                && let Some(at) = self.touches_near(
                    t,
                    &z,
                    &modes,
                    length,
                    (sample - spacing, sample + spacing),
                    (g, i),
                )
                && let Some(z_at) = self.substep_plain(t, &z, at, &modes, scale)
            {
                length = at;
                z_end = z_at;
                end_events = self.events(t + at, &z_at, &modes);
            }
            // The earliest crossing among the groups whose event value rose past zero.
            let mut first: Option<(f64, usize, usize)> = None;
            for g in 0..Group::COUNT {
                for i in 0..self.friction.branches.len() {
                    if end_events[g][i] > EVENT_TOLERANCE && changes[g][i] < MAX_CHANGES_AT_AN_INSTANT {
                        let at = if start_events[g][i] > EVENT_TOLERANCE {
                            0.0
                        } else {
                            self.crossing(
                                t,
                                &z,
                                length,
                                &modes,
                                scale,
                                (g, i),
                                start_events[g][i],
                                end_events[g][i],
                            )
                        };
                        if first.is_none_or(|(best, _, _)| at < best) {
                            first = Some((at, g, i));
                        }
                    }
                }
            }
            match first {
                None => {
                    z = z_end;
                    t += length;
                    changes = [[0; MAX_BRANCHES]; Group::COUNT];
                    self.hold_on_limits(&mut z, &modes);
                    length *= growth;
                }
                Some((at, g, i)) => {
                    if at > 0.0 {
                        let Some(z_at) = self.substep_plain(t, &z, at, &modes, scale) else {
                            return Err(NotConverged);
                        };
                        z = z_at;
                        t += at;
                        changes = [[0; MAX_BRANCHES]; Group::COUNT];
                    }
                    // On the limit before and after the change (a spring group that
                    // stops sliding sticks from the limit, not from just outside it).
                    self.hold_on_limits(&mut z, &modes);
                    modes[g][i] = !modes[g][i];
                    changes[g][i] += 1;
                    self.hold_on_limits(&mut z, &modes);
                }
            }
        }
        if t < h {
            return Err(NotConverged);
        }
        *x = self.unpack(&z, sliders);
        sliders.sliding = modes;
        Ok(())
    }

    /// A deflection typical of the elements: the largest elastic travel to a limit.
    fn deflection_scale(&self) -> f64 {
        self.friction
            .elements
            .iter()
            .enumerate()
            .filter_map(|(d, e)| e.map(|e| self.limits.0[d] / e.stiffness.max(f64::MIN_POSITIVE)))
            .fold(0.0, f64::max)
            .max(1e-9)
    }

    /// The longest substep: four of the fastest time constants (a quarter of one per
    /// midpoint step of the finest row).
    fn longest_substep(&self) -> f64 {
        let fastest = self.friction.fastest_rate(self.system);
        if fastest > 0.0 {
            4.0 / fastest
        } else {
            f64::INFINITY
        }
    }
}

impl<'a> SlidingStep<'a> {
    /// Brings the branches to the step's limits and inputs at its start: a spring force
    /// outside its limit is put on it (the load fell), and each group's mode is decided
    /// from its state. Returns true if every group sticks strictly inside its limit.
    pub fn prepare(&self, x: &mut StateVector, sliders: &mut SliderState) -> bool {
        let mut z = self.pack(x, sliders);
        let mut inside = true;
        for (d, element) in self.friction.elements.iter().enumerate() {
            if element.is_some() && self.limits.0[d] <= 0.0 {
                for i in 0..self.friction.branches.len() {
                    z[branch_index(d, i)] = 0.0;
                }
                inside = false;
            }
        }
        let states = self.model_states(&z);
        let rates = self.system.state_rates(&states, &self.inputs);
        for group in self.friction.groups() {
            for i in 0..self.friction.branches.len() {
                let input = self.group_input(group, i, &states, &rates, &z);
                let sliding = if input.damped() {
                    let utilisation = input.utilisation(&input.sticking_force());
                    inside &= utilisation < 1.0;
                    utilisation > 1.0
                } else {
                    let force = input.spring_force();
                    let utilisation = input.utilisation(&force);
                    inside &= utilisation < 1.0;
                    if utilisation > 1.0 {
                        let shrink = utilisation.sqrt().recip();
                        for &direction in group.directions() {
                            if input.present[direction as usize] {
                                z[branch_index(direction as usize, i)] *= shrink;
                            }
                        }
                    }
                    utilisation >= 1.0 - EVENT_TOLERANCE && input.outward_cosine(&force) > 0.0
                };
                sliders.sliding[group as usize][i] = sliding;
            }
        }
        *x = self.unpack(&z, sliders);
        inside
    }

    /// The change of the element forces (by direction) that the damped groups' limits
    /// make at these states and inputs: the sticking force where it is inside the limit,
    /// the closest point of the ellipse where it is not.
    pub fn damper_force_changes(&self, x: &StateVector, sliders: &SliderState) -> [f64; Direction::COUNT] {
        let z = self.pack(x, sliders);
        let states = self.model_states(&z);
        let rates = self.system.state_rates(&states, &self.inputs);
        let mut change = [0.0; Direction::COUNT];
        // A frictionless direction carries no force: its damper's share goes too.
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element
                && self.limits.0[d] <= 0.0
            {
                let k = element.state;
                change[d] -= element.stiffness * states[k] + element.damping * rates[k];
            }
        }
        for group in self.friction.groups() {
            for i in 0..self.friction.branches.len() {
                let input = self.group_input(group, i, &states, &rates, &z);
                if !input.damped() {
                    continue;
                }
                let trial = input.sticking_force();
                let utilisation = input.utilisation(&trial);
                if utilisation > 1.0 {
                    let force = input.closest_point(&trial, utilisation);
                    for d in 0..Direction::COUNT {
                        change[d] += force[d] - trial[d];
                    }
                }
            }
        }
        change
    }

    /// The rates of the model's states and of the branch offsets at these states (the
    /// state rates with the limits acting).
    pub fn rates_at(&self, x: &StateVector, sliders: &SliderState) -> (StateVector, SliderState) {
        let z = self.pack(x, sliders);
        let (rates, _) = self.rates(0.0, &z, &sliders.sliding);
        let mut offset_rates = SliderState::AT_REST;
        self.unpack(&rates, &mut offset_rates);
        (StateVector::from_column_slice(&rates[..MAX_STATES]), offset_rates)
    }
}
