//! The cost of one Model Exchange evaluation through the C ABI, as an importer's solver
//! makes it (docs/specification.md 6b): `cargo bench --bench me_evaluation` after
//! `./scripts/build-fmu`.
//!
//! Per evaluation: fmi2SetTime, fmi2SetContinuousStates of the 18 states, fmi2SetReal of
//! the 5 inputs, fmi2GetDerivatives and fmi2GetEventIndicators, on the packed binary
//! loaded with libloading and called through its function pointers, as a C importer
//! holds them. The states move along an explicit Euler integration at 0.1 ms (one
//! evaluation per step, its cost a few additions), so every evaluation sees new states;
//! the inputs are those of the shared yardstick, tabulated before timing, with vx and Fz
//! changing at every evaluation ("varying") or held ("constant"). Default Brush law,
//! every branch sticking (the inputs stay below 0.2 Fmax), and Unlimited. Median over
//! timed passes after a warm-up.

use std::hint::black_box;
use std::time::Instant;

#[path = "../tests/support/mod.rs"]
mod support;

use fmi_sys::fmi2::{Fmi2Binding, fmi2Component, fmi2EventInfo, fmi2Status, fmi2Type_fmi2ModelExchange};
use support::{OK, Slave, vr};

const STATES: usize = 18;
const INDICATORS: usize = 9;
const STEP: f64 = 1e-4;
const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];

/// The five calls of an evaluation, as a C importer holds them: the binary's own function
/// pointers, resolved once (not looked up in the loader's table at every call).
struct Calls {
    set_time: unsafe extern "C" fn(fmi2Component, f64) -> fmi2Status,
    set_states: unsafe extern "C" fn(fmi2Component, *const f64, usize) -> fmi2Status,
    set_real: unsafe extern "C" fn(fmi2Component, *const u32, usize, *const f64) -> fmi2Status,
    get_derivatives: unsafe extern "C" fn(fmi2Component, *mut f64, usize) -> fmi2Status,
    get_indicators: unsafe extern "C" fn(fmi2Component, *mut f64, usize) -> fmi2Status,
}

impl Calls {
    fn of(fmu: &Fmi2Binding) -> Self {
        let found = "the binary exports every Model Exchange function";
        Calls {
            set_time: *fmu.fmi2SetTime.as_ref().expect(found),
            set_states: *fmu.fmi2SetContinuousStates.as_ref().expect(found),
            set_real: *fmu.fmi2SetReal.as_ref().expect(found),
            get_derivatives: *fmu.fmi2GetDerivatives.as_ref().expect(found),
            get_indicators: *fmu.fmi2GetEventIndicators.as_ref().expect(found),
        }
    }
}

/// Nanoseconds per evaluation, one pass over `table` from states `x`.
fn pass(calls: &Calls, c: fmi2Component, table: &[[f64; 5]], x: &mut [f64; STATES]) -> f64 {
    let (mut derivatives, mut indicators) = ([0.0; STATES], [0.0; INDICATORS]);
    let start = Instant::now();
    for (k, inputs) in table.iter().enumerate() {
        // SAFETY: the arrays hold exactly the counts passed; the instance is live.
        unsafe {
            assert_eq!((calls.set_time)(c, k as f64 * STEP), OK);
            assert_eq!((calls.set_states)(c, x.as_ptr(), STATES), OK);
            assert_eq!((calls.set_real)(c, INPUTS.as_ptr(), 5, inputs.as_ptr()), OK);
            assert_eq!((calls.get_derivatives)(c, derivatives.as_mut_ptr(), STATES), OK);
            assert_eq!((calls.get_indicators)(c, indicators.as_mut_ptr(), INDICATORS), OK);
        }
        for (state, rate) in x.iter_mut().zip(&derivatives) {
            *state += STEP * rate;
        }
        black_box(&indicators);
    }
    start.elapsed().as_nanos() as f64 / table.len() as f64
}

fn main() {
    let (steps, passes) = support::bench_size();
    let fmu = support::load();
    let calls = Calls::of(&fmu);
    let tables = [true, false].map(|varying| support::yardstick_inputs(varying, steps, STEP));
    println!(
        "{:<26} {:>24} {:>24}",
        "ns per ME evaluation", "vx, Fz varying (min-max)", "constant (min-max)"
    );
    for (model, model_name) in [(1, "RLT"), (2, "DDT"), (3, "SecondOrder"), (4, "RingBody")] {
        for (law, law_name) in [(1, "Unlimited"), (3, "Brush")] {
            let mut cells = Vec::new();
            for table in &tables {
                let integers = [(vr::MODEL, model), (vr::FRICTION, law)];
                let slave = Slave::configured_as(&fmu, "bench", fmi2Type_fmi2ModelExchange, &integers, &[]);
                // SAFETY: the instance is live; the event info is written by the call.
                unsafe {
                    let mut info = std::mem::zeroed::<fmi2EventInfo>();
                    assert_eq!(fmu.fmi2NewDiscreteStates(slave.c, &mut info), OK);
                    assert_eq!(fmu.fmi2EnterContinuousTimeMode(slave.c), OK);
                }
                let mut x = [0.0; STATES];
                pass(&calls, slave.c, table, &mut x); // warm-up
                let times: Vec<f64> = (0..passes)
                    .map(|_| pass(&calls, slave.c, table, &mut x))
                    .collect();
                cells.push(support::timing_cell(times).1);
            }
            println!(
                "{:<26} {:>24} {:>24}",
                format!("{model_name} {law_name}"),
                cells[0],
                cells[1]
            );
        }
    }
}
