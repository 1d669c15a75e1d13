//! The tire as a hybrid system, for an importer that integrates it with its own solver
//! (FMI Model Exchange): a continuous state vector in one fixed layout, its rates in the
//! current modes, the guards where a mode ends, and the update at an event. The exact
//! Co-Simulation step ([`Tire::step`]) solves the same system.
//!
//! - **Continuous states**: the model's states in [`MAX_STATES`] slots (those a model
//!   lacks stay zero, with rate zero), then the offset `b_i - U` of branch `i` of each
//!   direction's element ([`SliderState::offsets`]), direction by direction.
//! - **Modes** (discrete states): which groups slide. Between events they hold, and the
//!   rates are smooth in the states, time and inputs; [`Tire::update_modes`] changes them.
//!   Whether the wheel is on the ground follows the load as it is set; the load's guard
//!   stops the importer's solver where it crosses zero.
//! - **Guards** ([`Tire::guards`]): one per group and branch, positive while the group
//!   keeps its mode (a sticking group inside its limit; a sliding one whose motion keeps
//!   its force on the limit) and crossing zero where it changes, half the event tolerance
//!   past the switch itself so that a group just put on its limit sits inside its new
//!   mode; then the load, crossing zero at lift-off and touchdown.

use super::{ContactMode, LIFT_OFF_RELAXATION_TIME, Tire};
use crate::physics::friction::{
    Direction, EVENT_TOLERANCE, Events, Friction, Group, InverseLimits, Limits, MAX_BRANCHES, NO_EVENT,
    SliderState,
};
use crate::physics::load::OperatingPoint;
use crate::physics::parameters::{Parameter, Parameters};
use crate::physics::signals::{Input, OutputVector};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateVector};

/// Entries of the continuous state vector.
pub const CONTINUOUS_STATES: usize = MAX_STATES + Direction::COUNT * MAX_BRANCHES;

/// Guards: every group's branches, then the load.
pub const GUARDS: usize = Group::COUNT * MAX_BRANCHES + 1;

pub type ContinuousStates = [f64; CONTINUOUS_STATES];
pub type Guards = [f64; GUARDS];

/// The rates and guards at the current point, and whether they are up to date. Kept in
/// place: the importer's next calls read them.
#[derive(Clone, Debug)]
pub struct Evaluation {
    pub(super) valid: bool,
    rates: ContinuousStates,
    guards: Guards,
    /// The load the limits below were made for (its bits; NaN's, which no input is, before
    /// the first), and the limits' inverses there
    /// ([`Friction::inverse_limits`](crate::physics::friction::Friction::inverse_limits)):
    /// a solver evaluates at one load many times.
    limits_load: u64,
    inverse_limits: Option<[f64; Direction::COUNT]>,
    limit_law: InverseLimits,
    /// While every branch sticks with its element, each group and branch's guard is
    /// `offset - weight * utilisation` in its group's utilisation, with the weights of
    /// [`Friction::together_branch_weights`] (zero where there is no such group or
    /// branch, whose offset is [`NO_GUARD`]).
    together_guard_offsets: ByBranch,
    /// The inputs (their bits) the last event update was made at (None before the first).
    decided_inputs: Option<[u64; Input::COUNT]>,
}

/// A value per group and branch.
type ByBranch = [[f64; MAX_BRANCHES]; Group::COUNT];

impl Evaluation {
    /// Nothing evaluated yet, for a tire of parameters `p` and its friction.
    pub fn new(p: &Parameters, friction: Option<&Friction>) -> Self {
        // The event value is u w - 1: group_guard(u w - 1) = group_guard(-1) - w u.
        let offsets = match friction.map(Friction::together_branch_weights) {
            Some(weights) => weights.map(|w| w.map(|w| if w > 0.0 { group_guard(-1.0) } else { NO_GUARD })),
            None => [[NO_GUARD; MAX_BRANCHES]; Group::COUNT],
        };
        Evaluation {
            valid: false,
            rates: [0.0; CONTINUOUS_STATES],
            guards: [NO_GUARD; GUARDS],
            limits_load: f64::NAN.to_bits(),
            inverse_limits: None,
            limit_law: InverseLimits::new(p),
            together_guard_offsets: offsets,
            decided_inputs: None,
        }
    }

    /// The guards while every branch sticks with its element, from each group's
    /// utilisation ([`Friction::together_utilisation`]) and its branches' weights
    /// ([`Friction::together_branch_weights`]), and of the load; the evaluation is then
    /// complete.
    #[inline]
    fn write_together_guards(&mut self, utilisation: &[f64; Group::COUNT], weights: &ByBranch, load: f64) {
        let lines = weights.iter().zip(&self.together_guard_offsets);
        for ((guards, &utilisation), (weights, offsets)) in self
            .guards
            .chunks_exact_mut(MAX_BRANCHES)
            .zip(utilisation)
            .zip(lines)
        {
            for ((guard, weight), offset) in guards.iter_mut().zip(weights).zip(offsets) {
                *guard = offset - utilisation * weight;
            }
        }
        self.guards[GUARDS - 1] = load;
        self.valid = true;
    }

    /// The guards of the groups' event values (`-inf` where there is no such group, or no
    /// events at all off the ground) and of the load; the evaluation is then complete.
    #[inline]
    fn write_guards(&mut self, events: Option<&Events>, load: f64) {
        match events {
            Some(events) => {
                for (guard, &event) in self.guards.iter_mut().zip(events.as_flattened()) {
                    // A select, not a branch: the loop stays straight.
                    *guard = if event > NO_EVENT {
                        group_guard(event)
                    } else {
                        NO_GUARD
                    };
                }
            }
            None => self.guards = [NO_GUARD; GUARDS],
        }
        self.guards[GUARDS - 1] = load;
        self.valid = true;
    }
}

/// The guard of a group or branch the tire does not have: it never crosses.
const NO_GUARD: f64 = 1.0;

/// Where branch `i` of direction `d` sits in the continuous state vector.
const fn offset_entry(d: usize, i: usize) -> usize {
    MAX_STATES + d * MAX_BRANCHES + i
}

/// For each model state count `n`, the bits kept of each state slot: all of the first
/// `n`, none of the others.
const STATE_MASKS: [[u64; MAX_STATES]; MAX_STATES + 1] = {
    let mut masks = [[0; MAX_STATES]; MAX_STATES + 1];
    let mut n = 0;
    while n <= MAX_STATES {
        let mut j = 0;
        while j < n {
            masks[n][j] = u64::MAX;
            j += 1;
        }
        n += 1;
    }
    masks
};

/// Whether every value is finite: `0 v` is zero for a finite value and NaN for any other,
/// and their sum by pairs (one chain of two-wide additions) is zero only if every one is.
#[inline]
fn all_finite(values: &ContinuousStates) -> bool {
    let pairs = values.as_chunks::<2>().0;
    let zeroed = |[a, b]: [f64; 2]| [0.0 * a, 0.0 * b];
    let sum = pairs[1..].iter().fold(zeroed(pairs[0]), |[s, t], &pair| {
        let [a, b] = zeroed(pair);
        [s + a, t + b]
    });
    sum[0] + sum[1] == 0.0
}

/// The error for states of which one is not finite.
#[cold]
#[inline(never)]
fn not_finite(z: &ContinuousStates) -> String {
    let k = z.iter().position(|v| !v.is_finite()).unwrap_or_default();
    format!("continuous state {} is {}: not finite", k + 1, z[k])
}

/// The branch offsets of the continuous states `z`, for the directions that have an
/// element.
#[cold]
#[inline(never)]
fn set_offsets(friction: &mut crate::physics::friction::Friction, z: &ContinuousStates) {
    let mut sliders = *friction.state();
    let branches = friction.branches.len();
    for (d, element) in friction.elements.iter().enumerate() {
        if element.is_some() {
            sliders.offsets[d][..branches].copy_from_slice(&z[offset_entry(d, 0)..offset_entry(d, branches)]);
        }
    }
    friction.set_state(sliders);
}

/// The guard of a group whose event value (negative while it keeps its mode) is `event`.
fn group_guard(event: f64) -> f64 {
    0.5 * EVENT_TOLERANCE - event
}

impl Tire {
    /// The continuous states: the model's, then the branch offsets.
    pub fn continuous_states(&self) -> ContinuousStates {
        let mut z = [0.0; CONTINUOUS_STATES];
        z[..MAX_STATES].copy_from_slice(self.states.as_slice());
        if let Some(friction) = &self.friction {
            z[MAX_STATES..].copy_from_slice(friction.state().offsets.as_flattened());
        }
        z
    }

    /// Sets the continuous states; the modes stay. Entries the tire does not have (states
    /// past the model's count, branches past the law's, directions without an element)
    /// are ignored. Every entry must be finite; on error nothing changes.
    pub fn set_continuous_states(&mut self, z: &ContinuousStates) -> Result<(), String> {
        if !all_finite(z) {
            return Err(not_finite(z));
        }
        // Every slot at once, those past the model's states masked to zero by a mask from
        // a table: two entries to an instruction, written as wide as the evaluation reads
        // them (a wide read of narrow writes just made waits for them to land).
        let keep = &STATE_MASKS[self.rolling.affine().states().min(MAX_STATES)];
        self.states = StateVector::from(std::array::from_fn(|j| f64::from_bits(z[j].to_bits() & keep[j])));
        if let Some(friction) = self.friction.as_mut() {
            // All offsets at once, bitwise and without a branch per entry: the usual call
            // moves none. (Entries the tire lacks, set to anything but zero, take the
            // general path, which leaves them out.)
            let moved = z[offset_entry(0, 0)..]
                .iter()
                .zip(friction.state().offsets.as_flattened())
                .fold(0, |moved, (new, old)| moved | (new.to_bits() ^ old.to_bits()));
            if moved != 0 {
                set_offsets(friction, z);
            }
        }
        self.changed();
        Ok(())
    }

    /// The rates of the continuous states in the current modes, at the current inputs.
    pub fn continuous_rates(&mut self) -> &ContinuousStates {
        &self.evaluation().rates
    }

    /// The guards at the current states and inputs, in the current modes: each group's by
    /// group and branch, then the normal load.
    pub fn guards(&mut self) -> &Guards {
        &self.evaluation().guards
    }

    /// The rates and guards, computed once per change of the states or inputs (a solver
    /// asks for both at the same point).
    fn evaluation(&mut self) -> &Evaluation {
        if !self.hybrid.valid {
            self.evaluate();
        }
        &self.hybrid
    }

    /// Writes the rates and guards at the current states and inputs.
    fn evaluate(&mut self) {
        let (x, u) = (self.states, self.driving);
        let load = self.input(Input::Fz);
        if self.contact_mode() == ContactMode::LiftedOff {
            let point = self.operating_point(self.input(Input::Vx), load);
            let system = self.lifted_off.dynamics_at(point);
            let e = &mut self.hybrid;
            e.rates = [0.0; CONTINUOUS_STATES];
            let (x_rates, offset_rates) = e.rates.split_at_mut(MAX_STATES);
            system.write_state_rates(&x, &u, x_rates.try_into().expect("the layout"));
            if let Some(friction) = &self.friction {
                for (rate, offset) in offset_rates
                    .iter_mut()
                    .zip(friction.state().offsets.as_flattened())
                {
                    *rate = -offset / LIFT_OFF_RELAXATION_TIME;
                }
            }
            e.write_guards(None, load);
            return;
        }
        // The inverse limits in hand, not read back from where they are kept.
        let mut inverse_limits = None;
        if let Some(friction) = &self.friction {
            if !friction.together() {
                return self.evaluate_modes();
            }
            let e = &mut self.hybrid;
            inverse_limits = if e.limits_load == load.to_bits() {
                e.inverse_limits
            } else {
                let made = friction.inverse_limits(&e.limit_law, load);
                (e.inverse_limits, e.limits_load) = (made, load.to_bits());
                made
            };
            if inverse_limits.is_none() {
                return self.evaluate_modes();
            }
        }
        // Every branch with its element and every limit acting: the model's own linear
        // system, its rates written where they are kept; each group's guard follows from
        // its elements' forces.
        let system = {
            let point = self.operating_point(self.input(Input::Vx), load);
            self.rolling.dynamics_at(point)
        };
        let e = &mut self.hybrid;
        e.rates = [0.0; CONTINUOUS_STATES];
        let x_rates: &mut [f64; MAX_STATES] = (&mut e.rates[..MAX_STATES]).try_into().expect("the layout");
        system.write_state_rates(&x, &u, x_rates);
        match self.friction.as_ref().zip(inverse_limits.as_ref()) {
            Some((friction, inverse)) => {
                let x: &[f64; MAX_STATES] = x.as_slice().try_into().expect("the layout");
                let utilisation = friction.together_utilisation(inverse, x, x_rates);
                e.write_together_guards(&utilisation, friction.together_branch_weights(), load);
            }
            None => e.write_guards(None, load),
        }
    }

    /// [`Tire::evaluate`] where a branch is apart from its element or slides: the law of
    /// each group in its mode. Out of line: the usual case keeps a small frame.
    #[cold]
    #[inline(never)]
    fn evaluate_modes(&mut self) {
        let (x, inputs, load) = (self.states, self.inputs, self.input(Input::Fz));
        let sliders = *self.sliders().expect("friction acts");
        let step = self
            .limited_system(&inputs, &[0.0; Input::COUNT])
            .expect("on the ground, with friction");
        let (x_rates, offset_rates, events) = step.mode_rates(&x, &sliders);
        let e = &mut self.hybrid;
        e.rates[..MAX_STATES].copy_from_slice(x_rates.as_slice());
        e.rates[MAX_STATES..].copy_from_slice(offset_rates.offsets.as_flattened());
        e.write_guards(Some(&events), load);
    }

    /// At an event: each group's mode decided anew from the states and inputs (a group on
    /// its limit whose motion pushes outward slides, with its force put on the limit; so
    /// does one the falling load left outside it; a sliding one whose motion turns inward
    /// sticks), as a step starts. Off the ground every group sticks.
    ///
    /// Returns whether the continuous states, the modes (each group's stick or slide) or the
    /// inputs (and with the load the contact) changed since the last update: the rates are
    /// then discontinuous there, and a solver that keeps a history (CVode's, for one) must
    /// start again. The first update, and the first after a restored FMU state, report a
    /// change.
    pub fn update_modes(&mut self) -> bool {
        let contact = self.contact_mode();
        let inputs = self.inputs.map(f64::to_bits);
        let inputs_changed = self.hybrid.decided_inputs.replace(inputs) != Some(inputs);
        let Some(friction) = self.friction.as_ref() else {
            return inputs_changed;
        };
        let mut sliders = *friction.state();
        let sliding_before = sliders.sliding;
        if contact == ContactMode::LiftedOff {
            sliders.sliding = SliderState::AT_REST.sliding;
            self.friction.as_mut().expect("checked above").set_state(sliders);
            return inputs_changed || sliders.sliding != sliding_before;
        }
        let before = self.continuous_states();
        let (inputs, mut x) = (self.inputs, self.states);
        let step = self
            .limited_system(&inputs, &[0.0; Input::COUNT])
            .expect("on the ground, with friction");
        step.update_modes(&mut x, &mut sliders);
        self.states = x;
        self.friction.as_mut().expect("checked above").set_state(sliders);
        self.changed();
        let after = self.continuous_states();
        let states_changed = before.iter().zip(&after).any(|(a, b)| a.to_bits() != b.to_bits());
        inputs_changed || sliders.sliding != sliding_before || states_changed
    }

    /// A typical magnitude of each continuous state: an element's state and its branch
    /// offsets, the elastic travel to its limit at the nominal load; the others 1.
    pub fn continuous_state_nominals(&self) -> ContinuousStates {
        let mut nominals = [1.0; CONTINUOUS_STATES];
        let limits = Limits::at(&self.parameters, self.parameters.get(Parameter::NominalLoad));
        let elements = self.model().contact_elements(&self.parameters);
        for (d, element) in elements.iter().enumerate() {
            let Some(element) = element else { continue };
            let travel = limits.0[d] / element.stiffness;
            if travel.is_finite() && travel > 0.0 {
                nominals[element.state] = travel;
                nominals[offset_entry(d, 0)..offset_entry(d, MAX_BRANCHES)].fill(travel);
            }
        }
        nominals
    }

    /// The directional derivative of the continuous rates and of the outputs along a
    /// change `dz` of the continuous states and `du` of the inputs, in the current modes.
    /// While no group slides the rates are linear in the states and affine in the
    /// operating point's coordinates, and so are the outputs: the result is exact. Where
    /// a group slides (or a limit shapes the outputs themselves), the law is nonlinear:
    /// a central difference along the change.
    pub fn hybrid_sensitivity(
        &mut self,
        dz: &ContinuousStates,
        du: &[f64; Input::COUNT],
    ) -> (ContinuousStates, OutputVector) {
        let sliding = self.sliders().is_some_and(SliderState::any_sliding);
        if sliding || self.limit_effect() == super::LimitEffect::OnTheOutputs {
            return self.hybrid_difference(dz, du);
        }
        let mut dq = [0.0; OperatingPoint::COORDINATES];
        for input in [Input::Vx, Input::Fz] {
            let slope = self.operating_point_slope(input);
            for (q, s) in dq.iter_mut().zip(slope) {
                *q += s * du[input as usize];
            }
        }
        let (x, u) = (self.states, self.driving);
        let mode = self.contact_mode();
        let mut dx = StateVector::zeros();
        dx.as_mut_slice().copy_from_slice(&dz[..MAX_STATES]);
        // On the ground an element's state is the weighted sum of its branches, `U + sum
        // w_i o_i` with the offsets `o_i` as the rates read them: a change of an offset
        // moves the element by `w_i` of it, and each offset relaxes apart from their mean,
        // `do_i/dt = a_kk (o_i - sum w_j o_j)`. (Off the ground each relaxes by itself.)
        if let Some(friction) = self.friction.as_ref().filter(|_| mode == ContactMode::Rolling) {
            for (d, element) in friction.elements.iter().enumerate() {
                if let Some(element) = element {
                    for (i, branch) in friction.branches.iter().enumerate() {
                        dx[element.state] += branch.stiffness_fraction * dz[offset_entry(d, i)];
                    }
                }
            }
        }
        let du_driving = Self::driving_inputs(du);
        let system = self.current_system().clone();
        let affine = match mode {
            ContactMode::Rolling => self.rolling.affine(),
            ContactMode::LiftedOff => self.lifted_off.affine(),
        };
        let mut rates = [0.0; CONTINUOUS_STATES];
        let x_rates = system.state_rates(&dx, &du_driving) + affine.rate_slope(dq, &x, &u);
        rates[..MAX_STATES].copy_from_slice(x_rates.as_slice());
        let outputs = system.outputs(&dx, &du_driving) + affine.output_slope(dq, &x, &u);
        if let Some(friction) = &self.friction {
            let offsets = &friction.state().offsets;
            for (d, element) in friction.elements.iter().enumerate() {
                let Some(element) = element else { continue };
                let k = element.state;
                let relaxation = system.a[(k, k)];
                let mean = |o: &dyn Fn(usize) -> f64| {
                    if mode == ContactMode::Rolling {
                        let weighted = friction.branches.iter().enumerate();
                        weighted.map(|(i, b)| b.stiffness_fraction * o(i)).sum::<f64>()
                    } else {
                        0.0
                    }
                };
                let change_mean = mean(&|i| dz[offset_entry(d, i)]);
                let offset_mean = mean(&|i| offsets[d][i]);
                for (i, offset) in offsets[d].iter().enumerate().take(friction.branches.len()) {
                    let entry = offset_entry(d, i);
                    rates[entry] = relaxation * (dz[entry] - change_mean);
                    if mode == ContactMode::Rolling {
                        // The relaxation rate moves with the operating point.
                        let mut apart = StateVector::zeros();
                        apart[k] = offset - offset_mean;
                        rates[entry] += affine.rate_slope(dq, &apart, &DrivingVector::zeros())[k];
                    }
                }
            }
        }
        (rates, outputs)
    }

    /// [`Tire::hybrid_sensitivity`] by a central difference along the change, each
    /// entry moved by about 1e-6 of its typical magnitude.
    fn hybrid_difference(
        &mut self,
        dz: &ContinuousStates,
        du: &[f64; Input::COUNT],
    ) -> (ContinuousStates, OutputVector) {
        let (z, inputs) = (self.continuous_states(), self.inputs);
        let nominals = self.continuous_state_nominals();
        let load_scale = self.parameters.get(Parameter::NominalLoad);
        let size = dz
            .iter()
            .zip(&nominals)
            .map(|(d, n)| (d / n).abs())
            .chain(Input::ALL.map(|i| {
                let scale = if i == Input::Fz { load_scale } else { 1.0 };
                (du[i as usize] / scale).abs()
            }))
            .fold(0.0, f64::max);
        if !(size > 0.0 && size.is_finite()) {
            return ([0.0; CONTINUOUS_STATES], OutputVector::zeros());
        }
        let delta = 1e-6 / size;
        let mut at = |sign: f64| {
            let moved_z: ContinuousStates = std::array::from_fn(|k| z[k] + sign * delta * dz[k]);
            let moved_inputs: [f64; Input::COUNT] = std::array::from_fn(|k| inputs[k] + sign * delta * du[k]);
            // Finite: a finite start moved by a bounded amount.
            let _ = self.set_continuous_states(&moved_z);
            self.set_inputs(moved_inputs);
            (*self.continuous_rates(), self.outputs())
        };
        let (plus, minus) = (at(1.0), at(-1.0));
        self.set_continuous_states(&z).expect("the states it had");
        self.set_inputs(inputs);
        let rates = std::array::from_fn(|k| (plus.0[k] - minus.0[k]) / (2.0 * delta));
        (rates, (plus.1 - minus.1) / (2.0 * delta))
    }
}
