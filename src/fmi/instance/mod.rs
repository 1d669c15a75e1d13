//! One FMU instance: the call sequence, variable access and FMU state around a [`Tire`].
//! Everything here is safe Rust; `exports` turns C pointers into the slices used here.
//! [`model_exchange`]: the calls of Model Exchange; [`tire_data`]: the tire property file.

mod model_exchange;
mod tire_data;

pub use tire_data::path_of_file_uri;

use crate::physics::tire::hybrid::{CONTINUOUS_STATES, ContinuousStates, GUARDS};
use crate::physics::{FrictionLaw, Input, ModelKind, Output, Parameter, Parameters, Tire};

use super::logger::{Category, Logger};
use super::snapshot::{FrictionState, Snapshot};
use super::state_machine::{Call, Phase};
use super::status::{CallResult, Rejection, Status};
use super::variables::{
    Causality, INPUT_BOUNDS, INPUT_BY_VALUE_REFERENCE, INPUT_VALUE_REFERENCES, NO_SIGNAL,
    OUTPUT_BY_VALUE_REFERENCE, OUTPUT_VALUE_REFERENCES, Role, VARIABLES, ValueType, Variable,
};

/// How far `currentCommunicationPoint` may be from the instance's time, relative to
/// `1 + |time|`: importers add step sizes in floating point.
const TIME_TOLERANCE: f64 = 1e-9;

/// Which interface an instance was made for (fmi2Instantiate's fmuType).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    CoSimulation,
    ModelExchange,
}

impl Interface {
    pub const fn name(self) -> &'static str {
        match self {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
        }
    }
}

/// What fmi2NewDiscreteStates reports (fmi2EventInfo).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EventUpdate {
    pub continuous_states_changed: bool,
}

pub struct Instance {
    pub logger: Logger,
    interface: Interface,
    phase: Phase,
    /// The parameters as set by the importer; checked together at initialisation.
    parameters: Parameters,
    /// Whether `parameters` changed since `tire` was made from them.
    parameters_changed: bool,
    /// Whether the importer has set Fz. Until it does, Fz follows the nominal load Fz0
    /// (docs/specification.md 3: Fz starts at Fz0), so that a changed Fz0 is not a
    /// changed load.
    normal_load_set: bool,
    tire: Tire,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    /// `tirFile`, as the importer set it (read at the end of initialisation).
    tire_data_file: std::ffi::CString,
    /// The FMU's resources folder (from fmi2Instantiate), for a relative `tirFile`.
    resources: Option<std::path::PathBuf>,
    /// By [`Parameter`]: whether the importer set it (a property file then leaves it).
    set_by_importer: [bool; Parameter::COUNT],
}

/// The parameters the model description declares as start values.
pub fn start_parameters() -> Result<Parameters, String> {
    let mut parameters = Parameters::default();
    for info in &VARIABLES {
        let Some(start) = info.start else { continue };
        match info.variable.role() {
            Role::Parameter(p) => parameters.set(p, start).map_err(|e| e.to_string())?,
            Role::ModelChoice => {
                parameters.model = ModelKind::from_value(start as i64)
                    .ok_or(format!("tireModel start value {start} is not a TireLagModel"))?
            }
            Role::FrictionChoice => {
                parameters.friction = FrictionLaw::from_value(start as i64)
                    .ok_or(format!("friction start value {start} is not a TireFriction"))?
            }
            Role::Input(_)
            | Role::Output(_)
            | Role::ContinuousState(_)
            | Role::Derivative(_)
            | Role::EventIndicator(_)
            | Role::Time
            | Role::TireDataFile => {}
        }
    }
    Ok(parameters)
}

/// A tire at the model description's start values.
fn start_tire(parameters: &Parameters) -> Result<Tire, String> {
    let mut tire = Tire::new(parameters.clone()).map_err(|e| e.to_string())?;
    for info in &VARIABLES {
        if let (Role::Input(input), Some(start)) = (info.variable.role(), info.start) {
            tire.set_input(input, start);
        }
    }
    Ok(tire)
}

fn lookup(value_reference: u32, expected: ValueType) -> CallResult<Variable> {
    let variable = Variable::from_value_reference(value_reference)
        .ok_or_else(|| Rejection::error(format!("unknown value reference {value_reference}")))?;
    let info = variable.info();
    if info.value_type != expected {
        return Err(Rejection::error(format!(
            "{} (value reference {value_reference}) is {:?}, not {:?}",
            info.name, info.value_type, expected
        )));
    }
    Ok(variable)
}

/// Whether two lists of value references are the same, without a branch per entry (an
/// array comparison becomes a memcmp call).
#[inline]
fn same_references<const N: usize>(refs: &[u32; N], expected: &[u32; N]) -> bool {
    refs.iter()
        .zip(expected)
        .fold(0, |differ, (a, b)| differ | (a ^ b))
        == 0
}

fn same_length(what: &str, a: usize, b: usize) -> CallResult {
    if a == b {
        Ok(())
    } else {
        Err(Rejection::error(format!(
            "{what}: {a} value references but {b} values"
        )))
    }
}

impl Instance {
    pub fn new(
        logger: Logger,
        interface: Interface,
        resources: Option<std::path::PathBuf>,
    ) -> Result<Self, String> {
        let parameters = start_parameters()?;
        let tire = start_tire(&parameters)?;
        Ok(Self {
            logger,
            interface,
            phase: Phase::Instantiated,
            parameters,
            parameters_changed: false,
            normal_load_set: false,
            tire,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            tire_data_file: std::ffi::CString::default(),
            resources,
            set_by_importer: [false; Parameter::COUNT],
        })
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    /// Marks the instance unusable after a panic was caught inside it.
    pub fn poison(&mut self) {
        self.phase = Phase::Fatal;
    }

    #[inline]
    pub fn require(&self, call: Call) -> CallResult {
        call.check(self.phase)
    }

    pub fn log(&self, status: Status, message: &str) {
        self.logger.log(status, Category::for_status(status), message);
    }

    pub fn set_debug_logging(&mut self, on: bool, names: &[&str]) -> CallResult {
        let categories = names
            .iter()
            .map(|name| {
                Category::from_name(name).ok_or_else(|| {
                    let known: Vec<_> = Category::ALL.iter().map(|c| c.name()).collect();
                    Rejection::error(format!(
                        "unknown log category '{name}'; known: {}",
                        known.join(", ")
                    ))
                })
            })
            .collect::<CallResult<Vec<_>>>()?;
        self.logger.set_categories(on, &categories);
        Ok(())
    }

    pub fn setup_experiment(&mut self, start_time: f64, stop_time: Option<f64>) -> CallResult {
        self.require(Call::SetupExperiment)?;
        if !start_time.is_finite() {
            return Err(Rejection::error(format!("startTime {start_time} is not finite")));
        }
        if let Some(stop) = stop_time
            && !(stop.is_finite() && stop >= start_time)
        {
            return Err(Rejection::error(format!(
                "stopTime {stop} must be finite and >= startTime {start_time}"
            )));
        }
        self.start_time = start_time;
        self.time = start_time;
        self.stop_time = stop_time;
        Ok(())
    }

    pub fn enter_initialization_mode(&mut self) -> CallResult {
        self.require(Call::EnterInitializationMode)?;
        self.phase = Phase::InitializationMode;
        Ok(())
    }

    /// Into step mode (Co-Simulation) or event mode (Model Exchange: the importer then
    /// asks for the initial modes with fmi2NewDiscreteStates).
    pub fn exit_initialization_mode(&mut self) -> CallResult {
        self.require(Call::ExitInitializationMode)?;
        self.apply_tire_data()?;
        self.sync_tire()?;
        self.phase = match self.interface {
            Interface::CoSimulation => Phase::StepComplete,
            Interface::ModelExchange => Phase::EventMode,
        };
        Ok(())
    }

    pub fn terminate(&mut self) -> CallResult {
        self.require(Call::Terminate)?;
        self.phase = Phase::Terminated;
        Ok(())
    }

    /// Back to the start values, start time and the instantiated phase: a new instance
    /// of the same interface, logger (its categories stay) and resources folder.
    pub fn reset(&mut self) -> CallResult {
        self.require(Call::Reset)?;
        *self = Instance::new(self.logger.clone(), self.interface, self.resources.clone())
            .map_err(Rejection::error)?;
        Ok(())
    }

    /// Rebuilds the tire when parameters changed since it was made, keeping the inputs.
    /// Fails, naming the parameter, if the parameters do not fit together.
    fn sync_tire(&mut self) -> CallResult {
        if self.parameters_changed {
            self.rebuild_tire()
        } else {
            Ok(())
        }
    }

    /// The slow half of [`Instance::sync_tire`], kept out of line: a tire is several
    /// kilobytes, and a frame that size on the hot path costs a stack probe per call.
    #[cold]
    #[inline(never)]
    fn rebuild_tire(&mut self) -> CallResult {
        if self.tire.parameters() != &self.parameters {
            let mut tire = Tire::new(self.parameters.clone())
                .map_err(|e| Rejection::error(format!("inconsistent parameters: {e}")))?;
            for input in Input::ALL {
                tire.set_input(input, self.tire.input(input));
                tire.set_input_rate(input, self.tire.input_rate(input));
            }
            if !self.normal_load_set {
                tire.set_input(Input::Fz, self.parameters.get(Parameter::NominalLoad));
            }
            self.tire = tire;
        }
        self.parameters_changed = false;
        Ok(())
    }

    fn real_value(&mut self, variable: Variable) -> CallResult<f64> {
        Ok(match variable.role() {
            Role::Input(input) => self.tire.input(input),
            Role::Parameter(p) => self.parameters.get(p),
            Role::Output(output) => {
                self.sync_tire()?;
                self.tire.outputs()[output as usize]
            }
            Role::ContinuousState(k) => {
                self.sync_tire()?;
                self.tire.continuous_states()[k]
            }
            Role::Derivative(k) => {
                self.sync_tire()?;
                self.tire.continuous_rates()[k]
            }
            Role::EventIndicator(k) => {
                self.sync_tire()?;
                self.tire.guards()[k]
            }
            Role::Time => self.time,
            Role::ModelChoice | Role::FrictionChoice | Role::TireDataFile => {
                unreachable!("lookup checked the type: the selectors are Integers, tirFile a String")
            }
        })
    }

    pub fn get_real(&mut self, value_references: &[u32], values: &mut [f64]) -> CallResult {
        if self.get_outputs_fast(value_references, values) {
            return Ok(());
        }
        self.get_reals(value_references, values)
    }

    /// [`Instance::get_real`] value by value, out of line: any variable, and the reason
    /// when one cannot be read.
    #[inline(never)]
    fn get_reals(&mut self, value_references: &[u32], values: &mut [f64]) -> CallResult {
        self.require(Call::GetValues)?;
        same_length("values", value_references.len(), values.len())?;
        for (&vr, value) in value_references.iter().zip(values.iter_mut()) {
            *value = self.real_value(lookup(vr, ValueType::Real)?)?;
        }
        Ok(())
    }

    /// The common case of a co-simulation step: every value reference is an output and
    /// the tire is up to date. One table load per value. Returns false (having perhaps
    /// written some values) when the general path must decide.
    fn get_outputs_fast(&mut self, refs: &[u32], values: &mut [f64]) -> bool {
        if refs.len() != values.len() || self.parameters_changed || !Call::GetValues.allows(self.phase) {
            return false;
        }
        // The outputs are made only for a read of outputs (not of states, parameters, ...).
        let first_is_output = refs.first().is_none_or(|&vr| {
            OUTPUT_BY_VALUE_REFERENCE
                .get(vr as usize)
                .is_some_and(|&output| output != NO_SIGNAL)
        });
        if !first_is_output {
            return false;
        }
        let outputs = self.tire.outputs_ref();
        // All outputs in their declared order, as importers usually ask: one copy.
        if let Ok(refs) = <&[u32; Output::COUNT]>::try_from(refs)
            && same_references(refs, &OUTPUT_VALUE_REFERENCES)
        {
            values.copy_from_slice(outputs.as_slice());
            return true;
        }
        for (&vr, value) in refs.iter().zip(values.iter_mut()) {
            match OUTPUT_BY_VALUE_REFERENCE.get(vr as usize) {
                Some(&output) if output != NO_SIGNAL => *value = outputs[output as usize],
                _ => return false,
            }
        }
        true
    }

    /// Checks that `variable` may be set now to `value`, naming both if not.
    fn check_settable(&self, variable: Variable, value: f64) -> CallResult {
        let info = variable.info();
        let refuse = |why: String| {
            Err(Rejection::error(format!(
                "cannot set {} = {value}: {why}",
                info.name
            )))
        };
        if !value.is_finite() {
            return refuse("the value is not finite".into());
        }
        match info.causality {
            // Inputs are bounded by the model description; parameters by the physics.
            Causality::Input => {
                if let Some(min) = info.min.filter(|&min| value < min) {
                    return refuse(format!("below its minimum {min} {}", info.unit));
                }
                if let Some(max) = info.max.filter(|&max| value > max) {
                    return refuse(format!("above its maximum {max} {}", info.unit));
                }
                Ok(())
            }
            // Importers such as the FMU Compliance Checker set every column of their input
            // file before every step: the value a fixed parameter already has is harmless.
            Causality::Parameter if self.phase.running() => {
                let current = self.parameter_value(variable);
                if value == current {
                    Ok(())
                } else {
                    refuse(format!(
                        "it is a fixed parameter and the FMU is initialised with {} = {current}; \
                         only inputs can change now",
                        info.name
                    ))
                }
            }
            Causality::Parameter => match variable.role() {
                Role::Parameter(p) => p.check(value).map_err(|e| Rejection::error(e.to_string())),
                Role::FrictionChoice => match FrictionLaw::from_value(value as i64) {
                    Some(_) if value.fract() == 0.0 => Ok(()),
                    _ => refuse("the TireFriction values are Unlimited = 1, Coulomb = 2, Brush = 3".into()),
                },
                _ => match ModelKind::from_value(value as i64) {
                    Some(_) if value.fract() == 0.0 => Ok(()),
                    _ => refuse(
                        "the TireLagModel values are RLT = 1, DDT = 2, SecondOrder = 3, RingBody = 4".into(),
                    ),
                },
            },
            Causality::Local => refuse(match variable.role() {
                Role::EventIndicator(_) => "it is an event indicator, computed by the FMU".into(),
                _ => "it is a continuous state or its derivative: Model Exchange sets the states \
                      with SetContinuousStates"
                    .into(),
            }),
            Causality::Independent => refuse(
                "it is the independent variable: DoStep advances it, and Model Exchange sets it with SetTime"
                    .into(),
            ),
            _ => refuse(format!("it is an {:?} and cannot be set", info.causality).to_lowercase()),
        }
    }

    /// The value in use of a parameter or selector; NaN for inputs and outputs.
    fn parameter_value(&self, variable: Variable) -> f64 {
        match variable.role() {
            Role::Parameter(p) => self.parameters.get(p),
            Role::ModelChoice => self.parameters.model as i32 as f64,
            Role::FrictionChoice => self.parameters.friction as i32 as f64,
            Role::Input(_)
            | Role::Output(_)
            | Role::ContinuousState(_)
            | Role::Derivative(_)
            | Role::EventIndicator(_)
            | Role::Time
            | Role::TireDataFile => f64::NAN,
        }
    }

    fn apply(&mut self, variable: Variable, value: f64) {
        // A parameter set to the value it has: the tire need not be rebuilt. (Inputs have
        // no parameter value: NaN equals nothing.)
        if self.parameter_value(variable) == value {
            return;
        }
        match variable.role() {
            Role::Input(input) => {
                self.normal_load_set |= input == Input::Fz;
                self.tire.set_input(input, value);
            }
            Role::Parameter(p) => {
                self.parameters.set(p, value).expect("checked by check_settable");
                self.parameters_changed = true;
                self.set_by_importer[p as usize] = true;
            }
            Role::ModelChoice => {
                self.parameters.model = ModelKind::from_value(value as i64).expect("checked");
                self.parameters_changed = true;
            }
            Role::FrictionChoice => {
                self.parameters.friction = FrictionLaw::from_value(value as i64).expect("checked");
                self.parameters_changed = true;
            }
            Role::Output(_)
            | Role::ContinuousState(_)
            | Role::Derivative(_)
            | Role::EventIndicator(_)
            | Role::Time
            | Role::TireDataFile => {
                unreachable!("outputs, locals and time are refused by check_settable, tirFile by its type")
            }
        }
    }

    /// Sets values all together: if any one is refused, none is set. Checks everything
    /// first, then applies (no buffer: a set must not allocate). Out of line: the inputs
    /// of a step take [`Instance::set_inputs_fast`].
    #[inline(never)]
    fn set_values<T: Copy + Into<f64>>(
        &mut self,
        expected: ValueType,
        refs: &[u32],
        values: &[T],
    ) -> CallResult {
        self.require(Call::SetValues)?;
        same_length("values", refs.len(), values.len())?;
        for (&vr, &value) in refs.iter().zip(values) {
            self.check_settable(lookup(vr, expected)?, value.into())?;
        }
        for (&vr, &value) in refs.iter().zip(values) {
            self.apply(lookup(vr, expected)?, value.into());
        }
        Ok(())
    }

    #[inline]
    pub fn set_real(&mut self, value_references: &[u32], values: &[f64]) -> CallResult {
        if self.set_inputs_fast(value_references, values) {
            return Ok(());
        }
        self.set_values(ValueType::Real, value_references, values)
    }

    /// The common case of a co-simulation step: every value is an input, finite and
    /// within its bounds. Sets them and returns true; otherwise changes nothing and
    /// returns false, and the general path decides (and names what is wrong).
    fn set_inputs_fast(&mut self, refs: &[u32], values: &[f64]) -> bool {
        if refs.len() != values.len() || !Call::SetValues.allows(self.phase) {
            return false;
        }
        // All inputs in their declared order, as importers usually set them: checked and
        // written at once.
        if let (Ok(refs), Ok(values)) = (
            <&[u32; Input::COUNT]>::try_from(refs),
            <&[f64; Input::COUNT]>::try_from(values),
        ) && same_references(refs, &INPUT_VALUE_REFERENCES)
        {
            // NaN fails both comparisons; `&` keeps the five checks free of branches.
            let within = values
                .iter()
                .zip(INPUT_BOUNDS)
                .fold(true, |all, (&value, [min, max])| {
                    all & (value >= min) & (value <= max)
                });
            if !within {
                return false;
            }
            self.tire.set_inputs(*values);
            self.normal_load_set = true;
            return true;
        }
        // Staged in a copy and written at once: one pass, and nothing changes on refusal.
        let mut inputs = self.tire.inputs();
        let mut sets_load = false;
        for (&vr, &value) in refs.iter().zip(values) {
            let input = match INPUT_BY_VALUE_REFERENCE.get(vr as usize) {
                Some(&input) if input != NO_SIGNAL => input as usize,
                _ => return false,
            };
            let [min, max] = INPUT_BOUNDS[input];
            // NaN fails both comparisons.
            if !(value >= min && value <= max) {
                return false;
            }
            inputs[input] = value;
            sets_load |= input == Input::Fz as usize;
        }
        self.tire.set_inputs(inputs);
        self.normal_load_set |= sets_load;
        true
    }

    /// The selectors: FMI 2.0 Integers (i32), FMI 3.0 Enumerations (i64).
    pub fn get_integer<T: From<i32>>(&mut self, value_references: &[u32], values: &mut [T]) -> CallResult {
        self.require(Call::GetValues)?;
        same_length("values", value_references.len(), values.len())?;
        for (&vr, value) in value_references.iter().zip(values.iter_mut()) {
            *value = match lookup(vr, ValueType::Integer)?.role() {
                Role::FrictionChoice => self.parameters.friction as i32,
                _ => self.parameters.model as i32,
            }
            .into();
        }
        Ok(())
    }

    pub fn set_integer(&mut self, value_references: &[u32], values: &[i32]) -> CallResult {
        self.set_values(ValueType::Integer, value_references, values)
    }

    /// Get/Set of a type this FMU has no variables of (Boolean; in FMI 3.0 also the
    /// other integer and float types, Binary and Clock).
    pub fn no_variables_of_type(&self, call: Call, value_references: &[u32]) -> CallResult {
        self.require(call)?;
        let Some(&vr) = value_references.first() else {
            return Ok(());
        };
        let what = match Variable::from_value_reference(vr) {
            Some(variable) => format!(
                "value reference {vr} is {}, a {}",
                variable.name(),
                variable.info().value_type.describe()
            ),
            None => format!("and no variable has value reference {vr}"),
        };
        Err(Rejection::error(format!(
            "this FMU has no variables of that type; {what}"
        )))
    }

    pub fn do_step(&mut self, communication_point: f64, step_size: f64) -> CallResult {
        self.require(Call::DoStep)?;
        let tolerance = TIME_TOLERANCE * (1.0 + self.time.abs());
        let offset = (communication_point - self.time).abs();
        if offset.is_nan() || offset > tolerance {
            return Err(Rejection::error(format!(
                "currentCommunicationPoint {communication_point} s is not the FMU's time {} s",
                self.time
            )));
        }
        // (Two comparisons: `is_finite` classifies the number.)
        if !(step_size > 0.0 && step_size <= f64::MAX) {
            return Err(Rejection::error(format!(
                "communicationStepSize {step_size} s must be finite and > 0"
            )));
        }
        let end = communication_point + step_size;
        if let Some(stop) = self.stop_time
            && end > stop + TIME_TOLERANCE * (1.0 + stop.abs())
        {
            return Err(Rejection::error(format!(
                "the step ends at {end} s, past stopTime {stop} s"
            )));
        }
        self.tire
            .step(step_size)
            .map_err(|e| Rejection::error(e.to_string()))?;
        self.time = end;
        Ok(())
    }

    pub fn set_input_derivatives(&mut self, refs: &[u32], orders: &[i32], values: &[f64]) -> CallResult {
        self.require(Call::SetInputDerivatives)?;
        same_length("values", refs.len(), values.len())?;
        same_length("orders", refs.len(), orders.len())?;
        let mut checked = Vec::with_capacity(refs.len());
        for ((&vr, &order), &value) in refs.iter().zip(orders).zip(values) {
            let variable = lookup(vr, ValueType::Real)?;
            let Role::Input(input) = variable.role() else {
                return Err(Rejection::error(format!(
                    "{} is not an input; only inputs have derivatives",
                    variable.name()
                )));
            };
            if order != 1 {
                return Err(Rejection::error(format!(
                    "derivative order {order} of {} is not supported: the maximum is 1",
                    variable.name()
                )));
            }
            if !value.is_finite() {
                return Err(Rejection::error(format!(
                    "cannot set d{}/dt = {value}: not finite",
                    variable.name()
                )));
            }
            checked.push((input, value));
        }
        for (input, value) in checked {
            self.tire.set_input_rate(input, value);
        }
        Ok(())
    }

    pub fn get_output_derivatives(&mut self, refs: &[u32], orders: &[i32], values: &mut [f64]) -> CallResult {
        self.require(Call::GetOutputDerivatives)?;
        same_length("values", refs.len(), values.len())?;
        same_length("orders", refs.len(), orders.len())?;
        let rates = self.tire.output_rates();
        for ((&vr, &order), value) in refs.iter().zip(orders).zip(values.iter_mut()) {
            let variable = lookup(vr, ValueType::Real)?;
            let Role::Output(output) = variable.role() else {
                return Err(Rejection::error(format!("{} is not an output", variable.name())));
            };
            if order != 1 {
                return Err(Rejection::error(format!(
                    "derivative order {order} of {} is not provided: maxOutputDerivativeOrder is 1",
                    variable.name()
                )));
            }
            *value = rates[output as usize];
        }
        Ok(())
    }

    /// `dv_unknown = (d unknowns / d knowns) dv_known`: unknowns outputs or state
    /// derivatives, knowns inputs or continuous states.
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        result: &mut [f64],
    ) -> CallResult {
        self.require(Call::GetDirectionalDerivative)?;
        same_length("dvKnown", knowns.len(), seed.len())?;
        same_length("dvUnknown", unknowns.len(), result.len())?;
        self.sync_tire()?;
        let unknown_roles = unknowns
            .iter()
            .map(|&vr| match lookup(vr, ValueType::Real)?.role() {
                role @ (Role::Output(_) | Role::Derivative(_)) => Ok(role),
                _ => Err(Rejection::error(format!(
                    "unknown {vr} is neither an output nor a state derivative"
                ))),
            })
            .collect::<CallResult<Vec<_>>>()?;
        let mut input_seed = [0.0; Input::COUNT];
        let mut state_seed: ContinuousStates = [0.0; CONTINUOUS_STATES];
        for (&vr, &dv) in knowns.iter().zip(seed) {
            if !dv.is_finite() {
                return Err(Rejection::error(format!(
                    "seed {dv} for known {vr} is not finite"
                )));
            }
            match lookup(vr, ValueType::Real)?.role() {
                Role::Input(input) => input_seed[input as usize] += dv,
                Role::ContinuousState(k) => state_seed[k] += dv,
                _ => {
                    return Err(Rejection::error(format!(
                        "known {vr} is neither an input nor a continuous state"
                    )));
                }
            }
        }
        let wants_rates = unknown_roles.iter().any(|r| matches!(r, Role::Derivative(_)));
        let (rates, outputs) = if wants_rates || state_seed.iter().any(|&d| d != 0.0) {
            self.tire.hybrid_sensitivity(&state_seed, &input_seed)
        } else {
            // Outputs by inputs: the sensitivities of the Co-Simulation outputs.
            let mut total = crate::physics::OutputVector::zeros();
            for input in Input::ALL {
                let dv = input_seed[input as usize];
                if dv != 0.0 {
                    total += self.tire.output_sensitivity(input) * dv;
                }
            }
            ([0.0; CONTINUOUS_STATES], total)
        };
        for (value, role) in result.iter_mut().zip(unknown_roles) {
            *value = match role {
                Role::Output(output) => outputs[output as usize],
                Role::Derivative(k) => rates[k],
                _ => unreachable!("checked above"),
            };
        }
        Ok(())
    }

    /// The states, sized for the selected model. Before initialisation the tire may still
    /// be the one of a previously selected model; its states are then at rest anyway.
    fn states_of_selected_model(&self) -> Vec<f64> {
        if self.tire.parameters().model == self.parameters.model {
            self.tire.states().to_vec()
        } else {
            vec![0.0; self.parameters.model.equations().state_names().len()]
        }
    }

    /// The friction's state: the sliders and the lengths the eighth-order pair's first
    /// two substeps of the next step start from ([`Tire::high_order_substeps`]), for the
    /// selected model and law (at rest, and any lengths, if the tire is still the one of
    /// another selection).
    fn friction_state_of_selected_law(&self) -> Option<FrictionState> {
        if self.parameters.friction == FrictionLaw::Unlimited {
            return None;
        }
        let same = self.tire.parameters().model == self.parameters.model
            && self.tire.parameters().friction == self.parameters.friction;
        Some(match self.tire.sliders().filter(|_| same) {
            Some(sliders) => FrictionState {
                sliders: *sliders,
                high_order_substeps: self.tire.high_order_substeps(),
            },
            None => FrictionState {
                sliders: crate::physics::friction::SliderState::AT_REST,
                high_order_substeps: crate::physics::friction::NOT_CARRIED,
            },
        })
    }

    pub fn snapshot(&self) -> CallResult<Snapshot> {
        self.require(Call::GetFmuState)?;
        Ok(Snapshot {
            phase: self.phase,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            parameters: self.parameters.clone(),
            inputs: Input::ALL.map(|i| self.tire.input(i)),
            input_rates: Input::ALL.map(|i| self.tire.input_rate(i)),
            states: self.states_of_selected_model(),
            friction: self.friction_state_of_selected_law(),
            tire_data_file: self.tire_data_file.to_string_lossy().into_owned(),
            set_by_importer: self.set_by_importer,
        })
    }

    pub fn restore(&mut self, snapshot: &Snapshot) -> CallResult {
        self.require(Call::SetFmuState)?;
        let belongs = match snapshot.phase {
            Phase::StepComplete => Some(Interface::CoSimulation),
            Phase::EventMode | Phase::ContinuousTimeMode => Some(Interface::ModelExchange),
            _ => None,
        };
        if let Some(interface) = belongs.filter(|&i| i != self.interface) {
            return Err(Rejection::error(format!(
                "the FMU state was taken from a {} instance in {}; this instance is for {}",
                interface.name(),
                snapshot.phase.name(),
                self.interface.name()
            )));
        }
        let before_initialisation = matches!(snapshot.phase, Phase::Instantiated | Phase::InitializationMode);
        let mut tire = match Tire::new(snapshot.parameters.clone()) {
            Ok(mut tire) => {
                tire.set_states(&snapshot.states).map_err(Rejection::error)?;
                if let Some(friction) = &snapshot.friction {
                    tire.set_sliders(&friction.sliders).map_err(Rejection::error)?;
                    tire.set_high_order_substeps(friction.high_order_substeps);
                }
                tire
            }
            // Before initialisation the parameters need not fit together yet (they are
            // checked at fmi2ExitInitializationMode) and the tire is at rest: the current
            // tire carries the inputs until it is rebuilt.
            Err(_) if before_initialisation => self.tire.clone(),
            Err(e) => {
                return Err(Rejection::error(format!(
                    "the FMU state holds inconsistent parameters: {e}"
                )));
            }
        };
        for (i, input) in Input::ALL.into_iter().enumerate() {
            tire.set_input(input, snapshot.inputs[i]);
            tire.set_input_rate(input, snapshot.input_rates[i]);
        }
        let tire_data_file = std::ffi::CString::new(snapshot.tire_data_file.as_str())
            .map_err(|_| Rejection::error("tirFile in the FMU state holds a NUL byte"))?;
        self.tire = tire;
        self.parameters = snapshot.parameters.clone();
        self.parameters_changed = true;
        self.tire_data_file = tire_data_file;
        self.set_by_importer = snapshot.set_by_importer;
        // The state carries its load explicitly.
        self.normal_load_set = true;
        self.phase = snapshot.phase;
        self.time = snapshot.time;
        self.start_time = snapshot.start_time;
        self.stop_time = snapshot.stop_time;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_instance_fits_in_16_kib() {
        // docs/specification.md 6b: an instance holds at most 16 KiB. The stepper's storage
        // is fixed-size and lives inside the instance; only the instance name is on the heap
        // besides.
        let size = std::mem::size_of::<Instance>();
        assert!(size <= 16 * 1024, "an instance takes {size} bytes");
        println!("size of an instance: {size} bytes");
    }
}
