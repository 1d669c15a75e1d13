//! SPEC 6b: no heap allocation in fmi2SetReal, fmi2GetReal or fmi2DoStep after the first
//! step. A counting global allocator watches this test's thread while 10,000 full steps
//! of each model (5 inputs set with vx and Fz changing every step, a step, 9 outputs
//! read), without a friction limit, with Brush sticking and with Brush sliding, run through
//! the crate's exported C functions, called in-process (a separately loaded .so would bring
//! its own allocator, which this one could not see). The same for Model Exchange: 10,000
//! evaluations (time, states and inputs set, derivatives and event indicators read) along
//! an explicit Euler integration, with the event updates a slide brings.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ffi::CString;

use fmi_sys::fmi2::{
    fmi2EventInfo, fmi2Status_fmi2OK, fmi2Type_fmi2CoSimulation, fmi2Type_fmi2ModelExchange,
};
use tirelag::fmi::exports::*;

mod support;

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

const INPUTS: [u32; 5] = [1, 2, 3, 4, 5];
const OUTPUTS: [u32; 9] = [11, 12, 13, 14, 15, 16, 17, 18, 19];
const TIRE_MODEL: u32 = 100;
const FRICTION: u32 = 121;
const MU: [u32; 2] = [122, 123];
const OK: i32 = fmi2Status_fmi2OK as i32;

fn inputs_at(k: usize) -> [f64; 5] {
    let t = k as f64 * 1e-3;
    [
        10.0 + 1e-3 * (k % 1000) as f64,
        0.1 * t.sin(),
        0.05 * t.cos(),
        0.01 * t.sin(),
        50_000.0 * (1.0 + 0.02 * (2.0 * t).sin()),
    ]
}

/// An instance (Co-Simulation or Model Exchange: `kind`) of model `model` with friction law
/// `friction` (and mu = `mu` in both directions), initialised.
fn initialised(name: &str, kind: u32, model: i32, friction: i32, mu: Option<f64>) -> *mut std::ffi::c_void {
    // The FMU keeps the logger and environment, not the table.
    let callbacks = support::callbacks();
    let guid = CString::new(tirelag::fmi::variables::GUID).unwrap();
    let name = CString::new(name).unwrap();
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
    c
}

#[test]
fn the_counter_sees_an_allocation() {
    assert_eq!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 16]))), 1);
}

#[test]
fn a_step_allocates_nothing_after_the_first() {
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
            let name = format!("no_allocation_{model}_{friction}_{h}");
            let c = initialised(&name, fmi2Type_fmi2CoSimulation, model, friction, mu);
            let table: Vec<[f64; 5]> = (0..10_001).map(inputs_at).collect();
            let mut outputs = [0.0; 9];
            let mut step = |k: usize| {
                assert_eq!(fmi2SetReal(c, INPUTS.as_ptr(), 5, table[k].as_ptr()) as i32, OK);
                assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1) as i32, OK);
                assert_eq!(
                    fmi2GetReal(c, OUTPUTS.as_ptr(), 9, outputs.as_mut_ptr()) as i32,
                    OK
                );
            };
            step(0);
            let allocations = allocations_in(|| (1..=10_000).for_each(&mut step));
            assert_eq!(
                allocations, 0,
                "model {model}, friction {friction}, mu {mu:?}, h {h}: {allocations} allocations in 10,000 steps"
            );
            assert!(outputs.iter().all(|v| v.is_finite()) && outputs[1] != 0.0);
            if mu.is_some() {
                assert!(
                    outputs[1].abs() <= 0.02 * 50_000.0 * 1.05,
                    "the limit acts: Fy = {}",
                    outputs[1]
                );
            }
            fmi2FreeInstance(c);
        }
    }
}

#[test]
fn a_model_exchange_evaluation_allocates_nothing() {
    const STATES: usize = 18;
    const INDICATORS: usize = 9;
    for model in 1..=4 {
        for (friction, mu) in [(1, None), (3, None), (3, Some(0.02)), (2, Some(0.02))] {
            let name = format!("no_allocation_me_{model}_{friction}_{mu:?}");
            let c = initialised(&name, fmi2Type_fmi2ModelExchange, model, friction, mu);
            let mut info = unsafe { std::mem::zeroed::<fmi2EventInfo>() };
            assert_eq!(fmi2NewDiscreteStates(c, &mut info) as i32, OK);
            assert_eq!(fmi2EnterContinuousTimeMode(c) as i32, OK);
            let h = 1e-4;
            let table: Vec<[f64; 5]> = (0..10_001).map(inputs_at).collect();
            let (mut x, mut dx) = ([0.0; STATES], [0.0; STATES]);
            let (mut before, mut after) = ([0.0; INDICATORS], [0.0; INDICATORS]);
            let mut events = 0;
            let mut evaluate = |k: usize| {
                assert_eq!(fmi2SetTime(c, k as f64 * h) as i32, OK);
                assert_eq!(fmi2SetContinuousStates(c, x.as_ptr(), STATES) as i32, OK);
                assert_eq!(fmi2SetReal(c, INPUTS.as_ptr(), 5, table[k].as_ptr()) as i32, OK);
                assert_eq!(fmi2GetDerivatives(c, dx.as_mut_ptr(), STATES) as i32, OK);
                assert_eq!(
                    fmi2GetEventIndicators(c, after.as_mut_ptr(), INDICATORS) as i32,
                    OK
                );
                if k > 0 && before.iter().zip(&after).any(|(b, a)| (*b > 0.0) != (*a > 0.0)) {
                    events += 1;
                    assert_eq!(fmi2EnterEventMode(c) as i32, OK);
                    assert_eq!(fmi2NewDiscreteStates(c, &mut info) as i32, OK);
                    assert_eq!(fmi2EnterContinuousTimeMode(c) as i32, OK);
                    assert_eq!(fmi2GetContinuousStates(c, x.as_mut_ptr(), STATES) as i32, OK);
                    assert_eq!(fmi2GetDerivatives(c, dx.as_mut_ptr(), STATES) as i32, OK);
                    assert_eq!(
                        fmi2GetEventIndicators(c, after.as_mut_ptr(), INDICATORS) as i32,
                        OK
                    );
                }
                before = after;
                for (state, rate) in x.iter_mut().zip(&dx) {
                    *state += h * rate;
                }
            };
            evaluate(0);
            let allocations = allocations_in(|| (1..=10_000).for_each(&mut evaluate));
            assert_eq!(
                allocations, 0,
                "model {model}, friction {friction}, mu {mu:?}: {allocations} allocations in 10,000 evaluations"
            );
            assert!(x.iter().all(|v| v.is_finite()));
            if mu.is_some() {
                assert!(
                    events > 0,
                    "model {model}, friction {friction}: the tire must slide"
                );
            }
            fmi2FreeInstance(c);
        }
    }
}
