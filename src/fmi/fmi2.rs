//! The exported FMI 2.0 functions: each names itself and hands its arguments to the
//! shared C boundary ([`super::boundary`]). Each function's signature is checked at
//! compile time against its typedef in the official headers (`fmi2...TYPE`).

#![allow(non_snake_case, non_upper_case_globals)]
// These are the C ABI: the FMI standard makes the importer promise valid pointers, and every
// one is checked for NULL before use. They are public so that Rust can call them in-process
// too (tests/no_allocation.rs), with the same promise.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::c_char;

use super::boundary::{self as b, Directional, Instantiation, out, with_instance};
use super::instance::{Instance, Interface, path_of_file_uri};
use super::logger::Callback;
use super::state_machine::Call;
use super::status::{CallResult, Rejection, Status};
use super::sys::*;

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2Instantiate(
    instanceName: fmi2String,
    fmuType: fmi2Type,
    fmuGUID: fmi2String,
    fmuResourceLocation: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    // SAFETY: a non-null callback table is the importer's, valid for the instance's life.
    // FMI 2.0 requires a logger: without one the instance is refused, silently.
    let Some(functions) = (unsafe { functions.as_ref() }).filter(|f| f.logger.is_some()) else {
        return std::ptr::null_mut();
    };
    let interface = match fmuType {
        fmi2Type_fmi2CoSimulation => Ok(Interface::CoSimulation),
        fmi2Type_fmi2ModelExchange => Ok(Interface::ModelExchange),
        _ => Err(format!(
            "fmuType {fmuType} is neither fmi2ModelExchange ({fmi2Type_fmi2ModelExchange}) nor \
             fmi2CoSimulation ({fmi2Type_fmi2CoSimulation})"
        )),
    };
    b::instantiate(Instantiation {
        function: "fmi2Instantiate",
        instance_name: instanceName,
        token: fmuGUID,
        interface: *interface.as_ref().unwrap_or(&Interface::CoSimulation),
        callback: Callback::Fmi2 {
            logger: functions.logger,
            environment: functions.componentEnvironment,
        },
        logging_on: loggingOn != 0,
        // The resources folder, for a relative tirFile, as a file: URI; an importer may
        // give none.
        resources: unsafe { b::text(fmuResourceLocation, "fmuResourceLocation") }
            .ok()
            .and_then(path_of_file_uri),
        refusal: interface.err(),
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    b::free_instance(c)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    nCategories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    b::set_debug_logging(c, "fmi2SetDebugLogging", loggingOn != 0, nCategories, categories)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _toleranceDefined: fmi2Boolean,
    _tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    let arguments = move || {
        format!(
            "toleranceDefined = {_toleranceDefined}, tolerance = {_tolerance}, startTime = {startTime}, \
             stopTimeDefined = {stopTimeDefined}, stopTime = {stopTime}"
        )
    };
    b::with_instance_logged(c, "fmi2SetupExperiment", arguments, |instance| {
        instance.setup_experiment(startTime, (stopTimeDefined != 0).then_some(stopTime))
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    with_instance(
        c,
        "fmi2EnterInitializationMode",
        Instance::enter_initialization_mode,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    with_instance(
        c,
        "fmi2ExitInitializationMode",
        Instance::exit_initialization_mode,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2Terminate", Instance::terminate)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2Reset", Instance::reset)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Real,
) -> fmi2Status {
    b::get_real(c, "fmi2GetReal", vr, nvr, value)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Integer,
) -> fmi2Status {
    let arguments =
        move || unsafe { format!("vr = {}, value -> {}", b::listed(vr, nvr), b::listed(value, nvr)) };
    b::with_instance_logged(c, "fmi2GetInteger", arguments, |instance| unsafe {
        instance.get_integer(b::array(vr, nvr, "vr")?, b::array_mut(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    _value: *mut fmi2Boolean,
) -> fmi2Status {
    b::no_variables_of_type(c, "fmi2GetBoolean", Call::GetValues, vr, nvr)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    b::get_string(c, "fmi2GetString", vr, nvr, value)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    b::set_real(c, "fmi2SetReal", vr, nvr, value)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Integer,
) -> fmi2Status {
    let arguments =
        move || unsafe { format!("vr = {}, value = {}", b::listed(vr, nvr), b::listed(value, nvr)) };
    b::with_instance_logged(c, "fmi2SetInteger", arguments, |instance| unsafe {
        instance.set_integer(b::array(vr, nvr, "vr")?, b::array(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    _value: *const fmi2Boolean,
) -> fmi2Status {
    b::no_variables_of_type(c, "fmi2SetBoolean", Call::SetValues, vr, nvr)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    b::set_string(c, "fmi2SetString", vr, nvr, value)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetFMUstate(c: fmi2Component, FMUstate: *mut fmi2FMUstate) -> fmi2Status {
    b::get_fmu_state(c, "fmi2GetFMUstate", FMUstate)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetFMUstate(c: fmi2Component, FMUstate: fmi2FMUstate) -> fmi2Status {
    b::set_fmu_state(c, "fmi2SetFMUstate", FMUstate)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeFMUstate(c: fmi2Component, FMUstate: *mut fmi2FMUstate) -> fmi2Status {
    b::free_fmu_state(c, "fmi2FreeFMUstate", FMUstate)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    b::serialized_fmu_state_size(c, "fmi2SerializedFMUstateSize", FMUstate, size)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    serializedState: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    b::serialize_fmu_state(c, "fmi2SerializeFMUstate", FMUstate, serializedState.cast(), size)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    serializedState: *const fmi2Byte,
    size: usize,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    b::deserialize_fmu_state(
        c,
        "fmi2DeSerializeFMUstate",
        serializedState.cast(),
        size,
        FMUstate,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    vUnknown_ref: *const fmi2ValueReference,
    nUnknown: usize,
    vKnown_ref: *const fmi2ValueReference,
    nKnown: usize,
    dvKnown: *const fmi2Real,
    dvUnknown: *mut fmi2Real,
) -> fmi2Status {
    let arrays = Directional {
        unknowns: vUnknown_ref,
        n_unknowns: nUnknown,
        knowns: vKnown_ref,
        n_knowns: nKnown,
        seed: dvKnown,
        n_seed: nKnown,
        sensitivity: dvUnknown,
        n_sensitivity: nUnknown,
    };
    b::directional_derivative(c, "fmi2GetDirectionalDerivative", arrays)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *const fmi2Real,
) -> fmi2Status {
    let arguments = move || unsafe {
        format!(
            "vr = {}, order = {}, value = {}",
            b::listed(vr, nvr),
            b::listed(order, nvr),
            b::listed(value, nvr)
        )
    };
    b::with_instance_logged(c, "fmi2SetRealInputDerivatives", arguments, |instance| unsafe {
        instance.set_input_derivatives(
            b::array(vr, nvr, "vr")?,
            b::array(order, nvr, "order")?,
            b::array(value, nvr, "value")?,
        )
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *mut fmi2Real,
) -> fmi2Status {
    b::get_output_derivatives(c, "fmi2GetRealOutputDerivatives", vr, nvr, order, value)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    b::do_step(c, "fmi2DoStep", currentCommunicationPoint, communicationStepSize)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2CancelStep", |instance| instance.require(Call::CancelStep))
}

// ---------------------------------------------------------------- Model Exchange

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetTime(c: fmi2Component, time: fmi2Real) -> fmi2Status {
    b::set_time(c, "fmi2SetTime", time)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetContinuousStates(c: fmi2Component, x: *const fmi2Real, nx: usize) -> fmi2Status {
    b::set_continuous_states(c, "fmi2SetContinuousStates", x, nx)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterEventMode(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2EnterEventMode", Instance::enter_event_mode)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2NewDiscreteStates(c: fmi2Component, fmi2eventInfo: *mut fmi2EventInfo) -> fmi2Status {
    b::update_discrete_states(c, "fmi2NewDiscreteStates", |update| {
        let info = unsafe { out(fmi2eventInfo, "fmi2eventInfo")? };
        *info = fmi2EventInfo {
            newDiscreteStatesNeeded: 0,
            terminateSimulation: 0,
            nominalsOfContinuousStatesChanged: 0,
            valuesOfContinuousStatesChanged: update.continuous_states_changed.into(),
            nextEventTimeDefined: 0,
            nextEventTime: 0.0,
        };
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterContinuousTimeMode(c: fmi2Component) -> fmi2Status {
    with_instance(
        c,
        "fmi2EnterContinuousTimeMode",
        Instance::enter_continuous_time_mode,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2CompletedIntegratorStep(
    c: fmi2Component,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
    enterEventMode: *mut fmi2Boolean,
    terminateSimulation: *mut fmi2Boolean,
) -> fmi2Status {
    b::completed_integrator_step(
        c,
        "fmi2CompletedIntegratorStep",
        enterEventMode,
        terminateSimulation,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetDerivatives(c: fmi2Component, derivatives: *mut fmi2Real, nx: usize) -> fmi2Status {
    b::get_continuous_values(
        c,
        "fmi2GetDerivatives",
        Instance::get_derivatives,
        derivatives,
        nx,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetEventIndicators(
    c: fmi2Component,
    eventIndicators: *mut fmi2Real,
    ni: usize,
) -> fmi2Status {
    b::get_continuous_values(
        c,
        "fmi2GetEventIndicators",
        Instance::get_event_indicators,
        eventIndicators,
        ni,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetContinuousStates(c: fmi2Component, x: *mut fmi2Real, nx: usize) -> fmi2Status {
    b::get_continuous_values(
        c,
        "fmi2GetContinuousStates",
        Instance::get_continuous_states,
        x,
        nx,
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetNominalsOfContinuousStates(
    c: fmi2Component,
    x_nominal: *mut fmi2Real,
    nx: usize,
) -> fmi2Status {
    b::get_continuous_values(
        c,
        "fmi2GetNominalsOfContinuousStates",
        Instance::get_nominals,
        x_nominal,
        nx,
    )
}

/// The status functions. fmi2DoStep never returns fmi2Pending, so the last step is
/// always complete, no status is pending, and the FMU never asks to terminate.
fn status_value<T>(
    c: fmi2Component,
    function: &str,
    value: *mut T,
    get: impl FnOnce(&Instance) -> CallResult<T>,
) -> fmi2Status {
    with_instance(c, function, |instance| {
        instance.require(Call::GetStatus)?;
        let slot = unsafe { out(value, "value")? };
        *slot = get(instance)?;
        Ok(())
    })
}

fn not_provided<T>(kind: fmi2StatusKind) -> CallResult<T> {
    Err(Rejection::discard(format!(
        "status kind {kind} is not provided by this function"
    )))
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Status) -> fmi2Status {
    status_value(c, "fmi2GetStatus", value, |_| match s {
        fmi2StatusKind_fmi2DoStepStatus => Ok(Status::Ok as fmi2Status),
        _ => not_provided(s),
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Real) -> fmi2Status {
    status_value(c, "fmi2GetRealStatus", value, |instance| match s {
        fmi2StatusKind_fmi2LastSuccessfulTime => Ok(instance.time()),
        _ => not_provided(s),
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Integer,
) -> fmi2Status {
    status_value(c, "fmi2GetIntegerStatus", value, |_| not_provided(s))
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetBooleanStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    status_value(c, "fmi2GetBooleanStatus", value, |_| match s {
        fmi2StatusKind_fmi2Terminated => Ok(0),
        _ => not_provided(s),
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2String,
) -> fmi2Status {
    status_value(c, "fmi2GetStringStatus", value, |_| not_provided(s))
}

// Every export has exactly the signature of its typedef in the official headers.
const _: fmi2GetTypesPlatformTYPE = Some(fmi2GetTypesPlatform);
const _: fmi2GetVersionTYPE = Some(fmi2GetVersion);
const _: fmi2SetDebugLoggingTYPE = Some(fmi2SetDebugLogging);
const _: fmi2InstantiateTYPE = Some(fmi2Instantiate);
const _: fmi2FreeInstanceTYPE = Some(fmi2FreeInstance);
const _: fmi2SetupExperimentTYPE = Some(fmi2SetupExperiment);
const _: fmi2EnterInitializationModeTYPE = Some(fmi2EnterInitializationMode);
const _: fmi2ExitInitializationModeTYPE = Some(fmi2ExitInitializationMode);
const _: fmi2TerminateTYPE = Some(fmi2Terminate);
const _: fmi2ResetTYPE = Some(fmi2Reset);
const _: fmi2GetRealTYPE = Some(fmi2GetReal);
const _: fmi2GetIntegerTYPE = Some(fmi2GetInteger);
const _: fmi2GetBooleanTYPE = Some(fmi2GetBoolean);
const _: fmi2GetStringTYPE = Some(fmi2GetString);
const _: fmi2SetRealTYPE = Some(fmi2SetReal);
const _: fmi2SetIntegerTYPE = Some(fmi2SetInteger);
const _: fmi2SetBooleanTYPE = Some(fmi2SetBoolean);
const _: fmi2SetStringTYPE = Some(fmi2SetString);
const _: fmi2GetFMUstateTYPE = Some(fmi2GetFMUstate);
const _: fmi2SetFMUstateTYPE = Some(fmi2SetFMUstate);
const _: fmi2FreeFMUstateTYPE = Some(fmi2FreeFMUstate);
const _: fmi2SerializedFMUstateSizeTYPE = Some(fmi2SerializedFMUstateSize);
const _: fmi2SerializeFMUstateTYPE = Some(fmi2SerializeFMUstate);
const _: fmi2DeSerializeFMUstateTYPE = Some(fmi2DeSerializeFMUstate);
const _: fmi2GetDirectionalDerivativeTYPE = Some(fmi2GetDirectionalDerivative);
const _: fmi2SetRealInputDerivativesTYPE = Some(fmi2SetRealInputDerivatives);
const _: fmi2GetRealOutputDerivativesTYPE = Some(fmi2GetRealOutputDerivatives);
const _: fmi2DoStepTYPE = Some(fmi2DoStep);
const _: fmi2CancelStepTYPE = Some(fmi2CancelStep);
const _: fmi2GetStatusTYPE = Some(fmi2GetStatus);
const _: fmi2GetRealStatusTYPE = Some(fmi2GetRealStatus);
const _: fmi2GetIntegerStatusTYPE = Some(fmi2GetIntegerStatus);
const _: fmi2GetBooleanStatusTYPE = Some(fmi2GetBooleanStatus);
const _: fmi2GetStringStatusTYPE = Some(fmi2GetStringStatus);
const _: fmi2SetTimeTYPE = Some(fmi2SetTime);
const _: fmi2SetContinuousStatesTYPE = Some(fmi2SetContinuousStates);
const _: fmi2EnterEventModeTYPE = Some(fmi2EnterEventMode);
const _: fmi2NewDiscreteStatesTYPE = Some(fmi2NewDiscreteStates);
const _: fmi2EnterContinuousTimeModeTYPE = Some(fmi2EnterContinuousTimeMode);
const _: fmi2CompletedIntegratorStepTYPE = Some(fmi2CompletedIntegratorStep);
const _: fmi2GetDerivativesTYPE = Some(fmi2GetDerivatives);
const _: fmi2GetEventIndicatorsTYPE = Some(fmi2GetEventIndicators);
const _: fmi2GetContinuousStatesTYPE = Some(fmi2GetContinuousStates);
const _: fmi2GetNominalsOfContinuousStatesTYPE = Some(fmi2GetNominalsOfContinuousStates);
