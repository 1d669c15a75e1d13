//! Random sequences of FMI calls with random arguments (non-finite, huge, negative and
//! null included) against the packed binary, through both versions' functions of the one
//! library: no crash, no hang, no panic leaking out as fmi2Fatal or fmi3Fatal, every status
//! one the standard has.
//!
//! - FMI 2.0: every function, Co-Simulation and Model Exchange instances.
//! - FMI 3.0: instantiation for Co-Simulation (random flags, eventModeUsed and intermediate
//!   variables included, which it refuses), Model Exchange and Scheduled Execution (refused);
//!   every typed get and set with array lengths that do not always match; steps with NULL
//!   out-pointers; Model Exchange; FMU states through random, corrupted and re-checksummed
//!   bytes (and states of earlier sequences); every function the FMU does not provide
//!   (always fmi3Error); calls without an instance. Every status is OK, Warning, Discard or
//!   Error, and the log messages name the instance environment and a declared category.
//!   A failure prints the sequence's calls and their arguments; TIRELAG_FUZZ_TRACE=1 prints
//!   every FMI 3.0 call as it is made (for a crash or a hang).
//!
//! `cargo test --test fuzz_calls` runs 2,000 sequences of each version (two tests, in
//! parallel); set TIRELAG_FUZZ_SEQUENCES=100000 for the full campaign and
//! TIRELAG_FUZZ_SEED to vary it. The two versions draw from separate streams of the seed,
//! so an FMI 2.0 sequence is the same with or without the FMI 3.0 part.

mod support;

use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicUsize, Ordering};

use fmi_sys::fmi2::*;
use fmi_sys::fmi3::*;
use support::{GUID, load};

/// xorshift64*: small, deterministic, good enough to pick calls and arguments.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn chance(&mut self, one_in: u64) -> bool {
        self.below(one_in) == 0
    }
    fn real(&mut self) -> f64 {
        match self.below(12) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => 1e300 * if self.chance(2) { 1.0 } else { -1.0 },
            4 => 0.0,
            5 => -1.0,
            6 => f64::MIN_POSITIVE / 8.0,
            7 => (self.below(2001) as f64 - 1000.0) * 1e3,
            _ => (self.below(20_001) as f64 - 10_000.0) * 1e-3,
        }
    }
    fn step_size(&mut self) -> f64 {
        match self.below(6) {
            0 => self.real(),
            1 => 10.0,
            2 => 1e-6,
            _ => 1e-3 * (1 + self.below(100)) as f64,
        }
    }
    fn value_reference(&mut self) -> u32 {
        // Every declared variable, from the generated table: a new one is fuzzed at once.
        let known = &tirelag::fmi::variables::VARIABLES;
        if self.chance(8) {
            self.next() as u32
        } else {
            known[self.below(known.len() as u64) as usize].value_reference
        }
    }
    fn value_references(&mut self, n: usize) -> Vec<u32> {
        (0..n).map(|_| self.value_reference()).collect()
    }
    fn reals(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.real()).collect()
    }
    fn flag(&mut self) -> bool {
        self.chance(2)
    }
    /// A state-sized vector for the Model Exchange calls: the count announced (the 18
    /// states mostly, sometimes any count below 30) and small values, at least the 9 event
    /// indicators' worth of them behind it.
    fn state_vector(&mut self) -> (usize, Vec<f64>) {
        let n = if self.chance(4) {
            self.below(30) as usize
        } else {
            18
        };
        (n, (0..n.max(9)).map(|_| self.real() * 1e-3).collect())
    }
    /// FMI 3.0 passes every array with its own length: the length of the values that go
    /// with `n` value references, mostly `n`, sometimes another.
    fn length_near(&mut self, n: usize) -> usize {
        match self.below(12) {
            0 => n + 1,
            1 => n.saturating_sub(1),
            2 => self.below(8) as usize,
            _ => n,
        }
    }
    /// An Int64 for the enumerations: mostly near their items, sometimes far out of i32.
    fn int64(&mut self) -> i64 {
        match self.below(8) {
            0 => i64::MIN,
            1 => i64::MAX,
            2 => i64::from(i32::MAX) + 1 + self.below(3) as i64,
            3 => self.next() as i64,
            _ => self.below(7) as i64 - 1,
        }
    }
    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
}

struct Arrays {
    refs: Vec<u32>,
    reals: Vec<f64>,
    integers: Vec<i32>,
    out_reals: Vec<f64>,
    out_integers: Vec<i32>,
}

impl Arrays {
    fn new(rng: &mut Rng) -> Self {
        let n = rng.below(6) as usize;
        Arrays {
            refs: rng.value_references(n),
            reals: rng.reals(n),
            integers: (0..n).map(|_| rng.below(7) as i32 - 1).collect(),
            out_reals: vec![0.0; n],
            out_integers: vec![0; n],
        }
    }
}

/// A pointer to `v`, or sometimes NULL even though `n` elements are announced.
fn maybe_null<T>(rng: &mut Rng, v: &[T]) -> *const T {
    if rng.chance(10) { null() } else { v.as_ptr() }
}
fn maybe_null_mut<T>(rng: &mut Rng, v: &mut [T]) -> *mut T {
    if rng.chance(10) {
        null_mut()
    } else {
        v.as_mut_ptr()
    }
}

fn run_sequence(fmu: &Fmi2Binding, rng: &mut Rng, callbacks: &fmi2CallbackFunctions) -> Vec<fmi2Status> {
    let name = CString::new(if rng.chance(20) { "" } else { "fuzz" }).unwrap();
    let guid = CString::new(if rng.chance(20) { "{bad}" } else { GUID }).unwrap();
    let kind = match rng.below(20) {
        0 => 2 + rng.below(5) as fmi2Type,
        k if k < 7 => fmi2Type_fmi2ModelExchange,
        _ => fmi2Type_fmi2CoSimulation,
    };
    let callbacks_ptr: *const fmi2CallbackFunctions = if rng.chance(30) { null() } else { callbacks };
    let c = unsafe {
        fmu.fmi2Instantiate(
            name.as_ptr(),
            kind,
            guid.as_ptr(),
            null(),
            callbacks_ptr,
            0,
            rng.below(2) as i32,
        )
    };
    if c.is_null() {
        return Vec::new();
    }
    let mut statuses = Vec::new();
    let mut time = 0.0;
    // Most sequences start from step mode with a random model and friction law (often
    // with friction low enough to slide), where most code lives.
    if !rng.chance(4) {
        let model = [1 + rng.below(4) as i32];
        let friction = [1 + rng.below(3) as i32];
        let mu = [0.01 * rng.below(80) as f64; 2];
        unsafe {
            fmu.fmi2SetInteger(c, [100u32].as_ptr(), 1, model.as_ptr());
            fmu.fmi2SetInteger(c, [121u32].as_ptr(), 1, friction.as_ptr());
            if rng.chance(2) {
                fmu.fmi2SetReal(c, [122u32, 123].as_ptr(), 2, mu.as_ptr());
            }
            fmu.fmi2EnterInitializationMode(c);
            fmu.fmi2ExitInitializationMode(c);
            if kind == fmi2Type_fmi2ModelExchange && rng.chance(2) {
                let mut info = std::mem::zeroed::<fmi2EventInfo>();
                fmu.fmi2NewDiscreteStates(c, &mut info);
                fmu.fmi2EnterContinuousTimeMode(c);
            }
        }
    }
    let mut saved: Vec<fmi2FMUstate> = Vec::new();
    let mut serialized: Vec<u8> = Vec::new();
    for _ in 0..rng.below(40) {
        let mut a = Arrays::new(rng);
        let n = a.refs.len();
        let status = unsafe {
            match rng.below(26) {
                0 => fmu.fmi2SetupExperiment(c, 0, 0.0, rng.real(), rng.below(2) as i32, rng.real()),
                1 => fmu.fmi2EnterInitializationMode(c),
                2 => fmu.fmi2ExitInitializationMode(c),
                3 | 4 => {
                    let point = if rng.chance(5) { rng.real() } else { time };
                    let h = rng.step_size();
                    let s = fmu.fmi2DoStep(c, point, h, 0);
                    if s == fmi2Status_fmi2OK {
                        time = point + h;
                    }
                    s
                }
                5 | 6 => fmu.fmi2SetReal(c, maybe_null(rng, &a.refs), n, maybe_null(rng, &a.reals)),
                7 => fmu.fmi2GetReal(
                    c,
                    maybe_null(rng, &a.refs),
                    n,
                    maybe_null_mut(rng, &mut a.out_reals),
                ),
                8 => fmu.fmi2SetInteger(c, maybe_null(rng, &a.refs), n, maybe_null(rng, &a.integers)),
                9 => fmu.fmi2GetInteger(
                    c,
                    maybe_null(rng, &a.refs),
                    n,
                    maybe_null_mut(rng, &mut a.out_integers),
                ),
                10 => {
                    let orders: Vec<i32> = (0..n).map(|_| rng.below(4) as i32 - 1).collect();
                    fmu.fmi2SetRealInputDerivatives(
                        c,
                        maybe_null(rng, &a.refs),
                        n,
                        maybe_null(rng, &orders),
                        maybe_null(rng, &a.reals),
                    )
                }
                11 => {
                    let orders: Vec<i32> = (0..n).map(|_| rng.below(3) as i32).collect();
                    fmu.fmi2GetRealOutputDerivatives(
                        c,
                        maybe_null(rng, &a.refs),
                        n,
                        maybe_null(rng, &orders),
                        maybe_null_mut(rng, &mut a.out_reals),
                    )
                }
                12 => {
                    let known = Arrays::new(rng);
                    fmu.fmi2GetDirectionalDerivative(
                        c,
                        maybe_null(rng, &a.refs),
                        n,
                        maybe_null(rng, &known.refs),
                        known.refs.len(),
                        maybe_null(rng, &known.reals),
                        maybe_null_mut(rng, &mut a.out_reals),
                    )
                }
                13 => {
                    let mut state = if rng.chance(3) {
                        saved.last().copied().unwrap_or(null_mut())
                    } else {
                        null_mut()
                    };
                    let s = fmu.fmi2GetFMUstate(c, if rng.chance(20) { null_mut() } else { &mut state });
                    if !state.is_null() && !saved.contains(&state) {
                        saved.push(state);
                    }
                    s
                }
                14 => fmu.fmi2SetFMUstate(c, saved.last().copied().unwrap_or(null_mut())),
                15 => match saved.pop() {
                    Some(mut state) => fmu.fmi2FreeFMUstate(c, &mut state),
                    None => fmu.fmi2FreeFMUstate(c, null_mut()),
                },
                16 => {
                    let Some(&state) = saved.last() else { continue };
                    let mut size = 0usize;
                    let s = fmu.fmi2SerializedFMUstateSize(c, state, &mut size);
                    if s == fmi2Status_fmi2OK {
                        let offered = if rng.chance(5) { size / 2 } else { size };
                        serialized = vec![0u8; offered];
                        fmu.fmi2SerializeFMUstate(c, state, serialized.as_mut_ptr().cast(), offered)
                    } else {
                        s
                    }
                }
                17 => {
                    if !serialized.is_empty() && rng.chance(2) {
                        let i = rng.below(serialized.len() as u64) as usize;
                        serialized[i] ^= 1 << rng.below(8);
                    }
                    let cut = if rng.chance(4) {
                        rng.below(serialized.len() as u64 + 1) as usize
                    } else {
                        serialized.len()
                    };
                    let mut state = null_mut();
                    let s = fmu.fmi2DeSerializeFMUstate(c, serialized.as_ptr().cast(), cut, &mut state);
                    if !state.is_null() {
                        saved.push(state);
                    }
                    s
                }
                22..=25 => model_exchange_call(fmu, c, rng),
                18 => fmu.fmi2Reset(c),
                19 => fmu.fmi2Terminate(c),
                20 => {
                    let categories = [
                        c"logAll".as_ptr(),
                        c"logStatusError".as_ptr(),
                        c"nonsense".as_ptr(),
                        null(),
                    ];
                    let k = rng.below(5) as usize;
                    fmu.fmi2SetDebugLogging(c, rng.below(2) as i32, k, categories.as_ptr())
                }
                _ => {
                    let mut real = 0.0;
                    let mut status = 0;
                    match rng.below(4) {
                        0 => fmu.fmi2CancelStep(c),
                        1 => fmu.fmi2GetStatus(c, rng.below(5) as u32, &mut status),
                        2 => fmu.fmi2GetRealStatus(c, rng.below(5) as u32, &mut real),
                        _ => {
                            let mut flag = 0;
                            fmu.fmi2GetBooleanStatus(c, rng.below(5) as u32, &mut flag)
                        }
                    }
                }
            }
        };
        statuses.push(status);
    }
    for mut state in saved {
        unsafe { fmu.fmi2FreeFMUstate(c, &mut state) };
    }
    unsafe { fmu.fmi2FreeInstance(c) };
    statuses
}

/// One Model Exchange call with random arguments: vectors of the right length mostly,
/// sometimes of another length or NULL.
unsafe fn model_exchange_call(fmu: &Fmi2Binding, c: fmi2Component, rng: &mut Rng) -> fmi2Status {
    let (n, mut values) = rng.state_vector();
    let pointer = maybe_null_mut(rng, &mut values);
    unsafe {
        match rng.below(10) {
            0 => fmu.fmi2SetTime(c, rng.real()),
            1 => fmu.fmi2SetContinuousStates(c, pointer, n),
            2 => fmu.fmi2GetContinuousStates(c, pointer, n),
            3 => fmu.fmi2GetDerivatives(c, pointer, n),
            4 => fmu.fmi2GetEventIndicators(c, pointer, if rng.chance(4) { n } else { 9 }),
            5 => fmu.fmi2GetNominalsOfContinuousStates(c, pointer, n),
            6 => fmu.fmi2EnterEventMode(c),
            7 => {
                let mut info = std::mem::zeroed::<fmi2EventInfo>();
                let target = if rng.chance(10) {
                    null_mut()
                } else {
                    &mut info as *mut _
                };
                fmu.fmi2NewDiscreteStates(c, target)
            }
            8 => fmu.fmi2EnterContinuousTimeMode(c),
            _ => {
                let (mut enter, mut terminate) = (0, 0);
                fmu.fmi2CompletedIntegratorStep(c, 1, &mut enter, &mut terminate)
            }
        }
    }
}

/// The number of sequences of each version and the seed: TIRELAG_FUZZ_SEQUENCES and
/// TIRELAG_FUZZ_SEED, or the default short run.
fn campaign() -> (u64, u64) {
    let sequences: u64 =
        std::env::var("TIRELAG_FUZZ_SEQUENCES").map_or(2_000, |v| v.parse().expect("a count"));
    let seed: u64 = std::env::var("TIRELAG_FUZZ_SEED").map_or(0x7153_1a6e, |v| v.parse().expect("a seed"));
    (sequences, seed)
}

#[test]
fn random_call_sequences_never_crash_or_leak_a_panic() {
    let (sequences, seed) = campaign();
    let fmu = load();
    let callbacks = support::callbacks();
    support::stop_recording();
    let mut rng = Rng(seed | 1);
    let mut counts = [0usize; 6];
    for _ in 0..sequences {
        for status in run_sequence(&fmu, &mut rng, &callbacks) {
            assert!(
                status <= fmi2Status_fmi2Pending,
                "status {status} is not an fmi2Status"
            );
            counts[status as usize] += 1;
        }
    }
    assert_eq!(
        counts[fmi2Status_fmi2Fatal as usize], 0,
        "a panic was caught inside the FMU"
    );
    assert!(counts[fmi2Status_fmi2OK as usize] > 0 && counts[fmi2Status_fmi2Error as usize] > 0);
    eprintln!(
        "{sequences} sequences: {} OK, {} warning, {} discard, {} error; {} log messages",
        counts[0],
        counts[1],
        counts[2],
        counts[3],
        support::message_count()
    );
}

// ---------------------------------------------------------------------------- FMI 3.0

/// Log messages of the FMI 3.0 instances; those not as the standard has them (another
/// instance environment, a status beyond fmi3Error, a category the model description does
/// not declare, a NULL message); calls of callbacks this FMU never calls.
static MESSAGES_3: AtomicUsize = AtomicUsize::new(0);
static MALFORMED_3: AtomicUsize = AtomicUsize::new(0);
static UNEXPECTED_CALLBACKS: AtomicUsize = AtomicUsize::new(0);

/// Every FMI 3.0 instance's environment is the address of this static.
static ENVIRONMENT: u8 = 0;

fn environment() -> fmi3InstanceEnvironment {
    (&raw const ENVIRONMENT).cast_mut().cast()
}

unsafe extern "C" fn log_message_3(
    given: fmi3InstanceEnvironment,
    status: fmi3Status,
    category: fmi3String,
    message: fmi3String,
) {
    MESSAGES_3.fetch_add(1, Ordering::Relaxed);
    let declared = !category.is_null()
        && matches!(
            unsafe { CStr::from_ptr(category) }.to_bytes(),
            b"logStatusError" | b"logStatusWarning" | b"logAll"
        );
    if given != environment() || status > fmi3Status_fmi3Error || !declared || message.is_null() {
        MALFORMED_3.fetch_add(1, Ordering::Relaxed);
    } else {
        // An importer reads the message: it is a NUL-terminated string.
        std::hint::black_box(unsafe { CStr::from_ptr(message) }.to_bytes().len());
    }
}

#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn intermediate_update(
    _: fmi3InstanceEnvironment,
    _: fmi3Float64,
    _: fmi3Boolean,
    _: fmi3Boolean,
    _: fmi3Boolean,
    _: fmi3Boolean,
    _: *mut fmi3Boolean,
    _: *mut fmi3Float64,
) {
    UNEXPECTED_CALLBACKS.fetch_add(1, Ordering::Relaxed);
}

unsafe extern "C" fn clock_update(_: fmi3InstanceEnvironment) {
    UNEXPECTED_CALLBACKS.fetch_add(1, Ordering::Relaxed);
}

unsafe extern "C" fn preemption() {
    UNEXPECTED_CALLBACKS.fetch_add(1, Ordering::Relaxed);
}

/// Values for the String variable tirFile: a real property file (as a path and as a
/// file URI), missing ones, a folder, another host, bad escapes, not UTF-8.
fn tir_file_names() -> Vec<CString> {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/mf61_passenger.tir");
    vec![
        CString::new(file).unwrap(),
        CString::new(format!("file://{file}")).unwrap(),
        c"".into(),
        c"missing.tir".into(),
        c"/".into(),
        c"file://elsewhere/x.tir".into(),
        c"file:///%zz%0".into(),
        CString::new(vec![0xff, 0xfe, b'x']).unwrap(),
    ]
}

/// An FMU state's layout (see src/fmi/snapshot.rs): magic, format version, GUID length,
/// the GUID; then the phase, model, friction law and stop-time flag bytes; then the
/// reals; an FNV-1a 64 checksum of everything before it at the end.
const MAGIC: &[u8; 8] = b"TIRELAG\0";
const HEADER: usize = 8 + 4 + 4 + GUID.len();

/// Writes the checksum over a changed state, so that what changed reaches the parser.
fn reseal(bytes: &mut [u8]) {
    if let Some(body) = bytes.len().checked_sub(8) {
        let sum = bytes[..body].iter().fold(0xcbf2_9ce4_8422_2325u64, |hash, &b| {
            (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        });
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
    }
}

/// One splitmix64 step: where the FMI 3.0 stream of a seed starts.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// An array argument as a trace shows it: NULL, or its elements.
fn shown<T: std::fmt::Debug>(pointer: *const T, values: &[T]) -> String {
    if pointer.is_null() {
        "NULL".into()
    } else {
        format!("{values:?}")
    }
}

/// An array the FMU writes, as a trace shows it: NULL, or how many elements it has.
fn slots<T>(pointer: *mut T, n: usize) -> String {
    if pointer.is_null() {
        "NULL".into()
    } else {
        format!("[{n} slots]")
    }
}

/// String arguments as a trace shows them.
fn strings_shown(pointer: *const fmi3String, values: &[fmi3String]) -> String {
    if pointer.is_null() {
        return "NULL".into();
    }
    let each: Vec<String> = values
        .iter()
        .map(|&p| {
            if p.is_null() {
                "NULL".into()
            } else {
                format!("{:?}", unsafe { CStr::from_ptr(p) })
            }
        })
        .collect();
    format!("[{}]", each.join(", "))
}

/// The kinds of [`Fuzz3::typed_call`]: the types without variables are 0 to
/// `TYPED_OTHERS - 1`, then the two with variables.
const TYPED_OTHERS: u64 = 11;
const TYPED_FLOAT64: u64 = TYPED_OTHERS;
const TYPED_INT64: u64 = TYPED_OTHERS + 1;

/// One FMI 3.0 sequence: an instance, its calls, their trace (printed with a failure, and
/// as they are made with TIRELAG_FUZZ_TRACE set), the status counts.
struct Fuzz3<'a> {
    fmu: &'a Fmi3Binding,
    rng: &'a mut Rng,
    tir_files: &'a [CString],
    /// Serialized states of earlier sequences (other interfaces, models, phases).
    pool: &'a mut Vec<Vec<u8>>,
    counts: &'a mut [usize; 5],
    live: bool,
    label: String,
    c: fmi3Instance,
    model_exchange: bool,
    time: f64,
    /// Model Exchange: the event indicators after the last integrator step.
    indicators: Vec<f64>,
    saved: Vec<fmi3FMUState>,
    serialized: Vec<u8>,
    trace: Vec<String>,
}

impl Fuzz3<'_> {
    fn enter(&mut self, call: String) {
        if self.live {
            eprintln!("{}: {call}", self.label);
        }
        self.trace.push(call);
    }

    /// Checks a status: one of OK, Warning, Discard, Error.
    fn done(&mut self, status: fmi3Status) -> fmi3Status {
        if let Some(last) = self.trace.last_mut() {
            last.push_str(&format!(" -> {status}"));
        }
        if self.live {
            eprintln!("{}:   -> {status}", self.label);
        }
        if status > fmi3Status_fmi3Error {
            let what = if status == fmi3Status_fmi3Fatal {
                "fmi3Fatal: a panic was caught inside the FMU"
            } else {
                "not an fmi3Status"
            };
            self.fail(&format!("status {status}, {what}"));
        }
        self.counts[status as usize] += 1;
        status
    }

    fn fail(&self, what: &str) -> ! {
        panic!(
            "{what}\n{} ({} calls):\n  {}",
            self.label,
            self.trace.len(),
            self.trace.join("\n  ")
        )
    }

    /// A pointer to a place the FMU writes one value to, sometimes NULL.
    fn out<T>(&mut self, place: &mut T) -> *mut T {
        if self.rng.chance(12) { null_mut() } else { place }
    }

    /// Value references (NULL sometimes) and the length of the values going with them.
    fn references(&mut self) -> (Vec<u32>, *const u32, usize) {
        self.references_with(None)
    }

    /// [`Fuzz3::references`], with `extra` at the end.
    fn references_with(&mut self, extra: Option<u32>) -> (Vec<u32>, *const u32, usize) {
        let n = self.rng.below(6) as usize;
        let mut refs = self.rng.value_references(n);
        refs.extend(extra);
        let n = refs.len();
        let pointer = maybe_null(self.rng, &refs);
        let n_values = self.rng.length_near(n);
        (refs, pointer, n_values)
    }

    fn run(mut self) {
        if !self.instantiate() {
            return;
        }
        if !self.rng.chance(4) {
            self.initialise();
        }
        for _ in 0..self.rng.below(40) {
            self.random_call();
        }
        for mut state in std::mem::take(&mut self.saved) {
            self.enter(format!("fmi3FreeFMUState(&{state:p})"));
            let s = unsafe { self.fmu.fmi3FreeFMUState(self.c, &mut state) };
            self.done(s);
        }
        self.enter("fmi3FreeInstance()".into());
        unsafe { self.fmu.fmi3FreeInstance(self.c) };
    }

    /// Instantiates for Co-Simulation (with random flags), Model Exchange or Scheduled
    /// Execution; whether there is an instance.
    fn instantiate(&mut self) -> bool {
        let rng = &mut *self.rng;
        let name = if rng.chance(20) { c"" } else { c"fuzz3" };
        let token = match rng.below(40) {
            0 => None,
            1 | 2 => Some(c"{bad}".to_owned()),
            _ => Some(CString::new(GUID).unwrap()),
        };
        let token_pointer = token.as_ref().map_or(null(), |t| t.as_ptr());
        let resources = [None, Some(c""), Some(c"/nonexistent/"), Some(c"relative")][rng.below(4) as usize];
        let resources_pointer = resources.map_or(null(), CStr::as_ptr);
        let (visible, logging_on) = (rng.flag(), rng.flag());
        let log: fmi3LogMessageCallback = if rng.chance(30) { None } else { Some(log_message_3) };
        let common = format!(
            "instanceName = {name:?}, instantiationToken = {token:?}, resourcePath = {resources:?}, \
             visible = {visible}, loggingOn = {logging_on}, logMessage = {}",
            if log.is_some() { "logger" } else { "NULL" }
        );
        let fmu = self.fmu;
        let kind = self.rng.below(20);
        self.model_exchange = (1..=6).contains(&kind);
        let (c, refused) = match kind {
            0 => {
                let rng = &mut *self.rng;
                let clock: fmi3ClockUpdateCallback = rng.flag().then_some(clock_update as _);
                let lock: fmi3LockPreemptionCallback = rng.flag().then_some(preemption as _);
                let unlock: fmi3UnlockPreemptionCallback = rng.flag().then_some(preemption as _);
                self.enter(format!("fmi3InstantiateScheduledExecution({common})"));
                let c = unsafe {
                    fmu.fmi3InstantiateScheduledExecution(
                        name.as_ptr(),
                        token_pointer,
                        resources_pointer,
                        visible,
                        logging_on,
                        environment(),
                        log,
                        clock,
                        lock,
                        unlock,
                    )
                };
                (c, true)
            }
            1..=6 => {
                self.enter(format!("fmi3InstantiateModelExchange({common})"));
                let c = unsafe {
                    fmu.fmi3InstantiateModelExchange(
                        name.as_ptr(),
                        token_pointer,
                        resources_pointer,
                        visible,
                        logging_on,
                        environment(),
                        log,
                    )
                };
                (c, false)
            }
            _ => {
                let rng = &mut *self.rng;
                let event_mode_used = rng.chance(6);
                let early_return_allowed = rng.flag();
                let n = 1 + rng.below(3) as usize;
                let required = rng.value_references(n);
                let (required_pointer, n_required) = match rng.below(10) {
                    0 => (required.as_ptr(), required.len()),
                    1 => (required.as_ptr(), 0),
                    _ => (null(), 0),
                };
                let update: fmi3IntermediateUpdateCallback = rng.flag().then_some(intermediate_update as _);
                self.enter(format!(
                    "fmi3InstantiateCoSimulation({common}, eventModeUsed = {event_mode_used}, \
                     earlyReturnAllowed = {early_return_allowed}, requiredIntermediateVariables = {}, \
                     nRequiredIntermediateVariables = {n_required}, intermediateUpdate = {})",
                    shown(required_pointer, &required[..n_required]),
                    if update.is_some() { "callback" } else { "NULL" }
                ));
                let c = unsafe {
                    fmu.fmi3InstantiateCoSimulation(
                        name.as_ptr(),
                        token_pointer,
                        resources_pointer,
                        visible,
                        logging_on,
                        event_mode_used,
                        early_return_allowed,
                        required_pointer,
                        n_required,
                        environment(),
                        log,
                        update,
                    )
                };
                (c, event_mode_used || n_required > 0)
            }
        };
        if let Some(last) = self.trace.last_mut() {
            last.push_str(&format!(" -> {c:p}"));
        }
        if self.live {
            eprintln!("{}:   -> {c:p}", self.label);
        }
        if refused && !c.is_null() {
            self.fail("an instance for what this FMU does not provide");
        }
        self.c = c;
        !c.is_null()
    }

    /// The model and friction law chosen (sometimes the parameters of the property file
    /// and low friction), initialised; Model Exchange sometimes on to continuous time.
    fn initialise(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let selectors = [1 + self.rng.below(4) as i64, 1 + self.rng.below(3) as i64];
        self.enter(format!("fmi3SetInt64(vr = [100, 121], values = {selectors:?})"));
        let s = unsafe { fmu.fmi3SetInt64(c, [100u32, 121].as_ptr(), 2, selectors.as_ptr(), 2) };
        self.done(s);
        if self.rng.chance(2) {
            let mu = [0.01 * self.rng.below(80) as f64; 2];
            self.enter(format!("fmi3SetFloat64(vr = [122, 123], values = {mu:?})"));
            let s = unsafe { fmu.fmi3SetFloat64(c, [122u32, 123].as_ptr(), 2, mu.as_ptr(), 2) };
            self.done(s);
        }
        if self.rng.chance(8) {
            let file = &self.tir_files[self.rng.below(self.tir_files.len() as u64) as usize];
            self.enter(format!("fmi3SetString(vr = [130], values = [{file:?}])"));
            let s = unsafe { fmu.fmi3SetString(c, [130u32].as_ptr(), 1, &file.as_ptr(), 1) };
            self.done(s);
        }
        let start = if self.rng.chance(5) { self.rng.real() } else { 0.0 };
        let (tolerance_defined, stop_defined) = (self.rng.flag(), self.rng.flag());
        self.enter(format!(
            "fmi3EnterInitializationMode(toleranceDefined = {tolerance_defined}, tolerance = 1e-6, \
             startTime = {start:?}, stopTimeDefined = {stop_defined}, stopTime = {:?})",
            start + 10.0
        ));
        let s = unsafe {
            fmu.fmi3EnterInitializationMode(c, tolerance_defined, 1e-6, start, stop_defined, start + 10.0)
        };
        if self.done(s) == fmi3Status_fmi3OK {
            self.time = start;
        }
        self.enter("fmi3ExitInitializationMode()".into());
        let s = unsafe { fmu.fmi3ExitInitializationMode(c) };
        self.done(s);
        if !self.rng.chance(4) {
            self.set_inputs();
        }
        if self.model_exchange && self.rng.chance(2) {
            // Initialisation leaves Model Exchange in event mode.
            self.event_iteration(false);
        }
    }

    fn random_call(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        match self.rng.below(36) {
            0 => {
                let rng = &mut *self.rng;
                let (tolerance_defined, tolerance) = (rng.flag(), rng.real());
                let start = if rng.chance(3) { rng.real() } else { 0.0 };
                let stop_defined = rng.flag();
                let stop = if rng.chance(2) { rng.real() } else { start + 10.0 };
                self.enter(format!(
                    "fmi3EnterInitializationMode(toleranceDefined = {tolerance_defined}, tolerance = \
                     {tolerance:?}, startTime = {start:?}, stopTimeDefined = {stop_defined}, stopTime = \
                     {stop:?})"
                ));
                let s = unsafe {
                    fmu.fmi3EnterInitializationMode(
                        c,
                        tolerance_defined,
                        tolerance,
                        start,
                        stop_defined,
                        stop,
                    )
                };
                if self.done(s) == fmi3Status_fmi3OK {
                    self.time = start;
                }
            }
            1 => {
                self.enter("fmi3ExitInitializationMode()".into());
                let s = unsafe { fmu.fmi3ExitInitializationMode(c) };
                self.done(s);
            }
            2 | 3 => self.do_step(),
            32 | 33 => self.set_inputs(),
            34 | 35 if self.model_exchange => self.integrate(),
            34 | 35 => self.steps(),
            4 | 5 => self.typed_call(TYPED_FLOAT64, false),
            6 => self.typed_call(TYPED_FLOAT64, true),
            7 => self.typed_call(TYPED_INT64, false),
            8 => self.typed_call(TYPED_INT64, true),
            9 => {
                let tir_file = self.rng.flag().then_some(130);
                let (refs, r, nv) = self.references_with(tir_file);
                let values: Vec<fmi3String> = (0..nv)
                    .map(|_| {
                        if self.rng.chance(15) {
                            null()
                        } else {
                            self.tir_files[self.rng.below(self.tir_files.len() as u64) as usize].as_ptr()
                        }
                    })
                    .collect();
                let v = maybe_null(self.rng, &values);
                self.enter(format!(
                    "fmi3SetString(vr = {}, nvr = {}, values = {}, nValues = {nv})",
                    shown(r, &refs),
                    refs.len(),
                    strings_shown(v, &values)
                ));
                let s = unsafe { fmu.fmi3SetString(c, r, refs.len(), v, nv) };
                self.done(s);
            }
            10 => {
                let tir_file = self.rng.flag().then_some(130);
                let (refs, r, nv) = self.references_with(tir_file);
                let mut values: Vec<fmi3String> = vec![null(); nv];
                let v = maybe_null_mut(self.rng, &mut values);
                self.enter(format!(
                    "fmi3GetString(vr = {}, nvr = {}, values = {}, nValues = {nv})",
                    shown(r, &refs),
                    refs.len(),
                    slots(v, nv)
                ));
                let s = unsafe { fmu.fmi3GetString(c, r, refs.len(), v, nv) };
                if self.done(s) == fmi3Status_fmi3OK {
                    // An importer reads what it got: strings, valid until the next call.
                    for &p in &values {
                        if p.is_null() {
                            self.fail("fmi3GetString returned OK and a NULL string");
                        }
                        std::hint::black_box(unsafe { CStr::from_ptr(p) }.to_bytes().len());
                    }
                }
            }
            11 => {
                let (kind, get) = (self.rng.below(TYPED_OTHERS), self.rng.flag());
                self.typed_call(kind, get)
            }
            12 => {
                let (refs, r, nv) = self.references();
                let orders: Vec<i32> = (0..refs.len()).map(|_| self.rng.below(4) as i32 - 1).collect();
                let o = maybe_null(self.rng, &orders);
                let mut values = vec![0.0; nv];
                let v = maybe_null_mut(self.rng, &mut values);
                self.enter(format!(
                    "fmi3GetOutputDerivatives(vr = {}, nvr = {}, orders = {}, values = {}, nValues = {nv})",
                    shown(r, &refs),
                    refs.len(),
                    shown(o, &orders),
                    slots(v, nv)
                ));
                let s = unsafe { fmu.fmi3GetOutputDerivatives(c, r, refs.len(), o, v, nv) };
                self.done(s);
            }
            13 => {
                let (unknowns, u, n_sensitivity) = self.references();
                let (knowns, k, n_seed) = self.references();
                let seed = self.rng.reals(n_seed);
                let sp = maybe_null(self.rng, &seed);
                let mut sensitivity = vec![0.0; n_sensitivity];
                let out = maybe_null_mut(self.rng, &mut sensitivity);
                self.enter(format!(
                    "fmi3GetDirectionalDerivative(unknowns = {}, nUnknowns = {}, knowns = {}, nKnowns = {}, \
                     seed = {}, nSeed = {n_seed}, sensitivity = {}, nSensitivity = {n_sensitivity})",
                    shown(u, &unknowns),
                    unknowns.len(),
                    shown(k, &knowns),
                    knowns.len(),
                    shown(sp, &seed),
                    slots(out, n_sensitivity)
                ));
                let s = unsafe {
                    fmu.fmi3GetDirectionalDerivative(
                        c,
                        u,
                        unknowns.len(),
                        k,
                        knowns.len(),
                        sp,
                        n_seed,
                        out,
                        n_sensitivity,
                    )
                };
                self.done(s);
            }
            14 => {
                let mut state = if self.rng.chance(3) {
                    self.saved.last().copied().unwrap_or(null_mut())
                } else {
                    null_mut()
                };
                let slot = if self.rng.chance(20) {
                    null_mut()
                } else {
                    &mut state as *mut _
                };
                self.enter(format!("fmi3GetFMUState(FMUState = {slot:p} holding {state:p})"));
                let s = unsafe { fmu.fmi3GetFMUState(c, slot) };
                self.done(s);
                if !state.is_null() && !self.saved.contains(&state) {
                    self.saved.push(state);
                }
            }
            15 => {
                let state = if self.saved.is_empty() || self.rng.chance(10) {
                    null_mut()
                } else {
                    self.saved[self.rng.below(self.saved.len() as u64) as usize]
                };
                self.enter(format!("fmi3SetFMUState({state:p})"));
                let s = unsafe { fmu.fmi3SetFMUState(c, state) };
                self.done(s);
            }
            16 => match self.saved.pop() {
                Some(mut state) => {
                    self.enter(format!("fmi3FreeFMUState(&{state:p})"));
                    let s = unsafe { fmu.fmi3FreeFMUState(c, &mut state) };
                    if self.done(s) == fmi3Status_fmi3OK && !state.is_null() {
                        self.fail("fmi3FreeFMUState left the state pointer set");
                    }
                }
                None => {
                    let mut state: fmi3FMUState = null_mut();
                    let slot = if self.rng.flag() {
                        null_mut()
                    } else {
                        &mut state as *mut _
                    };
                    self.enter(format!("fmi3FreeFMUState({slot:p} holding NULL)"));
                    let s = unsafe { fmu.fmi3FreeFMUState(c, slot) };
                    self.done(s);
                }
            },
            17 => self.serialize(),
            18 => self.deserialize(),
            19 => {
                self.enter("fmi3Reset()".into());
                let s = unsafe { fmu.fmi3Reset(c) };
                self.done(s);
            }
            20 => {
                self.enter("fmi3Terminate()".into());
                let s = unsafe { fmu.fmi3Terminate(c) };
                self.done(s);
            }
            21 => {
                let categories = [
                    c"logAll".as_ptr(),
                    c"logStatusError".as_ptr(),
                    c"nonsense".as_ptr(),
                    null(),
                ];
                let on = self.rng.flag();
                let k = self.rng.below(5) as usize;
                let p = if self.rng.chance(10) {
                    null()
                } else {
                    categories.as_ptr()
                };
                self.enter(format!(
                    "fmi3SetDebugLogging(loggingOn = {on}, nCategories = {k}, categories = {}{:?})",
                    if p.is_null() { "NULL " } else { "" },
                    ["logAll", "logStatusError", "nonsense", "NULL"].get(..k.min(4))
                ));
                let s = unsafe { fmu.fmi3SetDebugLogging(c, on, k, p) };
                self.done(s);
            }
            22 => self.unsupported_call(),
            23 => self.no_instance_call(),
            24..=31 => self.model_exchange_call(),
            _ => unreachable!(),
        }
    }

    /// The inputs vx, vy, steerRate, vsx, Fz: mostly as a vehicle gives them (standstill,
    /// reversing and wheel lift included), sometimes random.
    fn set_inputs(&mut self) {
        let rng = &mut *self.rng;
        let mut values = [
            (rng.below(81) as f64 - 20.0) * 0.5,
            (rng.below(41) as f64 - 20.0) * 0.1,
            (rng.below(41) as f64 - 20.0) * 0.05,
            (rng.below(41) as f64 - 20.0) * 0.1,
            rng.below(11) as f64 * 1e4,
        ];
        if rng.chance(4) {
            values[rng.below(5) as usize] = rng.real();
        }
        self.enter(format!(
            "fmi3SetFloat64(vr = [1, 2, 3, 4, 5], values = {values:?})"
        ));
        let s = unsafe {
            self.fmu
                .fmi3SetFloat64(self.c, [1u32, 2, 3, 4, 5].as_ptr(), 5, values.as_ptr(), 5)
        };
        self.done(s);
    }

    /// Co-Simulation: a run of steps as a master takes them, until one is refused.
    fn steps(&mut self) {
        for _ in 0..1 + self.rng.below(20) {
            let h = 1e-3 * (1 + self.rng.below(20)) as f64;
            let (mut event, mut terminate, mut early, mut last) = (true, true, true, f64::NAN);
            self.enter(format!(
                "fmi3DoStep(currentCommunicationPoint = {:?}, communicationStepSize = {h:?}, ..)",
                self.time
            ));
            let s = unsafe {
                self.fmu.fmi3DoStep(
                    self.c,
                    self.time,
                    h,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                )
            };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            self.time += h;
            self.check_step_report(event, terminate, early, last);
        }
    }

    /// Model Exchange: explicit Euler steps as an integrator takes them, an event update
    /// where an event indicator changes sign (or at random), until a call is refused.
    fn integrate(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let (mut x, mut dx, mut z) = (vec![0.0; 18], vec![0.0; 18], vec![0.0; 9]);
        for _ in 0..1 + self.rng.below(20) {
            let h = if self.rng.chance(8) {
                self.rng.step_size()
            } else {
                1e-4 * (1 + self.rng.below(50)) as f64
            };
            self.enter("fmi3GetContinuousStates(x, 18)".into());
            let s = unsafe { fmu.fmi3GetContinuousStates(c, x.as_mut_ptr(), 18) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            self.enter("fmi3GetContinuousStateDerivatives(dx, 18)".into());
            let s = unsafe { fmu.fmi3GetContinuousStateDerivatives(c, dx.as_mut_ptr(), 18) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            let t = self.time + h;
            self.enter(format!("fmi3SetTime({t:?})"));
            let s = unsafe { fmu.fmi3SetTime(c, t) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            self.time = t;
            for (x, dx) in x.iter_mut().zip(&dx) {
                *x += h * dx;
            }
            self.enter(format!("fmi3SetContinuousStates({x:?}, 18)"));
            let s = unsafe { fmu.fmi3SetContinuousStates(c, x.as_ptr(), 18) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            let (mut enter, mut terminate) = (true, true);
            self.enter("fmi3CompletedIntegratorStep(true, ..)".into());
            let s = unsafe { fmu.fmi3CompletedIntegratorStep(c, true, &mut enter, &mut terminate) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            if enter || terminate {
                self.fail("fmi3CompletedIntegratorStep asked for event mode or termination");
            }
            self.enter("fmi3GetEventIndicators(z, 9)".into());
            let s = unsafe { fmu.fmi3GetEventIndicators(c, z.as_mut_ptr(), 9) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
            let crossed = self.indicators.len() == 9
                && self
                    .indicators
                    .iter()
                    .zip(&z)
                    .any(|(a, b)| (*a > 0.0) != (*b > 0.0));
            self.indicators.clone_from(&z);
            if crossed || self.rng.chance(10) {
                self.event_iteration(true);
            }
        }
    }

    /// (EnterEventMode,) UpdateDiscreteStates, EnterContinuousTimeMode, as an importer
    /// does at an event.
    fn event_iteration(&mut self, enter_event_mode: bool) {
        let (fmu, c) = (self.fmu, self.c);
        if enter_event_mode {
            self.enter("fmi3EnterEventMode()".into());
            let s = unsafe { fmu.fmi3EnterEventMode(c) };
            if self.done(s) != fmi3Status_fmi3OK {
                return;
            }
        }
        let (mut again, mut terminate, mut nominals, mut changed, mut timed) = (true, true, true, true, true);
        let mut next = f64::NAN;
        self.enter("fmi3UpdateDiscreteStates(..)".into());
        let s = unsafe {
            fmu.fmi3UpdateDiscreteStates(
                c,
                &mut again,
                &mut terminate,
                &mut nominals,
                &mut changed,
                &mut timed,
                &mut next,
            )
        };
        if self.done(s) == fmi3Status_fmi3OK && (again || terminate || nominals || timed) {
            self.fail(&format!(
                "fmi3UpdateDiscreteStates: discreteStatesNeedUpdate = {again}, terminateSimulation = \
                 {terminate}, nominalsOfContinuousStatesChanged = {nominals}, nextEventTimeDefined = \
                 {timed} (expected all false)"
            ));
        }
        self.enter("fmi3EnterContinuousTimeMode()".into());
        let s = unsafe { fmu.fmi3EnterContinuousTimeMode(c) };
        self.done(s);
    }

    fn do_step(&mut self) {
        let point = if self.rng.chance(5) {
            self.rng.real()
        } else {
            self.time
        };
        let h = self.rng.step_size();
        let no_set = self.rng.flag();
        let (mut event, mut terminate, mut early, mut last) = (true, true, true, f64::NAN);
        let outs = (
            self.out(&mut event),
            self.out(&mut terminate),
            self.out(&mut early),
            self.out(&mut last),
        );
        self.enter(format!(
            "fmi3DoStep(currentCommunicationPoint = {point:?}, communicationStepSize = {h:?}, \
             noSetFMUStatePriorToCurrentPoint = {no_set}, eventHandlingNeeded = {:p}, \
             terminateSimulation = {:p}, earlyReturn = {:p}, lastSuccessfulTime = {:p})",
            outs.0, outs.1, outs.2, outs.3
        ));
        let s = unsafe {
            self.fmu
                .fmi3DoStep(self.c, point, h, no_set, outs.0, outs.1, outs.2, outs.3)
        };
        if self.done(s) == fmi3Status_fmi3OK {
            self.time = point + h;
            if outs.0.is_null() || outs.1.is_null() || outs.2.is_null() || outs.3.is_null() {
                self.fail("fmi3DoStep returned OK with a NULL out-pointer");
            }
            self.check_step_report(event, terminate, early, last);
        }
    }

    /// What a successful fmi3DoStep reports: no event, no termination, no early return,
    /// and the time it reached.
    fn check_step_report(&self, event: bool, terminate: bool, early: bool, last: f64) {
        if event || terminate || early || last != self.time {
            self.fail(&format!(
                "fmi3DoStep: eventHandlingNeeded = {event}, terminateSimulation = {terminate}, \
                 earlyReturn = {early}, lastSuccessfulTime = {last:?} (expected false, false, false, {:?})",
                self.time
            ));
        }
    }

    /// Get or set of one type, with values of that type: `kind` below [`TYPED_OTHERS`] is
    /// a type this FMU has no variables of (Float32, the integers but Int64, Boolean,
    /// Binary, Clock); [`TYPED_FLOAT64`] and [`TYPED_INT64`] are those of its variables.
    fn typed_call(&mut self, kind: u64, get: bool) {
        let (fmu, c) = (self.fmu, self.c);
        let (refs, r, nv) = self.references();
        let n = refs.len();
        macro_rules! typed {
            ($get:ident, $set:ident, $value:expr) => {{
                let mut values: Vec<_> = (0..nv).map(|_| $value).collect();
                if get {
                    let v = maybe_null_mut(self.rng, &mut values);
                    self.enter(format!(
                        "{}(vr = {}, nvr = {n}, values = {}, nValues = {nv})",
                        stringify!($get),
                        shown(r, &refs),
                        slots(v, nv)
                    ));
                    unsafe { fmu.$get(c, r, n, v, nv) }
                } else {
                    let v = maybe_null(self.rng, &values);
                    self.enter(format!(
                        "{}(vr = {}, nvr = {n}, values = {}, nValues = {nv})",
                        stringify!($set),
                        shown(r, &refs),
                        shown(v, &values)
                    ));
                    unsafe { fmu.$set(c, r, n, v, nv) }
                }
            }};
        }
        let s = match kind {
            TYPED_FLOAT64 => typed!(fmi3GetFloat64, fmi3SetFloat64, self.rng.real()),
            TYPED_INT64 => typed!(fmi3GetInt64, fmi3SetInt64, self.rng.int64()),
            0 => typed!(fmi3GetFloat32, fmi3SetFloat32, self.rng.real() as f32),
            1 => typed!(fmi3GetInt8, fmi3SetInt8, self.rng.next() as i8),
            2 => typed!(fmi3GetUInt8, fmi3SetUInt8, self.rng.next() as u8),
            3 => typed!(fmi3GetInt16, fmi3SetInt16, self.rng.next() as i16),
            4 => typed!(fmi3GetUInt16, fmi3SetUInt16, self.rng.next() as u16),
            5 => typed!(fmi3GetInt32, fmi3SetInt32, self.rng.next() as i32),
            6 => typed!(fmi3GetUInt32, fmi3SetUInt32, self.rng.next() as u32),
            7 => typed!(fmi3GetUInt64, fmi3SetUInt64, self.rng.next()),
            8 => typed!(fmi3GetBoolean, fmi3SetBoolean, self.rng.flag()),
            9 => {
                let data = self.rng.bytes(8);
                let mut sizes: Vec<usize> = (0..nv).map(|_| self.rng.below(9) as usize).collect();
                let mut values: Vec<fmi3Binary> = vec![data.as_ptr(); nv];
                let (sp, v) = (
                    maybe_null_mut(self.rng, &mut sizes),
                    maybe_null_mut(self.rng, &mut values),
                );
                let name = if get { "fmi3GetBinary" } else { "fmi3SetBinary" };
                self.enter(format!(
                    "{name}(vr = {}, nvr = {n}, valueSizes = {}, values = {}, nValues = {nv})",
                    shown(r, &refs),
                    shown(sp, &sizes),
                    slots(v, nv)
                ));
                unsafe {
                    if get {
                        fmu.fmi3GetBinary(c, r, n, sp, v, nv)
                    } else {
                        fmu.fmi3SetBinary(c, r, n, sp, v, nv)
                    }
                }
            }
            _ => {
                // Clocks: one value per value reference.
                let mut values: Vec<fmi3Clock> = (0..n).map(|_| self.rng.flag()).collect();
                let v = maybe_null_mut(self.rng, &mut values);
                let name = if get { "fmi3GetClock" } else { "fmi3SetClock" };
                self.enter(format!(
                    "{name}(vr = {}, nvr = {n}, values = {})",
                    shown(r, &refs),
                    slots(v, n)
                ));
                unsafe {
                    if get {
                        fmu.fmi3GetClock(c, r, n, v)
                    } else {
                        fmu.fmi3SetClock(c, r, n, v)
                    }
                }
            }
        };
        self.done(s);
    }

    /// A function of what the model description does not declare: fmi3Error, always.
    fn unsupported_call(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let (refs, r, _) = self.references();
        let n = refs.len();
        let rng = &mut *self.rng;
        let mut reals = vec![0.0; n];
        let (mut counters, mut resolutions) = (vec![0u64; n], vec![0u64; n]);
        let mut qualifiers: Vec<fmi3IntervalQualifier> = vec![0; n];
        let given = rng.reals(n);
        let integers: Vec<u64> = (0..n).map(|_| rng.next()).collect();
        let (vr, time) = (rng.value_reference(), rng.real());
        let mut count = 0usize;
        let (mut indices, mut independents, mut kinds) = (vec![0usize; n], vec![0u32; n], vec![0u32; n]);
        let (mut indices_of, mut sensitivity) = (vec![0usize; n], vec![0.0; n]);
        let which = rng.below(16);
        const NAMES: [&str; 16] = [
            "fmi3GetNumberOfVariableDependencies",
            "fmi3GetVariableDependencies",
            "fmi3GetAdjointDerivative",
            "fmi3EnterConfigurationMode",
            "fmi3ExitConfigurationMode",
            "fmi3GetIntervalDecimal",
            "fmi3GetIntervalFraction",
            "fmi3GetShiftDecimal",
            "fmi3GetShiftFraction",
            "fmi3SetIntervalDecimal",
            "fmi3SetIntervalFraction",
            "fmi3SetShiftDecimal",
            "fmi3SetShiftFraction",
            "fmi3EvaluateDiscreteStates",
            "fmi3ActivateModelPartition",
            "fmi3EnterStepMode",
        ];
        let name = NAMES[which as usize];
        self.enter(format!(
            "{name}(vr = {}, n = {n}, valueReference = {vr}, time = {time:?}, values = {given:?})",
            shown(r, &refs)
        ));
        let s = unsafe {
            match which {
                0 => fmu.fmi3GetNumberOfVariableDependencies(c, vr, &mut count),
                1 => fmu.fmi3GetVariableDependencies(
                    c,
                    vr,
                    indices.as_mut_ptr(),
                    independents.as_mut_ptr(),
                    indices_of.as_mut_ptr(),
                    kinds.as_mut_ptr(),
                    n,
                ),
                2 => fmu.fmi3GetAdjointDerivative(
                    c,
                    r,
                    n,
                    r,
                    n,
                    given.as_ptr(),
                    n,
                    sensitivity.as_mut_ptr(),
                    n,
                ),
                3 => fmu.fmi3EnterConfigurationMode(c),
                4 => fmu.fmi3ExitConfigurationMode(c),
                5 => fmu.fmi3GetIntervalDecimal(c, r, n, reals.as_mut_ptr(), qualifiers.as_mut_ptr()),
                6 => fmu.fmi3GetIntervalFraction(
                    c,
                    r,
                    n,
                    counters.as_mut_ptr(),
                    resolutions.as_mut_ptr(),
                    qualifiers.as_mut_ptr(),
                ),
                7 => fmu.fmi3GetShiftDecimal(c, r, n, reals.as_mut_ptr()),
                8 => fmu.fmi3GetShiftFraction(c, r, n, counters.as_mut_ptr(), resolutions.as_mut_ptr()),
                9 => fmu.fmi3SetIntervalDecimal(c, r, n, given.as_ptr()),
                10 => fmu.fmi3SetIntervalFraction(c, r, n, integers.as_ptr(), integers.as_ptr()),
                11 => fmu.fmi3SetShiftDecimal(c, r, n, given.as_ptr()),
                12 => fmu.fmi3SetShiftFraction(c, r, n, integers.as_ptr(), integers.as_ptr()),
                13 => fmu.fmi3EvaluateDiscreteStates(c),
                14 => fmu.fmi3ActivateModelPartition(c, vr, time),
                _ => fmu.fmi3EnterStepMode(c),
            }
        };
        if self.done(s) != fmi3Status_fmi3Error {
            self.fail(&format!("{name} is not provided, yet returned {s}"));
        }
    }

    /// A call with a NULL instance: refused, without a crash.
    fn no_instance_call(&mut self) {
        let fmu = self.fmu;
        let none: fmi3Instance = null_mut();
        let which = self.rng.below(9);
        let (mut value, mut flag, mut state) = ([0.0], [false; 3], null_mut());
        let s = unsafe {
            match which {
                0 => {
                    self.enter("fmi3EnterInitializationMode(instance = NULL, ..)".into());
                    fmu.fmi3EnterInitializationMode(none, false, 0.0, 0.0, false, 0.0)
                }
                1 => {
                    self.enter("fmi3DoStep(instance = NULL, ..)".into());
                    let [a, b, c] = &mut flag;
                    fmu.fmi3DoStep(none, 0.0, 1e-3, false, a, b, c, value.as_mut_ptr())
                }
                2 => {
                    self.enter("fmi3GetFloat64(instance = NULL, vr = [1], ..)".into());
                    fmu.fmi3GetFloat64(none, [1u32].as_ptr(), 1, value.as_mut_ptr(), 1)
                }
                3 => {
                    self.enter("fmi3SetTime(instance = NULL, 0)".into());
                    fmu.fmi3SetTime(none, 0.0)
                }
                4 => {
                    self.enter("fmi3GetFMUState(instance = NULL, ..)".into());
                    fmu.fmi3GetFMUState(none, &mut state)
                }
                5 => {
                    self.enter("fmi3Terminate(instance = NULL)".into());
                    fmu.fmi3Terminate(none)
                }
                6 => {
                    self.enter("fmi3SetDebugLogging(instance = NULL, ..)".into());
                    fmu.fmi3SetDebugLogging(none, true, 0, null())
                }
                7 => {
                    self.enter("fmi3EnterStepMode(instance = NULL)".into());
                    fmu.fmi3EnterStepMode(none)
                }
                _ => {
                    self.enter("fmi3FreeInstance(NULL); fmi3GetVersion()".into());
                    fmu.fmi3FreeInstance(none);
                    let version = CStr::from_ptr(fmu.fmi3GetVersion());
                    if version.to_bytes() != b"3.0" {
                        self.fail(&format!("fmi3GetVersion gave {version:?}"));
                    }
                    return;
                }
            }
        };
        self.done(s);
        if !state.is_null() {
            self.fail("fmi3GetFMUState made a state without an instance");
        }
    }

    /// The size of the last state taken and the state serialized, into buffers of the
    /// right size mostly; a serialized state joins the pool.
    fn serialize(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let state = self.saved.last().copied().unwrap_or(null_mut());
        let mut size = 0usize;
        let size_slot = if self.rng.chance(20) {
            null_mut()
        } else {
            &mut size as *mut _
        };
        self.enter(format!(
            "fmi3SerializedFMUStateSize(FMUState = {state:p}, size = {size_slot:p})"
        ));
        let s = unsafe { fmu.fmi3SerializedFMUStateSize(c, state, size_slot) };
        if self.done(s) != fmi3Status_fmi3OK {
            return;
        }
        let offered = match self.rng.below(6) {
            0 => size / 2,
            1 => size + 3,
            _ => size,
        };
        let mut buffer = vec![0u8; offered];
        let target = if self.rng.chance(15) {
            null_mut()
        } else {
            buffer.as_mut_ptr()
        };
        self.enter(format!(
            "fmi3SerializeFMUState(FMUState = {state:p}, serializedState = {}, size = {offered})",
            slots(target, offered)
        ));
        let s = unsafe { fmu.fmi3SerializeFMUState(c, state, target, offered) };
        if self.done(s) == fmi3Status_fmi3OK {
            buffer.truncate(size);
            if self.pool.len() < 8 {
                self.pool.push(buffer.clone());
            } else {
                let k = self.rng.below(8) as usize;
                self.pool[k] = buffer.clone();
            }
            self.serialized = buffer;
        }
    }

    /// Bytes for DeserializeFMUState: this instance's last serialized state, one of an
    /// earlier sequence or random bytes; then as they are, with a bit flipped, or changed
    /// where it counts (the phase, model and friction bytes, a real, a byte, the length) and
    /// the checksum written again, so that the parser sees the change.
    fn state_bytes(&mut self) -> Vec<u8> {
        let rng = &mut *self.rng;
        let mut bytes = match rng.below(5) {
            0 | 1 => self.serialized.clone(),
            2 if !self.pool.is_empty() => self.pool[rng.below(self.pool.len() as u64) as usize].clone(),
            3 => {
                let mut bytes = if rng.flag() { MAGIC.to_vec() } else { Vec::new() };
                let n = rng.below(700) as usize;
                bytes.extend(rng.bytes(n));
                bytes
            }
            _ => self.pool.first().cloned().unwrap_or_default(),
        };
        match rng.below(4) {
            0 => {}
            1 => {
                if !bytes.is_empty() {
                    let i = rng.below(bytes.len() as u64) as usize;
                    bytes[i] ^= 1 << rng.below(8);
                }
            }
            _ => {
                for _ in 0..1 + rng.below(3) {
                    let len = bytes.len() as u64;
                    match rng.below(6) {
                        0 if bytes.len() > HEADER + 4 => {
                            bytes[HEADER + rng.below(4) as usize] = rng.below(8) as u8;
                        }
                        1 if bytes.len() >= HEADER + 4 + 16 => {
                            let k = rng.below((len - HEADER as u64 - 4 - 8) / 8) as usize;
                            let at = HEADER + 4 + 8 * k;
                            bytes[at..at + 8].copy_from_slice(&rng.real().to_le_bytes());
                        }
                        2 if bytes.len() >= 8 => {
                            let at = rng.below(len - 7) as usize;
                            bytes[at..at + 8].copy_from_slice(&rng.real().to_le_bytes());
                        }
                        3 if !bytes.is_empty() => {
                            let at = rng.below(len) as usize;
                            bytes[at] = rng.next() as u8;
                        }
                        4 => {
                            let at = rng.below(len + 1) as usize;
                            bytes.truncate(at);
                        }
                        _ => {
                            let at = rng.below(len + 1) as usize;
                            let n = 1 + rng.below(8) as usize;
                            let inserted = rng.bytes(n);
                            bytes.splice(at..at, inserted);
                        }
                    }
                }
                reseal(&mut bytes);
            }
        }
        bytes
    }

    fn deserialize(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let bytes = self.state_bytes();
        let size = if self.rng.chance(6) {
            self.rng.below(bytes.len() as u64 + 1) as usize
        } else {
            bytes.len()
        };
        let source = if self.rng.chance(15) {
            null()
        } else {
            bytes.as_ptr()
        };
        let mut state = if self.rng.chance(4) {
            self.saved.last().copied().unwrap_or(null_mut())
        } else {
            null_mut()
        };
        let slot = if self.rng.chance(20) {
            null_mut()
        } else {
            &mut state as *mut _
        };
        let hex: String = bytes[..size].iter().map(|b| format!("{b:02x}")).collect();
        self.enter(format!(
            "fmi3DeserializeFMUState(serializedState = {}, size = {size}, FMUState = {slot:p} holding {state:p})",
            if source.is_null() { "NULL".into() } else { format!("hex {hex}") }
        ));
        let s = unsafe { fmu.fmi3DeserializeFMUState(c, source, size, slot) };
        self.done(s);
        if !state.is_null() && !self.saved.contains(&state) {
            self.saved.push(state);
        }
    }

    /// One Model Exchange call, vectors as in the FMI 2.0 part; the counts, the event
    /// update's and the integrator step's flags as this FMU gives them.
    fn model_exchange_call(&mut self) {
        let (fmu, c) = (self.fmu, self.c);
        let (n, mut values) = self.rng.state_vector();
        if self.rng.flag() {
            values
                .iter_mut()
                .filter(|v| !v.is_finite())
                .for_each(|v| *v = 0.0);
        }
        let p = maybe_null_mut(self.rng, &mut values);
        match self.rng.below(12) {
            0 => {
                let t = if self.rng.chance(3) {
                    self.rng.real()
                } else {
                    self.time + self.rng.step_size()
                };
                self.enter(format!("fmi3SetTime({t:?})"));
                let s = unsafe { fmu.fmi3SetTime(c, t) };
                if self.done(s) == fmi3Status_fmi3OK {
                    self.time = t;
                }
            }
            1 => {
                self.enter(format!(
                    "fmi3SetContinuousStates({}, {n})",
                    shown(p, &values[..n.min(values.len())])
                ));
                let s = unsafe { fmu.fmi3SetContinuousStates(c, p, n) };
                self.done(s);
            }
            which @ 2..=5 => {
                let (name, m) = match which {
                    2 => ("fmi3GetContinuousStates", n),
                    3 => ("fmi3GetContinuousStateDerivatives", n),
                    4 => ("fmi3GetEventIndicators", if self.rng.chance(4) { n } else { 9 }),
                    _ => ("fmi3GetNominalsOfContinuousStates", n),
                };
                self.enter(format!("{name}({}, {m})", slots(p, values.len())));
                let s = unsafe {
                    match which {
                        2 => fmu.fmi3GetContinuousStates(c, p, m),
                        3 => fmu.fmi3GetContinuousStateDerivatives(c, p, m),
                        4 => fmu.fmi3GetEventIndicators(c, p, m),
                        _ => fmu.fmi3GetNominalsOfContinuousStates(c, p, m),
                    }
                };
                self.done(s);
            }
            6 => {
                self.enter("fmi3EnterEventMode()".into());
                let s = unsafe { fmu.fmi3EnterEventMode(c) };
                self.done(s);
            }
            7 => {
                let (mut again, mut terminate, mut nominals, mut changed, mut timed) =
                    (true, true, true, true, true);
                let mut next = f64::NAN;
                let outs = (
                    self.out(&mut again),
                    self.out(&mut terminate),
                    self.out(&mut nominals),
                    self.out(&mut changed),
                    self.out(&mut timed),
                    self.out(&mut next),
                );
                self.enter(format!(
                    "fmi3UpdateDiscreteStates({:p}, {:p}, {:p}, {:p}, {:p}, {:p})",
                    outs.0, outs.1, outs.2, outs.3, outs.4, outs.5
                ));
                let s = unsafe {
                    fmu.fmi3UpdateDiscreteStates(c, outs.0, outs.1, outs.2, outs.3, outs.4, outs.5)
                };
                if self.done(s) == fmi3Status_fmi3OK && (again || terminate || nominals || timed) {
                    self.fail(&format!(
                        "fmi3UpdateDiscreteStates: discreteStatesNeedUpdate = {again}, terminateSimulation = \
                         {terminate}, nominalsOfContinuousStatesChanged = {nominals}, nextEventTimeDefined = \
                         {timed} (expected all false)"
                    ));
                }
            }
            8 => {
                self.enter("fmi3EnterContinuousTimeMode()".into());
                let s = unsafe { fmu.fmi3EnterContinuousTimeMode(c) };
                self.done(s);
            }
            9 => {
                let no_set = self.rng.flag();
                let (mut enter, mut terminate) = (true, true);
                let outs = (self.out(&mut enter), self.out(&mut terminate));
                self.enter(format!(
                    "fmi3CompletedIntegratorStep({no_set}, {:p}, {:p})",
                    outs.0, outs.1
                ));
                let s = unsafe { fmu.fmi3CompletedIntegratorStep(c, no_set, outs.0, outs.1) };
                if self.done(s) == fmi3Status_fmi3OK && (enter || terminate) {
                    self.fail("fmi3CompletedIntegratorStep asked for event mode or termination");
                }
            }
            which => {
                let mut count = usize::MAX;
                let slot = self.out(&mut count);
                let (name, expected) = if which == 10 {
                    ("fmi3GetNumberOfContinuousStates", 18)
                } else {
                    ("fmi3GetNumberOfEventIndicators", 9)
                };
                self.enter(format!("{name}({slot:p})"));
                let s = unsafe {
                    if which == 10 {
                        fmu.fmi3GetNumberOfContinuousStates(c, slot)
                    } else {
                        fmu.fmi3GetNumberOfEventIndicators(c, slot)
                    }
                };
                if self.done(s) == fmi3Status_fmi3OK && count != expected {
                    self.fail(&format!("{name} gave {count}, not {expected}"));
                }
            }
        }
    }
}

#[test]
fn random_fmi3_call_sequences_never_crash_or_leak_a_panic() {
    let (sequences, seed) = campaign();
    let fmu = support::fmi3::load();
    let tir_files = tir_file_names();
    let live = std::env::var_os("TIRELAG_FUZZ_TRACE").is_some();
    // A stream of its own: the FMI 2.0 sequences of a seed stay what they were.
    let mut rng = Rng(mix(seed) | 1);
    let mut pool = Vec::new();
    let mut counts = [0usize; 5];
    for sequence in 0..sequences {
        Fuzz3 {
            fmu: &fmu,
            rng: &mut rng,
            tir_files: &tir_files,
            pool: &mut pool,
            counts: &mut counts,
            live,
            label: format!("FMI 3.0 sequence {sequence} of TIRELAG_FUZZ_SEED={seed}"),
            c: null_mut(),
            model_exchange: false,
            time: 0.0,
            indicators: Vec::new(),
            saved: Vec::new(),
            serialized: Vec::new(),
            trace: Vec::new(),
        }
        .run();
    }
    assert_eq!(
        MALFORMED_3.load(Ordering::Relaxed),
        0,
        "log messages with another environment, a status beyond fmi3Error, an undeclared category or no text"
    );
    assert_eq!(
        UNEXPECTED_CALLBACKS.load(Ordering::Relaxed),
        0,
        "the FMU called an intermediate-update, clock or preemption callback"
    );
    assert!(counts[fmi3Status_fmi3OK as usize] > 0 && counts[fmi3Status_fmi3Error as usize] > 0);
    eprintln!(
        "FMI 3.0: {sequences} sequences: {} OK, {} warning, {} discard, {} error; {} log messages",
        counts[0],
        counts[1],
        counts[2],
        counts[3],
        MESSAGES_3.load(Ordering::Relaxed)
    );
}
