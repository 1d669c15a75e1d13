//! The C boundary both FMI versions share: pointer checks, the panic boundary, the mapping
//! from call results to status codes, and the bodies of the calls that are the same in
//! FMI 2.0 and 3.0 (which differ only in their names and in the type of their handle,
//! a `void*` in both). [`super::fmi2`] and [`super::fmi3`] are the thin exports on top.
//!
//! Every function here takes the importer's raw pointers: the FMI standard makes the
//! importer promise that they are valid, and every one is checked for NULL before use.

// They are public so that Rust can call the exports in-process too (tests/no_allocation.rs),
// with the same promise.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{CStr, CString, c_char, c_uint, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::ptr::null_mut;

use super::instance::{EventUpdate, Instance, Interface};
use super::logger::{self, Callback, Category, Logger};
use super::snapshot::Snapshot;
use super::state_machine::Call;
use super::status::{CallResult, Rejection, Status};
use super::variables::GUID;

/// fmi2Status and fmi3Status: the same C enum values (checked below).
pub type StatusCode = c_uint;

const _: () = {
    use super::{sys, sys3};
    assert!(sys::fmi2Status_fmi2OK == sys3::fmi3Status_fmi3OK);
    assert!(sys::fmi2Status_fmi2Warning == sys3::fmi3Status_fmi3Warning);
    assert!(sys::fmi2Status_fmi2Discard == sys3::fmi3Status_fmi3Discard);
    assert!(sys::fmi2Status_fmi2Error == sys3::fmi3Status_fmi3Error);
    assert!(sys::fmi2Status_fmi2Fatal == sys3::fmi3Status_fmi3Fatal);
};

/// An FMU state handle (fmi2FMUstate, fmi3FMUState): a snapshot owned by the importer
/// until it frees it.
struct FmuState(Snapshot);

/// Upper bound on the element count of any array argument; far above any real use, and
/// it keeps a garbage count from becoming an absurd slice.
const MAX_ELEMENTS: usize = 1 << 24;

/// Borrows a C array; null is accepted only for zero elements.
///
/// # Safety
/// A non-null `ptr` must point to `n` valid elements for the duration of the call.
#[inline]
pub unsafe fn array<'a, T>(ptr: *const T, n: usize, name: &str) -> CallResult<&'a [T]> {
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
pub unsafe fn array_mut<'a, T>(ptr: *mut T, n: usize, name: &str) -> CallResult<&'a mut [T]> {
    unsafe { array(ptr, n, name)? };
    if n == 0 {
        return Ok(&mut []);
    }
    // SAFETY: checked non-null and bounded above; the caller promises `n` elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// # Safety
/// A non-null `ptr` must point to a writable `T`.
#[inline]
pub unsafe fn out<'a, T>(ptr: *mut T, name: &str) -> CallResult<&'a mut T> {
    // SAFETY: the caller promises a writable T behind a non-null pointer.
    unsafe { ptr.as_mut() }.ok_or_else(|| Rejection::error(format!("{name} is NULL")))
}

/// # Safety
/// A non-null `ptr` must be a NUL-terminated string.
pub unsafe fn text<'a>(ptr: *const c_char, name: &str) -> CallResult<&'a str> {
    if ptr.is_null() {
        return Err(Rejection::error(format!("{name} is NULL")));
    }
    // SAFETY: non-null and NUL-terminated by the caller's promise.
    unsafe { CStr::from_ptr(ptr) }
        .to_str()
        .map_err(|_| Rejection::error(format!("{name} is not UTF-8")))
}

/// FMI 3.0 passes every array with its own length: for scalar variables the lengths of
/// the value references and of the values must agree.
pub fn same_count(values: &str, n_values: usize, n_references: usize) -> CallResult {
    if n_values == n_references {
        Ok(())
    } else {
        Err(Rejection::error(format!(
            "{values}: {n_values} values for {n_references} value references; every variable is a scalar"
        )))
    }
}

/// An FMI 3.0 call whose values come with their own count: `call` if it is the count of
/// the value references, else the error that says they differ. (FMI 2.0 passes one count
/// for both: its calls go straight to `call`'s body.)
#[inline]
pub fn counted(
    c: *mut c_void,
    function: &str,
    n_values: usize,
    n_references: usize,
    call: impl FnOnce() -> StatusCode,
) -> StatusCode {
    if n_values == n_references {
        call()
    } else {
        with_instance(c, function, |_| same_count("values", n_values, n_references))
    }
}

/// Runs `body` on the instance behind `c`, inside the panic boundary, and turns its
/// result into a status, logging the reason for anything but OK.
pub fn with_instance(
    c: *mut c_void,
    function: &str,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> StatusCode {
    with_instance_logged(c, function, String::new, body)
}

/// [`with_instance`] for a call with arguments: after the call succeeds, with logAll on,
/// the log names the function with `arguments()` (value references, values, times; the
/// values a get wrote). `arguments` is not called otherwise, so it costs nothing then.
#[inline]
pub fn with_instance_logged(
    c: *mut c_void,
    function: &str,
    arguments: impl FnOnce() -> String,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> StatusCode {
    let instance = c.cast::<Instance>();
    if instance.is_null() {
        return Status::Error as StatusCode;
    }
    // SAFETY: a non-null handle is an instance made by Instantiate and not yet freed; the
    // importer calls it from one thread at a time.
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
    status as StatusCode
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
pub unsafe fn listed<T: std::fmt::Debug>(ptr: *const T, n: usize) -> String {
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
                &format!("{function}: internal error; only FreeInstance and Reset are allowed now"),
            );
            Status::Fatal
        }
    }
}

/// What an importer gives at instantiation, in either version.
pub struct Instantiation {
    /// `fmi2Instantiate`, `fmi3InstantiateCoSimulation`, ...: the prefix of messages.
    pub function: &'static str,
    pub instance_name: *const c_char,
    /// The GUID (FMI 2.0) or instantiation token (FMI 3.0).
    pub token: *const c_char,
    pub interface: Interface,
    pub callback: Callback,
    pub logging_on: bool,
    /// The resources folder, for a relative tirFile; an importer may give none.
    pub resources: Option<PathBuf>,
    /// A reason to refuse that only the version's own arguments show.
    pub refusal: Option<String>,
}

/// Makes an instance, or logs why not (to the importer's logger, if any) and returns
/// NULL. Never unwinds.
pub fn instantiate(request: Instantiation) -> *mut c_void {
    let made = catch_unwind(AssertUnwindSafe(|| unsafe { make_instance(request) }));
    match made {
        Ok(Some(instance)) => Box::into_raw(instance).cast(),
        _ => null_mut(),
    }
}

/// # Safety
/// The pointers as the importer's Instantiate call gives them.
unsafe fn make_instance(request: Instantiation) -> Option<Box<Instance>> {
    let name = unsafe { text(request.instance_name, "instanceName") }
        .ok()
        .filter(|n| !n.is_empty());
    let report = |message: String| {
        let shown = CString::new(name.unwrap_or("")).unwrap_or_default();
        logger::send(
            request.callback,
            &shown,
            Status::Error,
            Category::StatusError,
            &format!("{}: {message}", request.function),
        );
        None
    };
    let Some(name) = name else {
        return report("instanceName must be a non-empty string".into());
    };
    if let Some(refusal) = request.refusal {
        return report(refusal);
    }
    match unsafe { text(request.token, "the instantiation token") } {
        Ok(given) if given == GUID => {}
        Ok(given) => {
            return report(format!(
                "the instantiation token (GUID) {given} does not match this FMU's {GUID}"
            ));
        }
        Err(e) => return report(e.message),
    }
    let logger = Logger::new(
        request.callback,
        CString::new(name).unwrap_or_default(),
        request.logging_on,
    );
    match Instance::new(logger, request.interface, request.resources) {
        Ok(instance) => Some(Box::new(instance)),
        Err(e) => report(e),
    }
}

pub fn free_instance(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: made by `instantiate` with Box::into_raw, freed once by the importer.
        let _ = catch_unwind(|| drop(unsafe { Box::from_raw(c.cast::<Instance>()) }));
    }
}

pub fn set_debug_logging(
    c: *mut c_void,
    function: &str,
    logging_on: bool,
    n_categories: usize,
    categories: *const *const c_char,
) -> StatusCode {
    let arguments = move || {
        let names = unsafe { array(categories, n_categories, "") }
            .map(|pointers| {
                pointers
                    .iter()
                    .map(|&p| unsafe { text(p, "") }.map_or("?", |t| t))
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default();
        format!("loggingOn = {logging_on}, categories = [{names}]")
    };
    with_instance_logged(c, function, arguments, |instance| {
        instance.require(Call::SetDebugLogging)?;
        let pointers = unsafe { array(categories, n_categories, "categories")? };
        let names = pointers
            .iter()
            .map(|&p| unsafe { text(p, "category") })
            .collect::<CallResult<Vec<_>>>()?;
        instance.set_debug_logging(logging_on, &names)
    })
}

pub fn get_real(c: *mut c_void, function: &str, vr: *const u32, nvr: usize, value: *mut f64) -> StatusCode {
    let arguments = move || unsafe { format!("vr = {}, value -> {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        instance.get_real(array(vr, nvr, "vr")?, array_mut(value, nvr, "value")?)
    })
}

#[inline]
pub fn set_real(c: *mut c_void, function: &str, vr: *const u32, nvr: usize, value: *const f64) -> StatusCode {
    let arguments = move || unsafe { format!("vr = {}, value = {}", listed(vr, nvr), listed(value, nvr)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        instance.set_real(array(vr, nvr, "vr")?, array(value, nvr, "value")?)
    })
}

pub fn get_string(
    c: *mut c_void,
    function: &str,
    vr: *const u32,
    nvr: usize,
    value: *mut *const c_char,
) -> StatusCode {
    let arguments = move || unsafe { format!("vr = {}", listed(vr, nvr)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        instance.get_string(array(vr, nvr, "vr")?, array_mut(value, nvr, "value")?)
    })
}

pub fn set_string(
    c: *mut c_void,
    function: &str,
    vr: *const u32,
    nvr: usize,
    value: *const *const c_char,
) -> StatusCode {
    let arguments = move || unsafe { format!("vr = {}", listed(vr, nvr)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
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

/// Get or set of a type this FMU has no variables of: fine for no value references.
pub fn no_variables_of_type(
    c: *mut c_void,
    function: &str,
    call: Call,
    vr: *const u32,
    nvr: usize,
) -> StatusCode {
    with_instance(c, function, |instance| {
        instance.no_variables_of_type(call, unsafe { array(vr, nvr, "vr")? })
    })
}

/// A function of the standard this FMU does not provide (its model description says so).
pub fn not_supported(c: *mut c_void, function: &str, why: &str) -> StatusCode {
    with_instance(c, function, |_| Err(Rejection::error(why.to_owned())))
}

/// # Safety
/// A non-null `state` must come from this file and not be freed.
unsafe fn fmu_state<'a>(state: *mut c_void) -> CallResult<&'a FmuState> {
    // SAFETY: the importer passes back a pointer we made and have not freed.
    unsafe { state.cast::<FmuState>().as_ref() }.ok_or_else(|| Rejection::error("FMUstate is NULL"))
}

/// Puts a snapshot into the importer's FMU-state slot, reusing the state already there.
///
/// # Safety
/// A non-null `*slot` must come from this file and not be freed.
unsafe fn store(slot: &mut *mut c_void, snapshot: Snapshot) {
    // SAFETY: per the contract above.
    match unsafe { slot.cast::<FmuState>().as_mut() } {
        Some(existing) => existing.0 = snapshot,
        None => *slot = Box::into_raw(Box::new(FmuState(snapshot))).cast(),
    }
}

pub fn get_fmu_state(c: *mut c_void, function: &str, state: *mut *mut c_void) -> StatusCode {
    let arguments = move || {
        format!(
            "FMUstate -> {:p}",
            unsafe { state.as_ref() }.map_or(null_mut(), |s| *s)
        )
    };
    with_instance_logged(c, function, arguments, |instance| {
        let slot = unsafe { out(state, "FMUstate")? };
        unsafe { store(slot, instance.snapshot()?) };
        Ok(())
    })
}

pub fn set_fmu_state(c: *mut c_void, function: &str, state: *mut c_void) -> StatusCode {
    let arguments = move || format!("FMUstate = {state:p}");
    with_instance_logged(c, function, arguments, |instance| {
        instance.restore(&unsafe { fmu_state(state)? }.0)
    })
}

pub fn free_fmu_state(c: *mut c_void, function: &str, state: *mut *mut c_void) -> StatusCode {
    with_instance(c, function, |_| {
        let Some(slot) = (unsafe { state.as_mut() }) else {
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

pub fn serialized_fmu_state_size(
    c: *mut c_void,
    function: &str,
    state: *mut c_void,
    size: *mut usize,
) -> StatusCode {
    let arguments = move || {
        format!(
            "FMUstate = {state:p}, size -> {}",
            unsafe { size.as_ref() }.map_or(0, |s| *s)
        )
    };
    with_instance_logged(c, function, arguments, |instance| {
        instance.require(Call::GetFmuState)?;
        let bytes = unsafe { fmu_state(state)? }.0.to_bytes();
        *unsafe { out(size, "size")? } = bytes.len();
        Ok(())
    })
}

pub fn serialize_fmu_state(
    c: *mut c_void,
    function: &str,
    state: *mut c_void,
    serialized: *mut u8,
    size: usize,
) -> StatusCode {
    let arguments = move || format!("FMUstate = {state:p}, size = {size}");
    with_instance_logged(c, function, arguments, |instance| {
        instance.require(Call::GetFmuState)?;
        let bytes = unsafe { fmu_state(state)? }.0.to_bytes();
        if size < bytes.len() {
            return Err(Rejection::error(format!(
                "size {size} is too small: the state needs {} bytes",
                bytes.len()
            )));
        }
        let target = unsafe { array_mut(serialized, bytes.len(), "serializedState")? };
        target.copy_from_slice(&bytes);
        Ok(())
    })
}

pub fn deserialize_fmu_state(
    c: *mut c_void,
    function: &str,
    serialized: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> StatusCode {
    let arguments = move || format!("size = {size}");
    with_instance_logged(c, function, arguments, |instance| {
        instance.require(Call::SetFmuState)?;
        let slot = unsafe { out(state, "FMUstate")? };
        let bytes = unsafe { array(serialized, size, "serializedState")? };
        unsafe { store(slot, Snapshot::from_bytes(bytes).map_err(Rejection::error)?) };
        Ok(())
    })
}

/// The arrays of a directional derivative: value references of the unknowns and knowns,
/// the seed and the result.
pub struct Directional {
    pub unknowns: *const u32,
    pub n_unknowns: usize,
    pub knowns: *const u32,
    pub n_knowns: usize,
    pub seed: *const f64,
    /// FMI 3.0's own count of the seed (FMI 2.0: `n_knowns`).
    pub n_seed: usize,
    pub sensitivity: *mut f64,
    /// FMI 3.0's own count of the sensitivity (FMI 2.0: `n_unknowns`).
    pub n_sensitivity: usize,
}

pub fn directional_derivative(c: *mut c_void, function: &str, d: Directional) -> StatusCode {
    let arguments = move || unsafe {
        format!(
            "unknowns = {}, knowns = {}, seed = {}, sensitivity -> {}",
            listed(d.unknowns, d.n_unknowns),
            listed(d.knowns, d.n_knowns),
            listed(d.seed, d.n_knowns),
            listed(d.sensitivity, d.n_unknowns)
        )
    };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        same_count("seed", d.n_seed, d.n_knowns)?;
        same_count("sensitivity", d.n_sensitivity, d.n_unknowns)?;
        instance.directional_derivative(
            array(d.unknowns, d.n_unknowns, "unknowns")?,
            array(d.knowns, d.n_knowns, "knowns")?,
            array(d.seed, d.n_knowns, "seed")?,
            array_mut(d.sensitivity, d.n_unknowns, "sensitivity")?,
        )
    })
}

pub fn get_output_derivatives(
    c: *mut c_void,
    function: &str,
    vr: *const u32,
    nvr: usize,
    order: *const i32,
    value: *mut f64,
) -> StatusCode {
    let arguments = move || unsafe {
        format!(
            "vr = {}, order = {}, value -> {}",
            listed(vr, nvr),
            listed(order, nvr),
            listed(value, nvr)
        )
    };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        instance.get_output_derivatives(
            array(vr, nvr, "vr")?,
            array(order, nvr, "order")?,
            array_mut(value, nvr, "value")?,
        )
    })
}

#[inline]
pub fn set_time(c: *mut c_void, function: &str, time: f64) -> StatusCode {
    with_instance_logged(
        c,
        function,
        move || format!("time = {time}"),
        |instance| instance.set_time(time),
    )
}

#[inline]
pub fn set_continuous_states(c: *mut c_void, function: &str, x: *const f64, nx: usize) -> StatusCode {
    let arguments = move || unsafe { format!("x = {}", listed(x, nx)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        instance.set_continuous_states(array(x, nx, "x")?)
    })
}

/// A Model Exchange getter of a state-sized or indicator-sized array (`get` is the
/// instance's method for it: each export is its own call, with nothing to choose at run
/// time).
#[inline]
pub fn get_continuous_values(
    c: *mut c_void,
    function: &str,
    get: impl FnOnce(&mut Instance, &mut [f64]) -> CallResult,
    values: *mut f64,
    n: usize,
) -> StatusCode {
    let arguments = move || unsafe { format!("values -> {}", listed(values, n)) };
    with_instance_logged(c, function, arguments, |instance| unsafe {
        get(instance, array_mut(values, n, "values")?)
    })
}

/// The event update; `report` writes the version's own event information.
pub fn update_discrete_states(
    c: *mut c_void,
    function: &str,
    report: impl FnOnce(EventUpdate) -> CallResult,
) -> StatusCode {
    with_instance(c, function, |instance| report(instance.new_discrete_states()?))
}

/// CompletedIntegratorStep: no event and no termination asked.
pub fn completed_integrator_step<B: From<bool>>(
    c: *mut c_void,
    function: &str,
    enter_event_mode: *mut B,
    terminate_simulation: *mut B,
) -> StatusCode {
    with_instance(c, function, |instance| {
        let enter = unsafe { out(enter_event_mode, "enterEventMode")? };
        let terminate = unsafe { out(terminate_simulation, "terminateSimulation")? };
        instance.completed_integrator_step()?;
        *enter = false.into();
        *terminate = false.into();
        Ok(())
    })
}

/// The time of the instance behind `c`, if there is one.
pub fn time_of(c: *mut c_void) -> Option<f64> {
    // SAFETY: a non-null handle is an instance made by Instantiate and not yet freed.
    unsafe { c.cast::<Instance>().as_ref() }.map(Instance::time)
}

#[inline]
pub fn do_step(c: *mut c_void, function: &str, communication_point: f64, step_size: f64) -> StatusCode {
    let arguments = move || {
        format!("currentCommunicationPoint = {communication_point}, communicationStepSize = {step_size}")
    };
    with_instance_logged(c, function, arguments, |instance| {
        instance.do_step(communication_point, step_size)
    })
}
