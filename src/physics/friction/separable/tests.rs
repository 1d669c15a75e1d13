//! The separable step against the general path ([`crate::physics::friction::sliding`]),
//! which integrates every branch and the model together: the same ends from the same
//! states, to the general path's accuracy.

use proptest::prelude::*;

use super::SeparableStep;
use crate::physics::friction::sliding::SlidingStep;
use crate::physics::friction::{Direction, Friction, FrictionLaw, Limits, MAX_BRANCHES, SliderState};
use crate::physics::parameters::STIFF_TREAD;
use crate::physics::state_space::{DrivingVector, StateVector};
use crate::physics::stepper::AffineSystem;
use crate::physics::{ModelKind, Parameter, Parameters, Tire};

/// The parts a step is split into for the references.
const PARTS: usize = 16;
/// How close the general path's end is held to the separable step's, by elastic travel.
const GENERAL_PATH_ACCURACY: f64 = 1e-7;

struct Case {
    stiff: bool,
    /// muX = 0: the ellipse has one member.
    frictionless_longitudinal: bool,
    law: FrictionLaw,
    vx: f64,
    load_ratio: f64,
    inputs: [f64; 2],
    /// Deflections by member and branch, as fractions of the elastic travel.
    deflections: [[f64; MAX_BRANCHES]; 2],
    h: f64,
}

fn compare(case: &Case) {
    let mut p = Parameters::default()
        .with_model(ModelKind::Rlt)
        .with_friction(case.law);
    p.set(Parameter::LateralFriction, 0.3).unwrap();
    if case.frictionless_longitudinal {
        p.set(Parameter::LongitudinalFriction, 0.0).unwrap();
    }
    if case.stiff {
        for (parameter, value) in STIFF_TREAD {
            p.set(parameter, value).unwrap();
        }
    }
    let load = case.load_ratio * p.get(Parameter::NominalLoad);
    let model = p.model.equations();
    let affine = AffineSystem::from_samples(|at| model.system(&p, &at));
    let mut friction = Friction::new(case.law, model.contact_elements(&p), &affine.state_coupling()).unwrap();
    let system = Tire::new(p.clone()).unwrap().system_at(case.vx, load);
    let limits = Limits::at(&p, load);
    let u = DrivingVector::new(case.inputs[0], 0.0, case.inputs[1]);
    let mut x = StateVector::zeros();
    let mut sliders = SliderState::AT_REST;
    let mut travel = [0.0; 2];
    for (m, direction) in [Direction::Longitudinal, Direction::Lateral]
        .into_iter()
        .enumerate()
    {
        let element = friction.elements[direction as usize].unwrap();
        // A frictionless direction's branches stay at zero: a scale for the others'.
        travel[m] =
            limits.0[direction as usize].max(limits.0[Direction::Lateral as usize]) / element.stiffness;
        let d = direction as usize;
        let mut state = 0.0;
        for (i, branch) in friction.branches.iter().enumerate() {
            let b = case.deflections[m][i] * branch.breakpoint() * travel[m];
            sliders.offsets[d][i] = b;
            state += branch.stiffness_fraction * b;
        }
        x[element.state] = state;
        for i in 0..friction.branches.len() {
            sliders.offsets[d][i] -= state;
        }
    }
    let separable = SeparableStep::new(&system, &friction, &limits, &u).expect("RLT is separable");
    let (fast_x, fast_sliders) = separable
        .step(&x, &sliders, case.h)
        .expect("a step of the separable path");
    // The general path in parts (in one step of a stiff slide its stiff method is less
    // accurate than its tolerance), and the separable path in parts too: the same ends.
    // The general path is held to 1e-7 of the travel, as the independent references are
    // (a stiff tire at a light load with Brush, kept in proptest-regressions/, ends 3e-8
    // of the travel away, where the separable step agrees with itself in parts to
    // rounding).
    let general = SlidingStep::new(
        &system,
        &mut friction,
        limits,
        (u, DrivingVector::zeros()),
        x.amax(),
    );
    let (mut slow_x, mut slow_sliders) = (x, sliders);
    let (mut split_x, mut split_sliders) = (x, sliders);
    for _ in 0..PARTS {
        general.prepare(&mut slow_x, &mut slow_sliders);
        general
            .integrate(&mut slow_x, &mut slow_sliders, case.h / PARTS as f64)
            .expect("a step of the general path");
        (split_x, split_sliders) = separable
            .step(&split_x, &split_sliders, case.h / PARTS as f64)
            .unwrap();
    }
    for (m, direction) in [Direction::Longitudinal, Direction::Lateral]
        .into_iter()
        .enumerate()
    {
        let d = direction as usize;
        let k = friction.elements[d].unwrap().state;
        let scale = travel[m];
        assert!(
            (fast_x[k] - slow_x[k]).abs() <= GENERAL_PATH_ACCURACY * scale,
            "state {k}: {} vs {} (travel {scale})",
            fast_x[k],
            slow_x[k]
        );
        for i in 0..friction.branches.len() {
            let (fast, slow) = (
                fast_x[k] + fast_sliders.offsets[d][i],
                slow_x[k] + slow_sliders.offsets[d][i],
            );
            assert!(
                (fast - slow).abs() <= GENERAL_PATH_ACCURACY * scale,
                "branch {i} of {direction:?}: {fast} vs {slow}"
            );
            let split = split_x[k] + split_sliders.offsets[d][i];
            assert!(
                (fast - split).abs() <= 1e-9 * scale,
                "branch {i} of {direction:?}: {fast} vs {split} in parts"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn the_separable_step_ends_where_the_general_path_does(
        stiff in any::<bool>(),
        frictionless_longitudinal in proptest::bool::weighted(0.2),
        brush in any::<bool>(),
        vx in prop_oneof![Just(0.0), -30.0..30.0_f64],
        load_ratio in 0.002..2.0_f64,
        vy in -1.0..1.0_f64,
        vsx in prop_oneof![Just(0.0), -0.5..0.5_f64],
        deflections in proptest::array::uniform2(proptest::array::uniform4(-1.3..1.3_f64)),
        h in prop_oneof![Just(1e-3), 1e-6..1e-3_f64, 1e-3..2.0_f64],
    ) {
        let law = if brush { FrictionLaw::Brush } else { FrictionLaw::Coulomb };
        compare(&Case { stiff, frictionless_longitudinal, law, vx, load_ratio, inputs: [vy, vsx], deflections, h });
    }
}
