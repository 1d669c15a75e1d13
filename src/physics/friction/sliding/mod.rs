//! A step in which a branch slides, or may start to: the model's states and every branch
//! deflection integrated together, piece by piece between stick/slide events.
//!
//! Within a piece every group keeps its mode, so the right-hand side is smooth; it is
//! integrated by Gragg-Bulirsch-Stoer extrapolation (modified midpoint rule, polynomial
//! extrapolation in h^2) to a relative 1e-12. A step that explicit method cannot finish
//! (a stiff tire at a light load sliding on its ellipse turns its force within
//! microseconds, and a long step would take too many substeps) is taken again from its
//! start by linearly implicit Euler extrapolation, which is stable at any stiffness.
//! Every step the explicit method finishes is its result, unchanged. After each substep the groups' event values
//! are checked; where one crosses zero, the crossing time is found by regula falsi
//! (Illinois) on the length of the substep, the state is taken there, the group changes
//! mode, and integration goes on. A spring group that slides is kept on its ellipse to
//! rounding after every substep, so the ellipse is never exceeded.
//!
//! The result is a function of the states, inputs and step size only (nothing is carried
//! from one step to the next), so a restored FMU state continues bit-identically.
//!
//! Here: the coupled system and the loop over pieces; [`extrapolation`]: one substep;
//! [`implicit`]: one substep of a stiff piece; [`events`]: where within a substep a group
//! changes mode.

// Groups and branches index several arrays together (modes, events, offsets).
#![allow(clippy::needless_range_loop)]
mod events;
mod extrapolation;
mod implicit;

use std::cell::Cell;

use super::group::{GroupInput, GroupOutput};
use super::{Direction, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateSpace, StateVector};
use events::{EVENT_TOLERANCE, MAX_CHANGES_AT_AN_INSTANT, first_past_tolerance};

/// The model's states, then the branch deflections by direction and branch.
const SIZE: usize = MAX_STATES + Direction::COUNT * MAX_BRANCHES;
type Vector = [f64; SIZE];

fn branch_index(direction: usize, branch: usize) -> usize {
    MAX_STATES + direction * MAX_BRANCHES + branch
}

/// At most this many substeps and events per step (a safeguard: a step takes a handful).
const MAX_SUBSTEPS: usize = 50_000;

type Modes = [[bool; MAX_BRANCHES]; Group::COUNT];
type Events = [[f64; MAX_BRANCHES]; Group::COUNT];

/// The coupled system of one step: the model at its operating point with held or ramped
/// driving inputs, and its branches at the step's limits.
pub struct SlidingStep<'a> {
    pub system: &'a StateSpace,
    pub friction: &'a Friction,
    pub limits: Limits,
    pub inputs: DrivingVector,
    pub input_rates: DrivingVector,
    /// The deflection scale of the error tolerance ([`SlidingStep::deflection_scale`]).
    scale: f64,
    /// Each group and branch with its constants filled in (present directions, branch
    /// stiffness, damping and limit): what stays fixed over the step.
    templates: [[GroupInput; MAX_BRANCHES]; Group::COUNT],
    /// Whether substeps are linearly implicit ([`implicit`]): for a step the explicit
    /// method could not finish. Event location integrates by the same method as the
    /// substeps it searches.
    stiff: Cell<bool>,
}

/// Why the integration gave up (the tire is left unchanged).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotConverged;

impl<'a> SlidingStep<'a> {
    pub fn new(
        system: &'a StateSpace,
        friction: &'a Friction,
        limits: Limits,
        (inputs, input_rates): (DrivingVector, DrivingVector),
        start_scale: f64,
    ) -> Self {
        let mut templates = [[GroupInput::default(); MAX_BRANCHES]; Group::COUNT];
        for group in Group::ALL {
            for (i, branch) in friction.branches.iter().enumerate() {
                let input = &mut templates[group as usize][i];
                for &direction in group.directions() {
                    let d = direction as usize;
                    // A direction with a zero limit is left out: its branch deflection
                    // stays at zero ([`SlidingStep::prepare`] puts it there).
                    let Some(element) = friction.elements[d].filter(|_| limits.0[d] > 0.0) else {
                        continue;
                    };
                    input.present[d] = true;
                    input.stiffness[d] = branch.stiffness_fraction * element.stiffness;
                    input.damping[d] = branch.stiffness_fraction * element.damping;
                    input.limit[d] = branch.limit_fraction * limits.0[d];
                }
            }
        }
        Self {
            system,
            friction,
            limits,
            inputs,
            input_rates,
            scale: Self::deflection_scale(friction, &limits, start_scale),
            templates,
            stiff: Cell::new(false),
        }
    }

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
        let mut input = self.templates[group as usize][i];
        for &direction in group.directions() {
            let d = direction as usize;
            if !input.present[d] {
                continue;
            }
            let k = self.friction.elements[d].as_ref().expect("present").state;
            let b = z[branch_index(d, i)];
            input.deflection[d] = b;
            // The model's rate of U with b in its own relaxation term.
            input.sticking_rate[d] = x_rates[k] + self.system.a[(k, k)] * (b - x[k]);
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

    /// Integrates over `h` seconds from `x` and `sliders`; on success both hold the end
    /// of the step. Explicitly first; a step the explicit method cannot finish (a stiff
    /// slide) is taken again from its start by the linearly implicit method.
    pub fn integrate(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        self.stiff.set(false);
        if self.integrate_by_current_method(x, sliders, h).is_ok() {
            return Ok(());
        }
        self.stiff.set(true);
        self.integrate_by_current_method(x, sliders, h)
    }

    /// [`SlidingStep::integrate`] by the method [`SlidingStep::stiff`] says.
    fn integrate_by_current_method(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        let mut z = self.pack(x, sliders);
        let mut modes = sliders.sliding;
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
            // The implicit substeps are stable at any length.
            length = length.min(h - t);
            if !self.stiff.get() {
                length = length.min(longest);
            }
            let Some((mut z_end, growth, interior, spacing)) = self.substep(t, &z, length, &modes) else {
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
                && let Some(z_at) = self.substep_plain(t, &z, at, &modes)
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
                                (g, i),
                                (start_events[g][i], end_events[g][i]),
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
                        let Some(z_at) = self.substep_plain(t, &z, at, &modes) else {
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
    /// Without friction (zero limits) the states' own size at the start of the step
    /// takes its place, so that the tolerance is never far below rounding.
    fn deflection_scale(friction: &Friction, limits: &Limits, start_scale: f64) -> f64 {
        let elastic = friction
            .elements
            .iter()
            .enumerate()
            .filter_map(|(d, e)| e.map(|e| limits.0[d] / e.stiffness.max(f64::MIN_POSITIVE)))
            .fold(0.0, f64::max);
        if elastic > 0.0 {
            elastic
        } else {
            start_scale.max(1e-9)
        }
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
