//! The exported FMI 3.0 functions: each names itself and hands its arguments to the
//! shared C boundary ([`super::boundary`]), as the FMI 2.0 ones do. Co-Simulation and
//! Model Exchange; the functions of what the model description does not declare
//! (Scheduled Execution, clocks, configuration mode, adjoint derivatives, variable
//! dependencies, event mode in Co-Simulation) return fmi3Error and say why. Each
//! function's signature is checked at compile time against its typedef in the official
//! headers (`fmi3...TYPE`).

#![allow(non_snake_case, non_upper_case_globals)]
// The C ABI: see `fmi2`.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::c_char;
use std::path::PathBuf;

use super::boundary::{self as b, Directional, Instantiation, out, with_instance};
use super::instance::{Instance, Interface};
use super::logger::Callback;
use super::state_machine::Call;
use super::status::{CallResult, Rejection};
use super::sys3::*;
use crate::physics::tire::hybrid::{CONTINUOUS_STATES, GUARDS};

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetDebugLogging(
    instance: fmi3Instance,
    loggingOn: fmi3Boolean,
    nCategories: usize,
    categories: *const fmi3String,
) -> fmi3Status {
    b::set_debug_logging(
        instance,
        "fmi3SetDebugLogging",
        loggingOn,
        nCategories,
        categories,
    )
}

/// The resources folder, a native path in FMI 3.0; an importer may give none.
fn resources(resourcePath: fmi3String) -> Option<PathBuf> {
    unsafe { b::text(resourcePath, "resourcePath") }
        .ok()
        .filter(|path| !path.is_empty())
        .map(PathBuf::from)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateModelExchange(
    instanceName: fmi3String,
    instantiationToken: fmi3String,
    resourcePath: fmi3String,
    _visible: fmi3Boolean,
    loggingOn: fmi3Boolean,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
) -> fmi3Instance {
    b::instantiate(Instantiation {
        function: "fmi3InstantiateModelExchange",
        instance_name: instanceName,
        token: instantiationToken,
        interface: Interface::ModelExchange,
        callback: Callback::Fmi3 {
            log_message: logMessage,
            environment: instanceEnvironment,
        },
        logging_on: loggingOn,
        resources: resources(resourcePath),
        refusal: None,
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateCoSimulation(
    instanceName: fmi3String,
    instantiationToken: fmi3String,
    resourcePath: fmi3String,
    _visible: fmi3Boolean,
    loggingOn: fmi3Boolean,
    eventModeUsed: fmi3Boolean,
    _earlyReturnAllowed: fmi3Boolean,
    _requiredIntermediateVariables: *const fmi3ValueReference,
    nRequiredIntermediateVariables: usize,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
    _intermediateUpdate: fmi3IntermediateUpdateCallback,
) -> fmi3Instance {
    // Every step completes exactly and at once: there are no events to hand back, no early
    // return and no intermediate update (the model description says so).
    let refusal = if eventModeUsed {
        Some(
            "eventModeUsed is true, but this FMU has no event mode in Co-Simulation (hasEventMode=\"false\")"
                .into(),
        )
    } else if nRequiredIntermediateVariables > 0 {
        Some(format!(
            "{nRequiredIntermediateVariables} required intermediate variables were given, but this FMU \
             provides no intermediate update (providesIntermediateUpdate=\"false\")"
        ))
    } else {
        None
    };
    b::instantiate(Instantiation {
        function: "fmi3InstantiateCoSimulation",
        instance_name: instanceName,
        token: instantiationToken,
        interface: Interface::CoSimulation,
        callback: Callback::Fmi3 {
            log_message: logMessage,
            environment: instanceEnvironment,
        },
        logging_on: loggingOn,
        resources: resources(resourcePath),
        refusal,
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateScheduledExecution(
    instanceName: fmi3String,
    instantiationToken: fmi3String,
    _resourcePath: fmi3String,
    _visible: fmi3Boolean,
    loggingOn: fmi3Boolean,
    instanceEnvironment: fmi3InstanceEnvironment,
    logMessage: fmi3LogMessageCallback,
    _clockUpdate: fmi3ClockUpdateCallback,
    _lockPreemption: fmi3LockPreemptionCallback,
    _unlockPreemption: fmi3UnlockPreemptionCallback,
) -> fmi3Instance {
    b::instantiate(Instantiation {
        function: "fmi3InstantiateScheduledExecution",
        instance_name: instanceName,
        token: instantiationToken,
        interface: Interface::CoSimulation,
        callback: Callback::Fmi3 {
            log_message: logMessage,
            environment: instanceEnvironment,
        },
        logging_on: loggingOn,
        resources: None,
        refusal: Some(NO_SCHEDULED_EXECUTION.into()),
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3FreeInstance(instance: fmi3Instance) {
    b::free_instance(instance)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EnterInitializationMode(
    instance: fmi3Instance,
    toleranceDefined: fmi3Boolean,
    tolerance: fmi3Float64,
    startTime: fmi3Float64,
    stopTimeDefined: fmi3Boolean,
    stopTime: fmi3Float64,
) -> fmi3Status {
    let arguments = move || {
        format!(
            "toleranceDefined = {toleranceDefined}, tolerance = {tolerance}, startTime = {startTime}, \
             stopTimeDefined = {stopTimeDefined}, stopTime = {stopTime}"
        )
    };
    b::with_instance_logged(instance, "fmi3EnterInitializationMode", arguments, |instance| {
        instance.setup_experiment(startTime, stopTimeDefined.then_some(stopTime))?;
        instance.enter_initialization_mode()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3ExitInitializationMode(instance: fmi3Instance) -> fmi3Status {
    with_instance(
        instance,
        "fmi3ExitInitializationMode",
        Instance::exit_initialization_mode,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EnterEventMode(instance: fmi3Instance) -> fmi3Status {
    with_instance(instance, "fmi3EnterEventMode", Instance::enter_event_mode)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3Terminate(instance: fmi3Instance) -> fmi3Status {
    with_instance(instance, "fmi3Terminate", Instance::terminate)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3Reset(instance: fmi3Instance) -> fmi3Status {
    with_instance(instance, "fmi3Reset", Instance::reset)
}

// ---------------------------------------------------------------- getting and setting

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetFloat64(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *mut fmi3Float64,
    nValues: usize,
) -> fmi3Status {
    b::counted(instance, "fmi3GetFloat64", nValues, nValueReferences, || {
        b::get_real(
            instance,
            "fmi3GetFloat64",
            valueReferences,
            nValueReferences,
            values,
        )
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetFloat64(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *const fmi3Float64,
    nValues: usize,
) -> fmi3Status {
    b::counted(instance, "fmi3SetFloat64", nValues, nValueReferences, || {
        b::set_real(
            instance,
            "fmi3SetFloat64",
            valueReferences,
            nValueReferences,
            values,
        )
    })
}

/// The enumerations (the selectors) as FMI 3.0 reads them: Int64.
#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetInt64(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *mut fmi3Int64,
    nValues: usize,
) -> fmi3Status {
    let (vr, nvr) = (valueReferences, nValueReferences);
    let arguments =
        move || unsafe { format!("vr = {}, value -> {}", b::listed(vr, nvr), b::listed(values, nvr)) };
    b::counted(instance, "fmi3GetInt64", nValues, nvr, || {
        b::with_instance_logged(instance, "fmi3GetInt64", arguments, |instance| unsafe {
            instance.get_integer(
                b::array(vr, nvr, "valueReferences")?,
                b::array_mut(values, nvr, "values")?,
            )
        })
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetInt64(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *const fmi3Int64,
    nValues: usize,
) -> fmi3Status {
    let (vr, nvr) = (valueReferences, nValueReferences);
    let arguments =
        move || unsafe { format!("vr = {}, value = {}", b::listed(vr, nvr), b::listed(values, nvr)) };
    b::counted(instance, "fmi3SetInt64", nValues, nvr, || {
        b::with_instance_logged(instance, "fmi3SetInt64", arguments, |instance| unsafe {
            let given = b::array(values, nvr, "values")?;
            let selectors = given
                .iter()
                .map(|&v| {
                    i32::try_from(v).map_err(|_| {
                        Rejection::error(format!("value {v} is not one of the enumeration's items"))
                    })
                })
                .collect::<CallResult<Vec<i32>>>()?;
            instance.set_integer(b::array(vr, nvr, "valueReferences")?, &selectors)
        })
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetString(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *mut fmi3String,
    nValues: usize,
) -> fmi3Status {
    b::counted(instance, "fmi3GetString", nValues, nValueReferences, || {
        b::get_string(
            instance,
            "fmi3GetString",
            valueReferences,
            nValueReferences,
            values,
        )
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetString(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    values: *const fmi3String,
    nValues: usize,
) -> fmi3Status {
    b::counted(instance, "fmi3SetString", nValues, nValueReferences, || {
        b::set_string(
            instance,
            "fmi3SetString",
            valueReferences,
            nValueReferences,
            values,
        )
    })
}

/// Get and set of the types this FMU has no variables of: fine for an empty list of
/// value references, an error naming the variable otherwise.
macro_rules! no_variables_of_type {
    ($($get:ident $set:ident $t:ty;)*) => {$(
        #[unsafe(no_mangle)]
        pub extern "C" fn $get(
            instance: fmi3Instance,
            valueReferences: *const fmi3ValueReference,
            nValueReferences: usize,
            _values: *mut $t,
            _nValues: usize,
        ) -> fmi3Status {
            b::no_variables_of_type(instance, stringify!($get), Call::GetValues, valueReferences, nValueReferences)
        }

        #[unsafe(no_mangle)]
        pub extern "C" fn $set(
            instance: fmi3Instance,
            valueReferences: *const fmi3ValueReference,
            nValueReferences: usize,
            _values: *const $t,
            _nValues: usize,
        ) -> fmi3Status {
            b::no_variables_of_type(instance, stringify!($set), Call::SetValues, valueReferences, nValueReferences)
        }
    )*};
}

no_variables_of_type! {
    fmi3GetFloat32 fmi3SetFloat32 fmi3Float32;
    fmi3GetInt8 fmi3SetInt8 fmi3Int8;
    fmi3GetUInt8 fmi3SetUInt8 fmi3UInt8;
    fmi3GetInt16 fmi3SetInt16 fmi3Int16;
    fmi3GetUInt16 fmi3SetUInt16 fmi3UInt16;
    fmi3GetInt32 fmi3SetInt32 fmi3Int32;
    fmi3GetUInt32 fmi3SetUInt32 fmi3UInt32;
    fmi3GetUInt64 fmi3SetUInt64 fmi3UInt64;
    fmi3GetBoolean fmi3SetBoolean fmi3Boolean;
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetBinary(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    _valueSizes: *mut usize,
    _values: *mut fmi3Binary,
    _nValues: usize,
) -> fmi3Status {
    b::no_variables_of_type(
        instance,
        "fmi3GetBinary",
        Call::GetValues,
        valueReferences,
        nValueReferences,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetBinary(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    _valueSizes: *const usize,
    _values: *const fmi3Binary,
    _nValues: usize,
) -> fmi3Status {
    b::no_variables_of_type(
        instance,
        "fmi3SetBinary",
        Call::SetValues,
        valueReferences,
        nValueReferences,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetClock(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    _values: *mut fmi3Clock,
) -> fmi3Status {
    b::no_variables_of_type(
        instance,
        "fmi3GetClock",
        Call::GetValues,
        valueReferences,
        nValueReferences,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetClock(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    _values: *const fmi3Clock,
) -> fmi3Status {
    b::no_variables_of_type(
        instance,
        "fmi3SetClock",
        Call::SetValues,
        valueReferences,
        nValueReferences,
    )
}

// ---------------------------------------------------------------- not provided

const NO_DEPENDENCIES: &str = "variable dependencies are not provided (providesPerElementDependencies=\"false\"); \
                               ModelStructure lists them";
const NO_CONFIGURATION: &str = "this FMU has no structural parameters, so no configuration mode";
const NO_CLOCKS: &str = "this FMU has no clocks";
const NO_SCHEDULED_EXECUTION: &str =
    "this FMU provides Co-Simulation and Model Exchange, not Scheduled Execution";

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetNumberOfVariableDependencies(
    instance: fmi3Instance,
    _valueReference: fmi3ValueReference,
    _nDependencies: *mut usize,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetNumberOfVariableDependencies", NO_DEPENDENCIES)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetVariableDependencies(
    instance: fmi3Instance,
    _dependent: fmi3ValueReference,
    _elementIndicesOfDependent: *mut usize,
    _independents: *mut fmi3ValueReference,
    _elementIndicesOfIndependents: *mut usize,
    _dependencyKinds: *mut fmi3DependencyKind,
    _nDependencies: usize,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetVariableDependencies", NO_DEPENDENCIES)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetAdjointDerivative(
    instance: fmi3Instance,
    _unknowns: *const fmi3ValueReference,
    _nUnknowns: usize,
    _knowns: *const fmi3ValueReference,
    _nKnowns: usize,
    _seed: *const fmi3Float64,
    _nSeed: usize,
    _sensitivity: *mut fmi3Float64,
    _nSensitivity: usize,
) -> fmi3Status {
    b::not_supported(
        instance,
        "fmi3GetAdjointDerivative",
        "adjoint derivatives are not provided (providesAdjointDerivatives=\"false\"); \
         fmi3GetDirectionalDerivative is",
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EnterConfigurationMode(instance: fmi3Instance) -> fmi3Status {
    b::not_supported(instance, "fmi3EnterConfigurationMode", NO_CONFIGURATION)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3ExitConfigurationMode(instance: fmi3Instance) -> fmi3Status {
    b::not_supported(instance, "fmi3ExitConfigurationMode", NO_CONFIGURATION)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetIntervalDecimal(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _intervals: *mut fmi3Float64,
    _qualifiers: *mut fmi3IntervalQualifier,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetIntervalDecimal", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetIntervalFraction(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _counters: *mut fmi3UInt64,
    _resolutions: *mut fmi3UInt64,
    _qualifiers: *mut fmi3IntervalQualifier,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetIntervalFraction", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetShiftDecimal(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _shifts: *mut fmi3Float64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetShiftDecimal", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetShiftFraction(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _counters: *mut fmi3UInt64,
    _resolutions: *mut fmi3UInt64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3GetShiftFraction", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetIntervalDecimal(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _intervals: *const fmi3Float64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3SetIntervalDecimal", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetIntervalFraction(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _counters: *const fmi3UInt64,
    _resolutions: *const fmi3UInt64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3SetIntervalFraction", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetShiftDecimal(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _shifts: *const fmi3Float64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3SetShiftDecimal", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetShiftFraction(
    instance: fmi3Instance,
    _valueReferences: *const fmi3ValueReference,
    _nValueReferences: usize,
    _counters: *const fmi3UInt64,
    _resolutions: *const fmi3UInt64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3SetShiftFraction", NO_CLOCKS)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EvaluateDiscreteStates(instance: fmi3Instance) -> fmi3Status {
    b::not_supported(
        instance,
        "fmi3EvaluateDiscreteStates",
        "this FMU has no clocks and no event mode in Co-Simulation (providesEvaluateDiscreteStates=\"false\")",
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3ActivateModelPartition(
    instance: fmi3Instance,
    _clockReference: fmi3ValueReference,
    _activationTime: fmi3Float64,
) -> fmi3Status {
    b::not_supported(instance, "fmi3ActivateModelPartition", NO_SCHEDULED_EXECUTION)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EnterStepMode(instance: fmi3Instance) -> fmi3Status {
    b::not_supported(
        instance,
        "fmi3EnterStepMode",
        "this FMU has no event mode in Co-Simulation (hasEventMode=\"false\"): a Co-Simulation \
         instance is in step mode from fmi3ExitInitializationMode on",
    )
}

// ---------------------------------------------------------------- FMU state

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetFMUState(instance: fmi3Instance, FMUState: *mut fmi3FMUState) -> fmi3Status {
    b::get_fmu_state(instance, "fmi3GetFMUState", FMUState)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetFMUState(instance: fmi3Instance, FMUState: fmi3FMUState) -> fmi3Status {
    b::set_fmu_state(instance, "fmi3SetFMUState", FMUState)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3FreeFMUState(instance: fmi3Instance, FMUState: *mut fmi3FMUState) -> fmi3Status {
    b::free_fmu_state(instance, "fmi3FreeFMUState", FMUState)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SerializedFMUStateSize(
    instance: fmi3Instance,
    FMUState: fmi3FMUState,
    size: *mut usize,
) -> fmi3Status {
    b::serialized_fmu_state_size(instance, "fmi3SerializedFMUStateSize", FMUState, size)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SerializeFMUState(
    instance: fmi3Instance,
    FMUState: fmi3FMUState,
    serializedState: *mut fmi3Byte,
    size: usize,
) -> fmi3Status {
    b::serialize_fmu_state(instance, "fmi3SerializeFMUState", FMUState, serializedState, size)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3DeserializeFMUState(
    instance: fmi3Instance,
    serializedState: *const fmi3Byte,
    size: usize,
    FMUState: *mut fmi3FMUState,
) -> fmi3Status {
    b::deserialize_fmu_state(
        instance,
        "fmi3DeserializeFMUState",
        serializedState,
        size,
        FMUState,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetDirectionalDerivative(
    instance: fmi3Instance,
    unknowns: *const fmi3ValueReference,
    nUnknowns: usize,
    knowns: *const fmi3ValueReference,
    nKnowns: usize,
    seed: *const fmi3Float64,
    nSeed: usize,
    sensitivity: *mut fmi3Float64,
    nSensitivity: usize,
) -> fmi3Status {
    let arrays = Directional {
        unknowns,
        n_unknowns: nUnknowns,
        knowns,
        n_knowns: nKnowns,
        seed,
        n_seed: nSeed,
        sensitivity,
        n_sensitivity: nSensitivity,
    };
    b::directional_derivative(instance, "fmi3GetDirectionalDerivative", arrays)
}

// ---------------------------------------------------------------- Model Exchange

#[unsafe(no_mangle)]
pub extern "C" fn fmi3UpdateDiscreteStates(
    instance: fmi3Instance,
    discreteStatesNeedUpdate: *mut fmi3Boolean,
    terminateSimulation: *mut fmi3Boolean,
    nominalsOfContinuousStatesChanged: *mut fmi3Boolean,
    valuesOfContinuousStatesChanged: *mut fmi3Boolean,
    nextEventTimeDefined: *mut fmi3Boolean,
    nextEventTime: *mut fmi3Float64,
) -> fmi3Status {
    b::update_discrete_states(instance, "fmi3UpdateDiscreteStates", |update| unsafe {
        // One update settles the modes; no time events.
        *out(discreteStatesNeedUpdate, "discreteStatesNeedUpdate")? = false;
        *out(terminateSimulation, "terminateSimulation")? = false;
        *out(
            nominalsOfContinuousStatesChanged,
            "nominalsOfContinuousStatesChanged",
        )? = false;
        *out(valuesOfContinuousStatesChanged, "valuesOfContinuousStatesChanged")? =
            update.continuous_states_changed;
        *out(nextEventTimeDefined, "nextEventTimeDefined")? = false;
        *out(nextEventTime, "nextEventTime")? = 0.0;
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3EnterContinuousTimeMode(instance: fmi3Instance) -> fmi3Status {
    with_instance(
        instance,
        "fmi3EnterContinuousTimeMode",
        Instance::enter_continuous_time_mode,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3CompletedIntegratorStep(
    instance: fmi3Instance,
    _noSetFMUStatePriorToCurrentPoint: fmi3Boolean,
    enterEventMode: *mut fmi3Boolean,
    terminateSimulation: *mut fmi3Boolean,
) -> fmi3Status {
    b::completed_integrator_step(
        instance,
        "fmi3CompletedIntegratorStep",
        enterEventMode,
        terminateSimulation,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetTime(instance: fmi3Instance, time: fmi3Float64) -> fmi3Status {
    b::set_time(instance, "fmi3SetTime", time)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3SetContinuousStates(
    instance: fmi3Instance,
    continuousStates: *const fmi3Float64,
    nContinuousStates: usize,
) -> fmi3Status {
    b::set_continuous_states(
        instance,
        "fmi3SetContinuousStates",
        continuousStates,
        nContinuousStates,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetContinuousStateDerivatives(
    instance: fmi3Instance,
    derivatives: *mut fmi3Float64,
    nContinuousStates: usize,
) -> fmi3Status {
    b::get_continuous_values(
        instance,
        "fmi3GetContinuousStateDerivatives",
        Instance::get_derivatives,
        derivatives,
        nContinuousStates,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetEventIndicators(
    instance: fmi3Instance,
    eventIndicators: *mut fmi3Float64,
    nEventIndicators: usize,
) -> fmi3Status {
    b::get_continuous_values(
        instance,
        "fmi3GetEventIndicators",
        Instance::get_event_indicators,
        eventIndicators,
        nEventIndicators,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetContinuousStates(
    instance: fmi3Instance,
    continuousStates: *mut fmi3Float64,
    nContinuousStates: usize,
) -> fmi3Status {
    b::get_continuous_values(
        instance,
        "fmi3GetContinuousStates",
        Instance::get_continuous_states,
        continuousStates,
        nContinuousStates,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetNominalsOfContinuousStates(
    instance: fmi3Instance,
    nominals: *mut fmi3Float64,
    nContinuousStates: usize,
) -> fmi3Status {
    b::get_continuous_values(
        instance,
        "fmi3GetNominalsOfContinuousStates",
        Instance::get_nominals,
        nominals,
        nContinuousStates,
    )
}

/// The fixed sizes of the Model Exchange arrays (the largest layout over the models and
/// laws, docs/specification.md 7b), known from instantiation on.
fn count(instance: fmi3Instance, function: &str, n: *mut usize, value: usize) -> fmi3Status {
    with_instance(instance, function, |_| {
        *unsafe { out(n, "the count")? } = value;
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetNumberOfEventIndicators(
    instance: fmi3Instance,
    nEventIndicators: *mut usize,
) -> fmi3Status {
    count(
        instance,
        "fmi3GetNumberOfEventIndicators",
        nEventIndicators,
        GUARDS,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetNumberOfContinuousStates(
    instance: fmi3Instance,
    nContinuousStates: *mut usize,
) -> fmi3Status {
    count(
        instance,
        "fmi3GetNumberOfContinuousStates",
        nContinuousStates,
        CONTINUOUS_STATES,
    )
}

// ---------------------------------------------------------------- Co-Simulation

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetOutputDerivatives(
    instance: fmi3Instance,
    valueReferences: *const fmi3ValueReference,
    nValueReferences: usize,
    orders: *const fmi3Int32,
    values: *mut fmi3Float64,
    nValues: usize,
) -> fmi3Status {
    b::counted(
        instance,
        "fmi3GetOutputDerivatives",
        nValues,
        nValueReferences,
        || {
            b::get_output_derivatives(
                instance,
                "fmi3GetOutputDerivatives",
                valueReferences,
                nValueReferences,
                orders,
                values,
            )
        },
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3DoStep(
    instance: fmi3Instance,
    currentCommunicationPoint: fmi3Float64,
    communicationStepSize: fmi3Float64,
    _noSetFMUStatePriorToCurrentPoint: fmi3Boolean,
    eventHandlingNeeded: *mut fmi3Boolean,
    terminateSimulation: *mut fmi3Boolean,
    earlyReturn: *mut fmi3Boolean,
    lastSuccessfulTime: *mut fmi3Float64,
) -> fmi3Status {
    let flags = [eventHandlingNeeded, terminateSimulation, earlyReturn];
    if flags.iter().any(|f| f.is_null()) || lastSuccessfulTime.is_null() {
        return null_step_output(instance, flags);
    }
    // FMI 3.0's reports around the step of FMI 2.0: a step is taken whole or not at all,
    // with no event and no early return (written first: nothing to keep across the step);
    // the time reached is the instance's.
    // SAFETY: checked non-null above; the importer promises writable values behind them.
    unsafe {
        for flag in flags {
            *flag = false;
        }
    }
    let status = b::do_step(
        instance,
        "fmi3DoStep",
        currentCommunicationPoint,
        communicationStepSize,
    );
    // SAFETY: as above.
    unsafe { *lastSuccessfulTime = b::time_of(instance).unwrap_or(currentCommunicationPoint) };
    status
}

/// fmi3DoStep with an output pointer NULL: refused, naming it, before anything moves.
#[cold]
#[inline(never)]
fn null_step_output(instance: fmi3Instance, flags: [*mut fmi3Boolean; 3]) -> fmi3Status {
    with_instance(instance, "fmi3DoStep", |_| {
        let names = ["eventHandlingNeeded", "terminateSimulation", "earlyReturn"];
        let null = flags
            .iter()
            .zip(names)
            .find(|(f, _)| f.is_null())
            .map(|(_, name)| name);
        Err(Rejection::error(format!(
            "{} is NULL",
            null.unwrap_or("lastSuccessfulTime")
        )))
    })
}

// Every export has exactly the signature of its typedef in the official headers.
const _: fmi3GetVersionTYPE = Some(fmi3GetVersion);
const _: fmi3SetDebugLoggingTYPE = Some(fmi3SetDebugLogging);
const _: fmi3InstantiateModelExchangeTYPE = Some(fmi3InstantiateModelExchange);
const _: fmi3InstantiateCoSimulationTYPE = Some(fmi3InstantiateCoSimulation);
const _: fmi3InstantiateScheduledExecutionTYPE = Some(fmi3InstantiateScheduledExecution);
const _: fmi3FreeInstanceTYPE = Some(fmi3FreeInstance);
const _: fmi3EnterInitializationModeTYPE = Some(fmi3EnterInitializationMode);
const _: fmi3ExitInitializationModeTYPE = Some(fmi3ExitInitializationMode);
const _: fmi3EnterEventModeTYPE = Some(fmi3EnterEventMode);
const _: fmi3TerminateTYPE = Some(fmi3Terminate);
const _: fmi3ResetTYPE = Some(fmi3Reset);
const _: fmi3GetFloat32TYPE = Some(fmi3GetFloat32);
const _: fmi3GetFloat64TYPE = Some(fmi3GetFloat64);
const _: fmi3GetInt8TYPE = Some(fmi3GetInt8);
const _: fmi3GetUInt8TYPE = Some(fmi3GetUInt8);
const _: fmi3GetInt16TYPE = Some(fmi3GetInt16);
const _: fmi3GetUInt16TYPE = Some(fmi3GetUInt16);
const _: fmi3GetInt32TYPE = Some(fmi3GetInt32);
const _: fmi3GetUInt32TYPE = Some(fmi3GetUInt32);
const _: fmi3GetInt64TYPE = Some(fmi3GetInt64);
const _: fmi3GetUInt64TYPE = Some(fmi3GetUInt64);
const _: fmi3GetBooleanTYPE = Some(fmi3GetBoolean);
const _: fmi3GetStringTYPE = Some(fmi3GetString);
const _: fmi3GetBinaryTYPE = Some(fmi3GetBinary);
const _: fmi3GetClockTYPE = Some(fmi3GetClock);
const _: fmi3SetFloat32TYPE = Some(fmi3SetFloat32);
const _: fmi3SetFloat64TYPE = Some(fmi3SetFloat64);
const _: fmi3SetInt8TYPE = Some(fmi3SetInt8);
const _: fmi3SetUInt8TYPE = Some(fmi3SetUInt8);
const _: fmi3SetInt16TYPE = Some(fmi3SetInt16);
const _: fmi3SetUInt16TYPE = Some(fmi3SetUInt16);
const _: fmi3SetInt32TYPE = Some(fmi3SetInt32);
const _: fmi3SetUInt32TYPE = Some(fmi3SetUInt32);
const _: fmi3SetInt64TYPE = Some(fmi3SetInt64);
const _: fmi3SetUInt64TYPE = Some(fmi3SetUInt64);
const _: fmi3SetBooleanTYPE = Some(fmi3SetBoolean);
const _: fmi3SetStringTYPE = Some(fmi3SetString);
const _: fmi3SetBinaryTYPE = Some(fmi3SetBinary);
const _: fmi3SetClockTYPE = Some(fmi3SetClock);
const _: fmi3GetNumberOfVariableDependenciesTYPE = Some(fmi3GetNumberOfVariableDependencies);
const _: fmi3GetVariableDependenciesTYPE = Some(fmi3GetVariableDependencies);
const _: fmi3GetFMUStateTYPE = Some(fmi3GetFMUState);
const _: fmi3SetFMUStateTYPE = Some(fmi3SetFMUState);
const _: fmi3FreeFMUStateTYPE = Some(fmi3FreeFMUState);
const _: fmi3SerializedFMUStateSizeTYPE = Some(fmi3SerializedFMUStateSize);
const _: fmi3SerializeFMUStateTYPE = Some(fmi3SerializeFMUState);
const _: fmi3DeserializeFMUStateTYPE = Some(fmi3DeserializeFMUState);
const _: fmi3GetDirectionalDerivativeTYPE = Some(fmi3GetDirectionalDerivative);
const _: fmi3GetAdjointDerivativeTYPE = Some(fmi3GetAdjointDerivative);
const _: fmi3EnterConfigurationModeTYPE = Some(fmi3EnterConfigurationMode);
const _: fmi3ExitConfigurationModeTYPE = Some(fmi3ExitConfigurationMode);
const _: fmi3GetIntervalDecimalTYPE = Some(fmi3GetIntervalDecimal);
const _: fmi3GetIntervalFractionTYPE = Some(fmi3GetIntervalFraction);
const _: fmi3GetShiftDecimalTYPE = Some(fmi3GetShiftDecimal);
const _: fmi3GetShiftFractionTYPE = Some(fmi3GetShiftFraction);
const _: fmi3SetIntervalDecimalTYPE = Some(fmi3SetIntervalDecimal);
const _: fmi3SetIntervalFractionTYPE = Some(fmi3SetIntervalFraction);
const _: fmi3SetShiftDecimalTYPE = Some(fmi3SetShiftDecimal);
const _: fmi3SetShiftFractionTYPE = Some(fmi3SetShiftFraction);
const _: fmi3EvaluateDiscreteStatesTYPE = Some(fmi3EvaluateDiscreteStates);
const _: fmi3UpdateDiscreteStatesTYPE = Some(fmi3UpdateDiscreteStates);
const _: fmi3EnterContinuousTimeModeTYPE = Some(fmi3EnterContinuousTimeMode);
const _: fmi3CompletedIntegratorStepTYPE = Some(fmi3CompletedIntegratorStep);
const _: fmi3SetTimeTYPE = Some(fmi3SetTime);
const _: fmi3SetContinuousStatesTYPE = Some(fmi3SetContinuousStates);
const _: fmi3GetContinuousStateDerivativesTYPE = Some(fmi3GetContinuousStateDerivatives);
const _: fmi3GetEventIndicatorsTYPE = Some(fmi3GetEventIndicators);
const _: fmi3GetContinuousStatesTYPE = Some(fmi3GetContinuousStates);
const _: fmi3GetNominalsOfContinuousStatesTYPE = Some(fmi3GetNominalsOfContinuousStates);
const _: fmi3GetNumberOfEventIndicatorsTYPE = Some(fmi3GetNumberOfEventIndicators);
const _: fmi3GetNumberOfContinuousStatesTYPE = Some(fmi3GetNumberOfContinuousStates);
const _: fmi3EnterStepModeTYPE = Some(fmi3EnterStepMode);
const _: fmi3GetOutputDerivativesTYPE = Some(fmi3GetOutputDerivatives);
const _: fmi3DoStepTYPE = Some(fmi3DoStep);
const _: fmi3ActivateModelPartitionTYPE = Some(fmi3ActivateModelPartition);
