//! Random sequences of FMI calls with random arguments (non-finite, huge, negative and
//! null included) against the packed binary: no crash, no hang, no panic leaking out as
//! fmi2Fatal. `cargo test --test fuzz_calls` runs 2,000 sequences; set
//! TIRELAG_FUZZ_SEQUENCES=100000 for the full campaign and TIRELAG_FUZZ_SEED to vary it.

mod support;

use std::ffi::CString;
use std::ptr::{null, null_mut};

use fmi_sys::fmi2::*;
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
            refs: (0..n).map(|_| rng.value_reference()).collect(),
            reals: (0..n).map(|_| rng.real()).collect(),
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
    let n = if rng.chance(4) { rng.below(30) as usize } else { 18 };
    let mut values: Vec<f64> = (0..n.max(9)).map(|_| rng.real() * 1e-3).collect();
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

#[test]
fn random_call_sequences_never_crash_or_leak_a_panic() {
    let sequences: u64 =
        std::env::var("TIRELAG_FUZZ_SEQUENCES").map_or(2_000, |v| v.parse().expect("a count"));
    let seed: u64 = std::env::var("TIRELAG_FUZZ_SEED").map_or(0x7153_1a6e, |v| v.parse().expect("a seed"));
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
