//! docs/specification.md 6b: no heap allocation in fmi2SetReal, fmi2GetReal or fmi2DoStep after the first
//! step, nor in their FMI 3.0 counterparts. A counting global allocator watches this test's thread while 10,000 full steps
//! of each model (5 inputs set with vx and Fz changing every step, a step, 9 outputs
//! read), without a friction limit, with Brush sticking and with Brush sliding, run through
//! the crate's exported C functions, called in-process (a separately loaded .so would bring
//! its own allocator, which this one could not see). The same for Model Exchange: 10,000
//! evaluations (time, states and inputs set, derivatives and event indicators read) along
//! an explicit Euler integration, with the event updates a slide brings. Each through the
//! FMI 2.0 and the FMI 3.0 functions ([`Api`]).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::CString;

use std::ffi::c_void;
use std::ptr::{null, null_mut};

use fmi_sys::fmi2::{
    fmi2EventInfo, fmi2Status_fmi2OK, fmi2Type_fmi2CoSimulation, fmi2Type_fmi2ModelExchange,
};
use tirelag::fmi::fmi2::*;
use tirelag::fmi::fmi3::*;

mod support;

use support::vr;

/// Counts allocations (and reallocations) made on a thread while it is watching.
struct CountingAllocator;

thread_local! {
    // Const-initialised and without destructors: safe to touch from the allocator.
    static WATCHING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn count() {
    if WATCHING.with(Cell::get) {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
    }
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Allocations made on this thread by `body`.
fn allocations_in(body: impl FnOnce()) -> u64 {
    ALLOCATIONS.with(|n| n.set(0));
    WATCHING.with(|w| w.set(true));
    body();
    WATCHING.with(|w| w.set(false));
    ALLOCATIONS.with(Cell::get)
}

const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];
const OUTPUTS: [u32; 9] = vr::OUTPUTS;
const TIRE_MODEL: u32 = vr::MODEL;
const FRICTION: u32 = vr::FRICTION;
const MU: [u32; 2] = [vr::MU_X, vr::MU_Y];
const OK: i32 = fmi2Status_fmi2OK as i32;

/// The calls of a step and of an evaluation, in one FMI version.
trait Api {
    const NAME: &str;
    /// An instance (Co-Simulation, or Model Exchange left in continuous-time mode) of
    /// model `model` with friction law `friction` (and mu = `mu` in both directions),
    /// initialised.
    fn initialised(
        name: &str,
        model_exchange: bool,
        model: i32,
        friction: i32,
        mu: Option<f64>,
    ) -> *mut c_void;
    fn set_inputs(c: *mut c_void, inputs: &[f64; 5]);
    fn step(c: *mut c_void, t: f64, h: f64);
    fn outputs(c: *mut c_void, outputs: &mut [f64; 9]);
    /// Time and states set; derivatives and event indicators read.
    fn evaluate(c: *mut c_void, t: f64, x: &[f64; STATES], dx: &mut [f64; STATES], z: &mut [f64; INDICATORS]);
    /// An event: the modes updated, the states read back.
    fn event(c: *mut c_void, x: &mut [f64; STATES]);
    fn free(c: *mut c_void);
}

const STATES: usize = 18;
const INDICATORS: usize = 9;

struct Fmi2;

impl Api for Fmi2 {
    const NAME: &str = "FMI 2.0";

    fn initialised(
        name: &str,
        model_exchange: bool,
        model: i32,
        friction: i32,
        mu: Option<f64>,
    ) -> *mut c_void {
        // The FMU keeps the logger and environment, not the table.
        let callbacks = support::callbacks();
        let guid = CString::new(tirelag::fmi::variables::GUID).unwrap();
        let name = CString::new(name).unwrap();
        let kind = if model_exchange {
            fmi2Type_fmi2ModelExchange
        } else {
            fmi2Type_fmi2CoSimulation
        };
        let c = fmi2Instantiate(
            name.as_ptr(),
            kind as _,
            guid.as_ptr(),
            c"".as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        assert_eq!(fmi2SetInteger(c, &TIRE_MODEL, 1, &model) as i32, OK);
        assert_eq!(fmi2SetInteger(c, &FRICTION, 1, &friction) as i32, OK);
        if let Some(mu) = mu {
            assert_eq!(fmi2SetReal(c, MU.as_ptr(), 2, [mu, mu].as_ptr()) as i32, OK);
        }
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) as i32, OK);
        assert_eq!(fmi2EnterInitializationMode(c) as i32, OK);
        assert_eq!(fmi2ExitInitializationMode(c) as i32, OK);
        if model_exchange {
            let mut info = unsafe { std::mem::zeroed::<fmi2EventInfo>() };
            assert_eq!(fmi2NewDiscreteStates(c, &mut info) as i32, OK);
            assert_eq!(fmi2EnterContinuousTimeMode(c) as i32, OK);
        }
        c
    }

    fn set_inputs(c: *mut c_void, inputs: &[f64; 5]) {
        assert_eq!(fmi2SetReal(c, INPUTS.as_ptr(), 5, inputs.as_ptr()) as i32, OK);
    }

    fn step(c: *mut c_void, t: f64, h: f64) {
        assert_eq!(fmi2DoStep(c, t, h, 1) as i32, OK);
    }

    fn outputs(c: *mut c_void, outputs: &mut [f64; 9]) {
        assert_eq!(
            fmi2GetReal(c, OUTPUTS.as_ptr(), 9, outputs.as_mut_ptr()) as i32,
            OK
        );
    }

    fn evaluate(
        c: *mut c_void,
        t: f64,
        x: &[f64; STATES],
        dx: &mut [f64; STATES],
        z: &mut [f64; INDICATORS],
    ) {
        assert_eq!(fmi2SetTime(c, t) as i32, OK);
        assert_eq!(fmi2SetContinuousStates(c, x.as_ptr(), STATES) as i32, OK);
        assert_eq!(fmi2GetDerivatives(c, dx.as_mut_ptr(), STATES) as i32, OK);
        assert_eq!(fmi2GetEventIndicators(c, z.as_mut_ptr(), INDICATORS) as i32, OK);
    }

    fn event(c: *mut c_void, x: &mut [f64; STATES]) {
        let mut info = unsafe { std::mem::zeroed::<fmi2EventInfo>() };
        assert_eq!(fmi2EnterEventMode(c) as i32, OK);
        assert_eq!(fmi2NewDiscreteStates(c, &mut info) as i32, OK);
        assert_eq!(fmi2EnterContinuousTimeMode(c) as i32, OK);
        assert_eq!(fmi2GetContinuousStates(c, x.as_mut_ptr(), STATES) as i32, OK);
    }

    fn free(c: *mut c_void) {
        fmi2FreeInstance(c);
    }
}

struct Fmi3;

impl Api for Fmi3 {
    const NAME: &str = "FMI 3.0";

    fn initialised(
        name: &str,
        model_exchange: bool,
        model: i32,
        friction: i32,
        mu: Option<f64>,
    ) -> *mut c_void {
        let token = CString::new(tirelag::fmi::variables::GUID).unwrap();
        let name = CString::new(name).unwrap();
        let c = if model_exchange {
            fmi3InstantiateModelExchange(
                name.as_ptr(),
                token.as_ptr(),
                null(),
                false,
                false,
                null_mut(),
                None,
            )
        } else {
            let (ptr, token) = (name.as_ptr(), token.as_ptr());
            fmi3InstantiateCoSimulation(
                ptr,
                token,
                null(),
                false,
                false,
                false,
                false,
                null(),
                0,
                null_mut(),
                None,
                None,
            )
        };
        assert!(!c.is_null());
        let selectors = [i64::from(model), i64::from(friction)];
        assert_eq!(
            fmi3SetInt64(c, [TIRE_MODEL, FRICTION].as_ptr(), 2, selectors.as_ptr(), 2) as i32,
            OK
        );
        if let Some(mu) = mu {
            assert_eq!(fmi3SetFloat64(c, MU.as_ptr(), 2, [mu, mu].as_ptr(), 2) as i32, OK);
        }
        assert_eq!(
            fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) as i32,
            OK
        );
        assert_eq!(fmi3ExitInitializationMode(c) as i32, OK);
        if model_exchange {
            Self::update(c);
            assert_eq!(fmi3EnterContinuousTimeMode(c) as i32, OK);
        }
        c
    }

    fn set_inputs(c: *mut c_void, inputs: &[f64; 5]) {
        assert_eq!(
            fmi3SetFloat64(c, INPUTS.as_ptr(), 5, inputs.as_ptr(), 5) as i32,
            OK
        );
    }

    fn step(c: *mut c_void, t: f64, h: f64) {
        let (mut event, mut terminate, mut early, mut last) = (false, false, false, 0.0);
        let status = fmi3DoStep(c, t, h, true, &mut event, &mut terminate, &mut early, &mut last);
        assert_eq!(status as i32, OK);
    }

    fn outputs(c: *mut c_void, outputs: &mut [f64; 9]) {
        assert_eq!(
            fmi3GetFloat64(c, OUTPUTS.as_ptr(), 9, outputs.as_mut_ptr(), 9) as i32,
            OK
        );
    }

    fn evaluate(
        c: *mut c_void,
        t: f64,
        x: &[f64; STATES],
        dx: &mut [f64; STATES],
        z: &mut [f64; INDICATORS],
    ) {
        assert_eq!(fmi3SetTime(c, t) as i32, OK);
        assert_eq!(fmi3SetContinuousStates(c, x.as_ptr(), STATES) as i32, OK);
        assert_eq!(
            fmi3GetContinuousStateDerivatives(c, dx.as_mut_ptr(), STATES) as i32,
            OK
        );
        assert_eq!(fmi3GetEventIndicators(c, z.as_mut_ptr(), INDICATORS) as i32, OK);
    }

    fn event(c: *mut c_void, x: &mut [f64; STATES]) {
        assert_eq!(fmi3EnterEventMode(c) as i32, OK);
        Self::update(c);
        assert_eq!(fmi3EnterContinuousTimeMode(c) as i32, OK);
        assert_eq!(fmi3GetContinuousStates(c, x.as_mut_ptr(), STATES) as i32, OK);
    }

    fn free(c: *mut c_void) {
        fmi3FreeInstance(c);
    }
}

impl Fmi3 {
    fn update(c: *mut c_void) {
        let mut flags = [false; 5];
        let [again, terminate, nominals, values, timed] = &mut flags;
        let mut next = 0.0;
        let status = fmi3UpdateDiscreteStates(c, again, terminate, nominals, values, timed, &mut next);
        assert_eq!(status as i32, OK);
    }
}

#[test]
fn the_counter_sees_an_allocation() {
    assert_eq!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);
}

#[test]
fn a_step_allocates_nothing_after_the_first() {
    steps_allocate_nothing::<Fmi2>();
    steps_allocate_nothing::<Fmi3>();
}

fn steps_allocate_nothing<I: Api>() {
    // Each model without a limit, with Brush (sticking at these inputs), with Brush at
    // mu = 0.02 (sliding: every step goes through the sliding integration), and with Brush
    // at 5 ms steps (sticking steps longer than one force bound: bounded part by part).
    let settings = [
        (1, None, 1e-3),
        (3, None, 1e-3),
        (3, Some(0.02), 1e-3),
        (3, None, 5e-3),
    ];
    for model in 1..=4 {
        for (friction, mu, h) in settings {
            let name = format!("no_allocation_{}_{model}_{friction}_{h}", I::NAME);
            let c = I::initialised(&name, false, model, friction, mu);
            let table = support::yardstick_inputs(true, 10_001, 1e-3);
            let mut outputs = [0.0; 9];
            let mut step = |k: usize| {
                I::set_inputs(c, &table[k]);
                I::step(c, k as f64 * h, h);
                I::outputs(c, &mut outputs);
            };
            step(0);
            let allocations = allocations_in(|| (1..=10_000).for_each(&mut step));
            assert_eq!(
                allocations,
                0,
                "{}: model {model}, friction {friction}, mu {mu:?}, h {h}: {allocations} allocations in 10,000 steps",
                I::NAME
            );
            assert!(outputs.iter().all(|v| v.is_finite()) && outputs[1] != 0.0);
            if mu.is_some() {
                assert!(
                    outputs[1].abs() <= 0.02 * 50_000.0 * 1.05,
                    "the limit acts: Fy = {}",
                    outputs[1]
                );
            }
            I::free(c);
        }
    }
}

#[test]
fn a_model_exchange_evaluation_allocates_nothing() {
    evaluations_allocate_nothing::<Fmi2>();
    evaluations_allocate_nothing::<Fmi3>();
}

fn evaluations_allocate_nothing<I: Api>() {
    for model in 1..=4 {
        for (friction, mu) in [(1, None), (3, None), (3, Some(0.02)), (2, Some(0.02))] {
            let name = format!("no_allocation_me_{}_{model}_{friction}_{mu:?}", I::NAME);
            let c = I::initialised(&name, true, model, friction, mu);
            let h = 1e-4;
            let table = support::yardstick_inputs(true, 10_001, 1e-3);
            let (mut x, mut dx) = ([0.0; STATES], [0.0; STATES]);
            let (mut before, mut after) = ([0.0; INDICATORS], [0.0; INDICATORS]);
            let mut events = 0;
            let mut evaluate = |k: usize| {
                I::set_inputs(c, &table[k]);
                I::evaluate(c, k as f64 * h, &x, &mut dx, &mut after);
                if k > 0 && before.iter().zip(&after).any(|(b, a)| (*b > 0.0) != (*a > 0.0)) {
                    events += 1;
                    I::event(c, &mut x);
                    I::evaluate(c, k as f64 * h, &x, &mut dx, &mut after);
                }
                before = after;
                for (state, rate) in x.iter_mut().zip(&dx) {
                    *state += h * rate;
                }
            };
            evaluate(0);
            let allocations = allocations_in(|| (1..=10_000).for_each(&mut evaluate));
            assert_eq!(
                allocations,
                0,
                "{}: model {model}, friction {friction}, mu {mu:?}: {allocations} allocations in 10,000 evaluations",
                I::NAME
            );
            assert!(x.iter().all(|v| v.is_finite()));
            if mu.is_some() {
                assert!(
                    events > 0,
                    "model {model}, friction {friction}: the tire must slide"
                );
            }
            I::free(c);
        }
    }
}
