//! A branch that sticks: each member follows its own equation `db/dt = g - a b` exactly,
//! and the first time the branch reaches its ellipse is found.

use super::ellipse::EllipseBranch;
use crate::physics::friction::EVENT_TOLERANCE;
use crate::physics::stepper::phi::scalar_phi_functions;

/// Pieces a sticking interval is split into, at most, to find its first contact.
const MAX_PIECES: usize = 200;

/// A branch sticking from its deflections at the start of a piece.
pub struct StickingMotion<'a> {
    branch: &'a EllipseBranch,
    start: [f64; 2],
    /// The sticking rate at the start, `g - a b0`.
    start_rate: [f64; 2],
}

/// A sticking branch at a time: its deflections, their rates, and its utilisation - 1.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sample {
    pub t: f64,
    pub deflection: [f64; 2],
    rate: [f64; 2],
    excess: f64,
}

/// Whether a sticking branch reaches its ellipse within a time.
pub enum Contact {
    /// It does not: the branch where the time ends.
    None(Sample),
    /// Where it does: just past the ellipse, by half the event tolerance.
    At(Sample),
    /// A graze too fine to decide within [`MAX_PIECES`] pieces.
    Undecided,
}

impl<'a> StickingMotion<'a> {
    pub fn new(branch: &'a EllipseBranch, start: [f64; 2]) -> Self {
        StickingMotion {
            branch,
            start,
            start_rate: branch.sticking_rate(start),
        }
    }

    /// The branch `t` seconds on: `b = b0 + t phi1(-a t) r0`, `db/dt = e^(-a t) r0`.
    pub fn at(&self, t: f64) -> Sample {
        let mut sample = Sample {
            t,
            deflection: self.start,
            ..Sample::default()
        };
        for k in 0..2 {
            let (decay, phi1, _) = scalar_phi_functions(-self.branch.relaxation[k] * t);
            sample.deflection[k] += t * phi1 * self.start_rate[k];
            sample.rate[k] = decay * self.start_rate[k];
        }
        sample.excess = self.branch.utilisation(sample.deflection) - 1.0;
        sample
    }

    /// The branch where it starts, as [`StickingMotion::at`] gives it at `t = 0`.
    fn at_start(&self) -> Sample {
        Sample {
            t: 0.0,
            deflection: self.start,
            rate: self.start_rate,
            excess: self.branch.utilisation(self.start) - 1.0,
        }
    }

    /// The rate of the utilisation, `2 sum b b' / P^2`.
    fn utilisation_rate(&self, at: &Sample) -> f64 {
        let weight = &self.branch.inverse_travel_squared;
        2.0 * (weight[0] * at.deflection[0] * at.rate[0] + weight[1] * at.deflection[1] * at.rate[1])
    }

    /// Where the branch first reaches its ellipse within `length` seconds. Each member and
    /// its rate move monotonically, so over a piece of time each is bounded by its values
    /// at the two ends, and so are the utilisation and its rate. The search marches from
    /// the start: a piece whose bound stays inside is passed (and the next one tried twice
    /// as long), one that may reach the limit is halved, until one ends outside with the
    /// utilisation rising throughout, where it has one root.
    pub fn first_contact(&self, length: f64) -> Contact {
        let mut left = self.at_start();
        let mut right = self.at(length);
        for _ in 0..MAX_PIECES {
            let (largest, slowest) = self.piece_bound(&left, &right);
            let width = right.t - left.t;
            if largest <= EVENT_TOLERANCE {
                if right.t >= length {
                    return Contact::None(right);
                }
                left = right;
                right = self.at((left.t + 2.0 * width).min(length));
                continue;
            }
            let outside = right.excess > EVENT_TOLERANCE;
            if outside && (slowest > 0.0 || width <= 1e-12 * length) {
                return Contact::At(self.root(left, right));
            }
            if width <= 1e-12 * length {
                // A graze within rounding of the limit: pass it, and go on with a piece
                // as long as the search is fine.
                left = right;
                right = self.at((left.t + 1e6 * width).min(length));
                continue;
            }
            right = self.at(left.t + 0.5 * width);
        }
        Contact::Undecided
    }

    /// The largest utilisation excess the branch can reach between two samples, and a
    /// lower bound of its rate there.
    fn piece_bound(&self, left: &Sample, right: &Sample) -> (f64, f64) {
        let weight = &self.branch.inverse_travel_squared;
        let (d1, d2, r1, r2) = (&left.deflection, &right.deflection, &left.rate, &right.rate);
        // By the sizes at the ends.
        let mut by_size = -1.0;
        // By the range of the rate 2 sum b b' / P^2, each product between its corners.
        let (mut fastest, mut slowest) = (0.0, 0.0);
        for k in 0..2 {
            by_size += (d1[k] * d1[k]).max(d2[k] * d2[k]) * weight[k];
            let (a, b, c, d) = (d1[k] * r1[k], d1[k] * r2[k], d2[k] * r1[k], d2[k] * r2[k]);
            fastest += 2.0 * weight[k] * a.max(b).max(c).max(d);
            slowest += 2.0 * weight[k] * a.min(b).min(c).min(d);
        }
        let (e1, e2, width) = (left.excess, right.excess, right.t - left.t);
        let by_rate = if fastest <= 0.0 {
            e1
        } else if slowest >= 0.0 {
            e2
        } else {
            // The highest a function with rates in [slowest, fastest] through both ends
            // reaches.
            let reach = ((e2 - e1 - slowest * width) / (fastest - slowest)).clamp(0.0, width);
            e1 + fastest * reach
        };
        (by_size.min(by_rate), slowest)
    }

    /// Where the utilisation crosses `1 + EVENT_TOLERANCE / 2` between two samples, rising
    /// monotonically, by Newton's method kept inside the bracket.
    fn root(&self, mut low: Sample, mut high: Sample) -> Sample {
        let target = 0.5 * EVENT_TOLERANCE;
        // A first guess by Newton's method from the start of the piece, if inside it, else
        // by the secant of its ends.
        let (low_value, high_value) = (low.excess - target, high.excess - target);
        let from_start = low.t - low_value / self.utilisation_rate(&low);
        let mut t = if from_start > low.t && from_start < high.t {
            from_start
        } else if high_value > low_value {
            low.t - low_value * (high.t - low.t) / (high_value - low_value)
        } else {
            high.t
        };
        for _ in 0..60 {
            let at = self.at(t);
            let value = at.excess - target;
            // Within a quarter of the tolerance of its middle: far enough from rounding.
            if value.abs() <= 0.5 * target {
                return at;
            }
            if value > 0.0 {
                high = at;
            } else {
                low = at;
            }
            if high.t - low.t <= 1e-15 * high.t {
                break;
            }
            let rate = self.utilisation_rate(&at);
            let next = t - value / rate;
            t = if rate > 0.0 && next > low.t && next < high.t {
                next
            } else {
                0.5 * (low.t + high.t)
            };
        }
        high
    }
}
