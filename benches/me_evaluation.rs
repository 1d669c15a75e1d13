//! The cost of one Model Exchange evaluation through the C ABI, as an importer's solver
//! makes it (SPEC 6b): `cargo bench --bench me_evaluation` after `./scripts/build-fmu`.
//!
//! Per evaluation: fmi2SetTime, fmi2SetContinuousStates of the 18 states, fmi2SetReal of
//! the 5 inputs, fmi2GetDerivatives and fmi2GetEventIndicators, on the packed binary
//! loaded with libloading. The states move along an explicit Euler integration at 0.1 ms
//! (one evaluation per step, its cost a few additions), so every evaluation sees new
//! states; the inputs are those of the shared yardstick, tabulated before timing, with vx
//! and Fz changing at every evaluation ("varying") or held ("constant"). Default Brush
//! law, every branch sticking (the inputs stay below 0.2 Fmax), and Unlimited. Median
//! over timed passes after a warm-up.

use std::hint::black_box;
use std::time::Instant;

#[path = "../tests/support/mod.rs"]
mod support;

use fmi_sys::fmi2::{fmi2EventInfo, fmi2Type_fmi2ModelExchange};
use support::{OK, Slave, vr};

const STATES: usize = 18;
const INDICATORS: usize = 9;
const STEP: f64 = 1e-4;
const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];

/// Nanoseconds per evaluation, one pass over `table` from states `x`.
fn pass(slave: &Slave, table: &[[f64; 5]], x: &mut [f64; STATES]) -> f64 {
    let fmu = slave.fmu;
    let (mut derivatives, mut indicators) = ([0.0; STATES], [0.0; INDICATORS]);
    let start = Instant::now();
    for (k, inputs) in table.iter().enumerate() {
        // SAFETY: the arrays hold exactly the counts passed; the instance is live.
        unsafe {
            assert_eq!(fmu.fmi2SetTime(slave.c, k as f64 * STEP), OK);
            assert_eq!(fmu.fmi2SetContinuousStates(slave.c, x.as_ptr(), STATES), OK);
            assert_eq!(fmu.fmi2SetReal(slave.c, INPUTS.as_ptr(), 5, inputs.as_ptr()), OK);
            assert_eq!(
                fmu.fmi2GetDerivatives(slave.c, derivatives.as_mut_ptr(), STATES),
                OK
            );
            assert_eq!(
                fmu.fmi2GetEventIndicators(slave.c, indicators.as_mut_ptr(), INDICATORS),
                OK
            );
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
                pass(&slave, table, &mut x); // warm-up
                let times: Vec<f64> = (0..passes).map(|_| pass(&slave, table, &mut x)).collect();
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
