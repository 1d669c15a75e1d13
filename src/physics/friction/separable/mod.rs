//! A step with sliding where every branch moves on its own: each element's state is
//! driven by the inputs alone and has no damper (RLT), and the driving inputs are held.
//! Branch `i` of the friction ellipse is then a small hybrid system of its own, stepped
//! exactly, independently of the other branches.
//!
//! - **Stick**: each member follows the model, `db/dt = g - a b` (`g` from the held
//!   inputs, `a` the relaxation rate): `b(t) = b0 + t phi1(-a t) (g - a b0)`, exact.
//! - **Slide**: the force stays on the ellipse, `b = (P cos theta, Q sin theta)`; the angle
//!   follows a scalar autonomous flow (`ellipse.rs`), integrated by exponential Rosenbrock
//!   steps ([`exponential`]), exact for its linearisation at any stiffness and accurate to
//!   1e-12. With one member (the other direction frictionless) the force is held on its
//!   limit.
//! - **Guards**: stick to slide where the utilisation reaches 1, the first root of a sum of
//!   exponentials after the pieces its ends exclude (each member moves monotonically);
//!   slide to stick where the slider would move inward (the outward cosine turns
//!   negative), located in time.
//! - **Reset**: a branch that reaches its ellipse is put on it exactly.
//!
//! The modes are decided from the states at the start of each step, as on the general
//! path ([`super::sliding`]), which takes any step this one gives up (more mode changes
//! than a step should have).

// Members and branches index several arrays together.
#![allow(clippy::needless_range_loop)]
mod ellipse;
pub mod exponential;

use super::{Direction, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::state_space::{DrivingVector, StateSpace, StateVector};
use ellipse::EllipseBranch;
use exponential::{Outcome, integrate};

/// An event value above this has crossed (as on the general path).
const EVENT_TOLERANCE: f64 = 1e-12;
/// Absolute error of the angle per integration step, rad (the relative error of the
/// force on the ellipse).
const ANGLE_TOLERANCE: f64 = 1e-12;
/// Mode changes of one branch within a step before it goes to the general path.
const MAX_CHANGES: usize = 12;
/// Integration steps of one sliding piece before it goes to the general path.
const MAX_ANGLE_STEPS: usize = 5_000;
/// Pieces a sticking interval is split into, at most, to find its first contact.
const MAX_PIECES: usize = 200;

/// The members of the ellipse, by [`Direction`]: longitudinal and lateral.
const MEMBERS: [Direction; 2] = [Direction::Longitudinal, Direction::Lateral];

/// The branches of one step at its operating point, limits and held inputs.
pub struct SeparableStep {
    branches: [EllipseBranch; MAX_BRANCHES],
    weights: [f64; MAX_BRANCHES],
    branch_count: usize,
    /// The model state of each member's element, if it has one.
    states: [Option<usize>; 2],
    /// Whether each member has a limit (a frictionless direction carries no force: its
    /// branch deflections stay zero).
    active: [bool; 2],
}

impl SeparableStep {
    /// `None` unless every branch of this model moves on its own ([`Friction::separable`]).
    pub fn new(
        system: &StateSpace,
        friction: &Friction,
        limits: &Limits,
        inputs: &DrivingVector,
    ) -> Option<Self> {
        if !friction.separable(system.states) {
            return None;
        }
        let mut step = SeparableStep {
            branches: [EllipseBranch::default(); MAX_BRANCHES],
            weights: [0.0; MAX_BRANCHES],
            branch_count: friction.branches.len(),
            states: [None; 2],
            active: [false; 2],
        };
        // By branch and member: K, L, a, g.
        let mut constants = [[[0.0; 2]; 4]; MAX_BRANCHES];
        for (m, direction) in MEMBERS.into_iter().enumerate() {
            let d = direction as usize;
            let Some(element) = friction.elements[d] else {
                continue;
            };
            let k = element.state;
            step.states[m] = Some(k);
            step.active[m] = limits.0[d] > 0.0;
            let drive: f64 = (0..inputs.len()).map(|j| system.b[(k, j)] * inputs[j]).sum();
            for (i, branch) in friction.branches.iter().enumerate() {
                step.weights[i] = branch.stiffness_fraction;
                let [stiffness, limit, relaxation, rate] = &mut constants[i];
                // An inactive member: no force, no motion, outside every sum.
                (stiffness[m], limit[m], relaxation[m], rate[m]) = if step.active[m] {
                    (
                        branch.stiffness_fraction * element.stiffness,
                        branch.limit_fraction * limits.0[d],
                        -system.a[(k, k)],
                        drive,
                    )
                } else {
                    (1.0, f64::INFINITY, 0.0, 0.0)
                };
            }
        }
        for (branch, [stiffness, limit, relaxation, drive]) in step.branches.iter_mut().zip(constants) {
            *branch = EllipseBranch::new(stiffness, limit, relaxation, drive);
        }
        Some(step)
    }

    /// The states and branches at the end of a step of `h` seconds from `x` and `sliders`;
    /// `None` if a branch changes mode more often than a step should, grazes its limit
    /// too finely to decide, or its angle's steps shrink to nothing (the general path then
    /// takes the step).
    pub fn step(&self, x: &StateVector, sliders: &SliderState, h: f64) -> Option<(StateVector, SliderState)> {
        let mut end_states = *x;
        let mut end_sliders = *sliders;
        let mut deflections = [[0.0; 2]; MAX_BRANCHES];
        for (i, deflection) in deflections.iter_mut().enumerate().take(self.branch_count) {
            let mut b = [0.0; 2];
            for (m, direction) in MEMBERS.into_iter().enumerate() {
                if let (Some(k), true) = (self.states[m], self.active[m]) {
                    b[m] = x[k] + sliders.offsets[direction as usize][i];
                }
            }
            let (end, sliding) = self.branch_step(&self.branches[i], b, h)?;
            *deflection = end;
            end_sliders.sliding[Group::Planar as usize][i] = sliding;
        }
        for (m, direction) in MEMBERS.into_iter().enumerate() {
            let Some(k) = self.states[m] else { continue };
            let element_state: f64 = (0..self.branch_count)
                .map(|i| self.weights[i] * deflections[i][m])
                .sum();
            end_states[k] = element_state;
            for i in 0..self.branch_count {
                end_sliders.offsets[direction as usize][i] = deflections[i][m] - element_state;
            }
        }
        Some((end_states, end_sliders))
    }

    /// One branch over the step from deflections `b`: its end and whether it slides there.
    fn branch_step(&self, branch: &EllipseBranch, mut b: [f64; 2], h: f64) -> Option<([f64; 2], bool)> {
        if !self.active.contains(&true) {
            return Some(([0.0; 2], false));
        }
        // The mode at the start: a force outside the ellipse (the load fell) is put on it.
        let utilisation = branch.utilisation(b);
        if utilisation > 1.0 {
            b = scaled(b, utilisation);
        }
        let mut sliding = utilisation >= 1.0 - EVENT_TOLERANCE && branch.outward_cosine(b) > 0.0;
        let mut t = 0.0;
        for _ in 0..MAX_CHANGES {
            let left = h - t;
            if left <= 0.0 {
                return Some((b, sliding));
            }
            if !sliding {
                let (elapsed, at) = match first_contact(branch, b, left) {
                    Contact::None => return Some((sticking(branch, b, left), false)),
                    Contact::Undecided => return None,
                    Contact::At(elapsed, at) => (elapsed, at),
                };
                b = scaled(at, branch.utilisation(at));
                t += elapsed;
                sliding = branch.outward_cosine(b) > 0.0;
            } else if self.active == [true, true] {
                let outward = |at: &exponential::Angle| branch.outward_cosine(branch.on_ellipse(at));
                let outcome = integrate(
                    &branch.flow(),
                    branch.angle_of(b),
                    left,
                    ANGLE_TOLERANCE,
                    (&outward, EVENT_TOLERANCE),
                    MAX_ANGLE_STEPS,
                )?;
                match outcome {
                    Outcome::End(at) => return Some((branch.on_ellipse(&at), true)),
                    Outcome::Event(elapsed, at) => {
                        b = branch.on_ellipse(&at);
                        t += elapsed;
                        sliding = false;
                    }
                }
            } else {
                // One member on its limit: its outward motion does not change under held
                // inputs, so it slides to the end of the step.
                return Some((b, true));
            }
        }
        None
    }
}

/// Deflections with `utilisation` scaled onto the ellipse.
fn scaled(b: [f64; 2], utilisation: f64) -> [f64; 2] {
    let shrink = utilisation.sqrt().recip();
    [b[0] * shrink, b[1] * shrink]
}

/// `e^z - 1` and `(e^z - 1)/z`: by their series for the small `z` of a sticking piece of
/// microseconds (the terms left out are below 1e-19), by the library's function beyond.
fn exp_m1_and_phi1(z: f64) -> (f64, f64) {
    if z.abs() < 0.01 {
        // 1/(k + 1)! for k = 0..7; four terms below 1e-4.
        const C: [f64; 8] = [
            1.0,
            0.5,
            1.0 / 6.0,
            1.0 / 24.0,
            1.0 / 120.0,
            1.0 / 720.0,
            1.0 / 5040.0,
            1.0 / 40320.0,
        ];
        let terms = if z.abs() < 1e-4 { 4 } else { C.len() };
        let phi1 = C[..terms].iter().rev().fold(0.0, |sum, c| sum * z + c);
        (z * phi1, phi1)
    } else {
        let change = z.exp_m1();
        (change, change / z)
    }
}

/// The deflections after sticking for `t` seconds from `b`.
fn sticking(branch: &EllipseBranch, b: [f64; 2], t: f64) -> [f64; 2] {
    let r = branch.sticking_rate(b);
    let mut end = b;
    for k in 0..2 {
        end[k] += t * exp_m1_and_phi1(-branch.relaxation[k] * t).1 * r[k];
    }
    end
}

/// Whether a sticking branch reaches its ellipse within a time.
enum Contact {
    None,
    /// The time, and the deflections there.
    At(f64, [f64; 2]),
    /// A graze too fine to decide within [`MAX_PIECES`] pieces.
    Undecided,
}

/// Where a branch sticking from `b` first reaches its ellipse within `length` seconds:
/// the time and its deflections there (just past the ellipse, by half the event
/// tolerance). Each member and its rate move monotonically, so over a piece of time each
/// is bounded by its values at the two ends, and so are the utilisation and its rate. The
/// search marches from the start: a piece whose bound stays inside is passed (and the next
/// one tried twice as long), one that may reach the limit is halved, until one ends
/// outside with the utilisation rising throughout, where it has one root.
fn first_contact(branch: &EllipseBranch, b: [f64; 2], length: f64) -> Contact {
    let r = branch.sticking_rate(b);
    let weight = branch.inverse_travel_squared;
    let excess = |d: &[f64; 2]| d[0] * d[0] * weight[0] + d[1] * d[1] * weight[1] - 1.0;
    let sample = |t: f64| {
        let mut sample = Sample {
            t,
            deflection: b,
            rate: r,
            excess: 0.0,
        };
        for k in 0..2 {
            // b + t phi1(-a t) r and e^(-a t) r from one exponential.
            let (change, phi1) = exp_m1_and_phi1(-branch.relaxation[k] * t);
            sample.deflection[k] += t * phi1 * r[k];
            sample.rate[k] += change * r[k];
        }
        sample.excess = excess(&sample.deflection);
        sample
    };
    let mut left = sample(0.0);
    let mut right = sample(length);
    for _ in 0..MAX_PIECES {
        let (largest, slowest) = piece_bound(&left, &right, &weight);
        let width = right.t - left.t;
        if largest <= EVENT_TOLERANCE {
            if right.t >= length {
                return Contact::None;
            }
            left = right;
            right = sample((left.t + 2.0 * width).min(length));
            continue;
        }
        // Rising throughout: one root.
        let outside = right.excess > EVENT_TOLERANCE;
        if outside && (slowest > 0.0 || width <= 1e-12 * length) {
            let (t, d) = root_of_excess(sample, &weight, (left, right));
            return Contact::At(t, d);
        }
        if width <= 1e-12 * length {
            // A graze within rounding of the limit: pass it.
            left = right;
            right = sample((left.t + 1e6 * width).min(length));
            continue;
        }
        right = sample(left.t + 0.5 * width);
    }
    Contact::Undecided
}

/// A sticking branch at a time: its deflections, their rates, and its utilisation - 1.
#[derive(Clone, Copy, Debug, Default)]
struct Sample {
    t: f64,
    deflection: [f64; 2],
    rate: [f64; 2],
    excess: f64,
}

/// The rate of a sticking branch's utilisation, `2 sum b b' / P^2`.
fn utilisation_rate(at: &Sample, weight: &[f64; 2]) -> f64 {
    2.0 * (weight[0] * at.deflection[0] * at.rate[0] + weight[1] * at.deflection[1] * at.rate[1])
}

/// The largest utilisation excess a sticking branch can reach between two samples, and a
/// lower bound of its rate there (`weight`: `1 / P^2` by member).
fn piece_bound(left: &Sample, right: &Sample, weight: &[f64; 2]) -> (f64, f64) {
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
        // The highest a function with rates in [slowest, fastest] through both ends reaches.
        let reach = ((e2 - e1 - slowest * width) / (fastest - slowest)).clamp(0.0, width);
        e1 + fastest * reach
    };
    (by_size.min(by_rate), slowest)
}

/// The time between two samples of a sticking branch where its utilisation crosses
/// `1 + EVENT_TOLERANCE / 2`, rising monotonically, by Newton's method kept inside the
/// bracket; with the deflections there.
fn root_of_excess(
    sample: impl Fn(f64) -> Sample,
    weight: &[f64; 2],
    (mut low, mut high): (Sample, Sample),
) -> (f64, [f64; 2]) {
    let target = 0.5 * EVENT_TOLERANCE;
    // A first guess by Newton's method from the start of the piece, if inside it, else by
    // the secant of its ends.
    let (low_value, high_value) = (low.excess - target, high.excess - target);
    let from_start = low.t - low_value / utilisation_rate(&low, weight);
    let mut t = if from_start > low.t && from_start < high.t {
        from_start
    } else if high_value > low_value {
        low.t - low_value * (high.t - low.t) / (high_value - low_value)
    } else {
        high.t
    };
    for _ in 0..60 {
        let at = sample(t);
        let value = at.excess - target;
        // Within a quarter of the tolerance of its middle: far enough from rounding.
        if value.abs() <= 0.5 * target {
            return (t, at.deflection);
        }
        if value > 0.0 {
            high = at;
        } else {
            low = at;
        }
        if high.t - low.t <= 1e-15 * high.t {
            break;
        }
        let rate = utilisation_rate(&at, weight);
        let (next, rising) = (t - value / rate, rate > 0.0);
        t = if rising && next > low.t && next < high.t {
            next
        } else {
            0.5 * (low.t + high.t)
        };
    }
    (high.t, high.deflection)
}

#[cfg(test)]
mod tests;
