use proptest::prelude::*;

use super::super::{with_prepared_step, with_settled_slide};
use crate::physics::friction::{FrictionLaw, SliderState};
use crate::physics::parameters::STIFF_TREAD;
use crate::physics::state_space::StateVector;
use crate::physics::{ModelKind, Parameter, Parameters};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Where the cascade takes a step, it ends where the whole-system path does by the
    /// same kind of method (explicit, or linearly implicit for a stiff slide; each to a
    /// relative 1e-12, here within 1e-10 of the largest state or offset), in the same
    /// modes: DDT sliding laterally or in both directions with either law, from a
    /// slide as the tire meets it, over steps of 0.1 to 20 ms; and the stiff light
    /// tire (Calpha = Ckappa = 1e7, sigma 0.05 m, a load of 50 to 200 N) the same.
    /// What it finds the limits take off the forces at its end is what the outputs'
    /// projections there find, bit for bit.
    #[test]
    fn a_cascade_step_ends_where_the_whole_system_path_does(
        law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
        combined in any::<bool>(),
        stiff_light in any::<bool>(),
        vx in -20.0..20.0f64,
        load_ratio in 0.2..2.0f64,
        inputs in prop::array::uniform3(-1.0..1.0f64),
        states in prop::array::uniform3(-1.5..1.5f64),
        h in prop::sample::select(vec![1e-4, 1e-3, 5e-3, 2e-2]),
    ) {
        let mut p = Parameters::default().with_model(ModelKind::Ddt).with_friction(law);
        let mut load = load_ratio * p.get(Parameter::NominalLoad);
        if stiff_light {
            for (parameter, value) in STIFF_TREAD {
                p.set(parameter, value).unwrap();
            }
            load = 100.0 * load_ratio;
        } else {
            p.set(Parameter::LateralFriction, 0.01).unwrap();
            if combined {
                p.set(Parameter::LongitudinalFriction, 0.01).unwrap();
            }
        }
        with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
        let stiff = h * step.start_sliding_rate.get() > super::super::STIFF_STEP;
        let (mut x_cascade, mut sliders_cascade) = (x, sliders);
        let carried = step.high_order_found.get();
        let shaped = step.cascade_step(&mut x_cascade, &mut sliders_cascade, h, super::Start::Prepared);
        // A step given up carries nothing of its substeps to the next step: the path
        // that takes it instead decides that, as it does from a restored state.
        if shaped.is_none() {
            prop_assert_eq!(step.high_order_found.get(), carried);
        }
        prop_assume!(shaped.is_some());
        // What the limits take off the sticking forces at the end, where the step's
        // last evaluation was there: the outputs' own projections there, the same bits.
        if let Some(Some(shaped)) = shaped {
            prop_assert_eq!(shaped.changes, step.damper_force_changes(&x_cascade, &sliders_cascade));
            // And within rounding of the whole system's projections there.
            let (whole, _) = step.whole_system_limit_changes(&step.layout.pack(&x_cascade, &sliders_cascade));
            let limit = step.limits.0.iter().fold(0.0_f64, |m, &l| m.max(l));
            for (a, b) in shaped.changes.iter().zip(&whole) {
                prop_assert!((a - b).abs() <= 1e-9 * limit, "{a} vs the whole system's {b}");
            }
        }
        let (mut x_whole, mut sliders_whole) = (x, sliders);
        step.stiff.set(stiff);
        step.exponential_declined.set(false);
        step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h).expect("a valid step");
        prop_assert_eq!(sliders_cascade.sliding, sliders_whole.sliding);
        let values = |x: &StateVector, s: &SliderState| {
            let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
            all.extend(s.offsets.iter().flatten());
            all
        };
        let (cascade, whole) = (values(&x_cascade, &sliders_cascade), values(&x_whole, &sliders_whole));
        let largest = cascade.iter().chain(&whole).fold(travel, |m, v| m.max(v.abs()));
        for (c, (a, b)) in cascade.iter().zip(&whole).enumerate() {
            prop_assert!(
                (a - b).abs() <= 1e-10 * largest,
                "{law:?} combined {combined} stiff {stiff}, value {c}: {a} vs {b} (largest {largest})"
            );
        }
        Ok(())
        })?;
    }

    /// The point a step's end is shaped at ([`SlidingStep::end_point`], made from its
    /// pieces) is, bit for bit, where the states and offsets the step writes there pack
    /// to again ([`SlidingStep::point_of`]), as the outputs are made on demand: DDT with
    /// either law, sliding laterally or in both directions, the driven groups anywhere
    /// within twice the elastic travel of their start.
    #[test]
    fn a_steps_end_is_shaped_where_its_states_and_offsets_pack_to(
        law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
        combined in any::<bool>(),
        vx in -20.0..20.0f64,
        inputs in prop::array::uniform3(-1.0..1.0f64),
        states in prop::array::uniform3(-1.5..1.5f64),
        moves in prop::array::uniform8(-2.0..2.0f64),
    ) {
        let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
        let load = p.get(Parameter::NominalLoad);
        with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
            let cascade = step.cascade().expect("DDT's slots form a cascade");
            let z = step.layout.pack(&x, &sliders);
            let drives = step.input_rates();
            let sum = super::DriverSum::at(step.layout.model_state(&z, cascade.driver_state));
            let groups = super::DrivenGroups::new(step, cascade, (sliders.sliding, &drives), &sum)
                .expect("driven groups");
            let mut u = groups.start(&z);
            for (n, slot) in groups.slots().enumerate() {
                for m in slot.law.members() {
                    u[super::entry(n, m)] += moves[super::entry(n, m)] * travel;
                }
            }
            let made = step.end_point(cascade, &groups, (&z, &u));
            let (mut end, mut x_end, mut sliders_end) = (z, x, sliders);
            step.whole_end(cascade, (&mut end, &sliders.sliding), &u, (&mut x_end, &mut sliders_end));
            let packed = step.point_of(cascade, &groups, &step.layout.pack(&x_end, &sliders_end));
            let bits = |values: &[f64]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&made.driven), bits(&packed.driven));
            prop_assert_eq!(bits(&made.drivers[..step.layout.branches]), bits(&packed.drivers[..step.layout.branches]));
            prop_assert_eq!(made.driver_state.to_bits(), packed.driver_state.to_bits());
            Ok(())
        })?;
    }
}

/// Where a group changes mode within a step, the cascade takes the step in the modes
/// the whole-system path ends in, and ends within 1e-10 of the largest state or offset
/// where it does (the count of such steps: at least one).
fn changes_of_mode_agree(
    group: crate::physics::friction::Group,
    cases: impl Iterator<Item = ([f64; 3], [f64; 3])>,
) -> usize {
    changes_of_mode_agree_at(group, 10.0, cases)
}

/// [`changes_of_mode_agree`] at the speed `vx`.
fn changes_of_mode_agree_at(
    group: crate::physics::friction::Group,
    vx: f64,
    cases: impl Iterator<Item = ([f64; 3], [f64; 3])>,
) -> usize {
    let mut p = Parameters::default()
        .with_model(ModelKind::Ddt)
        .with_friction(FrictionLaw::Brush);
    p.set(Parameter::LateralFriction, 0.01).unwrap();
    let load = p.get(Parameter::NominalLoad);
    let mut changed = 0;
    for (states, inputs) in cases {
        with_prepared_step(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
            let h = 1e-3;
            let (mut x_cascade, mut sliders_cascade) = (x, sliders);
            let taken = step.cascade_step(&mut x_cascade, &mut sliders_cascade, h, super::Start::Prepared);
            let g = group as usize;
            if taken.is_none() || sliders_cascade.sliding[g] == sliders.sliding[g] {
                return;
            }
            changed += 1;
            let (mut x_whole, mut sliders_whole) = (x, sliders);
            step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h)
                .expect("a valid step");
            assert_eq!(
                sliders_cascade.sliding, sliders_whole.sliding,
                "{states:?} {inputs:?}"
            );
            let values = |x: &StateVector, s: &SliderState| {
                let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
                all.extend(s.offsets.iter().flatten());
                all
            };
            let (cascade, whole) = (
                values(&x_cascade, &sliders_cascade),
                values(&x_whole, &sliders_whole),
            );
            let largest = cascade.iter().chain(&whole).fold(travel, |m, v| m.max(v.abs()));
            for (c, (a, b)) in cascade.iter().zip(&whole).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-10 * largest,
                    "{states:?} {inputs:?} value {c}: {a} vs {b} (largest {largest})"
                );
            }
        });
    }
    changed
}

/// A step from a restored state (its modes decided at its start) goes on bit for bit
/// as a step from the end of the last one does (prepared with the modes its outputs
/// decided there), also where a driven group is on its limit to rounding, which the
/// cascade leaves to the whole-system path, and where the whole system's trial forces
/// (rounded otherwise) would decide its mode otherwise: DDT with either law, sliding
/// laterally and in both directions, a lateral branch's offset set where its mode
/// changes by the cascade's decision and by the whole system's, steps of 1 and 20 ms.
#[test]
fn a_step_from_a_restored_state_at_a_limit_goes_on_as_a_prepared_one() {
    let mut decided_otherwise = 0;
    for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
        for combined in [false, true] {
            let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
            let load = p.get(Parameter::NominalLoad);
            for (k, vx) in (0..8).zip([10.0, -5.0, 0.5, 20.0].into_iter().cycle()) {
                let states = [0.3 * k as f64 - 0.6, 0.5, -0.2 * k as f64];
                let inputs = [0.0, 0.2 - 0.05 * k as f64, 0.1];
                decided_otherwise +=
                    with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                        let driven = step.cascade().expect("DDT's slots form a cascade").driven_count;
                        (0..driven)
                            .flat_map(|n| (0..2).map(move |m| (n, m)))
                            .map(|member| {
                                on_a_limit_restored_and_prepared_agree(step, (x, sliders), travel, member)
                            })
                            .sum::<usize>()
                    });
            }
        }
    }
    assert!(
        decided_otherwise > 0,
        "no start where the whole system decides otherwise"
    );
}

/// [`a_step_from_a_restored_state_at_a_limit_goes_on_as_a_prepared_one`] from one
/// settled slide: how many of its starts the whole system's trial forces decide
/// otherwise than the cascade's.
fn on_a_limit_restored_and_prepared_agree(
    step: &super::SlidingStep,
    (x, sliders): (StateVector, SliderState),
    travel: f64,
    (n, m): (usize, usize),
) -> usize {
    let cascade = step.cascade().expect("DDT's slots form a cascade");
    let slot = step.slots()[cascade.driven().nth(n).expect("a driven group")];
    if m >= slot.law.count {
        return 0;
    }
    let (d, i) = (slot.law.direction[m], slot.branch);
    let with_offset = |offset: f64| {
        let mut s = sliders;
        s.offsets[d][i] = offset;
        s
    };
    // The branch's mode by the cascade's decision (the outputs'), and by the whole
    // system's (preparing from its trial forces).
    let by_cascade = |offset: f64| step.limit_changes(&x, &with_offset(offset)).1[slot.group][slot.branch];
    let by_whole_system = |offset: f64| {
        let mut s = with_offset(offset);
        step.prepare(&mut x.clone(), &mut s);
        s.sliding[slot.group][slot.branch]
    };
    // Where each changes along the offset: bracketed, then halved down to two
    // neighbouring values.
    let start = sliders.offsets[d][i];
    let Some(bracket) = (1..=40).map(|k| k as f64 * 0.25 * travel).find_map(|reach| {
        [start - reach, start + reach]
            .into_iter()
            .find(|&o| by_cascade(o) != by_cascade(start))
            .map(|o| if by_cascade(start) { (o, start) } else { (start, o) })
    }) else {
        return 0;
    };
    let change = |sliding: &dyn Fn(f64) -> bool| {
        let (mut inside, mut outside) = bracket;
        for _ in 0..2000 {
            let middle = 0.5 * (inside + outside);
            if middle == inside || middle == outside {
                break;
            }
            if sliding(middle) {
                outside = middle;
            } else {
                inside = middle;
            }
        }
        [inside, outside]
    };
    let mut offsets = change(&by_cascade).to_vec();
    offsets.extend(change(&by_whole_system));
    let decided_otherwise = offsets
        .iter()
        .filter(|&&o| by_cascade(o) != by_whole_system(o))
        .count();
    for offset in offsets {
        let at = with_offset(offset);
        for h in [1e-3, 2e-2] {
            // Restored: the modes decided at the step's start.
            let (mut x_restored, mut restored) = (x, at);
            let restored_end = step.prepare_and_integrate(&mut x_restored, &mut restored, h);
            // Prepared with the modes the outputs there decide.
            let (mut x_prepared, mut prepared) = (x, at);
            let (_, preparation) = step.prepare_with_damper_force_changes(&mut x.clone(), &mut at.clone());
            step.prepare_from(
                &mut prepared,
                &preparation.expect("the cascade decides the modes"),
            );
            let prepared_end = step.integrate(&mut x_prepared, &mut prepared, h);
            assert_eq!(restored_end.is_ok(), prepared_end.is_ok(), "{offset} at {h} s");
            let bits = |x: &StateVector, s: &SliderState| {
                let mut all: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
                all.extend(s.offsets.iter().flatten().map(|v| v.to_bits()));
                (all, s.sliding)
            };
            assert_eq!(
                bits(&x_restored, &restored),
                bits(&x_prepared, &prepared),
                "offset {offset} (branch {i}), step {h} s"
            );
        }
    }
    decided_otherwise
}

/// A yaw branch (a driver) that reaches its limit within a step splits the cascade's
/// step there, in closed form. The yaw deflections start about their limit, the steer
/// rates move them across it; the lateral branches slide (muY 0.01).
#[test]
fn a_driver_that_reaches_its_limit_splits_the_step() {
    let cases = [-0.5, -0.1, 0.1, 0.5].into_iter().flat_map(|steer_rate| {
        (-20..=20).map(move |k| ([0.002 * f64::from(k), 0.3, 0.05], [0.05, steer_rate, 0.01]))
    });
    let changed = changes_of_mode_agree(crate::physics::friction::Group::Yaw, cases);
    assert!(changed > 0, "no step had a yaw branch change mode");
}

/// A lateral and longitudinal branch pair (a driven group) that reaches its limit
/// within a step changes mode where its course crosses its event, found by exprb42's
/// substeps. The lateral deflections start about the lateral limit (1/80 of the
/// travel), the lateral speeds move them across it.
#[test]
fn a_driven_group_that_reaches_its_limit_changes_mode_within_the_step() {
    let cases = [-0.2, -0.05, -0.01, 0.01, 0.05, 0.2].into_iter().flat_map(|vy| {
        (-50..=50).map(move |k| {
            (
                [0.0, 0.0125 * (1.0 + 0.002 * f64::from(k)), 0.001],
                [vy, 0.0, 0.0],
            )
        })
    });
    let changed = changes_of_mode_agree(crate::physics::friction::Group::Planar, cases);
    assert!(changed > 0, "no step had a planar group change mode");
}

/// The rest of a step in equal pieces: no piece longer than allowed, as few as that
/// takes, and a rest a rounding past a whole number of pieces is that number.
#[test]
fn the_rest_is_cut_into_as_few_equal_pieces_as_allowed() {
    use super::lengths::{in_equal_pieces, pieces_of};
    for (rest, allowed, pieces) in [
        (1e-3, 2e-3, 1.0),
        (1e-3, 1e-3, 1.0),
        (1e-3, 0.5e-3, 2.0),
        (1e-3, 0.49e-3, 3.0),
        (1e-3, 0.999e-3, 2.0),
        (0.3, 0.1, 3.0),
        (1e-3, 1e-3 / 3.0, 3.0),
    ] {
        assert_eq!(
            pieces_of(rest, allowed),
            pieces,
            "{rest} in pieces of at most {allowed}"
        );
        let piece = in_equal_pieces(rest, allowed);
        assert!(
            piece <= allowed * (1.0 + 1e-15),
            "{rest}: {piece} longer than {allowed}"
        );
        assert!(
            (piece * pieces - rest).abs() <= 1e-15 * rest,
            "{rest}: {pieces} x {piece}"
        );
    }
    // A rest a rounding past three pieces is three, not four.
    let allowed = 0.1;
    let rest = 3.0 * allowed * (1.0 + 2.0 * f64::EPSILON);
    assert_eq!(pieces_of(rest, allowed), 3.0);
}

/// An end prepares the next step's modes only where every group is in the mode that
/// deciding there finds: each event value below zero (none is, for a missing group).
#[test]
fn an_end_past_an_event_within_the_tolerance_prepares_nothing() {
    use super::super::{EVENT_TOLERANCE, NO_EVENT};
    use super::samples::ends_decided;
    let mut events =
        [[NO_EVENT; crate::physics::friction::MAX_BRANCHES]; crate::physics::friction::Group::COUNT];
    assert!(ends_decided(&events));
    events[0][1] = -1e-3;
    assert!(ends_decided(&events));
    // Within the tolerance past its event, still in its mode: deciding there finds the other.
    events[1][2] = 0.5 * EVENT_TOLERANCE;
    assert!(!ends_decided(&events));
    // On the limit: a sliding group's utilisation is one, which decides sticking.
    events[1][2] = 0.0;
    assert!(!ends_decided(&events));
    events[1][2] = f64::NAN;
    assert!(!ends_decided(&events));
}

/// A yaw branch (a driver) that reaches its limit within a step at standstill and
/// rolling backwards splits the cascade's step there too: the closed form's crossing
/// (the deflection where the trial force is on its limit, and `q(t)` inverted) holds
/// where the relaxation rates are those of vx = 0 or of a negative vx, and the step
/// ends where the whole-system path ends, in its modes (as at 10 m/s, above).
#[test]
fn a_driver_that_reaches_its_limit_splits_the_step_at_standstill_and_backwards() {
    for vx in [0.0, -0.5, -10.0] {
        let cases = [-0.5, -0.1, 0.1, 0.5].into_iter().flat_map(|steer_rate| {
            (-20..=20).map(move |k| ([0.002 * f64::from(k), 0.3, 0.05], [0.05, steer_rate, 0.01]))
        });
        let changed = changes_of_mode_agree_at(crate::physics::friction::Group::Yaw, vx, cases);
        assert!(changed > 0, "vx {vx}: no step had a yaw branch change mode");
    }
}

/// The states and branch offsets of a step's end, for comparing ends.
fn end_values(x: &StateVector, sliders: &SliderState) -> Vec<f64> {
    let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
    all.extend(sliders.offsets.iter().flatten());
    all
}

/// The largest difference between two ends' values, relative to the largest of them
/// (or the elastic `travel`, where that is larger).
fn end_difference(a: &[f64], b: &[f64], travel: f64) -> f64 {
    let largest = a.iter().chain(b).fold(travel, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / largest
}

/// Several changes of mode within one long step (20 ms): the yaw deflections start up
/// to 0.06 of the travel either side (past the yaw limits), the steer rates drive them
/// back through zero, the lateral deflections start about their limit and vy moves
/// them, so that drivers and driven groups stop and start sliding, some more than once
/// (the slip reverses within the step). Where the cascade takes such a step it ends in
/// the modes the whole-system path ends in and within 1e-10 of the largest state or
/// offset of where it ends (as the single changes above); the changes are counted on a
/// reference of 80 pieces by the whole-system path, and steps with at least two, and
/// with at least three, must be among those the cascade took.
#[test]
fn several_changes_of_mode_within_a_long_step_end_where_the_whole_system_path_does() {
    let h = 0.02;
    let (mut several, mut three_or_more) = (0, 0);
    for (law, combined) in [
        (FrictionLaw::Coulomb, false),
        (FrictionLaw::Coulomb, true),
        (FrictionLaw::Brush, false),
    ] {
        let mut p = Parameters::default()
            .with_model(ModelKind::Ddt)
            .with_friction(law);
        p.set(Parameter::LateralFriction, 0.01).unwrap();
        if combined {
            p.set(Parameter::LongitudinalFriction, 0.01).unwrap();
        }
        let load = p.get(Parameter::NominalLoad);
        for vx in [3.0, 10.0] {
            for yaw in (-3..=3).map(|k| 0.02 * f64::from(k)) {
                for lateral in (-3..=3).map(|k| 0.01 * f64::from(k)) {
                    for (steer_rate, vy) in [-0.5, -0.1, 0.1, 0.5]
                        .into_iter()
                        .flat_map(|r| [-0.1, -0.03, 0.03, 0.1].map(|vy| (r, vy)))
                    {
                        let states = [yaw, lateral, 0.001];
                        let inputs = [vy, steer_rate, 0.005];
                        with_prepared_step(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                            let (mut x_cascade, mut sliders_cascade) = (x, sliders);
                            let taken = step.cascade_step(
                                &mut x_cascade,
                                &mut sliders_cascade,
                                h,
                                super::Start::Prepared,
                            );
                            if taken.is_none() {
                                return;
                            }
                            let (mut x_fine, mut sliders_fine) = (x, sliders);
                            let mut changes = 0;
                            for _ in 0..80 {
                                let before = sliders_fine.sliding;
                                step.integrate_by_current_method(&mut x_fine, &mut sliders_fine, h / 80.0)
                                    .expect("a valid step");
                                changes += before
                                    .iter()
                                    .flatten()
                                    .zip(sliders_fine.sliding.iter().flatten())
                                    .filter(|(a, b)| a != b)
                                    .count();
                            }
                            let (mut x_whole, mut sliders_whole) = (x, sliders);
                            step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h)
                                .expect("a valid step");
                            let label = format!("{law:?} combined {combined} vx {vx} {states:?} {inputs:?}");
                            assert_eq!(sliders_cascade.sliding, sliders_whole.sliding, "{label}");
                            let difference = end_difference(
                                &end_values(&x_cascade, &sliders_cascade),
                                &end_values(&x_whole, &sliders_whole),
                                travel,
                            );
                            assert!(difference <= 1e-10, "{label}: {changes} changes, {difference:e}");
                            several += usize::from(changes >= 2);
                            three_or_more += usize::from(changes >= 3);
                        });
                    }
                }
            }
        }
    }
    assert!(
        several > 0 && three_or_more > 0,
        "too few steps with several changes taken: {several} with two or more, {three_or_more} with three or more"
    );
}

/// A slide as [`with_settled_slide`] meets it (from `states` under driving `inputs`
/// held, settled for 20 ms), its cascade step of `h` seconds taken from there by a
/// step whose friction carries `carried` ([`super::super::HighOrderSubsteps`], as
/// [`crate::physics::Tire::set_high_order_substeps`] or an FMU state sets it): the end's
/// values where the cascade takes the step, the lengths it carries to the next step,
/// and the elastic travel.
fn settled_cascade_step(
    p: &Parameters,
    (vx, load): (f64, f64),
    (states, inputs): (&[f64; 3], [f64; 3]),
    h: f64,
    carried: super::super::HighOrderSubsteps,
) -> (Option<Vec<f64>>, super::super::HighOrderSubsteps, f64) {
    use super::super::{SlidingStep, tire_at};
    use crate::physics::state_space::DrivingVector;
    let (system, mut friction, limits, travel) = tire_at(p, vx, load);
    let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
    let mut x = StateVector::zeros();
    for (k, state) in states.iter().enumerate() {
        x[k] = state * travel;
    }
    let mut sliders = SliderState::AT_REST;
    {
        let step = SlidingStep::new(
            &system,
            &mut friction,
            limits,
            (u, DrivingVector::zeros()),
            travel,
        );
        step.prepare(&mut x, &mut sliders);
        step.integrate(&mut x, &mut sliders, 0.02).expect("a valid step");
    }
    friction.set_high_order_substeps(carried);
    let step = SlidingStep::new(
        &system,
        &mut friction,
        limits,
        (u, DrivingVector::zeros()),
        travel,
    );
    assert_eq!(step.high_order_carried, carried);
    step.prepare(&mut x, &mut sliders);
    let taken = step
        .cascade_step(&mut x, &mut sliders, h, super::Start::Prepared)
        .map(|_| end_values(&x, &sliders));
    (taken, step.high_order_found.get(), travel)
}

/// A settled slide's parameters, speed and load, states and driving inputs.
type SettledSlide = (Parameters, (f64, f64), [f64; 3], [f64; 3]);

/// Settled DDT slides, laterally (muY 0.01) and in both directions (muX = muY = 0.01),
/// with either law, at 10 and -10 m/s, from a few starts and inputs: for each, its
/// parameters, speed and load, states and inputs.
fn settled_slides() -> Vec<SettledSlide> {
    let mut cases = Vec::new();
    for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
        for combined in [false, true] {
            let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
            let load = p.get(Parameter::NominalLoad);
            for vx in [10.0, -10.0] {
                for (states, inputs) in [
                    ([0.2, 0.5, 0.3], [0.1, 0.05, 0.01]),
                    ([-0.4, 0.1, -0.6], [-0.05, 0.02, -0.02]),
                    ([0.0, -0.8, 0.2], [0.3, -0.1, 0.05]),
                    ([0.5, 0.5, 0.5], [-0.2, 0.3, -0.1]),
                ] {
                    cases.push((p.clone(), (vx, load), states, inputs));
                }
            }
        }
    }
    cases
}

/// A carried first substep shorter than the step: the length the same step found
/// with nothing carried (as the next step would carry it), nine tenths of it, and a
/// third, 0.45 and 0.7 of the step. The step's first exprb42 substep is that length
/// in equal pieces of the step (`in_equal_pieces`: three, three and two pieces for the
/// shares), and the step, taken by the cascade, ends where the same step with nothing
/// carried ends (by the cascade too), within 1e-10 of the largest state or offset:
/// the carried length is the error control's first try, which moves the end by no
/// more than the tolerance. (Some ends differ in their bits: the carried length was
/// used, not ignored.)
#[test]
fn a_carried_first_substep_shorter_than_the_step_ends_where_nothing_carried_does() {
    let (mut compared, mut differing) = (0, 0);
    for (p, point, states, inputs) in settled_slides() {
        for h in [1e-3, 2e-3] {
            let (nothing, found, travel) =
                settled_cascade_step(&p, point, (&states, inputs), h, super::super::NOT_CARRIED);
            let Some(nothing) = nothing else {
                continue;
            };
            for (share, pieces) in [(1.0 / 3.0, 3.0), (0.45, 3.0), (0.7, 2.0)] {
                assert_eq!(super::lengths::in_equal_pieces(h, share * h), h / pieces);
            }
            let lengths = [found[0], 0.9 * found[0], h / 3.0, 0.45 * h, 0.7 * h];
            for carried in lengths.into_iter().filter(|&length| length < h) {
                let label = format!(
                    "{:?} {point:?} {states:?} {inputs:?} h {h} carried {carried}",
                    p.friction
                );
                let (with_carried, ..) =
                    settled_cascade_step(&p, point, (&states, inputs), h, [carried, f64::INFINITY]);
                let Some(with_carried) = with_carried else {
                    continue;
                };
                compared += 1;
                differing += usize::from(with_carried != nothing);
                let difference = end_difference(&nothing, &with_carried, travel);
                assert!(difference <= 1e-10, "{label}: {difference:e}");
            }
        }
    }
    assert!(
        compared > 0 && differing > 0,
        "{compared} steps compared, {differing} differing"
    );
}

/// A carried first substep so short that the step would need more pieces than it may
/// take ([`super::MAX_SUBSTEPS`]: a length from a far shorter step) tells the step
/// nothing: it is ignored and the whole step tried first, so the cascade still takes
/// every step it takes with nothing carried (were the length used, the step would
/// need more substeps than allowed and be given up), and ends where that step does:
/// within 1e-10 of the largest state or offset, and, ignored as if none were carried,
/// in the same bits.
#[test]
fn a_carried_first_substep_too_short_for_the_step_is_ignored() {
    let mut compared = 0;
    for (p, point, states, inputs) in settled_slides() {
        for h in [1e-3, 2e-3] {
            let (nothing, _, travel) =
                settled_cascade_step(&p, point, (&states, inputs), h, super::super::NOT_CARRIED);
            let Some(nothing) = nothing else {
                continue;
            };
            for pieces in [super::MAX_SUBSTEPS as f64 + 0.5, 20.0, 1e3] {
                let carried = h / pieces;
                let label = format!(
                    "{:?} {point:?} {states:?} {inputs:?} h {h} carried {carried}",
                    p.friction
                );
                let (with_carried, ..) =
                    settled_cascade_step(&p, point, (&states, inputs), h, [carried, f64::INFINITY]);
                let with_carried = with_carried.unwrap_or_else(|| panic!("{label}: given up"));
                compared += 1;
                let difference = end_difference(&nothing, &with_carried, travel);
                assert!(difference <= 1e-10, "{label}: {difference:e}");
                // Ignored as if none were carried: the same substeps, the same bits.
                assert!(
                    with_carried == nothing,
                    "{label}: not the same bits ({difference:e})"
                );
            }
        }
    }
    assert!(
        compared > 0,
        "no step was taken by the cascade with nothing carried"
    );
}

/// docs/specification.md 7, with a carried length: a DDT tire sliding in both directions
/// (muX = muY = 0.01, either law) under the slide yardstick's inputs in 2 ms steps, its
/// states, branches, inputs and carried substep lengths saved every tenth step where the
/// cascade's first substep length is carried (finite), continues bit for bit when they
/// are restored (as `Instance::restore` restores an FMU state) onto a fresh tire and onto
/// one that has been stepping elsewhere: its states, outputs and carried lengths after
/// each of the next ten steps, under the yardstick's inputs, and under the saved inputs
/// held (where the saved tire starts each step from what its last step's outputs
/// prepared, which the state does not hold, and the restored one decides the modes anew).
/// Restored without the carried lengths, some continue otherwise: the lengths are in play
/// here.
#[test]
fn a_restored_state_with_a_carried_length_continues_bit_for_bit() {
    use crate::physics::Tire;
    let h = 2e-3;
    let inputs_at = |k: usize| {
        let t = k as f64 * h;
        [10.0, 0.1 * t.sin(), 0.05 * t.cos(), 0.01 * t.sin(), 50_000.0]
    };
    let (mut restores, mut without_differs) = (0, 0);
    for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
        let p = super::super::slide_parameters(ModelKind::Ddt, law, true);
        let mut other = Tire::new(p.clone()).unwrap();
        for j in 0..50 {
            other.set_inputs([-5.0, 0.2, -0.1, 0.02, 30_000.0 + 100.0 * j as f64]);
            other.step(h).unwrap();
        }
        let mut tire = Tire::new(p.clone()).unwrap();
        for k in 0..100 {
            tire.set_inputs(inputs_at(k));
            tire.step(h).unwrap();
            let carried = tire.high_order_substeps();
            if k % 10 != 9 || !carried[0].is_finite() {
                continue;
            }
            let (states, sliders, inputs) = (tire.states().to_vec(), *tire.sliders().unwrap(), tire.inputs());
            let restore = |onto: &Tire, lengths: Option<super::super::HighOrderSubsteps>| {
                let mut restored = onto.clone();
                restored.set_states(&states).unwrap();
                restored.set_sliders(&sliders).unwrap();
                if let Some(lengths) = lengths {
                    restored.set_high_order_substeps(lengths);
                }
                restored.set_inputs(inputs);
                restored
            };
            for held in [false, true] {
                let run = |mut tire: Tire| -> Vec<u64> {
                    let mut bits = Vec::new();
                    for j in k + 1..k + 11 {
                        tire.set_inputs(if held { inputs } else { inputs_at(j) });
                        tire.step(h).unwrap();
                        bits.extend(tire.states().iter().map(|v| v.to_bits()));
                        bits.extend(tire.outputs().iter().map(|v| v.to_bits()));
                        bits.extend(tire.high_order_substeps().map(f64::to_bits));
                    }
                    bits
                };
                let first = run(tire.clone());
                let fresh = Tire::new(p.clone()).unwrap();
                for (name, onto) in [("fresh", &fresh), ("other", &other)] {
                    restores += 1;
                    assert!(
                        run(restore(onto, Some(carried))) == first,
                        "{law:?}, saved after step {k} (carrying {carried:?}), held {held}: the {name} tire continues otherwise"
                    );
                }
                without_differs += usize::from(run(restore(&fresh, None)) != first);
            }
        }
    }
    assert!(
        restores > 0 && without_differs > 0,
        "{restores} restores, {without_differs} continuing otherwise without the carried lengths"
    );
}
