//! One tire: parameters, states, inputs, and the exact step.

use std::fmt;

use nalgebra::{DVector, Vector3};

use super::linear::{LinearSystem, StepMatrices};
use super::models::TireLagModel;
use super::parameters::{ParameterError, Parameters};
use super::signals::{Input, Output, OutputVector};

/// How fast the deflections relax while the wheel is off the ground, s: a free carcass
/// springs back within a few hundredths of a second.
pub const LIFT_OFF_RELAXATION_TIME: f64 = 0.01;

/// How the contact patch is held. Each mode is its own linear system; the step picks the
/// mode from the inputs. (A friction limit adds a sliding mode here.)
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

/// Why a step was refused; the tire is unchanged.
#[derive(Clone, Debug, PartialEq)]
pub enum StepError {
    /// The step size must be finite and > 0.
    StepSize(f64),
    /// The inputs are so large that the states would overflow.
    NotFinite,
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::StepSize(h) => write!(f, "step size {h} s is not allowed: it must be finite and > 0"),
            StepError::NotFinite => write!(
                f,
                "the states would not be finite after this step: inputs too large"
            ),
        }
    }
}

impl std::error::Error for StepError {}

#[derive(Clone, Debug)]
struct Cache {
    system: Option<(u64, ContactMode, LinearSystem)>,
    step: Option<(u64, ContactMode, u64, StepMatrices)>,
}

/// A tire with one of the four tire-lag models.
///
/// Inputs are held, or ramped with their rates, over a step; `step` advances the states
/// by the exact solution of the model's linear ODE. The discretisation is reused while
/// `vx`, the contact mode and the step size are unchanged.
#[derive(Clone, Debug)]
pub struct Tire {
    parameters: Parameters,
    states: DVector<f64>,
    inputs: [f64; Input::COUNT],
    input_rates: [f64; Input::COUNT],
    cache: Cache,
}

impl Tire {
    /// A tire at rest (all states zero), standing still with its nominal load.
    pub fn new(parameters: Parameters) -> Result<Self, ParameterError> {
        parameters.validate()?;
        let states = DVector::zeros(parameters.model.equations().state_names().len());
        let mut inputs = [0.0; Input::COUNT];
        inputs[Input::Fz as usize] = parameters.get(super::Parameter::NominalLoad);
        Ok(Self {
            parameters,
            states,
            inputs,
            input_rates: [0.0; Input::COUNT],
            cache: Cache {
                system: None,
                step: None,
            },
        })
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

    pub fn states(&self) -> &DVector<f64> {
        &self.states
    }

    /// Replaces the states; the slice must have one finite value per state.
    pub fn set_states(&mut self, states: &[f64]) -> Result<(), String> {
        if states.len() != self.states.len() {
            return Err(format!(
                "the {} model has {} states, got {}",
                self.parameters.model.name(),
                self.states.len(),
                states.len()
            ));
        }
        if let Some(bad) = states.iter().find(|v| !v.is_finite()) {
            return Err(format!("state value {bad} is not finite"));
        }
        self.states.copy_from_slice(states);
        Ok(())
    }

    pub fn input(&self, input: Input) -> f64 {
        self.inputs[input as usize]
    }

    /// Sets an input; callers make sure it is finite.
    pub fn set_input(&mut self, input: Input, value: f64) {
        self.inputs[input as usize] = value;
    }

    pub fn input_rate(&self, input: Input) -> f64 {
        self.input_rates[input as usize]
    }

    /// Sets the time derivative of an input over the coming steps. The step is exact for
    /// ramps of vy, steerRate and vsx; vx and Fz are taken at the middle of the step.
    pub fn set_input_rate(&mut self, input: Input, rate: f64) {
        self.input_rates[input as usize] = rate;
    }

    pub fn contact_mode(&self) -> ContactMode {
        ContactMode::from_load(self.input(Input::Fz))
    }

    fn driving_inputs(values: &[f64; Input::COUNT]) -> Vector3<f64> {
        Vector3::new(
            values[Input::Vy as usize],
            values[Input::SteerRate as usize],
            values[Input::Vsx as usize],
        )
    }

    /// The system for speed `vx` and rolling speed `rho` in a contact mode (not cached).
    pub fn system_at(&self, vx: f64, rho: f64, mode: ContactMode) -> LinearSystem {
        let mut system = self.model().system(&self.parameters, vx, rho);
        if mode == ContactMode::LiftedOff {
            for load in Output::LOADS {
                system.c.row_mut(load as usize).fill(0.0);
            }
            system.d.fill(0.0);
            system.b.fill(0.0);
            system.a.fill_with_identity();
            system.a.scale_mut(-1.0 / LIFT_OFF_RELAXATION_TIME);
        }
        system
    }

    /// Makes the cached system the one for the current speed and contact mode.
    fn refresh_system(&mut self) {
        let vx = self.input(Input::Vx);
        let mode = self.contact_mode();
        let fresh = matches!(&self.cache.system, Some((bits, m, _)) if *bits == vx.to_bits() && *m == mode);
        if !fresh {
            let system = self.system_at(vx, vx.abs(), mode);
            self.cache.system = Some((vx.to_bits(), mode, system));
        }
    }

    /// The system made by the last [`Tire::refresh_system`].
    fn cached_system(&self) -> &LinearSystem {
        &self
            .cache
            .system
            .as_ref()
            .expect("refresh_system fills the cache")
            .2
    }

    /// Outputs for the current states and inputs.
    pub fn outputs(&mut self) -> OutputVector {
        self.refresh_system();
        self.cached_system()
            .outputs(&self.states, &Self::driving_inputs(&self.inputs))
    }

    /// Time derivatives of the outputs at the current states, inputs and input rates
    /// (exact for a constant vx and normal load).
    pub fn output_rates(&mut self) -> OutputVector {
        self.refresh_system();
        let u = Self::driving_inputs(&self.inputs);
        let du = Self::driving_inputs(&self.input_rates);
        self.cached_system().output_rates(&self.states, &u, &du)
    }

    /// Partial derivatives of every output with respect to one input, at the current
    /// states and inputs. Outputs are affine in vx and in rho = |vx| separately, so unit
    /// differences give the derivatives exactly; d|vx|/dvx is taken as 0 at vx = 0, the
    /// value a central difference gives. The normal load only switches the contact mode,
    /// so its derivative is zero.
    pub fn output_sensitivity(&mut self, input: Input) -> OutputVector {
        let mode = self.contact_mode();
        if let Some(driving) = input.driving() {
            self.refresh_system();
            let feedthrough = self.cached_system().d.column(driving as usize);
            return OutputVector::from_iterator(feedthrough.iter().copied());
        }
        if input == Input::Fz {
            return OutputVector::zeros();
        }
        let vx = self.input(Input::Vx);
        let rho = vx.abs();
        let u = Self::driving_inputs(&self.inputs);
        let at = |vx: f64, rho: f64| self.system_at(vx, rho, mode).outputs(&self.states, &u);
        let base = at(vx, rho);
        let by_vx = at(vx + 1.0, rho) - base;
        let by_rho = at(vx, rho + 1.0) - base;
        let rho_per_vx = if vx > 0.0 {
            1.0
        } else if vx < 0.0 {
            -1.0
        } else {
            0.0
        };
        by_vx + by_rho * rho_per_vx
    }

    /// Advances the states by `h` seconds with the inputs held (or ramped at their rates),
    /// and the inputs to their values at the end of the step. On error nothing changes.
    pub fn step(&mut self, h: f64) -> Result<(), StepError> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(StepError::StepSize(h));
        }
        let middle = |input: Input| self.input(input) + 0.5 * h * self.input_rate(input);
        let vx = middle(Input::Vx);
        let mode = ContactMode::from_load(middle(Input::Fz));
        let fresh = matches!(&self.cache.step,
            Some((vx_bits, m, h_bits, _)) if *vx_bits == vx.to_bits() && *m == mode && *h_bits == h.to_bits());
        if !fresh {
            let step = self.system_at(vx, vx.abs(), mode).discretise(h);
            self.cache.step = Some((vx.to_bits(), mode, h.to_bits(), step));
        }
        let step = &self.cache.step.as_ref().expect("filled above").3;
        let u0 = Self::driving_inputs(&self.inputs);
        let du = Self::driving_inputs(&self.input_rates);
        let next_states = step.advance(&self.states, &u0, &du);
        let mut next_inputs = self.inputs;
        for (value, rate) in next_inputs.iter_mut().zip(self.input_rates) {
            *value += h * rate;
        }
        if next_states
            .iter()
            .chain(next_inputs.iter())
            .any(|v| !v.is_finite())
        {
            return Err(StepError::NotFinite);
        }
        self.states = next_states;
        self.inputs = next_inputs;
        Ok(())
    }

    /// Mechanical energy stored in the tire's springs and masses, J.
    pub fn stored_energy(&self) -> f64 {
        self.model().stored_energy(&self.parameters, &self.states)
    }
}
