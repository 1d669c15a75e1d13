//! Stepping cost per model: `cargo bench --bench step`.
//! Two cases: constant speed (the discretisation is reused) and a speed that changes
//! every step (a new matrix exponential each step, the worst case in a vehicle model).

use std::hint::black_box;
use std::time::Instant;

use tirelag::physics::{Input, ModelKind, Parameters, Tire};

fn nanoseconds_per_step(model: ModelKind, varying_speed: bool, steps: u32) -> f64 {
    let mut tire = Tire::new(Parameters::default().with_model(model)).expect("default parameters are valid");
    tire.set_input(Input::Vx, 10.0);
    let start = Instant::now();
    for i in 0..steps {
        if varying_speed {
            tire.set_input(Input::Vx, 10.0 + 1e-3 * f64::from(i % 1000));
        }
        tire.set_input(Input::Vy, (f64::from(i) * 1e-3).sin());
        tire.step(1e-3).expect("finite step");
        black_box(tire.outputs());
    }
    start.elapsed().as_nanos() as f64 / f64::from(steps)
}

fn main() {
    // `cargo test --benches` passes --bench-less flags; run a short smoke pass then.
    let steps = if std::env::args().any(|a| a == "--bench") {
        200_000
    } else {
        1_000
    };
    println!(
        "{:<12} {:>22} {:>22}",
        "model", "constant vx [ns/step]", "varying vx [ns/step]"
    );
    for model in ModelKind::ALL {
        let constant = nanoseconds_per_step(model, false, steps);
        let varying = nanoseconds_per_step(model, true, steps / 10);
        println!("{:<12} {constant:>22.0} {varying:>22.0}", model.name());
    }
}
