//! One tire: parameters, states, inputs and outputs (with their derivatives); `step.rs`:
//! its Co-Simulation step, exact, and how it is split; [`hybrid`]: the same tire as a
//! hybrid system for an importer's solver.

pub mod hybrid;
mod step;

pub use step::StepError;

use super::friction::sliding::{LimitChanges, Preparation, SlidingStep};
use super::friction::{Friction, HighOrderSubsteps, Limits, NOT_CARRIED, SliderState};
use super::load::OperatingPoint;
use super::load::{InverseLengthFactors, LoadLaw};
use super::models::TireLagModel;
use super::parameters::{Parameter, ParameterError, Parameters};
use super::signals::{Input, OutputVector};
use super::state_space::{DrivingVector, StateSpace, StateVector};
use super::stepper::{AffineSystem, ContactSystem, StepKey};

/// How fast the deflections relax while the wheel is off the ground, s: a free carcass
/// springs back within a few hundredths of a second.
pub const LIFT_OFF_RELAXATION_TIME: f64 = 0.01;

/// How the contact patch is held. Each mode is its own linear system; the step picks the
/// mode from the inputs. (Sliding is per element, in [`super::friction`].)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ContactMode {
    /// Normal load > 0: the model's equations.
    Rolling,
    /// Normal load <= 0: forces zero, every state relaxes with [`LIFT_OFF_RELAXATION_TIME`].
    LiftedOff,
}

impl ContactMode {
    pub fn from_load(normal_load: f64) -> Self {
        if normal_load > 0.0 {
            ContactMode::Rolling
        } else {
            ContactMode::LiftedOff
        }
    }
}

/// How a friction limit shapes the outputs at the current states and inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LimitEffect {
    /// Every element sticks inside its limit: the linear model's outputs.
    None,
    /// Spring elements slide: the outputs are the linear model's function of the states,
    /// which move with the limits.
    OnTheStates,
    /// A force is put on its limit in the outputs themselves (a damper's force on its
    /// ellipse, or a load fallen below a spring's force).
    OnTheOutputs,
}

/// A tire with one of the four tire-lag models.
///
/// Inputs are held, or ramped with their rates, over a step; `step` advances the states
/// by the exact solution of the model's linear ODE. The step map is reused while the
/// operating point, the contact mode and the step size are unchanged; the outputs are
/// computed once per change of states or inputs.
#[derive(Clone, Debug)]
pub struct Tire {
    parameters: Parameters,
    load_law: LoadLaw,
    /// The load's inverse length factors last made, and the Fz bits they were made for.
    load_factors: (u64, InverseLengthFactors),
    rolling: ContactSystem,
    lifted_off: ContactSystem,
    states: StateVector,
    inputs: [f64; Input::COUNT],
    input_rates: [f64; Input::COUNT],
    /// The driving inputs of `inputs` and `input_rates`, kept with them: the step reads
    /// them where they were stored when set. (One just built, one value at a time, would
    /// stall the step's wide loads until the stores land.)
    driving: DrivingVector,
    driving_rates: DrivingVector,
    /// Whether any input rate is not zero.
    ramping: bool,
    /// What the step map of the mode last stepped in was made for ([`StepKey::NONE`]:
    /// not valid).
    step_made_for: StepKey,
    outputs: Option<OutputVector>,
    /// The continuous rates and guards ([`hybrid`]) for the current states and inputs,
    /// computed once per change of either.
    hybrid: hybrid::Evaluation,
    /// The friction sliders (`None` for the Unlimited law).
    friction: Option<Friction>,
    /// What preparing a sliding step from the current states would decide, found with
    /// the outputs of the step that ended here, and the step it was found for: valid
    /// until the states or inputs change, as the outputs are.
    prepared: Option<(StepKey, Preparation)>,
}

impl Tire {
    /// A tire at rest (all states zero), standing still with its nominal load.
    pub fn new(parameters: Parameters) -> Result<Self, ParameterError> {
        parameters.validate()?;
        let model = parameters.model.equations();
        let affine = AffineSystem::from_samples(|at| model.system(&parameters, &at));
        let lifted_off = ContactSystem::new(affine.lifted_off(LIFT_OFF_RELAXATION_TIME));
        let mut inputs = [0.0; Input::COUNT];
        inputs[Input::Fz as usize] = parameters.get(Parameter::NominalLoad);
        let load_law = LoadLaw::new(&parameters);
        let friction = Friction::new(
            parameters.friction,
            model.contact_elements(&parameters),
            &affine.state_coupling(),
        )
        .map(|f| f.with_passive_energy(model.passive().then(|| model.energy_weights(&parameters))));
        let hybrid = hybrid::Evaluation::new(&parameters, friction.as_ref());
        Ok(Self {
            load_law,
            load_factors: (0.0_f64.to_bits(), load_law.inverse_factors(0.0)),
            parameters,
            rolling: ContactSystem::new(affine),
            lifted_off,
            states: StateVector::zeros(),
            inputs,
            input_rates: [0.0; Input::COUNT],
            driving: Self::driving_inputs(&inputs),
            driving_rates: DrivingVector::zeros(),
            ramping: false,
            step_made_for: StepKey::NONE,
            outputs: None,
            hybrid,
            friction,
            prepared: None,
        })
    }

    /// The friction sliders' state (`None` for the Unlimited law).
    pub fn sliders(&self) -> Option<&SliderState> {
        self.friction.as_ref().map(|f| f.state())
    }

    /// How long the eighth-order pair's first two substeps of the next sliding step may
    /// be, s ([`HighOrderSubsteps`]; infinite for the Unlimited law).
    pub fn high_order_substeps(&self) -> HighOrderSubsteps {
        self.friction
            .as_ref()
            .map_or(NOT_CARRIED, Friction::high_order_substeps)
    }

    /// Replaces [`Tire::high_order_substeps`] (ignored for the Unlimited law).
    pub fn set_high_order_substeps(&mut self, lengths: HighOrderSubsteps) {
        if let Some(friction) = self.friction.as_mut() {
            friction.set_high_order_substeps(lengths);
        }
    }

    /// Replaces the sliders' state (after [`Tire::set_states`], which puts every branch at
    /// its element's state). The offsets must be finite.
    pub fn set_sliders(&mut self, sliders: &SliderState) -> Result<(), String> {
        let Some(friction) = self.friction.as_mut() else {
            return Err("the Unlimited law has no friction sliders".into());
        };
        if let Some(bad) = sliders.offsets.iter().flatten().find(|v| !v.is_finite()) {
            return Err(format!("branch offset {bad} is not finite"));
        }
        friction.set_state(*sliders);
        self.changed();
        Ok(())
    }

    /// The states or inputs changed: what was derived from them is computed anew.
    fn changed(&mut self) {
        self.outputs = None;
        self.prepared = None;
        self.hybrid.valid = false;
    }

    pub fn parameters(&self) -> &Parameters {
        &self.parameters
    }

    fn model(&self) -> &'static dyn TireLagModel {
        self.parameters.model.equations()
    }

    pub fn state_names(&self) -> &'static [&'static str] {
        self.model().state_names()
    }

    /// The states, one per name in [`Tire::state_names`].
    pub fn states(&self) -> &[f64] {
        &self.states.as_slice()[..self.state_names().len()]
    }

    /// Replaces the states; the slice must have one finite value per state.
    pub fn set_states(&mut self, states: &[f64]) -> Result<(), String> {
        let count = self.state_names().len();
        if states.len() != count {
            return Err(format!(
                "the {} model has {count} states, got {}",
                self.parameters.model.name(),
                states.len()
            ));
        }
        if let Some(bad) = states.iter().find(|v| !v.is_finite()) {
            return Err(format!("state value {bad} is not finite"));
        }
        self.states.as_mut_slice()[..count].copy_from_slice(states);
        if let Some(friction) = self.friction.as_mut() {
            friction.reset();
        }
        self.changed();
        Ok(())
    }

    pub fn input(&self, input: Input) -> f64 {
        self.inputs[input as usize]
    }

    /// Every input, indexed by `Input as usize`.
    pub fn inputs(&self) -> [f64; Input::COUNT] {
        self.inputs
    }

    /// Sets every input at once; callers make sure they are finite.
    pub fn set_inputs(&mut self, inputs: [f64; Input::COUNT]) {
        // Bitwise, element by element (an array comparison becomes a memcmp call).
        if inputs
            .iter()
            .zip(&self.inputs)
            .any(|(a, b)| a.to_bits() != b.to_bits())
        {
            self.inputs = inputs;
            self.driving = Self::driving_inputs(&inputs);
            self.changed();
        }
    }

    /// Sets an input; callers make sure it is finite.
    pub fn set_input(&mut self, input: Input, value: f64) {
        if self.inputs[input as usize].to_bits() != value.to_bits() {
            self.inputs[input as usize] = value;
            self.driving = Self::driving_inputs(&self.inputs);
            self.changed();
        }
    }

    pub fn input_rate(&self, input: Input) -> f64 {
        self.input_rates[input as usize]
    }

    /// Sets the time derivative of an input over the coming steps. The step is exact for
    /// ramps of vy, steerRate and vsx; vx and Fz are taken at the middle of the step.
    pub fn set_input_rate(&mut self, input: Input, rate: f64) {
        self.input_rates[input as usize] = rate;
        self.driving_rates = Self::driving_inputs(&self.input_rates);
        self.ramping = self.input_rates.iter().any(|&r| r != 0.0);
    }

    pub fn contact_mode(&self) -> ContactMode {
        ContactMode::from_load(self.input(Input::Fz))
    }

    fn driving_inputs(values: &[f64; Input::COUNT]) -> DrivingVector {
        DrivingVector::new(
            values[Input::Vy as usize],
            values[Input::SteerRate as usize],
            values[Input::Vsx as usize],
        )
    }

    fn contact_system(&mut self, mode: ContactMode) -> &mut ContactSystem {
        match mode {
            ContactMode::Rolling => &mut self.rolling,
            ContactMode::LiftedOff => &mut self.lifted_off,
        }
    }

    /// The operating point at speed `vx` and normal load `load`. The load's factors are
    /// kept while it does not change (they cost a division); the point itself is made
    /// anew (two products), in the caller's hands: a copy of it kept here would be read
    /// back wide right after it was written narrow, which waits for the writes to land.
    fn operating_point(&mut self, vx: f64, load: f64) -> OperatingPoint {
        if load.to_bits() != self.load_factors.0 {
            let factors = self.load_law.inverse_factors(load);
            self.load_factors = (load.to_bits(), factors);
            return OperatingPoint::new(vx, factors);
        }
        OperatingPoint::new(vx, self.load_factors.1)
    }

    /// The system at the current inputs.
    fn current_system(&mut self) -> &StateSpace {
        let point = self.operating_point(self.input(Input::Vx), self.input(Input::Fz));
        let mode = self.contact_mode();
        self.contact_system(mode).at(point)
    }

    /// The system at speed `vx` and normal load `load` (for checks against other
    /// integrators).
    pub fn system_at(&mut self, vx: f64, load: f64) -> StateSpace {
        let point = self.operating_point(vx, load);
        self.contact_system(ContactMode::from_load(load))
            .at(point)
            .clone()
    }

    /// Outputs for the current states and inputs.
    pub fn outputs(&mut self) -> OutputVector {
        *self.outputs_ref()
    }

    /// Outputs for the current states and inputs, computed once per change of either.
    pub fn outputs_ref(&mut self) -> &OutputVector {
        if self.outputs.is_none() {
            let states = self.states;
            let outputs = match self.friction.as_ref().map(|f| *f.state()) {
                Some(sliders) => self.outputs_with_limits(&states, &sliders, &self.inputs.clone()),
                None => {
                    let u = Self::driving_inputs(&self.inputs);
                    self.current_system().outputs(&states, &u)
                }
            };
            self.outputs = Some(outputs);
        }
        self.outputs.as_ref().expect("computed above")
    }

    /// The friction step at these inputs, for outputs and their derivatives: `None` off
    /// the ground or without a limit.
    fn limited_system(
        &mut self,
        inputs: &[f64; Input::COUNT],
        input_rates: &[f64; Input::COUNT],
    ) -> Option<SlidingStep<'_>> {
        let (vx, load) = (inputs[Input::Vx as usize], inputs[Input::Fz as usize]);
        if self.friction.is_none() || ContactMode::from_load(load) == ContactMode::LiftedOff {
            return None;
        }
        let point = self.operating_point(vx, load);
        let limits = Limits::at(&self.parameters, load);
        Some(SlidingStep::new(
            self.rolling.at(point),
            self.friction.as_mut().expect("checked above"),
            limits,
            (Self::driving_inputs(inputs), Self::driving_inputs(input_rates)),
            self.states.amax(),
        ))
    }

    /// Outputs at given states, branches and inputs, with the friction limits at the
    /// inputs' load: a spring force beyond its limit is on it (it slides at once), and a
    /// damped force is the closest point of its ellipse.
    fn outputs_with_limits(
        &mut self,
        x: &StateVector,
        sliders: &SliderState,
        inputs: &[f64; Input::COUNT],
    ) -> OutputVector {
        let u = Self::driving_inputs(inputs);
        let Some(step) = self.limited_system(inputs, &[0.0; Input::COUNT]) else {
            let point = self.operating_point(inputs[Input::Vx as usize], inputs[Input::Fz as usize]);
            let mode = ContactMode::from_load(inputs[Input::Fz as usize]);
            return self.contact_system(mode).at(point).outputs(x, &u);
        };
        shaped_outputs(&step, x, sliders, &u).0
    }

    /// How a friction limit shapes the outputs at the current states and inputs.
    fn limit_effect(&mut self) -> LimitEffect {
        let (inputs, rates) = (self.inputs, self.input_rates);
        let (mut x, sliders) = (self.states, self.friction.as_ref().map(|f| *f.state()));
        let damped = self.friction.as_ref().is_some_and(|f| f.damped());
        match (self.limited_system(&inputs, &rates), sliders) {
            (Some(step), Some(mut sliders)) => {
                if step.prepare(&mut x, &mut sliders) {
                    LimitEffect::None
                } else if x == self.states && !(damped && sliders.any_sliding()) {
                    LimitEffect::OnTheStates
                } else {
                    LimitEffect::OnTheOutputs
                }
            }
            _ => LimitEffect::None,
        }
    }

    /// Output rates where sliding springs change only how the states move: the linear
    /// outputs' rates along the limited motion, `C dx/dt + D du/dt`.
    fn sliding_output_rates(&mut self) -> OutputVector {
        let (inputs, rates) = (self.inputs, self.input_rates);
        let (x, sliders) = (
            self.states,
            *self.friction.as_ref().expect("a limit acts").state(),
        );
        let step = self.limited_system(&inputs, &rates).expect("a limit acts");
        let (x_rates, _) = step.rates_at(&x, &sliders);
        let du = Self::driving_inputs(&rates);
        step.system.c * x_rates + step.system.d * du
    }

    /// Output rates where a limit acts: a central difference along the motion with the
    /// limits (the outputs are smooth there, piece by piece).
    fn limited_output_rates(&mut self) -> OutputVector {
        let (inputs, rates) = (self.inputs, self.input_rates);
        let mut x = self.states;
        let mut sliders = *self.friction.as_ref().expect("a limit acts").state();
        let step = self.limited_system(&inputs, &rates).expect("a limit acts");
        step.prepare(&mut x, &mut sliders);
        let (x_rates, branch_rates) = step.rates_at(&x, &sliders);
        const DT: f64 = 1e-7;
        let mut at = |sign: f64| {
            let mut moved = sliders;
            for (b, r) in moved
                .offsets
                .iter_mut()
                .flatten()
                .zip(branch_rates.offsets.iter().flatten())
            {
                *b += sign * DT * r;
            }
            let mut moved_inputs = inputs;
            for (value, rate) in moved_inputs.iter_mut().zip(rates) {
                *value += sign * DT * rate;
            }
            self.outputs_with_limits(&(x + x_rates * (sign * DT)), &moved, &moved_inputs)
        };
        (at(1.0) - at(-1.0)) / (2.0 * DT)
    }

    /// Output sensitivities where a limit acts: a central difference in the input (zero
    /// along a saturated direction).
    fn limited_output_sensitivity(&mut self, input: Input) -> OutputVector {
        let inputs = self.inputs;
        let (x, sliders) = (
            self.states,
            *self.friction.as_ref().expect("a limit acts").state(),
        );
        let value = inputs[input as usize];
        let scale = if input == Input::Fz {
            self.parameters.get(Parameter::NominalLoad)
        } else {
            1.0
        };
        let delta = 1e-6 * (value.abs() + scale);
        let mut at = |sign: f64| {
            let mut moved = inputs;
            moved[input as usize] += sign * delta;
            self.outputs_with_limits(&x, &sliders, &moved)
        };
        (at(1.0) - at(-1.0)) / (2.0 * delta)
    }

    /// Time derivatives of the outputs at the current states, inputs and input rates
    /// (exact for a constant vx and normal load).
    pub fn output_rates(&mut self) -> OutputVector {
        match self.limit_effect() {
            LimitEffect::None => {}
            LimitEffect::OnTheStates => return self.sliding_output_rates(),
            LimitEffect::OnTheOutputs => return self.limited_output_rates(),
        }
        let u = Self::driving_inputs(&self.inputs);
        let du = Self::driving_inputs(&self.input_rates);
        let states = self.states;
        self.current_system().output_rates(&states, &u, &du)
    }

    /// Partial derivatives of every output with respect to one input, at the current
    /// states and inputs. The outputs are affine in the operating point's coordinates, so
    /// the chain rule through them is exact: d|vx|/dvx is taken as 0 at vx = 0 (the value
    /// a central difference gives), and the load enters through the length factors (zero
    /// off the ground, where they are fixed).
    pub fn output_sensitivity(&mut self, input: Input) -> OutputVector {
        // Sliding springs change how the states move, not how the outputs depend on the
        // inputs: the linear sensitivities stay exact.
        if self.limit_effect() == LimitEffect::OnTheOutputs {
            return self.limited_output_sensitivity(input);
        }
        if let Some(driving) = input.driving() {
            let feedthrough = self.current_system().d.column(driving as usize);
            return OutputVector::from_iterator(feedthrough.iter().copied());
        }
        let dq = self.operating_point_slope(input);
        let u = Self::driving_inputs(&self.inputs);
        let affine = match self.contact_mode() {
            ContactMode::Rolling => self.rolling.affine(),
            ContactMode::LiftedOff => self.lifted_off.affine(),
        };
        affine.output_slope(dq, &self.states, &u)
    }

    /// How the operating point's coordinates change per unit change of `input` (vx or
    /// Fz; zero for the others): d|vx|/dvx is taken as 0 at vx = 0 (the value a central
    /// difference gives), and the load enters through the length factors.
    fn operating_point_slope(&mut self, input: Input) -> [f64; OperatingPoint::COORDINATES] {
        let (vx, load) = (self.input(Input::Vx), self.input(Input::Fz));
        let point = self.operating_point(vx, load);
        match input {
            Input::Vx => {
                let rho_per_vx = if vx > 0.0 {
                    1.0
                } else if vx < 0.0 {
                    -1.0
                } else {
                    0.0
                };
                [
                    1.0,
                    rho_per_vx * point.inverse_lateral_factor(),
                    rho_per_vx * point.inverse_longitudinal_factor(),
                    0.0,
                    0.0,
                ]
            }
            Input::Fz => {
                let slopes = self.load_law.inverse_factor_slopes(load);
                let rho = vx.abs();
                [
                    0.0,
                    rho * slopes.lateral,
                    rho * slopes.longitudinal,
                    slopes.lateral,
                    slopes.longitudinal,
                ]
            }
            _ => [0.0; OperatingPoint::COORDINATES],
        }
    }

    /// Mechanical energy stored in the tire's springs and masses, J. With friction each
    /// element's spring energy is that of its branches, `sum w_i C b_i^2 / 2`.
    pub fn stored_energy(&self) -> f64 {
        let mut energy = self.model().stored_energy(&self.parameters, &self.states);
        if let Some(friction) = &self.friction {
            for (d, element) in friction.elements.iter().enumerate() {
                let Some(element) = element else { continue };
                energy -= 0.5 * element.stiffness * self.states[element.state].powi(2);
                let u = self.states[element.state];
                for (branch, offset) in friction.branches.iter().zip(&friction.state().offsets[d]) {
                    let b = u + offset;
                    energy += 0.5 * branch.stiffness_fraction * element.stiffness * b * b;
                }
            }
        }
        energy
    }
}

/// The outputs at states `x` and branches `sliders` with `step`'s limits: a spring force
/// beyond its limit is on it (it slides at once), and a damped force is the closest point
/// of its ellipse.
/// Also what preparing a step from them would decide, where it moves nothing.
fn shaped_outputs(
    step: &SlidingStep,
    x: &StateVector,
    sliders: &SliderState,
    u: &DrivingVector,
) -> (OutputVector, Option<Preparation>) {
    let (mut x, mut sliders) = (*x, *sliders);
    let (changes, preparation) = step.prepare_with_damper_force_changes(&mut x, &mut sliders);
    (outputs_with_changes(step, &x, u, &changes), preparation)
}

/// The outputs at states `x` with what the limits take off each element's force
/// (`changes`, by direction) added to the forces it feeds.
fn outputs_with_changes(
    step: &SlidingStep,
    x: &StateVector,
    u: &DrivingVector,
    changes: &LimitChanges,
) -> OutputVector {
    let mut y = step.system.outputs(x, u);
    for (d, element) in step.friction.elements.iter().enumerate() {
        if let Some(element) = element
            && changes[d] != 0.0
        {
            for (output, coefficient) in element.force_outputs {
                y[output as usize] += coefficient * changes[d];
            }
        }
    }
    y
}
