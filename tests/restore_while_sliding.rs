//! A tire restored from its state (what an FMU state holds: the model's states, the
//! branch offsets and modes, the substep lengths carried to the next step, the inputs and
//! their rates) goes on bit for bit as the tire it was taken from, while it slides. The
//! inputs are held for tens of steps at a time, so that the tire it was taken from
//! starts steps from the modes its last step prepared, where the restored one decides
//! them itself (docs/specification.md 7).

use tirelag::physics::{FrictionLaw, Input, ModelKind, Parameter, Parameters, Tire};

const STEP: f64 = 1e-3;
const STEPS: usize = 600;
/// Steps each restored tire is followed for.
const FOLLOWED: usize = 25;

/// vy and vsx move every 60 steps and are held in between; the slip reverses within
/// the run, so that branches stop sliding and start again.
fn inputs_at(k: usize) -> [(Input, f64); 5] {
    let phase = (k / 60) as f64;
    [
        (Input::Vx, 8.0),
        (Input::Vy, 0.3 * (0.9 * phase).cos()),
        (Input::SteerRate, 0.02),
        (Input::Vsx, 0.2 * (0.7 * phase).sin()),
        (Input::Fz, 4000.0),
    ]
}

fn set_inputs(tire: &mut Tire, k: usize) {
    for (input, value) in inputs_at(k) {
        // Setting an unchanged value is no change: the prepared modes stay.
        if tire.input(input) != value {
            tire.set_input(input, value);
        }
    }
}

/// Bit for bit: `-0.0` is not `0.0`, and a NaN is what it is.
fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

fn restored(parameters: &Parameters, from: &Tire) -> Tire {
    let mut tire = Tire::new(parameters.clone()).expect("a valid tire");
    tire.set_states(from.states()).expect("finite states");
    if let Some(sliders) = from.sliders() {
        tire.set_sliders(sliders).expect("finite offsets");
        tire.set_high_order_substeps(from.high_order_substeps());
    }
    for input in Input::ALL {
        tire.set_input(input, from.input(input));
        tire.set_input_rate(input, from.input_rate(input));
    }
    tire
}

#[test]
fn a_tire_restored_while_it_slides_goes_on_bit_for_bit() {
    for model in ModelKind::ALL {
        for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
            for (mu_x, mu_y) in [(0.8, 0.01), (0.01, 0.01)] {
                let mut parameters = Parameters::default().with_model(model).with_friction(law);
                parameters.set(Parameter::LongitudinalFriction, mu_x).unwrap();
                parameters.set(Parameter::LateralFriction, mu_y).unwrap();
                let case = format!("{model:?} {law:?} muX {mu_x} muY {mu_y}");
                let mut tire = Tire::new(parameters.clone()).expect("a valid tire");
                let mut slid = 0;
                let mut followed = Vec::new();
                for k in 0..STEPS {
                    set_inputs(&mut tire, k);
                    // The tire as it is, and one restored from its state, from here on.
                    if k % 37 == 11 {
                        followed.push((k, restored(&parameters, &tire), tire.clone()));
                    }
                    tire.step(STEP)
                        .unwrap_or_else(|e| panic!("{case}: step {k}: {e}"));
                    let outputs = tire.outputs().as_slice().to_vec();
                    slid += usize::from(
                        tire.sliders()
                            .is_some_and(|s| s.sliding.iter().flatten().any(|&b| b)),
                    );
                    followed.retain_mut(|(from, copy, original)| {
                        for twin in [&mut *copy, &mut *original] {
                            set_inputs(twin, k);
                        }
                        copy.step(STEP)
                            .unwrap_or_else(|e| panic!("{case}: restored at {from}, step {k}: {e}"));
                        original.step(STEP).expect("as the tire it copies");
                        assert_eq!(
                            bits(copy.states()),
                            bits(original.states()),
                            "{case}: restored at step {from}, states at step {k}"
                        );
                        assert_eq!(
                            bits(copy.outputs().as_slice()),
                            bits(original.outputs().as_slice()),
                            "{case}: restored at step {from}, outputs at step {k}"
                        );
                        k < *from + FOLLOWED
                    });
                    assert!(outputs.iter().all(|v| v.is_finite()), "{case}: step {k}");
                }
                assert!(slid > STEPS / 4, "{case}: slid in {slid} of {STEPS} steps");
            }
        }
    }
}
