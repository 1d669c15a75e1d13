//! How far a sliding step is from its linearisation: the accuracy that exponential
//! Rosenbrock steps over a whole 1 ms step would reach, measured on the tire itself.
//!
//! Each model is driven with the slide yardstick's inputs (`../shared/bench/host.c`: vx
//! and Fz varying, 1 ms steps, Brush friction, muY = 0.01 "lateral", or muX = muY = 0.01
//! "combined"). At every tenth step from 0.1 s to 3.5 s (every hundredth under
//! `cargo test --benches`, a smoke run) the step's start (states and modes
//! as the step decides them) is taken, and its rates in those modes (the Model Exchange
//! view of the tire, [`Tire::continuous_rates`]) are integrated over the step by:
//!
//! - a reference: classical Runge-Kutta with 4000 substeps (checked against 2000);
//! - exponential Euler: `z + h phi1(hJ) f(z)`, one evaluation, its error estimated from
//!   the rates at its end by `h D / 3` (exprb32's correction `2 h phi3(hJ) D` below,
//!   with `phi3` at its largest, `1/6`); a step takes Euler's end where that estimate is
//!   within the tolerance, and "euler/est." is the most its error reached of the
//!   estimate (over steps where the estimate is above 1e-13 of the state, ten times the
//!   reference's own error);
//! - exprb32 (Hochbruck, Ostermann, Schweitzer 2009): two evaluations, third order;
//! - exprb43: three evaluations, fourth order, with its embedded third-order solution,
//!   whose difference is the error estimate a step would be controlled by;
//! - exprb42 (Luan and Ostermann): `z + h phi1(hJ) f(z) + 32/9 h phi3(hJ) D2` with its
//!   stage at three quarters, fourth order from two evaluations where `hJ` is small, its
//!   error estimated against `z + h phi1(hJ) f(z) + 2 h phi3(hJ) D3` from the rates at its
//!   own end, as `h (32/9 D2 - 2 D3) / 6` (`phi3` at its largest); "42/est." is the most
//!   its error reached of that estimate (over steps where the estimate is above 1e-13 of
//!   the state). A step takes its end, whose rates it has made (the next substep's
//!   start, or the outputs'). Its own error is also estimated from the remainder's
//!   quartic part, as DDT's cascade estimates it where the force turns: with the slope
//!   at the end `N'(1) = h (J(end) - J) f(end)` (`J(end)` by central differences too),
//!   `c = 256/9 D2 - 24 D3 + 4 N'(1)`, `b = N'(1) - 2 D3 - 2 c`, and the estimate
//!   `h (|c| + |hJ b|) / 80`; over steps where the error is above 1e-13 of the state and
//!   the third-order estimate within 1e-9 of it (where the cascade trusts the quartic
//!   one), "42/sharp" is the most its error reached of that estimate where the estimate
//!   was at least a fifth of the cascade's tolerance, and "42 below" the largest error
//!   where it was less.
//!
//! `J` is the Jacobian of the rates at the start (central differences: its error, near
//! 1e-10 relative, enters a step as `h^2 dJ f`, below 1e-14 of the states here). A step
//! whose modes change inside (the Co-Simulation step leaves the fixed-mode reference by
//! more than 1e-11) is counted apart: there the event, not the method, decides.
//! Errors are relative to the largest state.
//!
//! ```text
//! cargo bench --bench exponential_probe
//! ```

use nalgebra::{DMatrix, DVector};
use tirelag::physics::tire::hybrid::{CONTINUOUS_STATES, ContinuousStates};
use tirelag::physics::{FrictionLaw, ModelKind, Parameter, Parameters, Tire};

#[path = "../tests/support/mod.rs"]
mod support;

const STEP: f64 = 1e-3;
/// To 3.5 s: past the yardstick's first reversal of the slip (at pi), where the
/// branches stop sliding one by one and start again, their forces turning.
const STEPS: usize = 3500;
const REFERENCE_SUBSTEPS: usize = 4000;
/// A fifth of the cascade's tolerance: below it, exprb42's quartic estimate is compared
/// with the tolerance, not with the error (the error there is of terms it leaves out).
const SHARP_FLOOR: f64 = 2e-13;

/// `phi_1(X) .. phi_4(X)` from the exponential of the block matrix with `X` in its
/// corner and identities above its diagonal (its top row of blocks is
/// `e^X, phi_1(X), .., phi_4(X)`).
fn phi_functions(x: &DMatrix<f64>) -> [DMatrix<f64>; 4] {
    let n = x.nrows();
    let mut block = DMatrix::<f64>::zeros(5 * n, 5 * n);
    block.view_mut((0, 0), (n, n)).copy_from(x);
    for k in 0..4 {
        block
            .view_mut((k * n, (k + 1) * n), (n, n))
            .copy_from(&DMatrix::<f64>::identity(n, n));
    }
    let e = block.exp();
    std::array::from_fn(|k| e.view((0, (k + 1) * n), (n, n)).into_owned())
}

/// Puts the tire's continuous states at `z`; its modes stay.
fn put(tire: &mut Tire, z: &DVector<f64>) {
    let mut states: ContinuousStates = [0.0; CONTINUOUS_STATES];
    states.copy_from_slice(z.as_slice());
    tire.set_continuous_states(&states).expect("finite states");
}

/// The rates of the tire's continuous states at `z`, in its current modes and inputs.
fn rates(tire: &mut Tire, z: &DVector<f64>) -> DVector<f64> {
    put(tire, z);
    DVector::from_column_slice(tire.continuous_rates())
}

fn runge_kutta(tire: &mut Tire, z0: &DVector<f64>, substeps: usize) -> DVector<f64> {
    let s = STEP / substeps as f64;
    let mut z = z0.clone();
    for _ in 0..substeps {
        let k1 = rates(tire, &z);
        let k2 = rates(tire, &(&z + &k1 * (0.5 * s)));
        let k3 = rates(tire, &(&z + &k2 * (0.5 * s)));
        let k4 = rates(tire, &(&z + &k3 * s));
        z += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (s / 6.0);
    }
    z
}

fn jacobian(tire: &mut Tire, z0: &DVector<f64>, scale: f64) -> DMatrix<f64> {
    let n = z0.len();
    let mut jacobian = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        let delta = 1e-5 * z0[j].abs().max(1e-3 * scale);
        let (mut up, mut down) = (z0.clone(), z0.clone());
        up[j] += delta;
        down[j] -= delta;
        let column = (rates(tire, &up) - rates(tire, &down)) / (2.0 * delta);
        jacobian.set_column(j, &column);
    }
    jacobian
}

/// The largest errors (relative to the largest state) over the probed steps.
#[derive(Default)]
struct Errors {
    probed: usize,
    with_events: usize,
    euler: f64,
    exprb32: f64,
    exprb43: f64,
    exprb43_estimate: f64,
    euler_of_estimate: f64,
    exprb42: f64,
    exprb42_of_estimate: f64,
    /// The most exprb42's error was of its quartic estimate where that was at least
    /// [`SHARP_FLOOR`], and the largest error where it was below.
    exprb42_of_sharp: f64,
    exprb42_below_floor: f64,
    reference: f64,
    /// Terms of the Taylor series of `phi1(hJ) f` to rounding: the matrix-vector
    /// products a step's phi-functions would take without scaling.
    taylor_terms: usize,
}

fn probe(model: ModelKind, combined: bool) -> Errors {
    let mut p = Parameters::default()
        .with_model(model)
        .with_friction(FrictionLaw::Brush);
    p.set(Parameter::LateralFriction, 0.01).expect("valid");
    if combined {
        p.set(Parameter::LongitudinalFriction, 0.01).expect("valid");
    }
    let mut tire = Tire::new(p).expect("valid parameters");
    let mut errors = Errors::default();
    let every = if std::env::args().any(|a| a == "--bench") {
        10
    } else {
        100
    };
    for (k, inputs) in support::yardstick_inputs(true, STEPS, STEP)
        .into_iter()
        .enumerate()
    {
        tire.set_inputs(inputs);
        if k >= 100 && k % every == 0 {
            tire.update_modes();
            let start = tire.continuous_states();
            let sliders = *tire.sliders().expect("friction");
            probe_step(&mut tire, &mut errors);
            tire.set_sliders(&sliders).expect("as it was");
            tire.set_continuous_states(&start).expect("as it was");
        }
        tire.step(STEP).expect("a valid step");
    }
    errors
}

/// The methods' errors at the tire's current start; the tire's states and modes are left
/// wherever the probe took them (the caller puts them back).
fn probe_step(tire: &mut Tire, errors: &mut Errors) {
    let z0 = DVector::from_column_slice(&tire.continuous_states());
    let reference = runge_kutta(tire, &z0, REFERENCE_SUBSTEPS);
    let coarser = runge_kutta(tire, &z0, REFERENCE_SUBSTEPS / 2);
    let scale = z0.amax().max(reference.amax());
    let error = |z: &DVector<f64>| (z - &reference).amax() / scale;

    let f0 = rates(tire, &z0);
    let jacobian = jacobian(tire, &z0, scale);
    let [phi1, _, phi3, phi4] = phi_functions(&(&jacobian * STEP));
    let [half_phi1, ..] = phi_functions(&(&jacobian * (0.5 * STEP)));
    let [three_quarters_phi1, ..] = phi_functions(&(&jacobian * (0.75 * STEP)));
    // The nonlinear remainder's change from the start: `g(u) - g(z0)`, `g = f - J z`.
    let mut remainder = |u: &DVector<f64>| rates(tire, u) - &f0 - &jacobian * (u - &z0);

    let euler = &z0 + &phi1 * &f0 * STEP;
    let d_euler = remainder(&euler);
    let exprb32 = &euler + &phi3 * &d_euler * (2.0 * STEP);

    let middle = &z0 + &half_phi1 * &f0 * (0.5 * STEP);
    let d2 = remainder(&middle);
    let end = &z0 + &phi1 * (&f0 + &d2) * STEP;
    let d3 = remainder(&end);
    let exprb43 =
        &euler + (&phi3 * 16.0 - &phi4 * 48.0) * &d2 * STEP + (&phi3 * -2.0 + &phi4 * 12.0) * &d3 * STEP;
    let embedded = &euler + &phi3 * (&d2 * 16.0 - &d3 * 2.0) * STEP;
    let stage = &z0 + &three_quarters_phi1 * &f0 * (0.75 * STEP);
    let d_stage = remainder(&stage);
    let exprb42 = &euler + &phi3 * &d_stage * (32.0 / 9.0 * STEP);
    let d_end = remainder(&exprb42);
    let exprb42_third = &exprb42 - (&d_stage * (32.0 / 9.0) - &d_end * 2.0) * (STEP / 6.0);
    // The remainder's quartic part, from `D2`, `D3` and the slope at the end.
    let end_rates = rates(tire, &exprb42);
    let end_jacobian = crate::jacobian(tire, &exprb42, scale);
    let slope = (&end_jacobian - &jacobian) * &end_rates * STEP;
    let quartic = &d_stage * (256.0 / 9.0) - &d_end * 24.0 + &slope * 4.0;
    let cubic = &slope - &d_end * 2.0 - &quartic * 2.0;
    let turned = &jacobian * &cubic * STEP;
    let sharp = (quartic.abs() + turned.abs()).amax() * STEP / 80.0 / scale;

    // The Co-Simulation step from the same start, in the same modes: where it leaves the
    // fixed-mode reference, a mode changed inside the step.
    put(tire, &z0);
    tire.step(STEP).expect("a valid step");
    errors.probed += 1;
    if error(&DVector::from_column_slice(&tire.continuous_states())) > 1e-11 {
        errors.with_events += 1;
        return;
    }
    errors.euler = errors.euler.max(error(&euler));
    errors.exprb32 = errors.exprb32.max(error(&exprb32));
    errors.exprb43 = errors.exprb43.max(error(&exprb43));
    errors.exprb43_estimate = errors.exprb43_estimate.max((&exprb43 - &embedded).amax() / scale);
    let euler_estimate = (&d_euler * (STEP / 3.0)).amax() / scale;
    if euler_estimate > 1e-13 {
        errors.euler_of_estimate = errors.euler_of_estimate.max(error(&euler) / euler_estimate);
    }
    errors.exprb42 = errors.exprb42.max(error(&exprb42));
    let exprb42_estimate = (&exprb42 - &exprb42_third).amax() / scale;
    if exprb42_estimate > 1e-13 {
        errors.exprb42_of_estimate = errors.exprb42_of_estimate.max(error(&exprb42) / exprb42_estimate);
    }
    if error(&exprb42) > 1e-13 && exprb42_estimate <= 1e-9 {
        if sharp >= SHARP_FLOOR {
            errors.exprb42_of_sharp = errors.exprb42_of_sharp.max(error(&exprb42) / sharp);
        } else {
            errors.exprb42_below_floor = errors.exprb42_below_floor.max(error(&exprb42));
        }
    }
    errors.reference = errors.reference.max(error(&coarser));
    errors.taylor_terms = errors.taylor_terms.max(taylor_terms(&(&jacobian * STEP), &f0));
}

/// The terms of `sum X^j v / (j + 1)!` until one is below rounding of the sum.
fn taylor_terms(x: &DMatrix<f64>, v: &DVector<f64>) -> usize {
    let (mut term, mut sum) = (v.clone(), v.clone());
    for j in 1..200 {
        term = x * term / (j + 1) as f64;
        sum += &term;
        if term.amax() <= 1e-17 * sum.amax() {
            return j;
        }
    }
    200
}

fn main() {
    println!(
        "{:<22} {:>7} {:>7} {:>9} {:>11} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9} {:>9} {:>9} {:>7}",
        "model, case",
        "steps",
        "events",
        "euler",
        "euler/est.",
        "exprb32",
        "exprb43",
        "estimate",
        "exprb42",
        "42/est.",
        "42/sharp",
        "42 below",
        "reference",
        "terms"
    );
    for model in ModelKind::ALL {
        for combined in [false, true] {
            let e = probe(model, combined);
            let case = if combined { "combined" } else { "lateral" };
            println!(
                "{:<22} {:>7} {:>7} {:>9.1e} {:>11.1e} {:>9.1e} {:>9.1e} {:>9.1e} {:>9.1e} {:>8.1e} {:>9.2} {:>9.1e} {:>9.1e} {:>7}",
                format!("{model:?} {case}"),
                e.probed,
                e.with_events,
                e.euler,
                e.euler_of_estimate,
                e.exprb32,
                e.exprb43,
                e.exprb43_estimate,
                e.exprb42,
                e.exprb42_of_estimate,
                e.exprb42_of_sharp,
                e.exprb42_below_floor,
                e.reference,
                e.taylor_terms
            );
        }
    }
}
