//! Stepping cost of the physics core alone, per model: `cargo bench --bench step`.
//! Two cases, as in a vehicle model: vx and Fz changing every step (a new step map each
//! step), and both constant (the step map is reused). Each step sets the inputs, steps
//! 1 ms and reads the outputs. `benches/cabi_step.rs` measures the same through the C ABI.

use std::hint::black_box;
use std::time::Instant;

use tirelag::physics::{Input, ModelKind, Parameters, Tire};

/// Inputs of step k: `[vx, Fz, vy]`, precomputed so that no sine is timed.
fn input_table(varying: bool, steps: u32) -> Vec<[f64; 3]> {
    (0..steps)
        .map(|i| {
            let t = f64::from(i) * 1e-3;
            let vy = 0.1 * t.sin();
            if varying {
                [
                    10.0 + 1e-3 * f64::from(i % 1000),
                    50_000.0 * (1.0 + 0.02 * (2.0 * t).sin()),
                    vy,
                ]
            } else {
                [10.0, 50_000.0, vy]
            }
        })
        .collect()
}

fn nanoseconds_per_step(model: ModelKind, inputs: &[[f64; 3]]) -> f64 {
    let mut tire = Tire::new(Parameters::default().with_model(model)).expect("default parameters are valid");
    let start = Instant::now();
    for &[vx, load, vy] in inputs {
        tire.set_input(Input::Vx, vx);
        tire.set_input(Input::Fz, load);
        tire.set_input(Input::Vy, vy);
        tire.step(1e-3).expect("finite step");
        black_box(tire.outputs());
    }
    start.elapsed().as_nanos() as f64 / inputs.len() as f64
}

/// Median of `runs` measurements.
fn median(mut runs: Vec<f64>) -> f64 {
    runs.sort_by(f64::total_cmp);
    runs[runs.len() / 2]
}

fn main() {
    // `cargo test --benches` passes no --bench flag; run a short smoke pass then.
    let (steps, runs) = if std::env::args().any(|a| a == "--bench") {
        (100_000, 7)
    } else {
        (1_000, 1)
    };
    println!(
        "{:<12} {:>26} {:>22}",
        "model", "vx, Fz varying [ns/step]", "constant [ns/step]"
    );
    let (varying, constant) = (input_table(true, steps), input_table(false, steps));
    for model in ModelKind::ALL {
        let ns_varying = median((0..runs).map(|_| nanoseconds_per_step(model, &varying)).collect());
        let ns_constant = median(
            (0..runs)
                .map(|_| nanoseconds_per_step(model, &constant))
                .collect(),
        );
        println!("{:<12} {ns_varying:>26.0} {ns_constant:>22.0}", model.name());
    }
}
