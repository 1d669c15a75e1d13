//! The Co-Simulation step of a [`Tire`]: the states and inputs `h` seconds on, exactly.
//!
//! How a step is split:
//! - **The system.** The operating point (`vx` and `Fz`, at mid-step where they ramp)
//!   and the contact mode decide the system; its exact step map is made for them and
//!   the step size, or reused while they stay ([`StepKey`]). (A step that starts with a
//!   branch sliding takes the system alone: it will not stick throughout.)
//! - **Sticking.** The map advances the states; with friction, the sticking check
//!   ([`Friction::sticking_step`]) bounds every branch's force over the step, and where
//!   every one stays within its limit the step is done: the linear model's exact step.
//! - **Sliding.** Otherwise the step is taken again from its start with the branches as
//!   a hybrid system: branch by branch where each moves on its own ([`SeparableStep`]:
//!   RLT under held inputs), else (or where that gives up) all together
//!   ([`SlidingStep`]), from the modes decided at the start (or those the last step's
//!   outputs decided there, where nothing has changed since).
//! - **Lifted off**, the map of the free carcass steps the states, and the branches'
//!   offsets decay towards zero ([`LIFT_OFF_RELAXATION_TIME`]).
//! - **Outputs.** With held inputs they come from the system at hand; a step that slid
//!   with damped elements shapes their forces by their limits, and keeps what that found
//!   for the next step's start ([`Preparation`]).
//!
//! Nothing changes where a step is refused ([`StepError`]).
//!
//! [`Preparation`]: crate::physics::friction::sliding::Preparation

use std::fmt;

use super::{ContactMode, LIFT_OFF_RELAXATION_TIME, Tire, outputs_with_changes, shaped_outputs};
use crate::physics::friction::separable::SeparableStep;
use crate::physics::friction::sliding::SlidingStep;
use crate::physics::friction::{Friction, Limits, LinearStep};
use crate::physics::signals::Input;
use crate::physics::stepper::StepKey;

/// Why a step was refused; the tire is unchanged.
#[derive(Clone, Debug, PartialEq)]
pub enum StepError {
    /// The step size must be finite and > 0.
    StepSize(f64),
    /// The inputs are so large that the states would overflow.
    NotFinite,
    /// A step with sliding did not reach its accuracy.
    NotConverged,
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::StepSize(h) => write!(f, "step size {h} s is not allowed: it must be finite and > 0"),
            StepError::NotFinite => write!(
                f,
                "the states would not be finite after this step: inputs too large"
            ),
            StepError::NotConverged => write!(
                f,
                "the friction sliders did not converge within this step; try a shorter step"
            ),
        }
    }
}

impl std::error::Error for StepError {}

impl Tire {
    /// Advances the states by `h` seconds with the inputs held (or ramped at their rates),
    /// and the inputs to their values at the end of the step. On error nothing changes.
    pub fn step(&mut self, h: f64) -> Result<(), StepError> {
        if !(h > 0.0 && h <= f64::MAX) {
            return Err(StepError::StepSize(h));
        }
        let ramping = self.ramping;
        let middle = |input: Input| self.input(input) + 0.5 * h * self.input_rate(input);
        let (vx, load) = if ramping {
            (middle(Input::Vx), middle(Input::Fz))
        } else {
            (self.input(Input::Vx), self.input(Input::Fz))
        };
        let mode = ContactMode::from_load(load);
        let made_for = StepKey::new(vx, load, h);
        let fresh = self.step_made_for.same_as(&made_for);
        // The operating point only for a new map; a map in hand knows its own.
        let point = (!fresh).then(|| self.operating_point(vx, load));
        let system = match mode {
            ContactMode::Rolling => &mut self.rolling,
            ContactMode::LiftedOff => &mut self.lifted_off,
        };
        // A step that starts with a branch sliding does not stick throughout: the sliding
        // path takes it from the system at its point, and its step map is not made.
        let starts_sliding =
            mode == ContactMode::Rolling && self.friction.as_ref().is_some_and(|f| !f.may_stick_throughout());
        let (state_space, linear_map) = match point {
            Some(point) if starts_sliding => (system.at(point), None),
            _ => {
                if let Some(point) = point {
                    // Invalid until made: a refused step must not leave a half-made map behind.
                    self.step_made_for = StepKey::NONE;
                    system.make_step_map(point, h);
                }
                let (state_space, map, blocks) = system.at_step_map_point();
                (state_space, Some((map, blocks)))
            }
        };
        let map_made = linear_map.is_some();
        let (u0, du) = (&self.driving, &self.driving_rates);
        let rate = |input: Input| self.input_rates[input as usize];
        let driving_held = rate(Input::Vy) == 0.0 && rate(Input::SteerRate) == 0.0 && rate(Input::Vsx) == 0.0;
        let mut next_states = match linear_map {
            Some((map, _)) => map.advance(&self.states, u0, ramping.then_some(du)),
            None => self.states,
        };
        let finite = |values: &[f64]| values.iter().all(|v| v.is_finite());
        // States past the model's count stay zero; held inputs stay as they were set.
        if !finite(&next_states.as_slice()[..state_space.states]) {
            return Err(StepError::NotFinite);
        }
        let mut next_inputs = self.inputs;
        if ramping {
            for (value, rate) in next_inputs.iter_mut().zip(self.input_rates) {
                *value += h * rate;
            }
            if !finite(&next_inputs) {
                return Err(StepError::NotFinite);
            }
        }
        // Friction: the sticking check commits the branches only if the step stands; a
        // step with sliding works on copies until it has succeeded.
        let mut sliding = false;
        let mut shaped = None;
        let (prepared, mut preparation) = (self.prepared.take(), None);
        let friction_damped = self.friction.as_ref().is_some_and(Friction::damped);
        if let Some(friction) = self.friction.as_mut() {
            match mode {
                ContactMode::LiftedOff => friction.lift_off(h / LIFT_OFF_RELAXATION_TIME),
                ContactMode::Rolling => {
                    let parameters = &self.parameters;
                    friction.prepare(made_for, state_space, || Limits::at(parameters, load));
                    let sticks = linear_map.is_some_and(|(map, blocks)| {
                        friction.sticking_step(&LinearStep {
                            system: state_space,
                            blocks,
                            transition: &map.transition,
                            start: &self.states,
                            end: &next_states,
                            inputs: u0,
                            input_rates: du,
                            held: driving_held,
                            h,
                        })
                    });
                    if !sticks {
                        let limits = friction.limits();
                        // Each branch by itself where they move on their own (RLT under
                        // held inputs); otherwise, or if that gives up, all together.
                        // (Used where it is made: moved through options, the step's
                        // branches were copied twice.)
                        let separable = if driving_held {
                            let step = SeparableStep::new(state_space, friction, &limits, u0);
                            step.as_ref()
                                .and_then(|step| step.step(&self.states, friction.state(), h))
                        } else {
                            None
                        };
                        // The whole-system path's substeps by the pair, for the next step.
                        let (end, sliders, high_order_substeps) = match separable {
                            Some((end, sliders)) => (end, sliders, None),
                            None => {
                                let mut sliders = *friction.state();
                                let mut end = self.states;
                                let sliding_step = SlidingStep::new(
                                    state_space,
                                    friction,
                                    limits,
                                    (*u0, *du),
                                    self.states.amax(),
                                );
                                // A step from where the last one ended, with nothing
                                // changed since: its outputs decided the modes here.
                                let shaped_end = match prepared.filter(|(key, _)| key.same_as(&made_for)) {
                                    Some((_, prepared)) => {
                                        sliding_step.prepare_from(&mut sliders, &prepared);
                                        sliding_step.integrate(&mut end, &mut sliders, h)
                                    }
                                    None => sliding_step.prepare_and_integrate(&mut end, &mut sliders, h),
                                }
                                .map_err(|_| StepError::NotConverged)?;
                                // Damped forces are shaped by their limits: the outputs
                                // at the end from this step's system and limits, which
                                // are those they are otherwise made from on demand (from
                                // the step's last evaluation where that was at the end).
                                if !ramping && friction_damped {
                                    let outputs;
                                    (outputs, preparation) = match shaped_end {
                                        Some(shaped_end) => (
                                            outputs_with_changes(
                                                &sliding_step,
                                                &end,
                                                u0,
                                                &shaped_end.changes,
                                            ),
                                            Some(shaped_end.preparation),
                                        ),
                                        None => shaped_outputs(&sliding_step, &end, &sliders, u0),
                                    };
                                    shaped = Some(outputs);
                                }
                                (end, sliders, Some(sliding_step.high_order_substeps()))
                            }
                        };
                        if !finite(end.as_slice()) {
                            return Err(StepError::NotFinite);
                        }
                        next_states = end;
                        friction.set_state(sliders);
                        if let Some(lengths) = high_order_substeps {
                            friction.set_high_order_substeps(lengths);
                        }
                        sliding = true;
                    }
                }
            }
        }
        // Held inputs end the step where they started: the outputs there come from the
        // system already at hand, so compute them now rather than look it up again. A
        // step with sliding ends with every spring force within its limit at this load;
        // damped forces are shaped by their limits (made with the step that slid, or on
        // demand).
        let shaped_by_limits = sliding && friction_damped;
        self.outputs = if shaped_by_limits {
            shaped
        } else {
            (!ramping).then(|| state_space.outputs(&next_states, u0))
        };
        self.prepared = preparation.map(|preparation| (made_for, preparation));
        self.hybrid.valid = false;
        if map_made {
            self.step_made_for = made_for;
        }
        self.states = next_states;
        if ramping {
            self.inputs = next_inputs;
            self.driving = Self::driving_inputs(&next_inputs);
        }
        Ok(())
    }
}
