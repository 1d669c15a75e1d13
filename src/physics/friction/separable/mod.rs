//! A step with sliding where every branch moves on its own: each element's state is
//! driven by the inputs alone and has no damper (RLT), and the driving inputs are held.
//! Branch `i` of the friction ellipse is then a small hybrid system of its own, stepped
//! exactly, independently of the other branches.
//!
//! - **Stick** ([`sticking`]): each member follows the model, `db/dt = g - a b` (`g` from
//!   the held inputs, `a` the relaxation rate): `b(t) = b0 + t phi1(-a t) (g - a b0)`, exact.
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
//!
//! A step is split in two. The usual case first, every branch side by side
//! ([`SeparableStep::step_together`]): a branch sticks throughout, or slides to the end of
//! the step, from its start or from its first contact, with one angle step; those angle
//! steps are taken stage by stage across the branches, so that their divisions overlap.
//! Then each branch that needs more (a shorter angle step, a slide that ends) by itself
//! ([`SeparableStep::branch_step`]), which gives the same values for the usual case.

// Members and branches index several arrays together.
#![allow(clippy::needless_range_loop)]
mod ellipse;
pub mod exponential;
mod sticking;

use super::{Direction, EVENT_TOLERANCE, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::brush::Branch;
use crate::physics::state_space::{DrivingVector, StateSpace, StateVector};
use ellipse::{EllipseBranch, EllipseFlow};
use exponential::{Angle, FirstStep, Outcome, first_steps_together, integrate};
use sticking::{Contact, StickingMotion};
/// Absolute error of the angle per integration step, rad (the relative error of the
/// force on the ellipse).
const ANGLE_TOLERANCE: f64 = 1e-12;
/// Mode changes of one branch within a step before it goes to the general path.
const MAX_CHANGES: usize = 12;
/// Integration steps of one sliding piece before it goes to the general path.
const MAX_ANGLE_STEPS: usize = 5_000;

/// The members of the ellipse, by [`Direction`]: longitudinal and lateral.
const MEMBERS: [Direction; 2] = [Direction::Longitudinal, Direction::Lateral];

/// The branches of one step at its operating point, limits and held inputs.
pub struct SeparableStep {
    /// The law's branches, and each one's constants at this step.
    branches: &'static [Branch],
    ellipses: [EllipseBranch; MAX_BRANCHES],
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
        let mut states = [None; 2];
        let mut active = [false; 2];
        // By member, the element's C, Fmax, a and g; an inactive member has no force and
        // no motion, and stays outside every sum.
        let (mut stiffness, mut limit, mut relaxation, mut drive) =
            ([1.0; 2], [f64::INFINITY; 2], [0.0; 2], [0.0; 2]);
        for (m, direction) in MEMBERS.into_iter().enumerate() {
            let d = direction as usize;
            let Some(element) = friction.elements[d] else {
                continue;
            };
            let k = element.state;
            states[m] = Some(k);
            active[m] = limits.0[d] > 0.0;
            if active[m] {
                stiffness[m] = element.stiffness;
                limit[m] = limits.0[d];
                relaxation[m] = -system.a[(k, k)];
                drive[m] = system.input_rate(k, inputs);
            }
        }
        let mut ellipses = [EllipseBranch::default(); MAX_BRANCHES];
        for (ellipse, branch) in ellipses.iter_mut().zip(friction.branches) {
            let (w, phi) = (branch.stiffness_fraction, branch.limit_fraction);
            *ellipse = EllipseBranch::new(
                stiffness.map(|c| w * c),
                limit.map(|l| phi * l),
                relaxation,
                drive,
            );
        }
        Some(SeparableStep {
            branches: friction.branches,
            ellipses,
            states,
            active,
        })
    }

    /// The states and branches at the end of a step of `h` seconds from `x` and `sliders`;
    /// `None` if a branch changes mode more often than a step should, grazes its limit
    /// too finely to decide, or its angle's steps shrink to nothing (the general path then
    /// takes the step).
    pub fn step(&self, x: &StateVector, sliders: &SliderState, h: f64) -> Option<(StateVector, SliderState)> {
        let mut end_states = *x;
        let mut end_sliders = *sliders;
        // Without a limit in either direction every branch deflection stays zero.
        let mut deflections = [[0.0; 2]; MAX_BRANCHES];
        let branches = if self.active.contains(&true) {
            self.branches.len()
        } else {
            0
        };
        let mut starts = [BranchAt::default(); MAX_BRANCHES];
        for i in 0..branches {
            let mut b = [0.0; 2];
            for (m, direction) in MEMBERS.into_iter().enumerate() {
                if let (Some(k), true) = (self.states[m], self.active[m]) {
                    b[m] = x[k] + sliders.offsets[direction as usize][i];
                }
            }
            starts[i] = start_mode(&self.ellipses[i], b);
        }
        let done = self.step_together(&mut starts[..branches], h, &mut deflections);
        for i in 0..branches {
            let sliding = match done[i] {
                Some(sliding) => sliding,
                None => {
                    let (end, sliding) = self.branch_step(&self.ellipses[i], starts[i], h)?;
                    deflections[i] = end;
                    sliding
                }
            };
            end_sliders.sliding[Group::Planar as usize][i] = sliding;
        }
        for (m, direction) in MEMBERS.into_iter().enumerate() {
            let Some(k) = self.states[m] else { continue };
            let element_state: f64 = self
                .branches
                .iter()
                .zip(&deflections)
                .map(|(branch, b)| branch.stiffness_fraction * b[m])
                .sum();
            end_states[k] = element_state;
            for i in 0..self.branches.len() {
                end_sliders.offsets[direction as usize][i] = deflections[i][m] - element_state;
            }
        }
        Some((end_states, end_sliders))
    }

    /// The usual step of every branch, side by side: a branch that sticks throughout, or
    /// slides on its ellipse from the start or from where it first reaches it, with one
    /// angle step to the end. `starts` holds each branch's deflections and mode at the
    /// start ([`start_mode`]). Writes those branches' ends to `deflections` and returns
    /// which are done, with their modes at the end; for the others (an angle step too
    /// long, an event, one member) `starts` then says where [`SeparableStep::branch_step`]
    /// goes on from, which computes the values this would have.
    fn step_together(
        &self,
        starts: &mut [BranchAt],
        h: f64,
        deflections: &mut [[f64; 2]; MAX_BRANCHES],
    ) -> [Option<bool>; MAX_BRANCHES] {
        let mut done = [None; MAX_BRANCHES];
        if self.active != [true, true] || h <= 0.0 {
            return done;
        }
        // The branches that slide to the end of the step: their angles' flows, where they
        // start to slide, and the time left.
        let mut slides = [0; MAX_BRANCHES];
        let mut flows = [EllipseFlow::default(); MAX_BRANCHES];
        let (mut angles, mut lengths) = ([Angle::ZERO; MAX_BRANCHES], [0.0; MAX_BRANCHES]);
        let mut count = 0;
        for (i, from) in starts.iter_mut().enumerate() {
            let branch = &self.ellipses[i];
            if !from.sliding {
                match sticking_piece(branch, from, h) {
                    Sticking::Throughout(end) => {
                        deflections[i] = end;
                        done[i] = Some(false);
                        continue;
                    }
                    Sticking::Undecided => continue,
                    Sticking::Until(contact) => *from = contact,
                }
                if !(from.sliding && h - from.t > 0.0) {
                    continue;
                }
            }
            slides[count] = i;
            (flows[count], angles[count], lengths[count]) =
                (branch.flow(), branch.angle_of(from.b), h - from.t);
            count += 1;
        }
        let outward = |k: usize, at: &Angle| {
            let branch = &self.ellipses[slides[k]];
            branch.outward_cosine(branch.on_ellipse(at))
        };
        let firsts = first_steps_together::<_, MAX_BRANCHES>(
            &flows[..count],
            &angles[..count],
            &lengths[..count],
            ANGLE_TOLERANCE,
            (&outward, EVENT_TOLERANCE),
        );
        for (k, &i) in slides[..count].iter().enumerate() {
            match firsts[k] {
                FirstStep::End(end) => {
                    deflections[i] = self.ellipses[i].on_ellipse(&end);
                    done[i] = Some(true);
                }
                FirstStep::Shorter(length) => starts[i].first_angle_step = Some(length),
                FirstStep::Again => {}
            }
        }
        done
    }

    /// One branch over the step from where it is ([`BranchAt`]; from the start,
    /// [`start_mode`]), piece by piece: its end and whether it slides there.
    fn branch_step(&self, branch: &EllipseBranch, from: BranchAt, h: f64) -> Option<([f64; 2], bool)> {
        let mut at = from;
        while at.changes < MAX_CHANGES {
            let left = h - at.t;
            if left <= 0.0 {
                return Some((at.b, at.sliding));
            }
            if !at.sliding {
                match sticking_piece(branch, &at, h) {
                    Sticking::Throughout(end) => return Some((end, false)),
                    Sticking::Undecided => return None,
                    Sticking::Until(contact) => at = contact,
                }
            } else if self.active == [true, true] {
                let outward = |angle: &Angle| branch.outward_cosine(branch.on_ellipse(angle));
                // A first step already found too long counts as one taken.
                let taken = usize::from(at.first_angle_step.is_some());
                let outcome = integrate(
                    &branch.flow(),
                    branch.angle_of(at.b),
                    (left, at.first_angle_step.unwrap_or(left)),
                    ANGLE_TOLERANCE,
                    (&outward, EVENT_TOLERANCE),
                    MAX_ANGLE_STEPS - taken,
                )?;
                match outcome {
                    Outcome::End(end) => return Some((branch.on_ellipse(&end), true)),
                    Outcome::Event(elapsed, angle) => {
                        at = BranchAt {
                            b: branch.on_ellipse(&angle),
                            sliding: false,
                            t: at.t + elapsed,
                            changes: at.changes + 1,
                            first_angle_step: None,
                        };
                    }
                }
            } else {
                // One member on its limit: its outward motion does not change under held
                // inputs, so it slides to the end of the step.
                return Some((at.b, true));
            }
        }
        None
    }
}

/// How a sticking piece ends ([`sticking_piece`]).
enum Sticking {
    /// At the end of the step, still sticking: the deflections there.
    Throughout([f64; 2]),
    /// On the ellipse, put on it exactly: where the branch goes on from.
    Until(BranchAt),
    /// A graze too fine to decide.
    Undecided,
}

/// A branch that sticks from `from` on, to its first contact with its ellipse or the end
/// of the step.
fn sticking_piece(branch: &EllipseBranch, from: &BranchAt, h: f64) -> Sticking {
    let left = h - from.t;
    let motion = StickingMotion::new(branch, from.b);
    match motion.first_contact(left) {
        Contact::None(end) => Sticking::Throughout(end.deflection),
        Contact::Undecided => Sticking::Undecided,
        Contact::At(at) => {
            let b = scaled(at.deflection, branch.utilisation(at.deflection));
            Sticking::Until(BranchAt {
                b,
                sliding: branch.outward_cosine(b) > 0.0,
                t: from.t + at.t,
                changes: from.changes + 1,
                first_angle_step: None,
            })
        }
    }
}

/// A branch's deflections and mode at the start of a step: a force outside the ellipse
/// (the load fell) is put on it; it slides if on the ellipse with its motion outward.
fn start_mode(branch: &EllipseBranch, mut b: [f64; 2]) -> BranchAt {
    let utilisation = branch.utilisation(b);
    if utilisation > 1.0 {
        b = scaled(b, utilisation);
    }
    BranchAt {
        b,
        sliding: utilisation >= 1.0 - EVENT_TOLERANCE && branch.outward_cosine(b) > 0.0,
        ..BranchAt::default()
    }
}

/// Where a branch's step goes on from: its deflections and mode `t` seconds into the
/// step, after `changes` mode changes; sliding, the length its first angle step tries
/// (the rest of the step unless a longer one was found too long).
#[derive(Clone, Copy, Debug, Default)]
struct BranchAt {
    b: [f64; 2],
    sliding: bool,
    t: f64,
    changes: usize,
    first_angle_step: Option<f64>,
}

/// Deflections with `utilisation` scaled onto the ellipse.
fn scaled(b: [f64; 2], utilisation: f64) -> [f64; 2] {
    let shrink = utilisation.sqrt().recip();
    [b[0] * shrink, b[1] * shrink]
}

#[cfg(test)]
mod tests;
