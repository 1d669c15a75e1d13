//! One substep within a piece, to a relative 1e-12: where no event is near, by exprb43
//! ([`super::exponential`]) or, where a force turns on its ellipse, by the eighth-order
//! pair ([`super::dormand_prince`]); otherwise by extrapolation: Gragg-Bulirsch-Stoer
//! (the modified midpoint rule with 2, 4, ..., 16 steps, polynomial extrapolation in h^2),
//! or for a stiff step the linearly implicit rows of [`super::implicit`] (extrapolation
//! in h). The midpoint samples also show where a limit may be touched inside the
//! substep ([`super::events`]).

use std::cell::OnceCell;

use super::dormand_prince::{HighOrder, reach};
use super::events::{Interior, InteriorSearch};
use super::exponential::Exponential;
use super::implicit::IMPLICIT_SEQUENCE;
use super::{Events, Modes, SIZE, SlidingStep, UNEVALUATED, Vector, made_whole, retry_shorter};
use crate::physics::math;
use crate::physics::state_space::DrivingVector;

/// What lies ahead of a substep, which decides how it is taken ([`SlidingStep::substep`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Toward {
    /// No event predicted within it.
    NoEvent,
    /// It ends at a predicted event.
    Event,
    /// It ends at a predicted event within a small fraction of the longest substep.
    NearEvent,
}

/// The factor by which a substep is shortened where it did not reach the tolerance and
/// its method gives no estimate of its own, or where an event inside it could not be
/// located.
pub(super) const SHORTER: f64 = 0.25;

/// Midpoint substep counts of the extrapolation rows.
const SEQUENCE: [usize; 8] = [2, 4, 6, 8, 10, 12, 14, 16];

/// One row's end, where a limit may have been touched inside it (the first sample past
/// the tolerance, the sample closest to it), and its sample spacing.
pub(super) type Row = (Vector, Option<Interior>, Option<Interior>, f64);
/// A substep taken: its end, the factor by which the next may grow, where a limit may
/// have been touched inside it, and the spacing of the samples that found it.
pub(super) type Taken = (Vector, f64, Option<Interior>, f64);

/// What a substep knows of its end besides the state there. (On the stack for one
/// substep; boxing the stage's values would allocate.)
#[allow(clippy::large_enum_variant)]
pub(super) enum End {
    /// Nothing more: the end is to be evaluated.
    Unknown,
    /// Sampled with every group clear of its event (an exponential substep's `U3`).
    Clear,
    /// The rates and event values of Kutta's last stage ([`SlidingStep::short_substep`]),
    /// at a point within about the tolerance of the end.
    Staged(Vector, Events),
}
/// The largest size of `values`.
pub(super) fn largest_of(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, v| larger(m, v.abs()))
}

/// The larger of `largest` and `value` by a plain comparison, as `f64::max` for a
/// `largest` that is not NaN (a NaN `value` leaves it): `f64::max` orders NaN in five
/// instructions where this takes one, in loops that run every row.
#[inline]
pub(super) fn larger(largest: f64, value: f64) -> f64 {
    if value > largest { value } else { largest }
}

/// The most the linearly implicit rows' estimate before the accepted one may be, in
/// tolerances ([`SlidingStep::extrapolate`]).
const IMPLICIT_SETTLED: f64 = 16.0;

/// Relative accuracy of each substep.
pub(super) const TOLERANCE: f64 = 1e-12;
/// A few rounding units: the error floor relative to the largest entry.
pub(super) const ROUNDING: f64 = 16.0 * f64::EPSILON;

impl SlidingStep<'_> {
    /// The modified midpoint rule with `n` substeps over `[t, t + length]`. Also gives the
    /// first interior point (time from `t`, group, branch) where an event value is, or
    /// may be between samples, past the tolerance: a limit touched and left again within
    /// the substep shows there. Between samples, a parabola through three consecutive
    /// event values finds a peak the samples straddle. Also gives the sample closest to
    /// its limit (within [`NEAR_EVENT`]) and the sample spacing.
    fn midpoint(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        length: f64,
        n: usize,
        modes: &Modes,
    ) -> Row {
        let h = length / n as f64;
        let size = self.size();
        // The last two points, `z_m` at `m % 2`: each next point is made in place of the
        // one before the current, not copied along.
        let mut points = [*z, self.advanced(z, start_rates, h)];
        let mut search = InteriorSearch::new(start_events);
        for m in 1..n {
            let (rates, events) = self.rates(t + m as f64 * h, &points[m % 2], modes);
            search.sample(m, h, &events);
            // Over every entry, in pairs: the rates past the entries in use are zero, so
            // those entries stay as they are, and the loop has a known length.
            let before = &mut points[(m + 1) % 2];
            for (pair, rates) in before.chunks_exact_mut(2).zip(rates.chunks_exact(2)) {
                let moved = [pair[0] + 2.0 * h * rates[0], pair[1] + 2.0 * h * rates[1]];
                pair.copy_from_slice(&moved);
            }
        }
        let (current, previous) = (&points[n % 2], &points[(n + 1) % 2]);
        let (rates, _) = self.rates(t + length, current, modes);
        let mut out = [0.0; SIZE];
        for k in 0..size {
            out[k] = 0.5 * (current[k] + previous[k] + h * rates[k]);
        }
        let (interior, closest) = search.found();
        (out, interior, closest, h)
    }

    /// The end of a substep, without looking inside it for events: exponential where that
    /// is accurate ([`SlidingStep::exponential_suited`]), else extrapolated.
    pub(super) fn substep_plain(&self, t: f64, z: &Vector, length: f64, modes: &Modes) -> Option<Vector> {
        let (rates, events) = self.rates(t, z, modes);
        if self.exponential_suited()
            && let Exponential::Taken(end, _) = self.exponential_substep(
                t,
                z,
                (&rates, &events),
                (length, self.return_rates(t, z, modes).least),
                modes,
                false,
            )
        {
            return Some(end);
        }
        self.substep_by(t, z, (&rates, &events), length, modes, false)
            .map(|(z, _, _, _)| z)
    }

    /// A substep from `z` with its `start` rates and event values, by what lies ahead
    /// ([`Toward`]): its end, the factor by which the next substep may grow, where a limit
    /// may have been touched inside it and the spacing of the samples that found it; or
    /// the factor by which it is to be shorter if it did not reach the tolerance.
    ///
    /// - No predicted event: by exprb43 ([`super::exponential`]) where it is suited
    ///   ([`SlidingStep::exponential_suited`]) and no limit is near; where it is not (a
    ///   force that turns on its ellipse within the substep), by the eighth-order pair
    ///   ([`super::dormand_prince`]); otherwise extrapolated. A substep by either that
    ///   comes back too long is tried again shorter; a second miss in a row leaves the
    ///   rest of the step to the next method.
    /// - A predicted event: extrapolated, so that its samples and accurate intermediate
    ///   values locate it.
    /// - A near one (far shorter than the motion's time scales): by Kutta's third-order
    ///   step first ([`SlidingStep::short_substep`]), two evaluations where the midpoint
    ///   rows take six; those follow if it is not accurate.
    ///
    /// A stiff step's substeps are all linearly implicit. Also what is known of the
    /// substep's end ([`End`]).
    pub(super) fn substep(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        length: &mut f64,
        modes: &Modes,
        toward: Toward,
    ) -> Result<(Taken, End), f64> {
        let asked = *length;
        if !self.stiff.get() {
            match toward {
                Toward::NoEvent => {
                    // How fast the forces return to their ellipses: the exponential
                    // substep's turn and the pair's reach, made once for both.
                    let returns = OnceCell::new();
                    let returns = || *returns.get_or_init(|| self.return_rates(t, z, modes));
                    if self.exponential_suited() {
                        let turning = (asked, returns().least);
                        match self.exponential_substep(t, z, start, turning, modes, true) {
                            Exponential::Taken(end, growth) => {
                                self.exponential_misses.set(0);
                                return Ok(((end, growth, None, 0.5 * asked), End::Clear));
                            }
                            // Too long: tried again as long as its estimate says; a
                            // second miss in a row leaves the rest of the step to the
                            // other methods.
                            Exponential::TooLong(factor) => {
                                if let Some(shorter) = retry_shorter(
                                    &self.exponential_misses,
                                    &self.exponential_declined,
                                    factor,
                                ) {
                                    return Err(shorter);
                                }
                            }
                            Exponential::Turning => self.exponential_declined.set(true),
                            Exponential::NotSuited => {}
                        }
                    }
                    if self.high_order_suited() {
                        let tried = self.high_order_first_length(asked).min(reach(returns()));
                        match self.high_order_substep(t, z, start, tried, modes) {
                            HighOrder::Taken(end, growth, aimed_length) => {
                                self.high_order_misses.set(0);
                                let growth = self.high_order_substep_taken(tried, growth, aimed_length);
                                *length = tried;
                                return Ok(((end, growth, None, 0.5 * tried), End::Clear));
                            }
                            // Too long: tried again as long as its estimate says, by the
                            // pair again; a second miss in a row leaves the rest of the
                            // step to the extrapolation.
                            HighOrder::TooLong(factor) => {
                                if let Some(shorter) =
                                    retry_shorter(&self.high_order_misses, &self.high_order_declined, factor)
                                {
                                    *length = tried;
                                    return Err(shorter);
                                }
                            }
                            HighOrder::NotSuited => {}
                        }
                    }
                }
                Toward::NearEvent => {
                    if let Some((taken, (rates, events))) = self.short_substep(t, z, start, asked, modes) {
                        return Ok((taken, End::Staged(rates, events)));
                    }
                }
                _ => {}
            }
        }
        self.substep_by(t, z, start, asked, modes, true)
            .map(|taken| (taken, End::Unknown))
            .ok_or(SHORTER)
    }

    /// Whether a substep may be exponential: an explicit step (the linearly implicit one
    /// takes a stiff slide, whose phi-series would be long) with held driving inputs,
    /// none of whose exponential substeps came back too long.
    pub(super) fn exponential_suited(&self) -> bool {
        !self.stiff.get() && !self.exponential_declined.get() && self.input_rates == DrivingVector::zeros()
    }

    /// Whether a substep without a predicted event is tried by the eighth-order pair: an
    /// explicit step not suited to the exponential substep, none of whose substeps by
    /// the pair came back too long twice in a row.
    pub(super) fn high_order_suited(&self) -> bool {
        !self.stiff.get() && !self.exponential_suited() && !self.high_order_declined.get()
    }

    /// Kutta's third-order step over a short substep (a stick that ends within
    /// microseconds of the step's start, as a rising load makes every sliding branch do):
    /// stages at the start, the middle and the end; the midpoint rule's value, of second
    /// order, from the same middle stage, gives the error estimate. `None` if it is not
    /// within the tolerance. The middle stage samples the event values, as the
    /// extrapolated rows' stages do. (Explicit Euler extrapolation took three
    /// evaluations to the same order.) Also the last stage's rates and event values.
    fn short_substep(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        length: f64,
        modes: &Modes,
    ) -> Option<(Taken, (Vector, Events))> {
        let size = self.size();
        let mut search = InteriorSearch::new(start_events);
        let middle = self.advanced(z, start_rates, 0.5 * length);
        let mut middle_made = UNEVALUATED;
        self.rates_into(t + 0.5 * length, &middle, modes, &mut middle_made);
        let (middle_rates, middle_events) = &middle_made;
        search.sample(1, 0.5 * length, middle_events);
        let end = made_whole(|c| z[c] + length * (2.0 * middle_rates[c] - start_rates[c]));
        let (end_rates, end_events) = self.rates(t + length, &end, modes);
        let third =
            made_whole(|c| z[c] + length * (start_rates[c] + 4.0 * middle_rates[c] + end_rates[c]) / 6.0);
        let second = self.advanced(z, middle_rates, length);
        let error = self.error_ratio(z, &third, &second);
        let accurate = error <= 1.0 && third[..size].iter().all(|v| v.is_finite());
        if !accurate {
            return None;
        }
        // Error ~ length^4 (the value taken is an order better than the estimate): aim at
        // a third of the tolerance next time.
        let growth = 0.9 / (3.0 * error).max(1e-10).sqrt().sqrt();
        let (interior, closest) = search.found();
        Some((
            (third, growth.clamp(0.2, 4.0), interior.or(closest), 0.5 * length),
            (end_rates, end_events),
        ))
    }

    /// `n` steps of `s = length / n` over `[t, t + length]`, each moving the state by
    /// `change(s f(t_k, z_k))` (the linearly implicit step's solve), with where a limit
    /// may have been touched inside them (as the midpoint rows find it) and the sample
    /// spacing.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn stepped_row(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        length: f64,
        n: usize,
        modes: &Modes,
        change: impl Fn(Vector) -> Vector,
    ) -> Row {
        let (start_rates, start_events) = start;
        let s = length / n as f64;
        let size = self.size();
        let mut current = *z;
        let mut rates = *start_rates;
        let mut search = InteriorSearch::new(start_events);
        for k in 0..n {
            if k > 0 {
                let events;
                (rates, events) = self.rates(t + k as f64 * s, &current, modes);
                search.sample(k, s, &events);
            }
            for r in 0..size {
                rates[r] *= s;
            }
            let change = change(rates);
            for r in 0..size {
                current[r] += change[r];
            }
        }
        let (interior, closest) = search.found();
        (current, interior, closest, s)
    }

    /// The largest difference between two rows' extrapolated values, relative to the
    /// tolerance: of each entry and the deflection scale, and never below the rounding of
    /// the largest entry (an entry decaying to zero next to a velocity of metres per
    /// second cannot be resolved further). At most 1: accurate.
    pub(super) fn error_ratio(&self, z: &Vector, best: &Vector, previous: &Vector) -> f64 {
        let size = self.size();
        self.error_ratio_of(
            (&z[..size], &best[..size], &previous[..size]),
            largest_of(&z[..size]),
        )
    }

    /// [`SlidingStep::error_ratio`] over the entries given (from, best and previous), with
    /// the rounding floor of the largest entry `largest`.
    pub(super) fn error_ratio_of(&self, (z, best, previous): (&[f64], &[f64], &[f64]), largest: f64) -> f64 {
        let floor = ROUNDING * largest;
        (0..z.len())
            .map(|c| {
                (best[c] - previous[c]).abs()
                    / (TOLERANCE * (self.scale + larger(z[c].abs(), best[c].abs())) + floor)
            })
            .fold(0.0, larger)
    }

    /// One extrapolated substep by the method of the step ([`SlidingStep::stiff`]);
    /// `None` if it did not reach the tolerance. Also returns the factor by which the next
    /// substep may grow, the first interior point where an event value was past the
    /// tolerance (from the finest row) when `look_inside`, and that row's sample spacing.
    pub(super) fn substep_by(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        length: f64,
        modes: &Modes,
        look_inside: bool,
    ) -> Option<Taken> {
        if self.stiff.get() {
            let jacobian = self.jacobian(t, z, start.0, modes);
            self.extrapolate(z, &IMPLICIT_SEQUENCE, 1, look_inside, |n| {
                self.implicit_row(t, z, start, &jacobian, length, n, modes)
            })
        } else {
            self.extrapolate(z, &SEQUENCE, 2, look_inside, |n| {
                Some(self.midpoint(t, z, start, length, n, modes))
            })
        }
    }

    /// Polynomial extrapolation of the rows `row_of(n)` for the step counts `sequence`,
    /// whose errors expand in powers of `(length / n)^power`, until two rows agree to the
    /// tolerance; `None` if they do not, or as soon as their estimates stop falling.
    pub(super) fn extrapolate<const ROWS: usize>(
        &self,
        z: &Vector,
        sequence: &[usize; ROWS],
        power: i32,
        look_inside: bool,
        mut row_of: impl FnMut(usize) -> Option<Row>,
    ) -> Option<Taken> {
        let size = self.size();
        // From the second row on, its difference from the row below is taken as the
        // error: that difference is the error of the unextrapolated value, and the
        // extrapolated one taken is better by the method's order step (two for the
        // midpoint rule, one for the linearly implicit rows). So a short substep (the few
        // microseconds to an event) ends after 6 evaluations, not 12, and a quasi-steady
        // stiff slide after 3 linearly implicit steps, not 6.
        // The tableau's last row, overwritten in place as the next one is made.
        let mut table = [[0.0; SIZE]; ROWS];
        let mut previous_error = f64::INFINITY;
        for j in 0..ROWS {
            let (mut value, interior, closest, spacing) = row_of(sequence[j])?;
            for k in 1..=j {
                let ratio = (sequence[j] as f64 / sequence[j - k] as f64).powi(power) - 1.0;
                let below = &mut table[k - 1];
                for c in 0..size {
                    let next = value[c] + (value[c] - below[c]) / ratio;
                    below[c] = value[c];
                    value[c] = next;
                }
            }
            table[j] = value;
            if j >= 1 {
                let error = self.error_ratio(z, &table[j], &table[j - 1]);
                // The linearly implicit rows' estimates fall by a factor of about 20 a
                // row where they converge; one that drops within the tolerance from far
                // outside it (44.5 to 0.81) is a chance agreement, 1e-10 away from the
                // solution: the next row must confirm it.
                let settled =
                    power != 1 || previous_error <= IMPLICIT_SETTLED || previous_error.is_infinite();
                if error <= 1.0 && settled {
                    // Error ~ length^(power j + 1): aim at a third of the tolerance next
                    // time.
                    let order = power as usize * j + 1;
                    let mut growth = 0.9 * inverse_root((3.0 * error).max(1e-10), order);
                    // Linearly implicit rows that settle at the second leave the later
                    // ones to a longer substep. That estimate alone (order 2) sits at a
                    // third of the tolerance where the substeps stopped growing: a sliding
                    // RingBody whose ring weighs a few grams took substeps of 2.4e-10 s,
                    // each at 0.27 tolerances, and was refused after a million of them.
                    if power == 1 && j == 1 {
                        growth = growth.max(IMPLICIT_LEAST_GROWTH);
                    }
                    // A sample past or close to its limit: the caller maximises the
                    // accurate event value around it.
                    let interior = if look_inside { interior.or(closest) } else { None };
                    return Some((table[j], growth.clamp(0.2, 4.0), interior, spacing));
                }
                // Within their range of convergence the rows' estimates fall by a large
                // factor a row. One that does not even halve shows a substep too long for
                // them (a fast turn of a sliding force, a stiff slide's stall): a later
                // row could agree with its neighbour by chance, far from the solution. A
                // shorter substep.
                if error > 0.5 * previous_error {
                    return None;
                }
                previous_error = error;
            }
        }
        None
    }
}

/// The least growth after a substep whose linearly implicit rows settled at the second
/// ([`SlidingStep::extrapolate`]).
const IMPLICIT_LEAST_GROWTH: f64 = 2.0;

/// `x^(-1/order)`: by square roots for the orders a quasi-steady slide's substeps end
/// with (a power would cost several times more).
fn inverse_root(x: f64, order: usize) -> f64 {
    match order {
        2 => x.sqrt().recip(),
        4 => x.sqrt().sqrt().recip(),
        _ => math::powf(x, -1.0 / order as f64),
    }
}
