//! One substep of a piece by the explicit Runge-Kutta pair of Dormand and Prince of
//! order 8 (DOP853: Hairer, Norsett and Wanner, Solving Ordinary Differential Equations
//! I, section II.10): where no event is near and the exponential substep is not suited
//! (a force that turns on its ellipse within the substep, as both directions sliding
//! together make it).
//!
//! Over a millisecond such a slide is smooth and the motion's time scales are a few
//! substeps long, so a high order pays: twelve stages make the eighth-order solution,
//! where the extrapolation's midpoint rows reach the same error at the row of ten steps,
//! thirty evaluations. The error estimate is the pair's own: the fifth- and third-order
//! differences `E5` and `E3` blended as `|E5|^2 / sqrt(|E5|^2 + 0.01 |E3|^2)`, which
//! falls like the eighth-order error as the substep shortens, measured entry by entry
//! against the tolerance as the extrapolation's rows are.
//!
//! The stages' event values are sampled: a group near its limit at a stage, or that may
//! come near it between two (a parabola through three neighbouring stages in time), hands
//! the substep to the extrapolation, whose finer samples and accurate intermediate values
//! locate events; so events are found where they were.

use super::events::NEAR_EVENT;
use super::extrapolation::{ROUNDING, TOLERANCE, larger, largest_of};
use super::{
    Events, HighOrderSubsteps, Modes, NO_EVENT, SIZE, SlidingStep, UNEVALUATED, Vector, by_entry_count,
};
use crate::physics::friction::group::ReturnRates;

/// The stages of the eighth-order solution.
const STAGES: usize = 12;

/// Where each stage is, as a fraction of the substep.
const NODES: [f64; STAGES] = [
    0.0,
    0.05260015195876773,
    0.0789002279381516,
    0.1183503419072274,
    0.2816496580927726,
    0.3333333333333333,
    0.25,
    0.3076923076923077,
    0.6512820512820513,
    0.6,
    0.8571428571428571,
    1.0,
];
/// The eighth-order solution's weights.
const WEIGHTS: [f64; STAGES] = [
    0.054293734116568765,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    0.3111643669578199,
    -0.1521609496625161,
    0.20136540080403034,
    0.04471061572777259,
];
/// The fifth-order difference of the error estimate.
const FIFTH_ORDER_ERROR: [f64; STAGES] = [
    0.01312004499419488,
    0.0,
    0.0,
    0.0,
    0.0,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.3341791187130175,
    0.08192320648511571,
    -0.022355307863886294,
];
/// The third-order difference of the error estimate.
const THIRD_ORDER_ERROR: [f64; STAGES] = [
    -0.18980075407240762,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    -0.4226823213237919,
    -0.1521609496625161,
    0.20136540080403034,
    0.02265179219836082,
];
/// Each stage's weights of the stages before it.
const COUPLING: [[f64; STAGES]; STAGES] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        0.05260015195876773,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.0197250569845379,
        0.0591751709536137,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.02958758547680685,
        0.0,
        0.08876275643042054,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.2413651341592667,
        0.0,
        -0.8845494793282861,
        0.924834003261792,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037037037037037035,
        0.0,
        0.0,
        0.17082860872947386,
        0.12546768756682242,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037109375,
        0.0,
        0.0,
        0.17025221101954405,
        0.06021653898045596,
        -0.017578125,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.03709200011850479,
        0.0,
        0.0,
        0.17038392571223998,
        0.10726203044637328,
        -0.015319437748624402,
        0.008273789163814023,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.6241109587160757,
        0.0,
        0.0,
        -3.3608926294469414,
        -0.868219346841726,
        27.59209969944671,
        20.154067550477894,
        -43.48988418106996,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.47766253643826434,
        0.0,
        0.0,
        -2.4881146199716677,
        -0.590290826836843,
        21.230051448181193,
        15.279233632882423,
        -33.28821096898486,
        -0.020331201708508627,
        0.0,
        0.0,
        0.0,
    ],
    [
        -0.9371424300859873,
        0.0,
        0.0,
        5.186372428844064,
        1.0914373489967295,
        -8.149787010746927,
        -18.52006565999696,
        22.739487099350505,
        2.4936055526796523,
        -3.0467644718982196,
        0.0,
        0.0,
    ],
    [
        2.273310147516538,
        0.0,
        0.0,
        -10.53449546673725,
        -2.0008720582248625,
        -17.9589318631188,
        27.94888452941996,
        -2.8589982771350235,
        -8.87285693353063,
        12.360567175794303,
        0.6433927460157636,
        0.0,
    ],
];

/// How many times the tolerance the error estimate may be. The estimate's lower-order
/// differences overstate the eighth-order solution's error: over the slide yardstick's
/// combined slides (SecondOrder), the error against the same substep in eight parts was
/// at most 0.26 of the estimate in 99 % of the substeps and 0.16 in half of them.
const ESTIMATE_MARGIN: f64 = 4.0;

/// The error estimate, in tolerances, that the lengths carried to the next step aim at
/// ([`HighOrderSubsteps`]; the substeps within a step aim at a third of
/// [`ESTIMATE_MARGIN`], with a margin). A slide's error is largest where its force turns,
/// at the step's start, and falls within the step, so its first substep is the shortest
/// and the second may be longer than the first's error would allow; the next step starts
/// with the lengths they could have had, where it would otherwise try the whole step and
/// then substeps as short as the first. Over 2000 steps of the slide yardstick's combined
/// case (1 ms), RingBody's sliding steps took three or four substeps by the pair, a
/// first attempt at the whole step coming back too long in 800 of them; with the first
/// length carried, three and a miss in 19; with both, two and no miss.
const CARRIED_AIM: f64 = 3.0;

/// `x^(1/8)` by three square roots (a power would cost several times more).
fn eighth_root(x: f64) -> f64 {
    x.sqrt().sqrt().sqrt()
}

/// The stages in the order of their nodes, from the start to the end of the substep.
const IN_TIME: [usize; STAGES] = [0, 1, 2, 3, 6, 4, 7, 5, 9, 8, 10, 11];

/// The second divided difference through the stages `k - 1`, `k` and `k + 1` in time
/// (`k` from 1 to 10) as weights of their values, `D = sum w_j v_j`.
const DIVIDED: [[f64; 3]; STAGES - 1] = {
    let mut weights = [[0.0; 3]; STAGES - 1];
    let mut k = 1;
    while k < STAGES - 1 {
        let (t0, t1, t2) = (NODES[IN_TIME[k - 1]], NODES[IN_TIME[k]], NODES[IN_TIME[k + 1]]);
        let before = 1.0 / ((t1 - t0) * (t2 - t0));
        let after = 1.0 / ((t2 - t1) * (t2 - t0));
        weights[k] = [before, -(before + after), after];
        k += 1;
    }
    weights
};

/// A quarter of the square of each gap between neighbouring stages in time.
const QUARTER_GAP_SQUARED: [f64; STAGES - 1] = {
    let mut quarter = [0.0; STAGES - 1];
    let mut k = 0;
    while k < STAGES - 1 {
        let gap = NODES[IN_TIME[k + 1]] - NODES[IN_TIME[k]];
        quarter[k] = 0.25 * gap * gap;
        k += 1;
    }
    quarter
};

/// The most a parabola of [`may_near_between`] rises above the larger value of its gap,
/// per unit of the range of the values (`D = w0 (v0 - v1) + w2 (v2 - v1)`): a group whose
/// values stay this far below [`NEAR_EVENT`] needs no parabola.
const MOST_RISE: f64 = {
    let mut most = 0.0;
    let mut k = 0;
    while k < STAGES - 1 {
        let mut bend = 0.0;
        let mut j = k;
        while j <= k + 1 {
            if j >= 1 && j < STAGES - 1 {
                let weight = DIVIDED[j][0] + DIVIDED[j][2];
                if weight > bend {
                    bend = weight;
                }
            }
            j += 1;
        }
        let rise = bend * QUARTER_GAP_SQUARED[k];
        if rise > most {
            most = rise;
        }
        k += 1;
    }
    most
};

/// Whether a group's event value may come within [`NEAR_EVENT`] of its limit between two
/// neighbouring stages in time, given its values `samples` at the stages (each below it):
/// above the larger of the two by at most what a parabola through them and a third
/// neighbour rises above their chord, `|D| w^2 / 4` for a gap `w` and the parabola's
/// second divided difference `D < 0`; the larger of the two parabolas of each gap.
fn may_near_between(samples: &[Events; STAGES]) -> bool {
    for (e, &start) in samples[0].as_flattened().iter().enumerate() {
        // A group that does not exist.
        if start == NO_EVENT {
            continue;
        }
        let values: [f64; STAGES] = std::array::from_fn(|k| samples[IN_TIME[k]].as_flattened()[e]);
        let highest = values.iter().fold(f64::NEG_INFINITY, |h, &v| larger(h, v));
        let lowest = values
            .iter()
            .fold(f64::INFINITY, |l, &v| if v < l { v } else { l });
        if highest + MOST_RISE * (highest - lowest) <= -NEAR_EVENT {
            continue;
        }
        let mut concavity = [0.0; STAGES];
        for k in 1..STAGES - 1 {
            let [w0, w1, w2] = DIVIDED[k];
            let divided = w0 * values[k - 1] + w1 * values[k] + w2 * values[k + 1];
            concavity[k] = if divided < 0.0 { -divided } else { 0.0 };
        }
        for k in 0..STAGES - 1 {
            let higher = values[k].max(values[k + 1]);
            let bend = concavity[k].max(concavity[k + 1]);
            if higher + bend * QUARTER_GAP_SQUARED[k] > -NEAR_EVENT {
                return true;
            }
        }
    }
    false
}

/// The pair's substeps reach at most this far into the slide's fastest mode, the
/// largest return of a sliding spring group's member to its ellipse (its rate times the
/// length; [`SlidingStep::return_rates`]). Only there does its estimate hold: for a
/// linear mode `exp(z)`, `z` = -4 at most, the blended estimate is at least seven times
/// the error; from -5 on, the fifth-order difference passes a zero and the estimate
/// falls below the error, 50 times at -5.6. A slide in two directions with the pair's
/// substep at -5.9 was accepted at 0.8 tolerances, its error 280 (SecondOrder, Coulomb,
/// muX = muY = 0.01, at a standstill). The fixed-length modes (the model's relaxation,
/// the dampers') stay within 4 as every substep does ([`SlidingStep::longest_substep`]).
const REACH: f64 = 4.0;

/// The longest substep the pair takes where the slide's members return to their
/// ellipses at `returns` ([`REACH`]).
pub(super) fn reach(returns: ReturnRates) -> f64 {
    REACH / returns.largest
}

/// What a substep by the pair gave.
pub(super) enum HighOrder {
    /// Accurate: the end, the factor by which the next substep may grow, and the length
    /// of a substep from the same start whose estimate would be [`CARRIED_AIM`].
    Taken(Vector, f64, f64),
    /// Its error estimate is past the tolerance: the factor by which a substep that
    /// would be within it is shorter.
    TooLong(f64),
    /// A limit is near inside it, or a value is not finite: the extrapolation takes it.
    NotSuited,
}

impl SlidingStep<'_> {
    /// [`HighOrderSubsteps`] as this step found them, for the next.
    pub fn high_order_substeps(&self) -> HighOrderSubsteps {
        self.high_order_found.get()
    }

    /// The length the pair's first substep of this step tries, from `asked`: at most the
    /// first the last step could have taken (the pair's first substep wherever it falls
    /// in the step: after a stick at its start, say).
    pub(super) fn high_order_first_length(&self, asked: f64) -> f64 {
        if self.high_order_none_accepted() {
            asked.min(self.high_order_carried[0])
        } else {
            asked
        }
    }

    /// The factor by which the substep after one of `length` that the pair took may grow,
    /// from the pair's `growth`: after the step's first, to at least the second the last
    /// step could have taken (the caller keeps it within the rest of the step and the
    /// longest substep). Also keeps `aimed_length` until the substep is accepted
    /// ([`SlidingStep::high_order_substep_accepted`]).
    pub(super) fn high_order_substep_taken(&self, length: f64, growth: f64, aimed_length: f64) -> f64 {
        self.high_order_pending.set(Some(aimed_length));
        if self.high_order_none_accepted() {
            growth.max(self.high_order_carried[1] / length)
        } else {
            growth
        }
    }

    /// The substep just taken is accepted whole: if the pair took it, it counts, and the
    /// length it could have had is kept for the next step.
    pub(super) fn high_order_substep_accepted(&self) {
        let Some(aimed_length) = self.high_order_pending.take() else {
            return;
        };
        // The first of the lengths not yet found (each is finite once found).
        let mut found = self.high_order_found.get();
        if let Some(length) = found.iter_mut().find(|length| length.is_infinite()) {
            *length = aimed_length;
        }
        self.high_order_found.set(found);
    }

    /// Whether no substep of this step by the pair has been accepted yet.
    fn high_order_none_accepted(&self) -> bool {
        self.high_order_found.get()[0].is_infinite()
    }

    /// A substep of `length` from `z` with its `start` rates and event values by the
    /// eighth-order pair (see the module's doc); `length` within its [`reach`].
    pub(super) fn high_order_substep(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        length: f64,
        modes: &Modes,
    ) -> HighOrder {
        by_entry_count!(self.size(), E => self.high_order_substep_for::<E>(t, z, start, length, modes))
    }

    /// [`SlidingStep::high_order_substep`] in arrays of `E` entries (at least those in
    /// use; the rest zero), so that its sums are loops of known length.
    fn high_order_substep_for<const E: usize>(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        length: f64,
        modes: &Modes,
    ) -> HighOrder {
        let from: [f64; E] = std::array::from_fn(|c| z[c]);
        // The event values at the stages (at the start, the start's).
        let mut samples = [*start_events; STAGES];
        let mut stages = [[0.0; E]; STAGES];
        stages[0] = std::array::from_fn(|c| start_rates[c]);
        let mut at = *z;
        let mut made = UNEVALUATED;
        for s in 1..STAGES {
            let mut stage = from;
            for (j, rates) in stages[..s].iter().enumerate() {
                let weight = length * COUPLING[s][j];
                if weight != 0.0 {
                    for c in 0..E {
                        stage[c] += weight * rates[c];
                    }
                }
            }
            at[..E].copy_from_slice(&stage);
            self.rates_into(t + NODES[s] * length, &at, modes, &mut made);
            let (rates, events) = &made;
            if events.as_flattened().iter().any(|&e| e > -NEAR_EVENT) {
                return HighOrder::NotSuited;
            }
            samples[s] = *events;
            stages[s].copy_from_slice(&rates[..E]);
        }
        if may_near_between(&samples) {
            return HighOrder::NotSuited;
        }
        let (mut end, mut fifth, mut third) = (from, [0.0; E], [0.0; E]);
        for (s, rates) in stages.iter().enumerate() {
            let weight = length * WEIGHTS[s];
            for c in 0..E {
                end[c] += weight * rates[c];
                fifth[c] += FIFTH_ORDER_ERROR[s] * rates[c];
                third[c] += THIRD_ORDER_ERROR[s] * rates[c];
            }
        }
        if !end.iter().all(|v| v.is_finite()) {
            return HighOrder::NotSuited;
        }
        // Each difference against each entry's share of the tolerance, as the rows'.
        let size = self.size();
        let floor = ROUNDING * largest_of(&z[..size]);
        let (mut fifth_size, mut third_size) = (0.0, 0.0);
        for c in 0..size {
            let allowed = TOLERANCE * (self.scale + larger(z[c].abs(), end[c].abs())) + floor;
            fifth_size = larger(fifth_size, (length * fifth[c]).abs() / allowed);
            third_size = larger(third_size, (length * third[c]).abs() / allowed);
        }
        let blend = (fifth_size * fifth_size + 0.01 * third_size * third_size).sqrt();
        let error = if blend > 0.0 {
            fifth_size * fifth_size / blend
        } else {
            0.0
        };
        // Error ~ length^8 (as the blend falls): aim at a third of ESTIMATE_MARGIN next
        // time, with a margin.
        let root = eighth_root(error.max(1e-10));
        let growth = 0.9 * eighth_root(ESTIMATE_MARGIN / 3.0) / root;
        if error <= ESTIMATE_MARGIN {
            let mut whole = *z;
            whole[..E].copy_from_slice(&end);
            // The length at which the estimate would have been CARRIED_AIM.
            let aimed_length = length * eighth_root(CARRIED_AIM) / root;
            HighOrder::Taken(
                whole,
                growth.clamp(0.2, 4.0),
                aimed_length.clamp(0.2 * length, 4.0 * length),
            )
        } else {
            HighOrder::TooLong(growth.clamp(0.2, 0.9))
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::{longest_taken_ends_where_extrapolated, slide_parameters, with_settled_slide};
    use super::{HighOrder, reach};
    use crate::physics::friction::FrictionLaw;
    use crate::physics::{ModelKind, Parameter};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// Where it takes a substep, the eighth-order pair ends where the extrapolation
        /// does (each to a relative 1e-12), for every model sliding in one direction or in
        /// two, after 20 ms from states about the elastic travel, over the longest substep
        /// of 4 ms down to 10 us that it takes.
        #[test]
        fn a_high_order_substep_ends_where_the_extrapolated_one_does(
            model in prop::sample::select(ModelKind::ALL.to_vec()),
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            combined in any::<bool>(),
            vx in -20.0..20.0f64,
            load_ratio in 0.2..2.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform4(-1.5..1.5f64),
        ) {
            let p = slide_parameters(model, law, combined);
            let load = load_ratio * p.get(Parameter::NominalLoad);
            with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                let label = format!("{model:?} {law:?} combined {combined}");
                longest_taken_ends_where_extrapolated(step, (&x, &sliders), travel, &label, |z, start, length, modes| {
                    // Within the pair's reach, as a step keeps it.
                    if length > reach(step.return_rates(0.0, z, modes)) {
                        return None;
                    }
                    match step.high_order_substep(0.0, z, start, length, modes) {
                        HighOrder::Taken(end, _, _) => Some(end),
                        _ => None,
                    }
                })
            })?;
        }
    }
}
