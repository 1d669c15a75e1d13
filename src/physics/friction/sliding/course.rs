//! The course of a spring-damper group's event value over one explicit substep of the
//! cascade, from what the substep already has: the values at its start, at its stage (a
//! fraction `c` on) and at its end, and the rates at its ends (the group's trial force
//! moves with the deflections' rates there). In the substep's own time `s` in `[0, 1]`:
//!
//! - the cubic `P` with the ends' values and rates (Hermite's), and the quartic
//!   `Q = P + k s^2 (1 - s)^2` through the stage's value too, whose last term is the part
//!   of the course the ends do not show;
//! - where the group nears its event but no sample is past it, it stays clear where the
//!   quartic with that part doubled (or dropped, where it is negative) stays at most at
//!   the event tolerance over the whole substep: its largest value, found exactly at the
//!   ends and at the roots of its slope;
//! - where a sample is past the event, the quartic's first crossing is where the search
//!   for the crossing on the substep itself starts ([`crossing_search`]).

use crate::physics::friction::EVENT_TOLERANCE;

/// A group's event value over a substep: at its start, its stage and its end, and the
/// rates at its ends times the substep's length.
#[derive(Clone, Copy, Debug)]
pub(super) struct Course {
    /// `Q`'s coefficients of `s^0` to `s^4`.
    quartic: [f64; 5],
    /// The part the ends do not show, `k` (the coefficient of `s^2 (1 - s)^2`).
    hidden: f64,
}

/// `s^2 (1 - s)^2` by powers of `s`.
const BUMP: [f64; 5] = [0.0, 0.0, 1.0, -2.0, 1.0];

impl Course {
    /// From the values `start`, `stage` (at the fraction `c` on) and `end`, and the rates
    /// `start_rate` and `end_rate` times the substep's length.
    pub(super) fn new(
        (start, start_rate): (f64, f64),
        (c, stage): (f64, f64),
        (end, end_rate): (f64, f64),
    ) -> Self {
        let mut quartic = [
            start,
            start_rate,
            -3.0 * start - 2.0 * start_rate + 3.0 * end - end_rate,
            2.0 * start + start_rate - 2.0 * end + end_rate,
            0.0,
        ];
        let hidden = (stage - value(&quartic, c)) / value(&BUMP, c);
        for (coefficient, bump) in quartic.iter_mut().zip(BUMP) {
            *coefficient += hidden * bump;
        }
        Course { quartic, hidden }
    }

    /// The quartic with its hidden part doubled where it is positive, dropped where it is
    /// negative: above the course wherever that part is right to within a factor of two.
    fn bound(&self) -> [f64; 5] {
        let mut bound = self.quartic;
        for (coefficient, bump) in bound.iter_mut().zip(BUMP) {
            *coefficient += self.hidden.abs() * bump;
        }
        bound
    }

    /// Whether the group stays in its mode over the substep: the bound's largest value
    /// on `[0, 1]` at most the event tolerance (and not a NaN).
    pub(super) fn stays(&self) -> bool {
        largest(&self.bound()) <= EVENT_TOLERANCE
    }

    /// Where the quartic first reaches `level` within `[0, until]`, the substep's
    /// fraction (`until` where it does not).
    pub(super) fn first_reaching(&self, level: f64, until: f64) -> f64 {
        let q = &self.quartic;
        let below = |s: f64| value(q, s) < level;
        // Its course is monotone between the roots of its slope: the first piece whose
        // end is at the level holds the crossing.
        let mut pieces = [0.0, until, until, until, until];
        let slope_roots = slope_roots(q);
        let mut count = 1;
        for root in slope_roots.into_iter().flatten() {
            if root > 0.0 && root < until {
                pieces[count] = root;
                count += 1;
            }
        }
        pieces[count] = until;
        pieces[1..=count].sort_by(f64::total_cmp);
        for piece in pieces[..=count].windows(2) {
            let (lo, hi) = (piece[0], piece[1]);
            if below(lo) && !below(hi) {
                return bisect(lo, hi, |s| !below(s));
            }
        }
        until
    }
}

/// Substeps a search for a driven group's crossing may take ([`crossing_search`]).
const CROSSING_SEARCH_STEPS: usize = 24;

/// Where `event(s)` (a driven group's event value at the end of a substep the fraction `s`
/// of the full one, with what that substep made) first crosses its event, within the
/// event tolerance past it: from `start` (the value at `s = 0`, below half the tolerance)
/// and the first sample `past` it (its fraction and value), by the Illinois method from
/// `guess` (the course's). `None` where the search does not settle or a substep gives up.
pub(super) fn crossing_search<T>(
    mut event: impl FnMut(f64) -> Option<(f64, T)>,
    start: f64,
    past: (f64, f64),
    guess: f64,
) -> Option<(f64, T)> {
    let aim = 0.5 * EVENT_TOLERANCE;
    let (mut lo, mut below) = (0.0, start - aim);
    let (mut hi, mut above) = past;
    above -= aim;
    let mut s = if guess > lo && guess < hi {
        guess
    } else {
        0.5 * (lo + hi)
    };
    // Which end moved last (-1 the lower, 1 the upper): the other's value is halved when
    // the same end moves twice (Illinois), so the bracket shrinks from both sides.
    let mut last = 0;
    for _ in 0..CROSSING_SEARCH_STEPS {
        let (value, made) = event(s)?;
        let off = value - aim;
        if off.abs() <= aim {
            return Some((s, made));
        }
        if off < 0.0 {
            (lo, below) = (s, off);
            if last == -1 {
                above *= 0.5;
            }
            last = -1;
        } else if off > 0.0 {
            (hi, above) = (s, off);
            if last == 1 {
                below *= 0.5;
            }
            last = 1;
        } else {
            return None;
        }
        s = (lo * above - hi * below) / (above - below);
        if !(s > lo && s < hi) {
            s = 0.5 * (lo + hi);
        }
    }
    None
}

/// `sum c_j s^j`.
fn value(coefficients: &[f64; 5], s: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |sum, &c| sum * s + c)
}

/// The slope of `sum c_j s^j`.
fn slope(coefficients: &[f64; 5], s: f64) -> f64 {
    let c = coefficients;
    ((4.0 * c[4] * s + 3.0 * c[3]) * s + 2.0 * c[2]) * s + c[1]
}

/// The largest value of the quartic on `[0, 1]`: at an end, or at a root of its slope,
/// which is monotone between the roots of its curvature (a quadratic).
fn largest(coefficients: &[f64; 5]) -> f64 {
    let mut largest = value(coefficients, 0.0).max(value(coefficients, 1.0));
    for root in slope_roots(coefficients).into_iter().flatten() {
        if (0.0..=1.0).contains(&root) {
            largest = largest.max(value(coefficients, root));
        }
    }
    if coefficients.iter().any(|c| c.is_nan()) {
        return f64::NAN;
    }
    largest
}

/// The roots of the quartic's slope (a cubic) in `[0, 1]`: on each piece between the
/// roots of its curvature the slope is monotone, so a change of sign there is one root.
fn slope_roots(coefficients: &[f64; 5]) -> [Option<f64>; 3] {
    let c = coefficients;
    // The curvature `12 c4 s^2 + 6 c3 s + 2 c2`.
    let (a, b, q) = (12.0 * c[4], 6.0 * c[3], 2.0 * c[2]);
    let mut ends = [0.0, 1.0, 1.0, 1.0];
    let mut count = 1;
    let mut add = |root: f64| {
        if root > 0.0 && root < 1.0 {
            ends[count] = root;
            count += 1;
        }
    };
    if a == 0.0 {
        if b != 0.0 {
            add(-q / b);
        }
    } else {
        let discriminant = b * b - 4.0 * a * q;
        if discriminant >= 0.0 {
            // The root of larger size without cancellation, the other from their product
            // (`q / a`): near `a = 0` the textbook form loses one of them.
            let large = -0.5 * (b + discriminant.sqrt().copysign(b));
            add(large / a);
            if large != 0.0 {
                add(q / large);
            }
        }
    }
    ends[count] = 1.0;
    ends[1..=count].sort_by(f64::total_cmp);
    let mut roots = [None; 3];
    for (piece, root) in ends[..=count].windows(2).zip(&mut roots) {
        let (lo, hi) = (piece[0], piece[1]);
        let (at_lo, at_hi) = (slope(c, lo), slope(c, hi));
        if (at_lo > 0.0) != (at_hi > 0.0) {
            *root = Some(bisect(lo, hi, |s| (slope(c, s) > 0.0) == (at_hi > 0.0)));
        }
    }
    roots
}

/// The point of `[lo, hi]` where `after` turns true (false at `lo`, true at `hi`), to
/// rounding.
fn bisect(mut lo: f64, mut hi: f64, after: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..64 {
        let middle = 0.5 * (lo + hi);
        if middle <= lo || middle >= hi {
            break;
        }
        if after(middle) {
            hi = middle;
        } else {
            lo = middle;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The course of `e(s)` sampled as a substep samples it (at the ends with rates, and
    /// at the stage `c`).
    fn course_of(e: impl Fn(f64) -> f64, rate: impl Fn(f64) -> f64, c: f64) -> Course {
        Course::new((e(0.0), rate(0.0)), (c, e(c)), (e(1.0), rate(1.0)))
    }

    #[test]
    fn a_quartic_course_is_its_own_quartic() {
        let e = |s: f64| -1e-3 + 2e-3 * s - 5e-3 * s * s + 1e-3 * s.powi(3) + 4e-4 * s.powi(4);
        let rate = |s: f64| 2e-3 - 1e-2 * s + 3e-3 * s * s + 1.6e-3 * s.powi(3);
        let course = course_of(e, rate, 0.75);
        for j in 0..=10 {
            let s = f64::from(j) / 10.0;
            assert!((value(&course.quartic, s) - e(s)).abs() < 1e-15, "{s}");
        }
    }

    /// A group leaving its limit (just inside it at the start, moving away) stays; one
    /// that rises to just past it inside the substep and falls back does not, though
    /// every sample is inside; one far inside stays.
    #[test]
    fn a_touch_between_samples_shows() {
        let leaving = course_of(|s| -0.4e-12 - 1e-3 * s, |_| -1e-3, 0.75);
        assert!(leaving.stays());
        let touching = |s: f64| -1e-4 + 6e-4 * s * (1.0 - s) - 1e-4 * s;
        let touching_rate = |s: f64| 6e-4 * (1.0 - 2.0 * s) - 1e-4;
        assert!(touching(0.75) < 0.0 && touching(1.0) < 0.0);
        assert!(!course_of(touching, touching_rate, 0.75).stays());
        let far = course_of(|s| -0.5 + 0.1 * s * s, |s| 0.2 * s, 0.5);
        assert!(far.stays());
    }

    /// The search ends within the event tolerance past the event, from a poor guess too,
    /// and gives up where the value never crosses.
    #[test]
    fn the_search_ends_just_past_the_event() {
        let e = |s: f64| -2e-3 + 1e-2 * s * s * s + 1e-3 * s;
        for guess in [0.3, 0.9, 2.0] {
            let (s, value) =
                crossing_search(|s| Some((e(s), e(s))), e(0.0), (1.0, e(1.0)), guess).expect("found");
            assert!((0.0..=EVENT_TOLERANCE).contains(&value), "{guess}: {s} {value}");
        }
        let never = |s: f64| -1.0 + 0.0 * s;
        assert!(crossing_search(|s| Some((never(s), ())), -1.0, (1.0, -0.5), 0.5).is_none());
    }

    #[test]
    fn the_first_crossing_of_a_rising_course() {
        let e = |s: f64| -1e-3 + 3e-3 * s * s;
        let course = course_of(e, |s| 6e-3 * s, 0.5);
        let at = course.first_reaching(0.0, 1.0);
        assert!((at - (1.0f64 / 3.0).sqrt()).abs() < 1e-12, "{at}");
        assert_eq!(course.first_reaching(1.0, 1.0), 1.0);
    }
}
