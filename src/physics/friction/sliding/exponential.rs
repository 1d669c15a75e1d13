//! One substep of a piece by an exponential Rosenbrock method, exprb43 (Hochbruck,
//! Ostermann and Schweitzer, SIAM J. Numer. Anal. 47, 2009): where no event is near.
//!
//! Within a piece every group keeps its mode, and over a millisecond the right-hand side
//! `f` is linear to a few parts in 1e9 (`cargo bench --bench exponential_probe`). So the
//! substep takes its linear part `J` (the closed-form Jacobian at the start,
//! [`super::implicit`]) exactly through phi-functions, and only the small remainder
//! `N(u) = f(u) - J u` by quadrature. With `X = H J`, `D_i = N(U_i) - N(z)`:
//!
//! ```text
//! U2 = z + H/2 phi1(X/2) f(z)
//! U3 = z + H phi1(X) (f(z) + D2)
//! z' = z + H phi1(X) f(z) + H (16 phi3(X) - 48 phi4(X)) D2 + H (12 phi4(X) - 2 phi3(X)) D3
//! ```
//!
//! three evaluations for fourth order, where the extrapolation takes 13 to 31. Dropping
//! the `phi4` terms gives the embedded third-order solution; their difference,
//! `H phi4(X) (12 D3 - 48 D2)`, controls the substep's length as the extrapolation's
//! error does. A linear piece (every group sticking) has no remainder: the substep is the
//! exact solution.
//!
//! DDT's cascade ([`super::cascade`]) wants the rates at each substep's end anyway (the
//! next substep's start, and at a step's end the outputs), so it steps by methods whose
//! last evaluation is at their end:
//! - **exprb42** (Luan and Ostermann): fourth order from two evaluations, its stage at
//!   three quarters:
//!
//!   ```text
//!   U2 = z + 3H/4 phi1(3X/4) f(z)
//!   z' = z + H phi1(X) f(z) + 32/9 H phi3(X) D2
//!   ```
//!
//!   (`32/9 phi3` meets the third-order condition `b2 c2^2 = 2 phi3`, and the
//!   fourth-order one `b2 c2^3 = 6 phi4` where `X` is small, as over a non-stiff
//!   substep.) Its error is estimated from the rates at its end, `D3`, by the third-order
//!   `z + H phi1(X) f(z) + 2 H phi3(X) D3` (exprb32 with its stage at the end): their
//!   difference `H phi3(X) (32/9 D2 - 2 D3)`, taken with `phi3` at its largest, `1/6`
//!   (where the slide's modes decay, `X <= 0`, as DDT's do), so that the estimate needs no
//!   series of its own. Over DDT's slides (`cargo bench --bench exponential_probe`, column
//!   "42/est.") the fourth-order end's error was at most 0.14 of that estimate
//!   ([`EXPRB42_MARGIN`]). (Where the modes oscillate, as SecondOrder's and RingBody's
//!   ring, `1/6` is not the largest and the estimate would fall short: their substeps
//!   take exprb43.)
//! - **Exponential Euler** `z + H phi1(X) f(z)` where a slide in one direction turns its
//!   force so little that it is within the tolerance: one evaluation, at its end, whose
//!   rates estimate its error the same way, `H D3 / 3` ([`exponential_euler`],
//!   [`EULER_MARGIN`]).
//!
//! The products `phi_k(X) v` are Taylor series of matrix-vector products, summed to
//! below the tolerance; one series of powers `X^j v` serves every phi-function of the
//! same `v`. `X` is made dense once, in arrays of the entries' size rounded up to even
//! (at most twelve), so that a product is a short loop of known length. A substep whose
//! series would be long (`X` large: a stiff slide, which the linearly implicit method
//! takes) is not taken this way.
//!
//! The event values at `U2` and `U3` are checked as the midpoint rows check their
//! samples ([`super::events::InteriorSearch`]): a group near its limit anywhere in the
//! substep hands the substep to the extrapolation, whose finer samples and accurate
//! intermediate values locate events; so events are found where they were.

use super::events::InteriorSearch;
use super::extrapolation::{ROUNDING, TOLERANCE, largest_of};
use super::{Events, Modes, SIZE, SlidingStep, UNEVALUATED, Vector, by_entry_count};
use crate::physics::math;
use crate::physics::stepper::phi::inverse_factorials;

/// The most terms of one phi-series; a substep that needs more is too long for it.
const MAX_TERMS: usize = 30;
/// `1/k!` as far as the longest series of `phi4` reads.
const INVERSE_FACTORIAL: [f64; MAX_TERMS + 5] = inverse_factorials();
/// `c^j`, for `phi1(c X)` from the powers of `X`.
const fn powers_of(c: f64) -> [f64; MAX_TERMS] {
    let mut table = [1.0; MAX_TERMS];
    let mut j = 1;
    while j < MAX_TERMS {
        table[j] = c * table[j - 1];
        j += 1;
    }
    table
}
/// `2^-j`, for `phi1(X / 2)`.
const HALF_POWERS: [f64; MAX_TERMS] = powers_of(0.5);
/// `(3/4)^j`, for `phi1(3X / 4)`.
const THREE_QUARTER_POWERS: [f64; MAX_TERMS] = powers_of(0.75);
/// A series ends where a term moves every entry by less than this fraction of the
/// substep's tolerance.
const NEGLIGIBLE: f64 = 1e-3;

/// How many times the tolerance the embedded estimate may be. It is the third-order
/// solution's error; the fourth-order one taken is far closer: over the slide
/// yardstick's steps, 20 to 700 times (`cargo bench --bench exponential_probe`).
const ESTIMATE_MARGIN: f64 = 20.0;

/// How many times the tolerance exprb42's estimate may be: its fourth-order end's error
/// was at most 0.14 of the estimate over DDT's slides in one direction and in two, to 3.5
/// s, past the slip's first reversal (`cargo bench --bench exponential_probe`, column
/// "42/est."), so its end stays within 0.7 of the tolerance.
pub(super) const EXPRB42_MARGIN: f64 = 5.0;

/// How many times the tolerance exponential Euler's estimate of its own error may be: its
/// error was at most 1.1 times the estimate over DDT's slides (column "euler/est."), a
/// maximum over sampled whole steps, so this keeps its end within the tolerance with
/// room for steps the probe did not sample.
pub(super) const EULER_MARGIN: f64 = 0.5;

/// The band of turns in which an exponential substep is not tried: a sliding spring
/// group's least-moved member returned to the ellipse by between a thousandth of its
/// deflection and three times it over the substep (the least of
/// [`GroupInput::return_rates`] times the length, the largest over the groups). There
/// the group slides in two directions (a friction ellipse about as long as it is wide,
/// as any tire's with muX close to muY, at any longitudinal slip) and its force turns
/// towards the slip on a time scale within the substep's: the linearisation at the
/// substep's start misses the end by tens to thousands of times the tolerance. Below the band the force hardly turns (a
/// slide in one direction: muX = 0.3 and muY = 0.01 reach 6e-4); above it, the turn is
/// over within the substep's first part and exprb43 is within its tolerance most of the
/// time. Over 2000 steps of the slide yardstick's combined case (the turn and the
/// outcome of each attempt written out), 93 % of SecondOrder's and 99 % of RingBody's
/// attempts with turns up to 2 failed; with turns from 2 to 3, 94 % of RingBody's failed
/// (1052 of 1122, each an exprb43 substep thrown away, about 15 % of the case's
/// instructions); above 3, 89 % were taken.
///
/// [`GroupInput::return_rates`]: crate::physics::friction::group::GroupInput::return_rates
const TURNING_BAND: (f64, f64) = (1e-3, 3.0);

/// How an exponential substep ended.
pub(super) enum Exponential {
    /// Accurate: the end, and the factor by which the next substep may grow.
    Taken(Vector, f64),
    /// Its error estimate is past the tolerance: the piece is further from linear than a
    /// fourth-order step of this length takes; the factor by which a substep that would be
    /// within it is shorter.
    TooLong(f64),
    /// Not tried, or not to be tried shorter: a force turns on its ellipse within the
    /// substep ([`TURNING_BAND`]).
    Turning,
    /// A limit is near inside it, or the series would be long: the extrapolation takes it.
    NotSuited,
}

/// `X = H J` made dense in `E` x `E` arrays (`E` at least the entries in use; the rows
/// and columns past them zero), and what its series need.
pub(super) struct Linearisation<const E: usize> {
    /// By column: a product adds columns, every entry's sum independent of the others'.
    pub(super) columns: [[f64; E]; E],
    pub(super) length: f64,
    /// The size of a term's contribution below which it no longer counts.
    pub(super) negligible: f64,
}

impl<const E: usize> Linearisation<E> {
    /// `X = H J` from its columns, for a substep of `length` from a state whose largest
    /// entry is `largest`, at the deflection scale `scale`.
    pub(super) fn new(columns: [[f64; E]; E], length: f64, scale: f64, largest: f64) -> Self {
        Linearisation {
            columns,
            length,
            negligible: negligible_term(scale, largest),
        }
    }
}

/// [`LinearPart::negligible`] at the deflection scale `scale`, for a substep from a state
/// whose largest entry is `largest`.
pub(super) fn negligible_term(scale: f64, largest: f64) -> f64 {
    NEGLIGIBLE * (TOLERANCE * scale + ROUNDING * largest)
}

/// A substep's linear part `X = H J` as its series need it: its product with a vector,
/// the substep's length, and the size of a term's contribution below which it no longer
/// counts. Dense ([`Linearisation`]), or in blocks where the entries fall into systems of
/// their own (`super::cascade`).
pub(super) trait LinearPart<const E: usize> {
    fn times(&self, v: &[f64; E]) -> [f64; E];
    fn length(&self) -> f64;
    fn negligible(&self) -> f64;

    /// How much a term `v` of a series counts, as a rate of the states: its largest
    /// entry's size (a NaN ignored) where every entry is a state's.
    #[inline(always)]
    fn size(&self, v: &[f64; E]) -> f64 {
        largest_size(v)
    }

    /// `sum_j weights(j)[k] X^j v` for each `k` (`weights(j)[0]` the largest); `None` if the terms do not fall below
    /// [`LinearPart::negligible`] within [`MAX_TERMS`]. A term ends the series where
    /// its contribution is negligible and the next one is at most half of it (the powers
    /// grow by less than the weights fall), so that the rest is too.
    #[inline(always)]
    fn series<const K: usize>(
        &self,
        v: &[f64; E],
        weights: impl Fn(usize) -> [f64; K],
    ) -> Option<[[f64; E]; K]> {
        let mut sums = [[0.0; E]; K];
        let mut power = *v;
        let mut previous_largest = f64::INFINITY;
        for j in 0..MAX_TERMS {
            let w = weights(j);
            let largest = self.size(&power);
            for k in 0..K {
                for c in 0..E {
                    sums[k][c] += w[k] * power[c];
                }
            }
            // The first weight is the largest (phi-functions of lower index first).
            let heaviest = w[0];
            // The powers grow by `largest / previous_largest` a term, the weights fall by
            // `1 / (j + 2)` or faster.
            let next_at_most_half = largest <= 0.5 * (j + 2) as f64 * previous_largest;
            if self.length() * heaviest * largest <= self.negligible()
                && (j > 0 && next_at_most_half || largest == 0.0)
            {
                return Some(sums);
            }
            previous_largest = largest;
            power = self.times(&power);
        }
        None
    }
}

impl<const E: usize> LinearPart<E> for Linearisation<E> {
    fn times(&self, v: &[f64; E]) -> [f64; E] {
        let mut product = [0.0; E];
        for (column, &factor) in self.columns.iter().zip(v) {
            // By pairs of rows: so written, the product is made two entries an
            // instruction (entry by entry, the compiler made it one).
            for (pair, entries) in product.chunks_exact_mut(2).zip(column.chunks_exact(2)) {
                let sums = [pair[0] + entries[0] * factor, pair[1] + entries[1] * factor];
                pair.copy_from_slice(&sums);
            }
        }
        product
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn negligible(&self) -> f64 {
        self.negligible
    }
}

/// The largest size of the entries of `v` (`E` even), a NaN ignored as by `f64::max`: in
/// two lanes of plain comparisons, which the series' every term waits on.
#[inline]
pub(super) fn largest_size<const E: usize>(v: &[f64; E]) -> f64 {
    const { assert!(E.is_multiple_of(2)) };
    let mut lanes = [0.0_f64; 2];
    for pair in v.chunks_exact(2) {
        for (lane, value) in lanes.iter_mut().zip(pair) {
            let size = value.abs();
            if size > *lane {
                *lane = size;
            }
        }
    }
    if lanes[1] > lanes[0] { lanes[1] } else { lanes[0] }
}

/// The first `E` entries of a coupled vector.
fn shortened<const E: usize>(v: &Vector) -> [f64; E] {
    std::array::from_fn(|c| v[c])
}

impl SlidingStep<'_> {
    /// One exprb43 substep of `length` from `z` at `t`, with its start rates and event
    /// values, where the slide's forces turn on their ellipses at `turning_rate` (the
    /// least of [`SlidingStep::return_rates`]; see the module's doc); with `look_inside`,
    /// one near a limit is not taken. Held driving inputs only: the linearisation carries
    /// no time.
    pub(super) fn exponential_substep(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        (length, turning_rate): (f64, f64),
        modes: &Modes,
        look_inside: bool,
    ) -> Exponential {
        by_entry_count!(self.size(), E => self.exponential_substep_for::<E>(t, z, start, (length, turning_rate), modes, look_inside))
    }

    /// [`SlidingStep::exponential_substep`] in arrays of `E` entries.
    fn exponential_substep_for<const E: usize>(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        (length, turning_rate): (f64, f64),
        modes: &Modes,
        look_inside: bool,
    ) -> Exponential {
        // Checked before the Jacobian is made: in a combined slide the band declines
        // nearly every attempt.
        let turn = turning_rate * length;
        if turn > TURNING_BAND.0 && turn < TURNING_BAND.1 {
            return Exponential::Turning;
        }
        let jacobian = self.jacobian(t, z, start_rates, modes);
        let largest = largest_of(z);
        let linear = Linearisation::new(jacobian.scaled_columns::<E>(length), length, self.scale, largest);
        let mut search = InteriorSearch::new(start_events);
        // The stages' rates from the whole coupled vector, their event values sampled.
        let stage_rates = |stage: usize, u: &[f64; E]| {
            let mut at = *z;
            at[..E].copy_from_slice(u);
            let mut made = UNEVALUATED;
            self.rates_into(t + 0.5 * stage as f64 * length, &at, modes, &mut made);
            let (rates, events) = &made;
            search.sample(stage, 0.5 * length, events);
            let near = stage == 2 && look_inside && search.found() != (None, None);
            (!near).then(|| shortened::<E>(rates))
        };
        let Some((fourth, third)) = exprb43(
            &linear,
            &shortened::<E>(z),
            &shortened::<E>(start_rates),
            stage_rates,
        ) else {
            return Exponential::NotSuited;
        };
        let size = self.size();
        let error = self.error_ratio_of(
            (&z[..size], &fourth[..size], &third[..size]),
            largest_of(&z[..size]),
        );
        match resize(error, ESTIMATE_MARGIN) {
            (true, growth) => {
                let mut end = *z;
                end[..E].copy_from_slice(&fourth);
                Exponential::Taken(end, growth)
            }
            // Shorter, the turn would fall into the band: the other methods take it.
            (false, factor) if turn * factor < TURNING_BAND.1 => Exponential::Turning,
            (false, factor) => Exponential::TooLong(factor),
        }
    }
}

/// Whether a substep whose estimate is `error_ratio` times the tolerance is taken (at
/// most `margin` times: [`ESTIMATE_MARGIN`] or [`EXPRB42_MARGIN`]), and the factor by
/// which the next (or the one tried again) is to be longer. The estimate is a third-order
/// solution's error (~ length^4); it aims at a third of the allowed.
pub(super) fn resize(error_ratio: f64, margin: f64) -> (bool, f64) {
    let error = error_ratio / margin;
    let factor = 0.9 / (3.0 * error).max(1e-10).sqrt().sqrt();
    resized(error, factor)
}

/// [`resize`] for exponential Euler's estimate of its own error ([`EULER_MARGIN`]), which
/// grows as the substep's cube: its error is second order, its estimate `H D3 / 3` with
/// `D3 ~ H^2`.
pub(super) fn resize_euler(error_ratio: f64) -> (bool, f64) {
    let error = error_ratio / EULER_MARGIN;
    resized(error, 0.9 / math::cbrt((3.0 * error).max(1e-10)))
}

/// Whether [`resize_euler`] takes the substep, without its growth.
pub(super) fn euler_within(error_ratio: f64) -> bool {
    error_ratio / EULER_MARGIN <= 1.0
}

/// Whether an error of `error` allowances is taken, and the growth `factor` clamped: at
/// most four times longer, and where not taken at least a fifth as long and a tenth
/// shorter.
pub(super) fn resized(error: f64, factor: f64) -> (bool, f64) {
    if error <= 1.0 {
        (true, factor.clamp(0.2, 4.0))
    } else {
        (false, factor.clamp(0.2, 0.9))
    }
}

/// The difference of two ends relative to the tolerance (the caller's error ratio):
/// exponential Euler's estimate of its own error ([`exponential_euler`]).
pub(super) type ErrorOf<'a, const E: usize> = dyn Fn(&[f64; E], &[f64; E]) -> f64 + 'a;

/// `1/(j + k)!`, the weight of `X^j` in `phi_k(X)`.
fn phi(k: usize, j: usize) -> f64 {
    INVERSE_FACTORIAL[j + k]
}

/// `phi1(X) f(z)`, and the stage a fraction `c` of the substep on, `z + c H phi1(c X)
/// f(z)`, from one series (`powers` holds `c^j`).
#[inline(always)]
fn whole_and_stage<const E: usize>(
    linear: &impl LinearPart<E>,
    z: &[f64; E],
    f0: &[f64; E],
    (c, powers): (f64, &[f64; MAX_TERMS]),
) -> Option<([f64; E], [f64; E])> {
    let [whole, part] = linear.series(f0, |j| [phi(1, j), phi(1, j) * powers[j]])?;
    let mut stage = *z;
    for k in 0..E {
        stage[k] += c * linear.length() * part[k];
    }
    Some((whole, stage))
}

/// A two-stage method's first stage ([`exprb43`], [`exprb42`]): `phi1(X) f(z)`, and
/// `D2 = N(U2) - N(z)` at `U2`, the fraction `c` of the substep on ([`whole_and_stage`]),
/// with the rates there that `stage_rates(1, U2)` gives.
fn first_stage<const E: usize>(
    linear: &impl LinearPart<E>,
    (z, f0): (&[f64; E], &[f64; E]),
    (c, powers): (f64, &[f64; MAX_TERMS]),
    stage_rates: &mut impl FnMut(usize, &[f64; E]) -> Option<[f64; E]>,
) -> Option<([f64; E], [f64; E])> {
    let (whole, stage) = whole_and_stage(linear, z, f0, (c, powers))?;
    let d2 = remainder(linear, (z, f0), &stage, &stage_rates(1, &stage)?);
    Some((whole, d2))
}

/// `N(u) - N(z)`, `N(u) = f(u) - J u`, from `u` and its rates (`z` with its rates `f0`).
fn remainder<const E: usize>(
    linear: &impl LinearPart<E>,
    (z, f0): (&[f64; E], &[f64; E]),
    u: &[f64; E],
    rates: &[f64; E],
) -> [f64; E] {
    let mut moved = [0.0; E];
    for c in 0..E {
        moved[c] = u[c] - z[c];
    }
    let linear_part = linear.times(&moved);
    let length = linear.length();
    let mut d = [0.0; E];
    for c in 0..E {
        d[c] = rates[c] - f0[c] - linear_part[c] / length;
    }
    d
}

/// One exponential Euler substep of `X = H J` from `z` with its rates `f0`,
/// `z' = z + H phi1(X) f(z)`, with its error estimated from the rates at its own end:
/// exprb32's third-order solution `z' + 2 H phi3(X) D3`, `D3 = N(z') - N(z)`, differs
/// from it by about Euler's error (taken as `H D3 / 3`, see the module's doc). Where a
/// slide turns its force so little that Euler is within the tolerance, its end is taken,
/// and the evaluation there (which a caller may make as the outputs are made) serves the
/// next substep's start: one evaluation a substep.
///
/// `middle(u)` is given `z + H/2 phi1(X/2) f(z)`, half the substep on (for its event
/// values); `end_rates(z')` gives the rates at the end. Returns the end and `error(third,
/// end)`, the estimate relative to the tolerance; `None` where a series would be long, a
/// value is not finite, or a callback gives up.
pub(super) fn exponential_euler<const E: usize>(
    linear: &impl LinearPart<E>,
    z: &[f64; E],
    f0: &[f64; E],
    mut middle: impl FnMut(&[f64; E]) -> Option<()>,
    mut end_rates: impl FnMut(&[f64; E]) -> Option<[f64; E]>,
    error: &ErrorOf<'_, E>,
) -> Option<([f64; E], f64)> {
    let length = linear.length();
    let (whole, at_middle) = whole_and_stage(linear, z, f0, (0.5, &HALF_POWERS))?;
    let mut end = *z;
    for c in 0..E {
        end[c] += length * whole[c];
    }
    middle(&at_middle)?;
    if !end.iter().all(|v| v.is_finite()) {
        return None;
    }
    let d3 = remainder(linear, (z, f0), &end, &end_rates(&end)?);
    // `2 H phi3(X) D3` with `phi3(X)` at its largest, `1/6` (as where the slide's modes
    // decay, `X <= 0`): an estimate no smaller, and no series of its own.
    let mut third = end;
    for c in 0..E {
        third[c] += length / 3.0 * d3[c];
    }
    third
        .iter()
        .all(|v| v.is_finite())
        .then(|| (end, error(&third, &end)))
}

/// One exprb43 substep of `X = H J` from `z` with its rates `f0` (see the module's doc):
/// its fourth-order solution and the embedded third-order one, or `None` where a series
/// would be long, a value is not finite, or `stage_rates` gives up. `stage_rates(k, u)`
/// gives the rates at `U2` (`k = 1`, half the substep on) and at `U3` (`k = 2`, its end).
pub(super) fn exprb43<const E: usize>(
    linear: &impl LinearPart<E>,
    z: &[f64; E],
    f0: &[f64; E],
    mut stage_rates: impl FnMut(usize, &[f64; E]) -> Option<[f64; E]>,
) -> Option<([f64; E], [f64; E])> {
    let length = linear.length();
    let (whole, d2) = first_stage(linear, (z, f0), (0.5, &HALF_POWERS), &mut stage_rates)?;
    let [d2_phi1, d2_phi3, d2_phi4] = linear.series(&d2, |j| [phi(1, j), phi(3, j), phi(4, j)])?;
    let mut end = *z;
    for c in 0..E {
        end[c] += length * (whole[c] + d2_phi1[c]);
    }
    let d3 = remainder(linear, (z, f0), &end, &stage_rates(2, &end)?);
    let [d3_phi3, d3_phi4] = linear.series(&d3, |j| [phi(3, j), phi(4, j)])?;
    let mut fourth = *z;
    let mut third = *z;
    for c in 0..E {
        third[c] += length * (whole[c] + 16.0 * d2_phi3[c] - 2.0 * d3_phi3[c]);
        fourth[c] = third[c] + length * (12.0 * d3_phi4[c] - 48.0 * d2_phi4[c]);
    }
    fourth.iter().all(|v| v.is_finite()).then_some((fourth, third))
}

/// One exprb42 substep of `X = H J` from `z` with its rates `f0` (see the module's doc):
/// its fourth-order end, the third-order solution from the rates there, and the
/// remainders `D2` and `D3` at the stage and the end; or `None` where a series would be
/// long, a value is not finite, or `stage_rates` gives up.
/// `stage_rates(k, u)` gives the rates at `U2` (`k = 1`, three quarters of the substep
/// on) and at the end (`k = 2`), which the caller keeps as the next substep's start.
#[inline(always)]
pub(super) fn exprb42<const E: usize>(
    linear: &impl LinearPart<E>,
    z: &[f64; E],
    f0: &[f64; E],
    mut stage_rates: impl FnMut(usize, &[f64; E]) -> Option<[f64; E]>,
) -> Option<Exprb42Substep<E>> {
    let length = linear.length();
    let (whole, d2) = first_stage(linear, (z, f0), (0.75, &THREE_QUARTER_POWERS), &mut stage_rates)?;
    let [d2_phi3] = linear.series(&d2, |j| [phi(3, j)])?;
    let mut euler = *z;
    let mut end = *z;
    for c in 0..E {
        euler[c] += length * whole[c];
        end[c] = euler[c] + (32.0 / 9.0) * length * d2_phi3[c];
    }
    if !end.iter().all(|v| v.is_finite()) {
        return None;
    }
    let d3 = remainder(linear, (z, f0), &end, &stage_rates(2, &end)?);
    // The estimate `H phi3(X) (32/9 D2 - 2 D3)` with `phi3(X)` at its largest, `1/6` (as
    // where the slide's modes decay, `X <= 0`): no smaller, and no series of its own.
    let mut third = end;
    for c in 0..E {
        third[c] -= length / 6.0 * ((32.0 / 9.0) * d2[c] - 2.0 * d3[c]);
    }
    third.iter().all(|v| v.is_finite()).then_some(Exprb42Substep {
        end,
        third,
        remainders: [d2, d3],
    })
}

/// An [`exprb42`] substep: its fourth-order end, the third-order solution from the rates
/// there (their difference is its estimate), and the remainders `D2` and `D3` at the
/// stage and the end (from which its own error is estimated where that estimate is far
/// above it).
pub(super) struct Exprb42Substep<const E: usize> {
    pub(super) end: [f64; E],
    pub(super) third: [f64; E],
    pub(super) remainders: [[f64; E]; 2],
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::{longest_taken_ends_where_extrapolated, slide_parameters, with_settled_slide};
    use super::Exponential;
    use crate::physics::friction::FrictionLaw;
    use crate::physics::{ModelKind, Parameter};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// Where it takes a substep, the exponential one ends where the extrapolated one
        /// does (each to a relative 1e-12), for every model sliding in one direction or
        /// in two, after 20 ms from states about the elastic travel, over the longest
        /// substep of 4 ms down to 10 us that it takes (the shortest it nearly always
        /// does).
        #[test]
        fn an_exponential_substep_ends_where_the_extrapolated_one_does(
            model in prop::sample::select(ModelKind::ALL.to_vec()),
            combined in any::<bool>(),
            vx in -20.0..20.0f64,
            load_ratio in 0.2..2.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform4(-1.5..1.5f64),
        ) {
            let p = slide_parameters(model, FrictionLaw::Brush, combined);
            let load = load_ratio * p.get(Parameter::NominalLoad);
            with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                let label = format!("{model:?} combined {combined}");
                longest_taken_ends_where_extrapolated(step, (&x, &sliders), travel, &label, |z, start, length, modes| {
                    let turning_rate = step.return_rates(0.0, z, modes).least;
                    match step.exponential_substep(0.0, z, start, (length, turning_rate), modes, true) {
                        Exponential::Taken(end, _) => Some(end),
                        _ => None,
                    }
                })
            })?;
        }
    }
}
