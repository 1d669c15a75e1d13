//! The exported FMI 2.0 functions: pointer checks, the panic boundary and the mapping
//! from call results to status codes. Each function's signature is checked at compile
//! time against its typedef in the official headers (`fmi2...TYPE`).

#![allow(non_snake_case, non_upper_case_globals)]
// These are the C ABI: the FMI standard makes the importer promise valid pointers, and every
// one is checked for NULL before use. They are public so that Rust can call them in-process
// too (tests/no_allocation.rs), with the same promise.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr::null_mut;

use super::instance::{Instance, Interface};
use super::logger::{self, Category, Logger};
use super::snapshot::Snapshot;
use super::state_machine::Call;
use super::status::{CallResult, Rejection, Status};
use super::sys::*;
use super::variables::GUID;

/// An fmi2FMUstate: a snapshot owned by the importer until fmi2FreeFMUstate.
struct FmuState(Snapshot);

/// Upper bound on the element count of any array argument; far above any real use, and
/// it keeps a garbage count from becoming an absurd slice.
const MAX_ELEMENTS: usize = 1 << 24;

/// Borrows a C array; null is accepted only for zero elements.
///
/// # Safety
/// A non-null `ptr` must point to `n` valid elements for the duration of the call.
#[inline]
unsafe fn array<'a, T>(ptr: *const T, n: usize, name: &str) -> CallResult<&'a [T]> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() || n > MAX_ELEMENTS {
        return Err(bad_array(ptr.is_null(), n, name));
    }
    // SAFETY: non-null, and the caller promises `n` elements.
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

#[cold]
#[inline(never)]
fn bad_array(null: bool, n: usize, name: &str) -> Box<Rejection> {
    if null {
        Rejection::error(format!("{name} is NULL but {n} elements were given"))
    } else {
        Rejection::error(format!(
            "{name}: {n} elements is more than the {MAX_ELEMENTS} allowed"
        ))
    }
}

/// # Safety
/// As [`array`], for writing.
unsafe fn array_mut<'a, T>(ptr: *mut T, n: usize, name: &str) -> CallResult<&'a mut [T]> {
    unsafe { array(ptr, n, name)? };
    if n == 0 {
        return Ok(&mut []);
    }
    // SAFETY: checked non-null and bounded above; the caller promises `n` elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// # Safety
/// A non-null `ptr` must point to a writable `T`.
unsafe fn out<'a, T>(ptr: *mut T, name: &str) -> CallResult<&'a mut T> {
    // SAFETY: the caller promises a writable T behind a non-null pointer.
    unsafe { ptr.as_mut() }.ok_or_else(|| Rejection::error(format!("{name} is NULL")))
}

/// # Safety
/// A non-null `ptr` must be a NUL-terminated string.
unsafe fn text<'a>(ptr: *const c_char, name: &str) -> CallResult<&'a str> {
    if ptr.is_null() {
        return Err(Rejection::error(format!("{name} is NULL")));
    }
    // SAFETY: non-null and NUL-terminated by the caller's promise.
    unsafe { CStr::from_ptr(ptr) }
        .to_str()
        .map_err(|_| Rejection::error(format!("{name} is not UTF-8")))
}

/// Runs `body` on the instance behind `c`, inside the panic boundary, and turns its
/// result into a status, logging the reason for anything but fmi2OK.
fn with_instance(
    c: fmi2Component,
    function: &str,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> fmi2Status {
    with_instance_logged(c, function, String::new, body)
}

/// [`with_instance`] for a call with arguments: after the call succeeds, with logAll on,
/// the log names the function with `arguments()` (value references, values, times; the
/// values a get wrote). `arguments` is not called otherwise, so it costs nothing then.
fn with_instance_logged(
    c: fmi2Component,
    function: &str,
    arguments: impl FnOnce() -> String,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> fmi2Status {
    let instance = c.cast::<Instance>();
    if instance.is_null() {
        return Status::Error as fmi2Status;
    }
    // SAFETY: a non-null component is an instance made by fmi2Instantiate and not yet
    // freed; the importer calls it from one thread at a time.
    let result = catch_unwind(AssertUnwindSafe(|| body(unsafe { &mut *instance })));
    let instance = unsafe { &mut *instance };
    let status = match result {
        Ok(Ok(())) => {
            if instance.logger.enabled(Category::All) {
                log_call(instance, function, arguments);
            }
            Status::Ok
        }
        failure => report_failure(instance, function, failure),
    };
    status as fmi2Status
}

/// The logAll message of a call that succeeded: `function(arguments)`.
#[cold]
#[inline(never)]
fn log_call(instance: &Instance, function: &str, arguments: impl FnOnce() -> String) {
    let arguments = catch_unwind(AssertUnwindSafe(arguments)).unwrap_or_default();
    instance
        .logger
        .log(Status::Ok, Category::All, &format!("{function}({arguments})"));
}

/// At most this many elements of an array argument are written into a log message.
const LOGGED_ELEMENTS: usize = 64;

/// An array argument for a log message, `[a, b, c]`; the first [`LOGGED_ELEMENTS`] and the
/// count of the rest.
///
/// # Safety
/// As [`array`]; only called for arrays the call itself has read or written.
unsafe fn listed<T: std::fmt::Debug>(ptr: *const T, n: usize) -> String {
    let Ok(elements) = (unsafe { array(ptr, n, "") }) else {
        return "?".into();
    };
    let shown: Vec<String> = elements
        .iter()
        .take(LOGGED_ELEMENTS)
        .map(|e| format!("{e:?}"))
        .collect();
    match elements.len().checked_sub(LOGGED_ELEMENTS) {
        Some(rest) if rest > 0 => format!("[{}, ... {rest} more]", shown.join(", ")),
        _ => format!("[{}]", shown.join(", ")),
    }
}

/// Logs why a call failed and gives its status; out of line, off the path of a call that
/// succeeds.
#[cold]
#[inline(never)]
fn report_failure(
    instance: &mut Instance,
    function: &str,
    failure: std::thread::Result<CallResult>,
) -> Status {
    match failure {
        Ok(Ok(())) => Status::Ok,
        Ok(Err(rejection)) => {
            instance.log(rejection.status, &format!("{function}: {}", rejection.message));
            rejection.status
        }
        Err(_) => {
            instance.poison();
            instance.log(
                Status::Fatal,
                &format!("{function}: internal error; only fmi2FreeInstance and fmi2Reset are allowed now"),
            );
            Status::Fatal
        }
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// Checks fmi2Instantiate's arguments and makes the instance, or says why not.
///
/// # Safety
/// Pointers as fmi2Instantiate's.
unsafe fn instantiate(
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    guid: fmi2String,
    resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    logging_on: bool,
) -> Option<Box<Instance>> {
    // SAFETY: a non-null callback table is the importer's, valid for the instance's life.
    let functions = unsafe { functions.as_ref() }?;
    let callback = functions.logger;
    callback?;
    let environment = functions.componentEnvironment;
    let name = unsafe { text(instance_name, "instanceName") }
        .ok()
        .filter(|n| !n.is_empty());
    let report = |message: String| {
        let shown = CString::new(name.unwrap_or("")).unwrap_or_default();
        logger::send(
            callback,
            environment,
            &shown,
            Status::Error,
            Category::StatusError,
            &format!("fmi2Instantiate: {message}"),
        );
        None
    };
    let Some(name) = name else {
        return report("instanceName must be a non-empty string".into());
    };
    let interface = match fmu_type {
        fmi2Type_fmi2CoSimulation => Interface::CoSimulation,
        fmi2Type_fmi2ModelExchange => Interface::ModelExchange,
        _ => {
            return report(format!(
                "fmuType {fmu_type} is neither fmi2ModelExchange ({fmi2Type_fmi2ModelExchange}) nor \
                 fmi2CoSimulation ({fmi2Type_fmi2CoSimulation})"
            ));
        }
    };
    match unsafe { text(guid, "fmuGUID") } {
        Ok(given) if given == GUID => {}
        Ok(given) => return report(format!("fmuGUID {given} does not match this FMU's {GUID}")),
        Err(e) => return report(e.message),
    }
    let logger = Logger::new(
        callback,
        environment,
        CString::new(name).unwrap_or_default(),
        logging_on,
    );
    // The resources folder, for a relative tirFile; an importer may give none.
    let resources = unsafe { text(resource_location, "fmuResourceLocation") }
        .ok()
        .and_then(super::instance::path_of_file_uri);
    match Instance::new(logger, interface, resources) {
        Ok(instance) => Some(Box::new(instance)),
        Err(e) => report(e),
    }
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
    let made = catch_unwind(|| unsafe {
        instantiate(
            instanceName,
            fmuType,
            fmuGUID,
            fmuResourceLocation,
            functions,
            loggingOn != 0,
        )
    });
    match made {
        Ok(Some(instance)) => Box::into_raw(instance).cast(),
        _ => null_mut(),
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    if !c.is_null() {
        // SAFETY: made by fmi2Instantiate with Box::into_raw, freed once by the importer.
        let _ = catch_unwind(|| drop(unsafe { Box::from_raw(c.cast::<Instance>()) }));
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    nCategories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    let arguments = move || {
        let names = unsafe { array(categories, nCategories, "") }
            .map(|pointers| {
                pointers
                    .iter()
                    .map(|&p| unsafe { text(p, "") }.map_or("?", |t| t))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default();
        format!("loggingOn = {loggingOn}, categories = [{names}]")
    };
    with_instance_logged(c, "fmi2SetDebugLogging", arguments, |instance| {
        instance.require(Call::SetDebugLogging)?;
        let pointers = unsafe { array(categories, nCategories, "categories")? };
        let names = pointers
            .iter()
            .map(|&p| unsafe { text(p, "category") })
            .collect::<CallResult<Vec<_>>>()?;
        instance.set_debug_logging(loggingOn != 0, &names)
    })
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
    with_instance_logged(c, "fmi2SetupExperiment", arguments, |instance| {
        instance.require(Call::SetupExperiment)?;
        instance.setup_experiment(startTime, (stopTimeDefined != 0).then_some(stopTime))
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2EnterInitializationMode", |instance| {
        instance.require(Call::EnterInitializationMode)?;
        instance.enter_initialization_mode()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2ExitInitializationMode", |instance| {
        instance.require(Call::ExitInitializationMode)?;
        instance.exit_initialization_mode()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2Terminate", |instance| {
        instance.require(Call::Terminate)?;
        instance.terminate()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2Reset", |instance| {
        instance.require(Call::Reset)?;
        instance.reset()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Real,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}, value -> {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, "fmi2GetReal", arguments, |instance| unsafe {
        instance.get_real(array(vr, nvr, "vr")?, array_mut(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Integer,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}, value -> {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, "fmi2GetInteger", arguments, |instance| unsafe {
        instance.get_integer(array(vr, nvr, "vr")?, array_mut(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    _value: *mut fmi2Boolean,
) -> fmi2Status {
    with_instance(c, "fmi2GetBoolean", |instance| {
        instance.no_variables_of_type(Call::GetValues, unsafe { array(vr, nvr, "vr")? })
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}", listed(vr, nvr)) };
    with_instance_logged(c, "fmi2GetString", arguments, |instance| unsafe {
        instance.get_string(array(vr, nvr, "vr")?, array_mut(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}, value = {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, "fmi2SetReal", arguments, |instance| unsafe {
        instance.set_real(array(vr, nvr, "vr")?, array(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Integer,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}, value = {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, "fmi2SetInteger", arguments, |instance| unsafe {
        instance.set_integer(array(vr, nvr, "vr")?, array(value, nvr, "value")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    _value: *const fmi2Boolean,
) -> fmi2Status {
    with_instance(c, "fmi2SetBoolean", |instance| {
        instance.no_variables_of_type(Call::SetValues, unsafe { array(vr, nvr, "vr")? })
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    let arguments = move || unsafe { format!("vr = {}", listed(vr, nvr)) };
    with_instance_logged(c, "fmi2SetString", arguments, |instance| unsafe {
        let pointers = array(value, nvr, "value")?;
        let strings = pointers
            .iter()
            .map(|&p| {
                // SAFETY: a non-null value is a NUL-terminated string, by the importer's promise.
                (!p.is_null())
                    .then(|| CStr::from_ptr(p))
                    .ok_or_else(|| Rejection::error("a value is NULL"))
            })
            .collect::<CallResult<Vec<_>>>()?;
        instance.set_string(array(vr, nvr, "vr")?, &strings)
    })
}

/// # Safety
/// A non-null `state` must come from fmi2GetFMUstate or fmi2DeSerializeFMUstate.
unsafe fn fmu_state<'a>(state: fmi2FMUstate) -> CallResult<&'a FmuState> {
    // SAFETY: the importer passes back a pointer we made and have not freed.
    unsafe { state.cast::<FmuState>().as_ref() }.ok_or_else(|| Rejection::error("FMUstate is NULL"))
}

/// Puts a snapshot into the importer's FMUstate slot, reusing the state already there.
///
/// # Safety
/// A non-null `*slot` must come from this file and not be freed.
unsafe fn store(slot: &mut fmi2FMUstate, snapshot: Snapshot) {
    // SAFETY: per the contract above.
    match unsafe { slot.cast::<FmuState>().as_mut() } {
        Some(existing) => existing.0 = snapshot,
        None => *slot = Box::into_raw(Box::new(FmuState(snapshot))).cast(),
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetFMUstate(c: fmi2Component, FMUstate: *mut fmi2FMUstate) -> fmi2Status {
    let arguments = move || {
        format!(
            "FMUstate -> {:p}",
            unsafe { FMUstate.as_ref() }.map_or(null_mut(), |s| *s)
        )
    };
    with_instance_logged(c, "fmi2GetFMUstate", arguments, |instance| {
        let slot = unsafe { out(FMUstate, "FMUstate")? };
        unsafe { store(slot, instance.snapshot()?) };
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetFMUstate(c: fmi2Component, FMUstate: fmi2FMUstate) -> fmi2Status {
    let arguments = move || format!("FMUstate = {FMUstate:p}");
    with_instance_logged(c, "fmi2SetFMUstate", arguments, |instance| {
        instance.restore(&unsafe { fmu_state(FMUstate)? }.0)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeFMUstate(c: fmi2Component, FMUstate: *mut fmi2FMUstate) -> fmi2Status {
    with_instance(c, "fmi2FreeFMUstate", |_| {
        let Some(slot) = (unsafe { FMUstate.as_mut() }) else {
            return Ok(());
        };
        if !slot.is_null() {
            // SAFETY: made by Box::into_raw in this file; the slot is cleared so it is freed once.
            drop(unsafe { Box::from_raw(slot.cast::<FmuState>()) });
            *slot = null_mut();
        }
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    let arguments = move || {
        format!(
            "FMUstate = {FMUstate:p}, size -> {}",
            unsafe { size.as_ref() }.map_or(0, |s| *s)
        )
    };
    with_instance_logged(c, "fmi2SerializedFMUstateSize", arguments, |instance| {
        instance.require(Call::GetFmuState)?;
        let bytes = unsafe { fmu_state(FMUstate)? }.0.to_bytes();
        *unsafe { out(size, "size")? } = bytes.len();
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    serializedState: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    let arguments = move || format!("FMUstate = {FMUstate:p}, size = {size}");
    with_instance_logged(c, "fmi2SerializeFMUstate", arguments, |instance| {
        instance.require(Call::GetFmuState)?;
        let bytes = unsafe { fmu_state(FMUstate)? }.0.to_bytes();
        if size < bytes.len() {
            return Err(Rejection::error(format!(
                "size {size} is too small: the state needs {} bytes",
                bytes.len()
            )));
        }
        let target = unsafe { array_mut(serializedState.cast::<u8>(), bytes.len(), "serializedState")? };
        target.copy_from_slice(&bytes);
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    serializedState: *const fmi2Byte,
    size: usize,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    let arguments = move || format!("size = {size}");
    with_instance_logged(c, "fmi2DeSerializeFMUstate", arguments, |instance| {
        instance.require(Call::SetFmuState)?;
        let slot = unsafe { out(FMUstate, "FMUstate")? };
        let bytes = unsafe { array(serializedState.cast::<u8>(), size, "serializedState")? };
        unsafe { store(slot, Snapshot::from_bytes(bytes).map_err(Rejection::error)?) };
        Ok(())
    })
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
    let arguments = move || unsafe {
        format!(
            "vUnknown_ref = {}, vKnown_ref = {}, dvKnown = {}, dvUnknown -> {}",
            listed(vUnknown_ref, nUnknown),
            listed(vKnown_ref, nKnown),
            listed(dvKnown, nKnown),
            listed(dvUnknown, nUnknown)
        )
    };
    with_instance_logged(c, "fmi2GetDirectionalDerivative", arguments, |instance| unsafe {
        instance.directional_derivative(
            array(vUnknown_ref, nUnknown, "vUnknown_ref")?,
            array(vKnown_ref, nKnown, "vKnown_ref")?,
            array(dvKnown, nKnown, "dvKnown")?,
            array_mut(dvUnknown, nUnknown, "dvUnknown")?,
        )
    })
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
            listed(vr, nvr),
            listed(order, nvr),
            listed(value, nvr)
        )
    };
    with_instance_logged(c, "fmi2SetRealInputDerivatives", arguments, |instance| unsafe {
        instance.set_input_derivatives(
            array(vr, nvr, "vr")?,
            array(order, nvr, "order")?,
            array(value, nvr, "value")?,
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
    let arguments = move || unsafe {
        format!(
            "vr = {}, order = {}, value -> {}",
            listed(vr, nvr),
            listed(order, nvr),
            listed(value, nvr)
        )
    };
    with_instance_logged(c, "fmi2GetRealOutputDerivatives", arguments, |instance| unsafe {
        instance.get_output_derivatives(
            array(vr, nvr, "vr")?,
            array(order, nvr, "order")?,
            array_mut(value, nvr, "value")?,
        )
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    let arguments = move || {
        format!(
            "currentCommunicationPoint = {currentCommunicationPoint}, communicationStepSize = \
             {communicationStepSize}, noSetFMUStatePriorToCurrentPoint = {_noSetFMUStatePriorToCurrentPoint}"
        )
    };
    with_instance_logged(c, "fmi2DoStep", arguments, |instance| {
        instance.do_step(currentCommunicationPoint, communicationStepSize)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2CancelStep", |instance| instance.require(Call::CancelStep))
}

// ---------------------------------------------------------------- Model Exchange

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetTime(c: fmi2Component, time: fmi2Real) -> fmi2Status {
    with_instance_logged(
        c,
        "fmi2SetTime",
        move || format!("time = {time}"),
        |instance| instance.set_time(time),
    )
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetContinuousStates(c: fmi2Component, x: *const fmi2Real, nx: usize) -> fmi2Status {
    let arguments = move || unsafe { format!("x = {}", listed(x, nx)) };
    with_instance_logged(c, "fmi2SetContinuousStates", arguments, |instance| unsafe {
        instance.set_continuous_states(array(x, nx, "x")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterEventMode(c: fmi2Component) -> fmi2Status {
    with_instance(c, "fmi2EnterEventMode", Instance::enter_event_mode)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2NewDiscreteStates(c: fmi2Component, fmi2eventInfo: *mut fmi2EventInfo) -> fmi2Status {
    with_instance(c, "fmi2NewDiscreteStates", |instance| {
        let info = unsafe { out(fmi2eventInfo, "fmi2eventInfo")? };
        let update = instance.new_discrete_states()?;
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
    with_instance(c, "fmi2CompletedIntegratorStep", |instance| {
        let enter = unsafe { out(enterEventMode, "enterEventMode")? };
        let terminate = unsafe { out(terminateSimulation, "terminateSimulation")? };
        instance.completed_integrator_step()?;
        *enter = 0;
        *terminate = 0;
        Ok(())
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetDerivatives(c: fmi2Component, derivatives: *mut fmi2Real, nx: usize) -> fmi2Status {
    let arguments = move || unsafe { format!("derivatives -> {}", listed(derivatives, nx)) };
    with_instance_logged(c, "fmi2GetDerivatives", arguments, |instance| unsafe {
        instance.get_derivatives(array_mut(derivatives, nx, "derivatives")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetEventIndicators(
    c: fmi2Component,
    eventIndicators: *mut fmi2Real,
    ni: usize,
) -> fmi2Status {
    let arguments = move || unsafe { format!("eventIndicators -> {}", listed(eventIndicators, ni)) };
    with_instance_logged(c, "fmi2GetEventIndicators", arguments, |instance| unsafe {
        instance.get_event_indicators(array_mut(eventIndicators, ni, "eventIndicators")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetContinuousStates(c: fmi2Component, x: *mut fmi2Real, nx: usize) -> fmi2Status {
    let arguments = move || unsafe { format!("x -> {}", listed(x, nx)) };
    with_instance_logged(c, "fmi2GetContinuousStates", arguments, |instance| unsafe {
        instance.get_continuous_states(array_mut(x, nx, "x")?)
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetNominalsOfContinuousStates(
    c: fmi2Component,
    x_nominal: *mut fmi2Real,
    nx: usize,
) -> fmi2Status {
    let arguments = move || unsafe { format!("x_nominal -> {}", listed(x_nominal, nx)) };
    with_instance_logged(
        c,
        "fmi2GetNominalsOfContinuousStates",
        arguments,
        |instance| unsafe { instance.get_nominals(array_mut(x_nominal, nx, "x_nominal")?) },
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
