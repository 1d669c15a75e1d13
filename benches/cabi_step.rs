//! The cost of a full co-simulation step through the C ABI, as a native importer drives
//! the packed binary (docs/specification.md 6b): `cargo bench --bench cabi_step` after
//! `./scripts/build-fmu`.
//!
//! Per step: fmi2SetReal of the 5 inputs, fmi2DoStep of 1 ms, fmi2GetReal of the 9
//! outputs, on `target/fmu/TireLag.so` (or `TIRELAG_SO`) loaded with libloading. Two cases:
//! "varying", vx = 10 + 0.001 (k mod 1000) and Fz = 50000 (1 + 0.02 sin 2t) changing every
//! step as in a vehicle model, and "constant", vx = 10 and Fz = 50000; vy = 0.1 sin t,
//! steerRate = 0.05 cos t, vsx = 0.01 sin t throughout (the inputs of the shared yardstick).
//! The inputs are tabulated before timing. Median over timed passes after a warm-up.
//!
//! `TIRELAG_BENCH_STEP` sets another communication step in seconds (e.g. 0.005: steps
//! longer than the sticking check bounds at once for the contact-mass models).
//!
//! Each model runs with three friction settings: `Unlimited` (the linear model), `Brush`
//! (the default; these inputs stay below 0.2 Fmax, so every branch sticks), and `Brush`
//! with mu = 0.02 (Fmax 1 kN: the tire slides, and steps go through the sliding path).
//!
//! Then a stiff tire at a light load, as every wheel passes through on its way to
//! lift-off: Calpha = Ckappa = 1e7, sigmaY = sigmaX = 0.05 m (2e8 N/m), Fz = 100 N,
//! vx = 5 m/s, with Coulomb and Brush. "sliding": vy = -0.5, vsx = -0.3 m/s, both
//! directions sliding on the friction ellipse, whose force turns towards the slip within
//! microseconds; "sticking": the same tire at vy = vsx = -2e-6 m/s, below 0.1 Fmax.
//! "sliding, varying": the slide with inputs that change every step as in a vehicle
//! model (vx = 5 + 0.001 (k mod 1000), Fz = 100 (1 + 0.02 sin 2t), vy = -0.5 + 0.1 sin t,
//! steerRate = 0.05 cos t, vsx = -0.3 + 0.01 sin t), so that every step starts off the
//! equilibrium of its inputs and relaxes towards it.

use std::hint::black_box;
use std::time::Instant;

#[path = "../tests/support/mod.rs"]
mod support;

use support::{OK, Slave, vr};

/// The communication step, s: 1 ms unless `TIRELAG_BENCH_STEP` says otherwise.
fn step_size() -> f64 {
    std::env::var("TIRELAG_BENCH_STEP")
        .ok()
        .and_then(|s| s.parse().ok())
        .filter(|h: &f64| *h > 0.0 && h.is_finite())
        .unwrap_or(1e-3)
}
const INPUTS: [u32; 5] = [vr::VX, vr::VY, vr::STEER_RATE, vr::VSX, vr::FZ];

/// Nanoseconds per full step, one pass over `table` on one instance.
fn pass(slave: &mut Slave, table: &[[f64; 5]], step: f64, outputs: &mut [f64; 9]) -> f64 {
    let fmu = slave.fmu;
    let start = Instant::now();
    for inputs in table {
        // SAFETY: the arrays hold exactly the counts passed; the instance is live.
        unsafe {
            assert_eq!(fmu.fmi2SetReal(slave.c, INPUTS.as_ptr(), 5, inputs.as_ptr()), OK);
            assert_eq!(fmu.fmi2DoStep(slave.c, slave.time, step, 1), OK);
            assert_eq!(
                fmu.fmi2GetReal(slave.c, vr::OUTPUTS.as_ptr(), 9, outputs.as_mut_ptr()),
                OK
            );
        }
        slave.time += step;
        black_box(&outputs);
    }
    start.elapsed().as_nanos() as f64 / table.len() as f64
}

/// A friction setting: its name, the `friction` value and Real parameters to set.
type Setting = (&'static str, i32, &'static [(u32, f64)]);

fn main() {
    let (steps, passes) = support::bench_size();
    let fmu = support::load();
    let step = step_size();
    let tables = [true, false].map(|varying| support::yardstick_inputs(varying, steps, step));
    println!(
        "{:<26} {:>24} {:>24}",
        format!("ns per step (h = {} ms)", step * 1e3),
        "vx, Fz varying (min-max)",
        "constant (min-max)"
    );
    let settings: [Setting; 3] = [
        ("Unlimited", 1, &[]),
        ("Brush", 3, &[]),
        ("Brush sliding", 3, &[(vr::MU_X, 0.02), (vr::MU_Y, 0.02)]),
    ];
    for (model, model_name) in [(1, "RLT"), (2, "DDT"), (3, "SecondOrder"), (4, "RingBody")] {
        for (law_name, law, reals) in settings {
            let name = format!("{model_name} {law_name}");
            let mut cells = Vec::new();
            for table in &tables {
                let integers = [(vr::MODEL, model), (vr::FRICTION, law)];
                let mut slave = Slave::configured(&fmu, "bench", &integers, reals);
                let mut outputs = [0.0; 9];
                pass(&mut slave, table, step, &mut outputs); // warm-up
                let times: Vec<f64> = (0..passes)
                    .map(|_| pass(&mut slave, table, step, &mut outputs))
                    .collect();
                cells.push(support::timing_cell(times).1);
            }
            println!("{name:<26} {:>24} {:>24}", cells[0], cells[1]);
        }
    }
    stiff_light_tire(&fmu, steps, passes, step);
}

/// The stiff tire at a light load, sticking and sliding, per model and law (see the top).
fn stiff_light_tire(fmu: &fmi_sys::fmi2::Fmi2Binding, steps: usize, passes: usize, step: f64) {
    // Sliding steps of this tire cost up to milliseconds: far fewer of them per pass.
    let (steps, passes) = ((steps / 100).max(20), passes.min(5));
    println!(
        "\n{:<26} {:>24} {:>24} {:>7} {:>28}",
        "stiff light tire, ns/step",
        "sticking (min-max)",
        "sliding (min-max)",
        "ratio",
        "sliding, varying (min-max)"
    );
    let reals = [
        (vr::CALPHA, 1e7),
        (vr::CKAPPA, 1e7),
        (vr::SIGMA_Y, 0.05),
        (vr::SIGMA_X, 0.05),
        // The tread of SecondOrder and RingBody shorter than the relaxation lengths.
        (vr::SIGMA_TREAD, 0.01),
    ];
    for (model, model_name) in [(1, "RLT"), (2, "DDT"), (3, "SecondOrder"), (4, "RingBody")] {
        for (law, law_name) in [(2, "Coulomb"), (3, "Brush")] {
            let mut cells = Vec::new();
            let mut medians = Vec::new();
            let held = |slip: f64| vec![[5.0, 0.5 * slip, 0.0, 0.3 * slip, 100.0]; steps];
            for table in [held(-2e-6), held(-1.0), varying_stiff_slide(steps, step)] {
                let integers = [(vr::MODEL, model), (vr::FRICTION, law)];
                let mut slave = Slave::configured(fmu, "stiff", &integers, &reals);
                let mut outputs = [0.0; 9];
                pass(&mut slave, &table, step, &mut outputs); // warm-up, into steady sliding
                let times: Vec<f64> = (0..passes)
                    .map(|_| pass(&mut slave, &table, step, &mut outputs))
                    .collect();
                let (median, cell) = support::timing_cell(times);
                medians.push(median);
                cells.push(cell);
            }
            println!(
                "{:<26} {:>24} {:>24} {:>7.1} {:>28}",
                format!("{model_name} {law_name}"),
                cells[0],
                cells[1],
                medians[1] / medians[0],
                cells[2]
            );
        }
    }
}

/// The stiff light tire's slide with every input changing from step to step (see the top):
/// the shared yardstick's inputs moved to its slide and scaled to its load.
fn varying_stiff_slide(steps: usize, step: f64) -> Vec<[f64; 5]> {
    support::yardstick_inputs(true, steps, step)
        .into_iter()
        .map(|[vx, vy, steer_rate, vsx, fz]| {
            [vx - 5.0, vy - 0.5, steer_rate, vsx - 0.3, fz * (100.0 / 50_000.0)]
        })
        .collect()
}
