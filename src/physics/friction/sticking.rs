//! The sticking check: whether a step in which every group sticks stays inside the
//! limits throughout, so that the exact linear step of the model stands
//! ([`Friction::sticking_step`]), with what it keeps per operating point
//! ([`Friction::prepare`]).

use super::{Direction, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::lu;
use crate::physics::math;
use crate::physics::signals::DrivingInput;
use crate::physics::state_space::{
    DrivingVector, MAX_STATES, StateMatrix, StateSpace, StateVector, by_state_count,
};
use crate::physics::stepper::{Blocks, StepKey, StepMap};

/// What the sticking check needs of an element.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct PresentElement {
    pub(super) direction: usize,
    pub(super) state: usize,
    pub(super) stiffness: f64,
    pub(super) damping: f64,
}

/// The sticking check at one operating point and step size ([`Friction::prepare`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct StickingCheck {
    /// The bits of vx, Fz and h it was made for ([`StepKey::NONE`]: not made yet).
    made_for: StepKey,
    limits: Limits,
    /// What each direction's force bound is multiplied by before it is squared into its
    /// group's sum, and each group's threshold for that sum ([`Friction::within_limits`]).
    cross: [f64; Direction::COUNT],
    thresholds: [f64; Group::COUNT],
    /// Whether the step is short against the dynamics, so that the force bound holds
    /// (`None`: not asked yet; a step that needs no force bound never asks).
    short: Option<bool>,
    /// For a step too long for one force bound: the parts it is bounded in (0: not
    /// decided yet; `usize::MAX`: too many), and the exact map of one part.
    parts: usize,
    part_map: StepMap,
    /// Whether `rows` are made: only from the second step at the same point, since a
    /// point that changes every step is cheaper to check from the system directly.
    rows_ready: bool,
    /// By present element.
    rows: [ElementRows; Direction::COUNT],
}

/// A row over the states (the first [`MAX_STATES`] entries) and the driving inputs.
type Row = [f64; MAX_STATES + DrivingInput::COUNT];

/// An element's force `force . [x, u]` and its rate `rate . [x, u] + rate_input_rates . du`
/// (the element itself is the [`PresentElement`] of the same index).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ElementRows {
    force: Row,
    rate: Row,
    rate_input_rates: [f64; DrivingInput::COUNT],
}

/// What the sticking check carries from part to part of a step: the largest bound on each
/// direction's element force (branches together), or the branch offsets (branches apart).
#[derive(Clone, Copy)]
struct PartBounds {
    worst: [f64; Direction::COUNT],
    offsets: [[f64; MAX_BRANCHES]; Direction::COUNT],
}

impl PartBounds {
    fn start(state: &SliderState) -> Self {
        Self {
            worst: [0.0; Direction::COUNT],
            offsets: state.offsets,
        }
    }
}

impl Friction {
    /// [`Friction::short_against_dynamics`] for this step, asked once per step map.
    fn short(&mut self, step: &LinearStep) -> bool {
        match self.check.short {
            Some(short) => short,
            None => {
                let short = self.short_against_dynamics(step.system, step.h);
                self.check.short = Some(short);
                short
            }
        }
    }

    /// Whether `h * fastest_rate <= MAX_STICKING_STEP`, without square roots.
    fn short_against_dynamics(&self, system: &StateSpace, h: f64) -> bool {
        let limit = MAX_STICKING_STEP / h;
        if self.fastest_slide_rate > limit {
            return false;
        }
        let (n, a) = (system.states, &system.a);
        let limit_squared = limit * limit;
        for i in 0..n {
            if a[(i, i)].abs() > limit {
                return false;
            }
            for j in 0..i {
                if (a[(i, j)] * a[(j, i)]).abs() > limit_squared {
                    return false;
                }
            }
        }
        true
    }

    /// Makes the sticking check for a step map (`made_for`: the bits of vx, Fz and h that
    /// decide it): the limits at the step's load and, from the second step at the same
    /// point, each element's force and force rate as rows over the states and inputs.
    /// (Whether the step is short against the dynamics is asked when a force bound needs
    /// it.) Kept while `made_for` does not change, so a step at a constant operating point
    /// only applies the rows.
    #[inline]
    pub fn prepare(&mut self, made_for: StepKey, system: &StateSpace, limits: impl FnOnce() -> Limits) {
        if !self.check.made_for.same_as(&made_for) {
            // The key is stored here, where it is in registers: an out-of-line copy would
            // load it whole from where it was just stored word by word, and wait.
            self.check.made_for = made_for;
            self.at_new_point(limits);
        } else if !self.check.rows_ready {
            // A second step at the same point: the rows pay off from now on.
            self.make_rows(system);
        }
        // The usual case, a step at the point of the last one with its rows made: nothing.
    }

    /// [`Friction::prepare`] at a new point: the limits at the step's load (computed here,
    /// not passed in, for the same reason as the key).
    #[inline(never)]
    fn at_new_point(&mut self, limits: impl FnOnce() -> Limits) {
        let limits = limits();
        self.check.short = None;
        self.check.limits = limits;
        // Sum over a group of (bound / limit)^2 < phi_1^2, multiplied out so that nothing
        // divides (three divisions by the limits at every new load cost DDT's step about
        // 6 ns): (bx Ly)^2 + (by Lx)^2 < (phi_1 Lx Ly)^2 for the ellipse.
        let [limit_x, limit_y, limit_yaw] = limits.0;
        let share = self.first_breakpoint;
        let [x, y, yaw] = self.present_directions;
        let (cross_x, cross_y, planar) = match (x, y) {
            (true, true) => (limit_y, limit_x, share * limit_x * limit_y),
            (true, false) => (1.0, 0.0, share * limit_x),
            (false, true) => (0.0, 1.0, share * limit_y),
            (false, false) => (0.0, 0.0, f64::INFINITY),
        };
        let yaw_threshold = if yaw { share * limit_yaw } else { f64::INFINITY };
        self.check.cross = [cross_x, cross_y, 1.0];
        self.check.thresholds = [planar * planar, yaw_threshold * yaw_threshold];
        self.check.rows_ready = false;
        self.check.parts = 0;
    }

    /// [`Friction::prepare`] at the same point for a second step: the rows.
    #[inline(never)]
    fn make_rows(&mut self, system: &StateSpace) {
        by_state_count!(system.states, N => self.prepare_rows::<N>(system));
        self.check.rows_ready = true;
    }

    /// The rows of [`Friction::prepare`] for a model of `N` states.
    fn prepare_rows<const N: usize>(&mut self, system: &StateSpace) {
        let a = system.a.fixed_view::<N, N>(0, 0);
        let b = system.b.fixed_view::<N, { DrivingInput::COUNT }>(0, 0);
        for (rows, element) in self
            .check
            .rows
            .iter_mut()
            .zip(&self.present[..self.present_count])
        {
            let (k, stiffness, damping) = (element.state, element.stiffness, element.damping);
            let (a_k, b_k) = (a.row(k), b.row(k));
            // A spring's force C U has the rate C dU/dt, dU/dt = A_k x + B_k u.
            rows.force = [0.0; MAX_STATES + DrivingInput::COUNT];
            rows.force[k] = stiffness;
            for j in 0..N {
                rows.rate[j] = stiffness * a_k[j];
            }
            for i in 0..DrivingInput::COUNT {
                rows.rate[MAX_STATES + i] = stiffness * b_k[i];
            }
            if damping == 0.0 {
                continue;
            }
            // A spring-damper's force C U + D dU/dt has the rate C dU/dt + D d2U/dt2,
            // d2U/dt2 = (A_k A) x + (A_k B) u + B_k du.
            let (second_states, second_inputs) = (a_k * a, a_k * b);
            for j in 0..N {
                rows.force[j] += damping * a_k[j];
                rows.rate[j] += damping * second_states[j];
            }
            for i in 0..DrivingInput::COUNT {
                rows.force[MAX_STATES + i] = damping * b_k[i];
                rows.rate[MAX_STATES + i] += damping * second_inputs[i];
                rows.rate_input_rates[i] = damping * b_k[i];
            }
        }
    }

    /// The limits of the step last prepared ([`Friction::prepare`]).
    pub fn limits(&self) -> Limits {
        self.check.limits
    }

    /// After an exact linear step from `start` to `end` (`transition` its map) while
    /// every group sticks, and [`Friction::prepare`] for its step map: if no branch force
    /// can have reached its limit within the step ([`force_bound`]), moves the branch
    /// offsets to the end of the step (each `b_i - U` decays with its element's
    /// relaxation) and returns true; otherwise (or if a group slides) changes nothing and
    /// returns false.
    ///
    /// While the branches move together (no offsets, the usual case) this is four dot
    /// products per element; work per branch only while they differ (after sliding).
    #[inline]
    pub fn sticking_step(&mut self, step: &LinearStep) -> bool {
        // The bound of a force over the step from its ends is trusted where the step is
        // short against the dynamics; a longer step is bounded part by part, or goes to
        // the event-locating path. (Undriven elements under held inputs are bounded
        // exactly, at any step size.)
        if !self.may_stick_throughout() {
            return false;
        }
        let held = step.held;
        if self.together && held && self.all_rigorous && !self.all_undriven {
            // Bounds that hold at any step size, from the ends of the step: exact for
            // undriven elements, enough for a lag-bounded one while its force is well inside
            // its limit. (Otherwise the bounds below, from the force rates. With every
            // element undriven those are the exact ones.)
            let utilisation: GroupUtilisation = self.rigorous_bounds_any(step);
            if utilisation.within(&self.check.thresholds) {
                return true;
            }
        }
        let exact = self.together && self.all_undriven && held;
        if !exact && !self.short(step) {
            // A passive model's forces are bounded by its energy at any step size: a
            // light load makes its relaxation too fast to bound part by part.
            if self.together
                && held
                && let Some(weights) = &self.passive_energy
            {
                let utilisation: GroupUtilisation = self.energy_bounds_any(step, weights);
                if utilisation.within(&self.check.thresholds) {
                    return true;
                }
            }
            return self.sticks_part_by_part(step, held);
        }
        if self.together {
            // The usual case, kept short: one bound per element.
            let utilisation: GroupUtilisation = self.together_bounds_any(step, held);
            return utilisation.within(&self.check.thresholds);
        }
        let mut bounds = PartBounds::start(&self.state);
        self.bound_part(step, held, &mut bounds) && self.commit(bounds)
    }

    /// Bounds the branch forces over one step (or one part of it) and adds the result to
    /// `bounds`: the largest bound on each direction's force while every branch is at its
    /// element's state, else the branch offsets at the part's end. False if a limit may be
    /// reached.
    #[inline]
    fn bound_part(&self, part: &LinearStep, held: bool, bounds: &mut PartBounds) -> bool {
        if self.together {
            let part_bounds: [f64; Direction::COUNT] = self.together_bounds_any(part, held);
            for (worst, bound) in bounds.worst.iter_mut().zip(part_bounds) {
                // NaN is kept (and refused by the limits).
                if bound.is_nan() || bound > *worst {
                    *worst = bound;
                }
            }
            return true;
        }
        match self.offset_bounds_any(part, bounds.offsets) {
            Some(offsets) => {
                bounds.offsets = offsets;
                true
            }
            None => false,
        }
    }

    /// After every part is bounded: whether the branches stick through the step, and if
    /// they differ, their offsets moved to its end.
    #[inline]
    fn commit(&mut self, bounds: PartBounds) -> bool {
        if self.together {
            return self.within_limits(bounds.worst);
        }
        let sliding = self.state.sliding;
        self.set_state(SliderState {
            offsets: bounds.offsets,
            sliding,
        });
        true
    }

    /// [`Friction::together_bounds`] where the rows are made, else
    /// [`Friction::together_bounds_direct`], sized by the model's state count.
    fn together_bounds_any<S: ForceBounds>(&self, step: &LinearStep, held: bool) -> S {
        by_state_count!(step.system.states, N => self.together_bounds_sized::<N, S>(step, held))
    }

    /// [`Friction::together_bounds_any`] for a model of `N` states (out of line: the
    /// bounds take a large frame, which a step without friction should not pay for).
    #[inline(never)]
    fn together_bounds_sized<const N: usize, S: ForceBounds>(&self, step: &LinearStep, held: bool) -> S {
        if self.check.rows_ready {
            self.together_bounds::<N, S>(step, held)
        } else {
            self.together_bounds_direct::<N, S>(step, held)
        }
    }

    /// [`Friction::rigorous_bounds`] sized by the model's state count.
    fn rigorous_bounds_any<S: ForceBounds>(&self, step: &LinearStep) -> S {
        by_state_count!(step.system.states, N => self.rigorous_bounds::<N, S>(step))
    }

    /// For [`Friction::sticking_step`] while every branch is at its element's state, with
    /// held inputs, and every element undriven or lag-bounded: bounds on the element forces
    /// that hold at any step size, from the system and the states at the ends of the step.
    ///
    /// - An undriven element's force moves monotonically: its values at the ends bound it.
    /// - A lag-bounded element's state `U` has `dU/dt = a U + g(t)` with `a <= 0` and
    ///   `|g| <= G`, G from the ends of its monotone drivers. So `|U|` stays within
    ///   `|U(0)| + G h` and within `max(|U(0)|, G / |a|)`, and its force
    ///   `C U + D dU/dt = (C + D a) U + D g` is at most `|C + D a| |U|max + D G`.
    ///   (Infinite where `a > 0`.)
    #[inline(never)]
    fn rigorous_bounds<const N: usize, S: ForceBounds>(&self, step: &LinearStep) -> S {
        let LinearStep {
            system,
            start,
            end,
            h,
            ..
        } = *step;
        let (a, b, u) = (&system.a, &system.b, step.inputs);
        // B u, and each state's largest magnitude at the ends, for every state at once.
        let inputs: [f64; N] =
            std::array::from_fn(|i| b[(i, 0)] * u[0] + b[(i, 1)] * u[1] + b[(i, 2)] * u[2]);
        let extent: [f64; N] = std::array::from_fn(|j| larger(start[j].abs(), end[j].abs()));
        let mut bounds = S::default();
        for e in 0..self.present_count.min(Direction::COUNT) {
            let element = &self.present[e];
            let (k, stiffness, damping) = (element.state.min(N - 1), element.stiffness, element.damping);
            let diagonal = a[(k, k)];
            let bound = if self.undriven[e] {
                let force = |x: f64| stiffness * x + damping * (diagonal * x + inputs[k]);
                larger(force(start[k]).abs(), force(end[k]).abs())
            } else if diagonal <= 0.0 {
                let mut drive = inputs[k].abs();
                for (j, &extent) in extent.iter().enumerate() {
                    let coupling = if j == k { 0.0 } else { a[(k, j)].abs() };
                    drive += coupling * extent;
                }
                let growing = start[k].abs() + drive * h;
                let state = if diagonal < 0.0 {
                    growing.min(larger(start[k].abs(), drive / -diagonal))
                } else {
                    growing
                };
                (stiffness + damping * diagonal).abs() * state + damping * drive
            } else {
                f64::INFINITY
            };
            bounds.put(element.direction, bound, &self.check.cross);
        }
        bounds
    }

    /// [`Friction::energy_bounds`] sized by the model's state count.
    fn energy_bounds_any<S: ForceBounds>(&self, step: &LinearStep, weights: &StateVector) -> S {
        by_state_count!(step.system.states, N => self.energy_bounds::<N, S>(step, weights))
    }

    /// For [`Friction::sticking_step`] of a passive model while every branch is at its
    /// element's state, with held inputs: bounds on the element forces that hold at any
    /// step size. About the equilibrium `x_e` (`A x_e + B u = 0`) the stored energy
    /// `E(d) = sum q_j d_j^2 / 2` of `d = x - x_e` never grows. An element force is
    /// `C U + D dU/dt = C x_e[k] + c.d` with `c_j = C [j = k] + D A_kj`, so by the
    /// Cauchy-Schwarz inequality in the energy's metric it stays within
    /// `|C x_e[k]| + sqrt(sum c_j^2 / q_j) sqrt(2 E(d(0)))` over any step. Infinite (or
    /// NaN, refused alike) without a single equilibrium (a lag at standstill) or where a
    /// force depends on a state that stores no energy.
    #[inline(never)]
    fn energy_bounds<const N: usize, S: ForceBounds>(&self, step: &LinearStep, weights: &StateVector) -> S {
        let (a, b, u) = (&step.system.a, &step.system.b, step.inputs);
        // States past the model's count (zero) solve to zero; the elimination over all
        // `N` rows, a constant, is unrolled.
        let n = step.system.states;
        let system: [[f64; N]; N] = std::array::from_fn(|i| {
            std::array::from_fn(|j| if i < n { a[(i, j)] } else { f64::from(i == j) })
        });
        let forcing: [f64; N] =
            std::array::from_fn(|i| -(b[(i, 0)] * u[0] + b[(i, 1)] * u[1] + b[(i, 2)] * u[2]));
        let equilibrium = lu::solve(system, forcing, N);
        let twice_energy = equilibrium.map_or(f64::INFINITY, |x_e| {
            (0..N)
                .map(|j| weights[j] * (step.start[j] - x_e[j]).powi(2))
                .sum()
        });
        let mut bounds = S::default();
        for element in &self.present[..self.present_count.min(Direction::COUNT)] {
            let k = element.state.min(N - 1);
            let mut metric = 0.0;
            for j in 0..N {
                let diagonal = if j == k { element.stiffness } else { 0.0 };
                let c = diagonal + element.damping * a[(k, j)];
                if c != 0.0 {
                    metric += c * c / weights[j];
                }
            }
            let centre = equilibrium.map_or(f64::INFINITY, |x_e| (element.stiffness * x_e[k]).abs());
            bounds.put(
                element.direction,
                centre + (metric * twice_energy).sqrt(),
                &self.check.cross,
            );
        }
        bounds
    }

    /// [`Friction::sticking_bounds`] sized by the model's state count: the branch offsets
    /// at the end of the step from `offsets` at its start, or `None` if a limit may be
    /// reached.
    fn offset_bounds_any(
        &self,
        step: &LinearStep,
        offsets: [[f64; MAX_BRANCHES]; Direction::COUNT],
    ) -> Option<[[f64; MAX_BRANCHES]; Direction::COUNT]> {
        by_state_count!(step.system.states, N => self.sticking_bounds::<N>(step, offsets))
    }

    /// [`Friction::sticking_step`] for a step too long for one force bound, while every
    /// group sticks: the step is cut into equal parts short against the dynamics, each
    /// part's states come from the exact map of one part, and each part is bounded (the
    /// branch offsets carried from part to part). The step itself stays the exact map of
    /// the whole step. The map of a part is made once per step map; past
    /// [`MAX_CHECK_PARTS`] parts the step goes to the event-locating path.
    fn sticks_part_by_part(&mut self, step: &LinearStep, held: bool) -> bool {
        if self.check.parts == 0 {
            let parts = (step.h * self.fastest_rate(step.system) / MAX_STICKING_STEP).ceil();
            self.check.parts = if parts <= MAX_CHECK_PARTS as f64 {
                let parts = parts.max(1.0) as usize;
                self.check
                    .part_map
                    .make(step.system, step.blocks, step.h / parts as f64);
                parts
            } else {
                usize::MAX
            };
        }
        if self.check.parts == usize::MAX {
            return false;
        }
        let (parts, map) = (self.check.parts, &self.check.part_map);
        let length = step.h / parts as f64;
        let (mut x, mut bounds) = (*step.start, PartBounds::start(&self.state));
        for i in 0..parts {
            let inputs = step.inputs + step.input_rates * (i as f64 * length);
            let next = map.advance(&x, &inputs, (!held).then_some(step.input_rates));
            let part = LinearStep {
                transition: &map.transition,
                start: &x,
                end: &next,
                inputs: &inputs,
                h: length,
                ..*step
            };
            if !self.bound_part(&part, held, &mut bounds) {
                return false;
            }
            x = next;
        }
        self.commit(bounds)
    }

    /// For [`Friction::sticking_step`] while every branch is at its element's state, from
    /// the rows: a bound on each direction's element force over the step, as a share of
    /// its first branch's limit (each branch carries `w_i` of the element force, so the
    /// first breakpoint decides).
    #[inline(always)]
    fn together_bounds<const N: usize, S: ForceBounds>(&self, step: &LinearStep, held: bool) -> S {
        let LinearStep { start, end, h, .. } = *step;
        let (u0, du, u1) = step.driving_inputs();
        let states = |row: &Row, x: &StateVector| {
            let mut sum = 0.0;
            for j in 0..N {
                sum += row[j] * x[j];
            }
            sum
        };
        let inputs = |row: &Row, u: &[f64; 3]| {
            row[MAX_STATES] * u[0] + row[MAX_STATES + 1] * u[1] + row[MAX_STATES + 2] * u[2]
        };
        // A row's input part at both ends: the same while the inputs are held.
        let input_ends = |row: &Row| {
            let first = inputs(row, &u0);
            (first, if held { first } else { inputs(row, &u1) })
        };
        let check = &self.check;
        let mut bounds = S::default();
        // By index: a zip of the three arrays costs more than their bounds checks.
        for e in 0..self.present_count.min(Direction::COUNT) {
            let (element, rows, undriven) = (&self.present[e], &check.rows[e], self.undriven[e]);
            let k = element.state;
            // A spring's force, or an undriven element's, has one state term.
            let (f0, f1) = if element.damping > 0.0 {
                let (p0, p1) = input_ends(&rows.force);
                if undriven {
                    (rows.force[k] * start[k] + p0, rows.force[k] * end[k] + p1)
                } else {
                    (states(&rows.force, start) + p0, states(&rows.force, end) + p1)
                }
            } else {
                (element.stiffness * start[k], element.stiffness * end[k])
            };
            let bound = if held && undriven {
                larger(f0.abs(), f1.abs())
            } else {
                let change = if held {
                    0.0
                } else {
                    let rates = &rows.rate_input_rates;
                    rates[0] * du[0] + rates[1] * du[1] + rates[2] * du[2]
                };
                let (p0, p1) = input_ends(&rows.rate);
                let r0 = states(&rows.rate, start) + p0 + change;
                let r1 = states(&rows.rate, end) + p1 + change;
                force_bound(f0, f1, r0, r1, h)
            };
            bounds.put(element.direction, bound, &self.check.cross);
        }
        bounds
    }

    /// [`Friction::together_bounds`] from the system itself, without the rows: the state
    /// rates at both ends, then each element's force and force rate.
    #[inline(always)]
    fn together_bounds_direct<const N: usize, S: ForceBounds>(&self, step: &LinearStep, held: bool) -> S {
        let LinearStep {
            system,
            start,
            end,
            h,
            ..
        } = *step;
        // Column-major storage: entry (i, j) at i + MAX_STATES j.
        let (a, b) = (system.a.as_slice(), system.b.as_slice());
        let (x0, x1) = (&start.as_slice()[..N], &end.as_slice()[..N]);
        let (u0, du, u1) = step.driving_inputs();
        // B u for every state at once, column by column (the columns are contiguous): at
        // the start, at the end (the same while held), and for the input rates.
        let inputs_times = |u: &[f64; 3]| -> [f64; N] {
            std::array::from_fn(|i| b[i] * u[0] + b[i + MAX_STATES] * u[1] + b[i + 2 * MAX_STATES] * u[2])
        };
        let input0 = inputs_times(&u0);
        let (input1, input_change) = if held {
            (input0, [0.0; N])
        } else {
            (inputs_times(&u1), inputs_times(&du))
        };
        let row = |i: usize, x: &[f64], input_part: f64| {
            let mut sum = input_part;
            for j in 0..N {
                sum += a[i + MAX_STATES * j] * x[j];
            }
            sum
        };
        // dx/dt at both ends, for the states the bounds below read.
        let needed = &self.rates_needed[usize::from(!held)];
        let (mut rates0, mut rates1) = ([0.0; N], [0.0; N]);
        for i in 0..N {
            if needed[i] {
                rates0[i] = row(i, x0, input0[i]);
                rates1[i] = row(i, x1, input1[i]);
            }
        }
        let mut bounds = S::default();
        for (e, element) in self.present[..self.present_count].iter().enumerate() {
            let (k, stiffness, damping) = (element.state, element.stiffness, element.damping);
            let bound = if held && self.undriven[e] {
                // Monotone between the ends; a damper's rate has only its own state's term.
                let (f0, f1) = if damping > 0.0 {
                    let (diagonal, input_part) = (a[k + MAX_STATES * k], input0[k]);
                    let force = |x: f64| stiffness * x + damping * (diagonal * x + input_part);
                    (force(x0[k]), force(x1[k]))
                } else {
                    (stiffness * x0[k], stiffness * x1[k])
                };
                larger(f0.abs(), f1.abs())
            } else if damping > 0.0 {
                // The damper's force rate needs the states' second derivatives.
                let change = input_change[k];
                force_bound(
                    stiffness * x0[k] + damping * rates0[k],
                    stiffness * x1[k] + damping * rates1[k],
                    stiffness * rates0[k] + damping * row(k, &rates0, change),
                    stiffness * rates1[k] + damping * row(k, &rates1, change),
                    h,
                )
            } else {
                force_bound(
                    stiffness * x0[k],
                    stiffness * x1[k],
                    stiffness * rates0[k],
                    stiffness * rates1[k],
                    h,
                )
            };
            bounds.put(element.direction, bound, &self.check.cross);
        }
        bounds
    }

    /// Whether every group's first branches stay inside their limits, given a bound on each
    /// direction's element force (zero for a direction the model does not have): each
    /// branch carries `w_i` of the element force, so the first breakpoint `phi_1` decides,
    /// `sum over the group (bound / limit)^2 < phi_1^2` (multiplied out as made at the
    /// step map's point). Refused for NaN and for a zero limit of a direction the model
    /// has.
    fn within_limits(&self, bounds: [f64; Direction::COUNT]) -> bool {
        let mut sums = GroupUtilisation::default();
        for (d, &bound) in bounds.iter().enumerate() {
            sums.put(d, bound, &self.check.cross);
        }
        sums.within(&self.check.thresholds)
    }

    /// The body of [`Friction::sticking_step`] while branches differ, for a model of `N`
    /// states (sized loops): the branch offsets at the end of the step from `offsets` at
    /// its start, or `None` if a limit may be reached.
    #[inline(never)]
    fn sticking_bounds<const N: usize>(
        &self,
        step: &LinearStep,
        offsets: [[f64; MAX_BRANCHES]; Direction::COUNT],
    ) -> Option<[[f64; MAX_BRANCHES]; Direction::COUNT]> {
        let limits = &self.check.limits;
        let LinearStep {
            system,
            transition,
            start,
            end,
            h,
            ..
        } = *step;
        let (u0, du, u1) = step.driving_inputs();
        // Row k of A x + B u over the N states.
        let rate = |x: &[f64; MAX_STATES], u: &[f64; 3], k: usize| {
            let mut rate = system.b[(k, 0)] * u[0] + system.b[(k, 1)] * u[1] + system.b[(k, 2)] * u[2];
            for (j, xj) in x.iter().enumerate().take(N) {
                rate += system.a[(k, j)] * xj;
            }
            rate
        };
        let (x0, x1): (&[f64; MAX_STATES], &[f64; MAX_STATES]) = (&start.data.0[0], &end.data.0[0]);
        // A damper's force needs the state rates, and its rate their rates.
        let (mut rates0, mut rates1) = ([0.0; MAX_STATES], [0.0; MAX_STATES]);
        if self.damped {
            for k in 0..N {
                rates0[k] = rate(x0, &u0, k);
                rates1[k] = rate(x1, &u1, k);
            }
        }
        let mut offsets = offsets;
        // Per direction: a bound on max_i |F_i| / phi_i over the step, F_i the force of
        // branch i. Branch i holds if sum_d (F_i,d / (phi_i L_d))^2 < 1.
        let mut scaled_bound = [0.0; Direction::COUNT];
        for element in &self.present[..self.present_count] {
            let (d, k) = (element.direction, element.state);
            let (stiffness, damping) = (element.stiffness, element.damping);
            // The element force C U + D dU/dt and its rate, at both ends.
            let (f0, r0, f1, r1) = if damping > 0.0 {
                (
                    stiffness * x0[k] + damping * rates0[k],
                    stiffness * rates0[k] + damping * rate(&rates0, &du, k),
                    stiffness * x1[k] + damping * rates1[k],
                    stiffness * rates1[k] + damping * rate(&rates1, &du, k),
                )
            } else {
                (
                    stiffness * x0[k],
                    stiffness * rate(x0, &u0, k),
                    stiffness * x1[k],
                    stiffness * rate(x1, &u1, k),
                )
            };
            let branch_offsets = &mut offsets[d][..self.branches.len()];
            if branch_offsets.iter().all(|&o| o == 0.0) {
                // Every branch carries w_i of the element force; the largest w_i / phi_i
                // is that of the first breakpoint.
                scaled_bound[d] = force_bound(f0, f1, r0, r1, h) * self.inverse_first_breakpoint;
                continue;
            }
            // Branches differ by offsets that relax at the element's rate.
            let relaxation = system.a[(k, k)];
            let decay = if decoupled(system, k) {
                transition[(k, k)]
            } else {
                math::exp(relaxation * h)
            };
            let offset_force = stiffness + damping * relaxation;
            // An offset far below the rounding of the limit deflection is gone.
            let negligible = 1e-15 * limits.0[d] / stiffness;
            for (offset, branch) in branch_offsets.iter_mut().zip(self.branches) {
                let (offset0, offset1) = (*offset, *offset * decay);
                let bound = force_bound(
                    f0 + offset_force * offset0,
                    f1 + offset_force * offset1,
                    r0 + offset_force * relaxation * offset0,
                    r1 + offset_force * relaxation * offset1,
                    h,
                );
                let scaled = bound / branch.breakpoint();
                if scaled > scaled_bound[d] {
                    scaled_bound[d] = scaled;
                }
                *offset = if offset1.abs() <= negligible { 0.0 } else { offset1 };
            }
        }
        for directions in &self.group_members {
            let mut utilisation = 0.0;
            for (d, &member) in directions.iter().enumerate() {
                if member {
                    let ratio = scaled_bound[d] / limits.0[d];
                    utilisation += ratio * ratio;
                }
            }
            // Also refused for NaN (a zero limit).
            if utilisation.partial_cmp(&1.0) != Some(std::cmp::Ordering::Less) {
                return None;
            }
        }
        Some(offsets)
    }
}

/// Where the sticking check puts each direction's force bound.
trait ForceBounds: Default {
    /// The bound on the element force in `direction`; `cross` is the check's
    /// [`StickingCheck::cross`].
    fn put(&mut self, direction: usize, bound: f64, cross: &[f64; Direction::COUNT]);
}

/// Every direction's bound (zero for a direction the model does not have).
impl ForceBounds for [f64; Direction::COUNT] {
    fn put(&mut self, direction: usize, bound: f64, _cross: &[f64; Direction::COUNT]) {
        self[direction] = bound;
    }
}

/// The groups' sums for [`Friction::within_limits`], summed as the bounds come: two
/// numbers that stay in registers (an array of bounds written by direction and read back
/// at once would live in memory, and its reads wait on its writes).
#[derive(Default)]
struct GroupUtilisation {
    planar: f64,
    yaw: f64,
}

impl ForceBounds for GroupUtilisation {
    #[inline(always)]
    fn put(&mut self, direction: usize, bound: f64, cross: &[f64; Direction::COUNT]) {
        let term = bound * cross[direction];
        if direction == Direction::Yaw as usize {
            self.yaw += term * term;
        } else {
            self.planar += term * term;
        }
    }
}

impl GroupUtilisation {
    /// Both sums below their thresholds (false for NaN).
    fn within(&self, thresholds: &[f64; Group::COUNT]) -> bool {
        self.planar < thresholds[0] && self.yaw < thresholds[1]
    }
}

/// The longest step, in units of the fastest time constant, that the sticking check
/// takes on its own ([`Friction::sticking_step`]).
const MAX_STICKING_STEP: f64 = 0.5;

/// The most parts a long sticking step is bounded in ([`Friction::sticks_part_by_part`]).
const MAX_CHECK_PARTS: usize = 256;

/// An exact linear step just made, for the sticking check: the system and its step map's
/// transition, the states at both ends, and the driving inputs with their rates.
#[derive(Clone, Copy)]
pub struct LinearStep<'a> {
    pub system: &'a StateSpace,
    /// The system's decoupled blocks (to make a step map of part of the step).
    pub blocks: &'a Blocks,
    pub transition: &'a StateMatrix,
    pub start: &'a StateVector,
    pub end: &'a StateVector,
    pub inputs: &'a DrivingVector,
    pub input_rates: &'a DrivingVector,
    /// Whether `input_rates` are all zero.
    pub held: bool,
    pub h: f64,
}

impl LinearStep<'_> {
    /// The driving inputs at the start, their rates, and the inputs at the end.
    fn driving_inputs(&self) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (u0, du) = (self.inputs, self.input_rates);
        let u1 = [
            u0[0] + self.h * du[0],
            u0[1] + self.h * du[1],
            u0[2] + self.h * du[2],
        ];
        ([u0[0], u0[1], u0[2]], [du[0], du[1], du[2]], u1)
    }
}

/// Whether state `k` neither drives nor is driven by the other states: then the step
/// map's diagonal entry is `e^(A_kk h)`, the decay of a branch offset. (Block-triangular is
/// enough: a zero row or column off the diagonal.)
fn decoupled(system: &StateSpace, k: usize) -> bool {
    let n = system.states;
    (0..n).all(|j| j == k || system.a[(k, j)] == 0.0) || (0..n).all(|j| j == k || system.a[(j, k)] == 0.0)
}

/// A bound on a force over a step from its values and rates at both ends. The cubic
/// through them stays within `max(|F0|, |F1|) + 4/27 h (|F0'| + |F1'|)` (the Hermite
/// basis functions of the end rates peak at 4/27); the bound uses 1/4 for a margin. A
/// step stays on the fast path only if this bound is inside the limit, so a force that
/// could have touched its limit within the step goes to [`sliding`], which locates the
/// event.
pub fn force_bound(start: f64, end: f64, start_rate: f64, end_rate: f64, h: f64) -> f64 {
    larger(start.abs(), end.abs()) + 0.25 * h * (start_rate.abs() + end_rate.abs())
}

/// The larger of two magnitudes, or NaN if the first is NaN (one comparison, where
/// `f64::max` also handles NaN in either place): a NaN bound is refused by the limits.
#[inline(always)]
fn larger(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::stepper::{AffineSystem, ContactSystem};
    use crate::physics::{FrictionLaw, Input, ModelKind, Output, Parameter, Parameters, Tire};

    /// The states of test case `case` for a model of `n` states.
    fn test_states(case: usize, n: usize) -> StateVector {
        StateVector::from_fn(|i, _| {
            if i < n {
                2e-3 * (1.3 * (i + case) as f64).sin()
            } else {
                0.0
            }
        })
    }

    /// Held steps of each of `lengths` from test case `case` (its states, and inputs of
    /// its own): for each step its length, the bounds `bound` gives for it, and the largest
    /// magnitude of each direction's element force at 401 points of the exact solution.
    fn held_steps(
        friction: &Friction,
        system: &StateSpace,
        blocks: &Blocks,
        case: usize,
        lengths: &[f64],
        bound: impl Fn(&LinearStep) -> [f64; Direction::COUNT],
    ) -> Vec<(f64, [f64; Direction::COUNT], [f64; Direction::COUNT])> {
        let x0 = test_states(case, system.states);
        let u = DrivingVector::new(
            0.4 * (case as f64 - 1.5),
            0.3 - 0.2 * case as f64,
            -0.1 * case as f64,
        );
        let mut steps = Vec::new();
        for &h in lengths {
            let map = StepMap::new(system, blocks, h);
            let x1 = map.advance(&x0, &u, None);
            let step = LinearStep {
                system,
                blocks,
                transition: &map.transition,
                start: &x0,
                end: &x1,
                inputs: &u,
                input_rates: &DrivingVector::zeros(),
                held: true,
                h,
            };
            let mut largest = [0.0_f64; Direction::COUNT];
            for i in 0..=400 {
                let t = h * f64::from(i) / 400.0;
                let x = StepMap::new(system, blocks, t).advance(&x0, &u, None);
                let rates = system.state_rates(&x, &u);
                for element in &friction.present[..friction.present_count] {
                    let k = element.state;
                    let force = element.stiffness * x[k] + element.damping * rates[k];
                    largest[element.direction] = largest[element.direction].max(force.abs());
                }
            }
            steps.push((h, bound(&step), largest));
        }
        steps
    }

    /// After a slide the branches differ by offsets. A long step with every group
    /// sticking carries them part by part and agrees with short steps.
    #[test]
    fn long_steps_after_a_slide_agree_with_short_ones() {
        for model in [ModelKind::SecondOrder, ModelKind::RingBody] {
            let parameters = Parameters::default()
                .with_model(model)
                .with_friction(FrictionLaw::Brush);
            let fmax = parameters.get(Parameter::LateralFriction) * parameters.get(Parameter::NominalLoad);
            let mut tire = Tire::new(parameters).unwrap();
            tire.set_input(Input::Vx, 1.0);
            tire.set_input(Input::Vy, 0.3);
            for _ in 0..200 {
                tire.step(1e-3).unwrap();
            }
            // Rolling on without slip: the forces and the offsets relax, inside the limits.
            tire.set_input(Input::Vx, 5.0);
            tire.set_input(Input::Vy, 0.0);
            for _ in 0..300 {
                tire.step(1e-3).unwrap();
            }
            let sliders = tire.sliders().unwrap();
            assert!(!sliders.any_sliding(), "{model:?}: every group sticks again");
            assert!(!sliders.together(), "{model:?}: the branches keep offsets");
            let (mut short, mut long) = (tire.clone(), tire);
            for _ in 0..20 {
                short.step(1e-3).unwrap();
            }
            long.step(2e-2).unwrap();
            let (a, b) = (short.outputs(), long.outputs());
            let fy = Output::Fy as usize;
            assert!(
                (a[fy] - b[fy]).abs() <= 1e-9 * fmax,
                "{model:?}: {} against {}",
                a[fy],
                b[fy]
            );
        }
    }

    /// Steps of 2 to 20 ms, longer than the force bound takes at once for the contact-mass
    /// models, while every branch sticks: they are bounded part by part and are the exact
    /// linear steps, to the bit (the event-locating path would differ in the last digits).
    #[test]
    fn long_sticking_steps_are_the_linear_steps_to_the_bit() {
        for model in ModelKind::ALL {
            for h in [2e-3, 5e-3, 2e-2] {
                let brush = Parameters::default()
                    .with_model(model)
                    .with_friction(FrictionLaw::Brush);
                let linear = brush.clone().with_friction(FrictionLaw::Unlimited);
                let mut tires = [Tire::new(brush).unwrap(), Tire::new(linear).unwrap()];
                for k in 0..100 {
                    let t = k as f64 * h;
                    for tire in &mut tires {
                        tire.set_input(Input::Vx, 10.0);
                        tire.set_input(Input::Vy, 0.05 * t.sin());
                        tire.set_input(Input::SteerRate, 0.02 * t.cos());
                        tire.set_input(Input::Vsx, 0.005 * t.sin());
                        tire.step(h).unwrap();
                    }
                    let [brush, linear] = &mut tires;
                    assert_eq!(brush.outputs(), linear.outputs(), "{model:?}, h {h}, step {k}");
                }
            }
        }
    }

    /// The rows made once per operating point and the direct evaluation from the system
    /// bound the same forces, for every model and law, held and ramped inputs.
    #[test]
    fn rows_and_direct_evaluation_bound_the_same_forces() {
        for model in ModelKind::ALL {
            for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
                let parameters = Parameters::default().with_model(model).with_friction(law);
                let load = 0.8 * parameters.get(Parameter::NominalLoad);
                let mut tire = Tire::new(parameters.clone()).unwrap();
                let system = tire.system_at(7.0, load);
                let elements = model.equations().contact_elements(&parameters);
                let coupling = system.a.map(f64::abs).transpose().data.0;
                let mut friction = Friction::new(law, elements, &coupling).unwrap();
                let contact = ContactSystem::new(AffineSystem::from_samples(|at| {
                    model.equations().system(&parameters, &at)
                }));
                let h: f64 = 1e-3;
                let key = StepKey::new(7.0, load, h);
                friction.prepare(key, &system, || Limits::at(&parameters, load));
                assert!(!friction.check.rows_ready, "rows only from the second step");
                friction.prepare(key, &system, || unreachable!("limits kept"));
                assert!(friction.check.rows_ready);
                let n = system.states;
                let state = |phase: f64| {
                    StateVector::from_fn(|i, _| {
                        if i < n {
                            1e-3 * (phase + i as f64).sin()
                        } else {
                            0.0
                        }
                    })
                };
                let (start, end) = (state(0.3), state(1.7));
                for input_rates in [DrivingVector::zeros(), DrivingVector::new(0.4, -0.2, 0.3)] {
                    let step = LinearStep {
                        system: &system,
                        blocks: contact.blocks(),
                        transition: &system.a,
                        start: &start,
                        end: &end,
                        inputs: &DrivingVector::new(0.05, -0.02, 0.01),
                        input_rates: &input_rates,
                        held: input_rates == DrivingVector::zeros(),
                        h,
                    };
                    let held = step.held;
                    let rows: [f64; Direction::COUNT] =
                        friction.together_bounds::<MAX_STATES, _>(&step, held);
                    let direct: [f64; Direction::COUNT] =
                        friction.together_bounds_direct::<MAX_STATES, _>(&step, held);
                    for d in 0..Direction::COUNT {
                        assert!(
                            (rows[d] - direct[d]).abs() <= 1e-12 * rows[d].abs().max(1e-300),
                            "{model:?} {law:?} direction {d}: {} against {}",
                            rows[d],
                            direct[d]
                        );
                        assert_eq!(rows[d] > 0.0, elements[d].is_some(), "{model:?} {law:?} {d}");
                    }
                }
            }
        }
    }

    /// The bounds that hold at any step size really bound each element force over the
    /// step: against the force on a fine grid of exact sub-steps, at standstill, slow,
    /// fast and reversing, for steps of 0.1 ms to 2 s. DDT is the model with a lag-bounded
    /// element (its lateral spring-damper, driven by the yaw lag).
    #[test]
    fn rigorous_bounds_bound_the_force_over_the_step() {
        let mut checked_lag_bounded = 0;
        for model in ModelKind::ALL {
            let parameters = Parameters::default()
                .with_model(model)
                .with_friction(FrictionLaw::Brush);
            let elements = model.equations().contact_elements(&parameters);
            let contact = ContactSystem::new(AffineSystem::from_samples(|at| {
                model.equations().system(&parameters, &at)
            }));
            let coupling = contact.affine().state_coupling();
            let friction = Friction::new(FrictionLaw::Brush, elements, &coupling).unwrap();
            if !friction.all_rigorous {
                continue;
            }
            let nominal = parameters.get(Parameter::NominalLoad);
            for (case, &(vx, load)) in [
                (0.0, nominal),
                (0.3, 0.5 * nominal),
                (12.0, nominal),
                (-25.0, 1.4 * nominal),
            ]
            .iter()
            .enumerate()
            {
                let mut tire = Tire::new(parameters.clone()).unwrap();
                let system = tire.system_at(vx, load);
                let lengths = [1e-4, 1e-3, 0.02, 0.3, 2.0];
                let steps = held_steps(&friction, &system, contact.blocks(), case, &lengths, |step| {
                    friction.rigorous_bounds::<MAX_STATES, _>(step)
                });
                for (h, bounds, largest) in steps {
                    for (e, element) in friction.present[..friction.present_count].iter().enumerate() {
                        let d = element.direction;
                        assert!(
                            largest[d] <= bounds[d] * (1.0 + 1e-12) + 1e-12,
                            "{model:?} vx {vx} h {h} direction {d}: force {} above its bound {}",
                            largest[d],
                            bounds[d]
                        );
                        if friction.lag_bounded[e] {
                            checked_lag_bounded += 1;
                            // Useful, not just true: within 1.6 times the force over a
                            // millisecond (here the drive barely moves).
                            assert!(bounds[d].is_finite());
                            if h <= 1e-3 {
                                assert!(bounds[d] <= 1.6 * largest[d], "{model:?} vx {vx} h {h}");
                            }
                        }
                    }
                }
            }
        }
        assert!(checked_lag_bounded > 0, "no lag-bounded element was checked");
    }

    /// The models that say they are passive are: at every operating point, light loads
    /// and reversing included, `Q A + A^T Q` (Q the weights of the stored energy) has no
    /// positive eigenvalue, so the energy about the equilibrium never grows. And their
    /// energy bounds hold over steps from 0.1 ms to 10 s, at any load.
    #[test]
    fn energy_bounds_of_passive_models_bound_the_force_over_the_step() {
        use nalgebra::DMatrix;
        let mut checked = 0;
        for model in ModelKind::ALL.into_iter().filter(|m| m.equations().passive()) {
            let parameters = Parameters::default()
                .with_model(model)
                .with_friction(FrictionLaw::Brush);
            let equations = model.equations();
            let weights = equations.energy_weights(&parameters);
            let contact = ContactSystem::new(AffineSystem::from_samples(|at| {
                equations.system(&parameters, &at)
            }));
            let coupling = contact.affine().state_coupling();
            let friction = Friction::new(
                FrictionLaw::Brush,
                equations.contact_elements(&parameters),
                &coupling,
            )
            .unwrap()
            .with_passive_energy(Some(weights));
            let nominal = parameters.get(Parameter::NominalLoad);
            for (case, &(vx, load)) in [
                (0.3, 0.5 * nominal),
                (12.0, nominal),
                (-25.0, 1.4 * nominal),
                (5.0, 1e-3 * nominal),
            ]
            .iter()
            .enumerate()
            {
                let mut tire = Tire::new(parameters.clone()).unwrap();
                let system = tire.system_at(vx, load);
                let n = system.states;
                // The stored energy is the sum of squares its weights say.
                let x0 = test_states(case, n);
                let energy: f64 = (0..n).map(|j| 0.5 * weights[j] * x0[j] * x0[j]).sum();
                let stored = equations.stored_energy(&parameters, &x0);
                assert!(
                    (energy - stored).abs() <= 1e-12 * stored,
                    "{model:?}: {energy} against {stored}"
                );
                let dissipation = DMatrix::from_fn(n, n, |i, j| {
                    weights[i] * system.a[(i, j)] + system.a[(j, i)] * weights[j]
                });
                let largest = dissipation.symmetric_eigenvalues().max();
                assert!(
                    largest <= 1e-12 * dissipation.norm(),
                    "{model:?} vx {vx} Fz {load}: Q A + A^T Q has eigenvalue {largest}"
                );
                let lengths = [1e-4, 1e-3, 0.02, 0.3, 10.0];
                let steps = held_steps(&friction, &system, contact.blocks(), case, &lengths, |step| {
                    friction.energy_bounds::<MAX_STATES, _>(step, &weights)
                });
                for (h, bounds, largest) in steps {
                    for element in &friction.present[..friction.present_count] {
                        let d = element.direction;
                        assert!(bounds[d].is_finite(), "{model:?} vx {vx} h {h}: no bound");
                        assert!(
                            largest[d] <= bounds[d] * (1.0 + 1e-12) + 1e-12,
                            "{model:?} vx {vx} h {h} direction {d}: force {} above its bound {}",
                            largest[d],
                            bounds[d]
                        );
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 0, "no passive model was checked");
    }
}
