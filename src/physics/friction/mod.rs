//! The friction limit (SPEC 4c): a rate-independent slider in series with each contact
//! element of a model.
//!
//! A model names its contact elements ([`ContactElement`]: which state is the element's
//! deflection, its stiffness and damping, and which outputs its force feeds). The law
//! ([`FrictionLaw`]) splits each element into parallel branches ([`crate::physics::brush`]):
//! one for `Coulomb`, four for `Brush`. Branch `i` of every element carries the fractions
//! `w_i` of the stiffness and damping and `phi_i` of the limit, and has its own deflection
//! `b_i`; the model's state is the stiffness-weighted sum `U = sum w_i b_i`.
//!
//! Branch `i` of the longitudinal and lateral elements shares one friction ellipse
//! (a planar [`group`]); branch `i` of DDT's yaw element has its own limit. A group sticks
//! (each `b_i` follows the model's equations with `b_i` in place of `U`) or slides (its
//! force stays on the limit, [`group::evaluate`]).
//!
//! How a step is computed ([`crate::physics::Tire::step`]):
//! 1. The limits at the step's load; a spring force outside them is put on them at once.
//! 2. If every group sticks, the exact linear step of the model (the stepper) moves `U`,
//!    and `b_i - U` decays with the element's relaxation rate. The step is kept if no
//!    branch can have reached its limit within it ([`force_bound`]).
//! 3. Otherwise [`sliding`] integrates the branches and the model together, piece by
//!    piece between stick/slide events located in time, to 1e-12.

pub mod group;
pub mod sliding;

use super::brush::{BRUSH_BRANCHES, Branch};
use super::parameters::{Parameter, Parameters};
use super::signals::Output;

/// The friction law; the values are those of the FMI type `TireFriction`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrictionLaw {
    /// No limit: the linear model (with load dependence).
    Unlimited = 1,
    /// One slider per element: linear up to the limit, flat beyond.
    Coulomb = 2,
    /// Four parallel branches per element, fitted to the brush curve.
    Brush = 3,
}

/// The single branch of the Coulomb law.
const COULOMB_BRANCH: [Branch; 1] = [Branch {
    stiffness_fraction: 1.0,
    limit_fraction: 1.0,
}];

impl FrictionLaw {
    pub const ALL: [FrictionLaw; 3] = [FrictionLaw::Unlimited, FrictionLaw::Coulomb, FrictionLaw::Brush];

    pub fn from_value(value: i64) -> Option<Self> {
        Self::ALL.into_iter().find(|law| *law as i64 == value)
    }

    pub const fn name(self) -> &'static str {
        match self {
            FrictionLaw::Unlimited => "Unlimited",
            FrictionLaw::Coulomb => "Coulomb",
            FrictionLaw::Brush => "Brush",
        }
    }

    /// The branches each element is split into (none without a limit).
    pub fn branches(self) -> &'static [Branch] {
        match self {
            FrictionLaw::Unlimited => &[],
            FrictionLaw::Coulomb => &COULOMB_BRANCH,
            FrictionLaw::Brush => &BRUSH_BRANCHES,
        }
    }
}

/// The most branches an element has.
pub const MAX_BRANCHES: usize = 4;

/// The direction an element's force acts in. The longitudinal and lateral elements share
/// the friction ellipse; the yaw element (DDT) has a limit of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Direction {
    Longitudinal = 0,
    Lateral = 1,
    Yaw = 2,
}

impl Direction {
    pub const COUNT: usize = 3;
    pub const ALL: [Direction; Direction::COUNT] = [Direction::Longitudinal, Direction::Lateral, Direction::Yaw];
}

/// The groups of directions that share a limit: the ellipse, and the yaw moment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Group {
    Planar = 0,
    Yaw = 1,
}

impl Group {
    pub const COUNT: usize = 2;
    pub const ALL: [Group; Group::COUNT] = [Group::Planar, Group::Yaw];

    pub const fn directions(self) -> &'static [Direction] {
        match self {
            Group::Planar => &[Direction::Longitudinal, Direction::Lateral],
            Group::Yaw => &[Direction::Yaw],
        }
    }
}

/// A spring (or spring-damper) through which a model touches the road. Its force is
/// `stiffness U + damping dU/dt`, with `U` the state `state`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactElement {
    pub state: usize,
    pub stiffness: f64,
    pub damping: f64,
    /// How the outputs change per unit change of the element force at fixed states: the
    /// outputs that show the force directly (with the trail and rolling radius terms).
    pub force_outputs: [(Output, f64); 2],
}

impl ContactElement {
    /// An element whose force is not an output by itself (a tread spring that acts on a
    /// contact mass).
    pub const NO_OUTPUTS: [(Output, f64); 2] = [(Output::Fx, 0.0), (Output::Fx, 0.0)];
}

/// A model's contact elements, by [`Direction`].
pub type ContactElements = [Option<ContactElement>; Direction::COUNT];

/// The friction limits at a normal load: `Fmax_x`, `Fmax_y` (N) and the yaw moment's
/// (N.m), by [`Direction`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits(pub [f64; Direction::COUNT]);

impl Limits {
    /// `mu(Fz) = mu (1 + muLoadSensitivity (Fz/Fz0 - 1))`, never below 0;
    /// `Fmax = mu(Fz) Fz`; the yaw moment's limit is `boreRadius muY(Fz) Fz`. A zero limit
    /// makes its direction frictionless: the branch force is zero.
    pub fn at(p: &Parameters, load: f64) -> Self {
        let nominal = p.get(Parameter::NominalLoad);
        let load = load.max(0.0);
        let factor = (1.0 + p.get(Parameter::FrictionLoadSensitivity) * (load / nominal - 1.0)).max(0.0);
        let limit = |mu: f64, lever: f64| mu * factor * load * lever;
        let (mu_x, mu_y) = (p.get(Parameter::LongitudinalFriction), p.get(Parameter::LateralFriction));
        let bore = p.get(Parameter::BoreRadius);
        Limits([limit(mu_x, 1.0), limit(mu_y, 1.0), limit(mu_y, bore)])
    }
}

/// Each branch's deflection and whether its groups slide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliderState {
    /// `b_i` by [`Direction`] and branch, in the unit of the element's state.
    pub deflections: [[f64; MAX_BRANCHES]; Direction::COUNT],
    /// By [`Group`] and branch.
    pub sliding: [[bool; MAX_BRANCHES]; Group::COUNT],
}

impl SliderState {
    pub const AT_REST: SliderState = SliderState {
        deflections: [[0.0; MAX_BRANCHES]; Direction::COUNT],
        sliding: [[false; MAX_BRANCHES]; Group::COUNT],
    };

    pub fn any_sliding(&self) -> bool {
        self.sliding.iter().flatten().any(|&s| s)
    }
}

/// The friction part of a tire: the law, the model's elements and the branches' states.
#[derive(Clone, Debug, PartialEq)]
pub struct Friction {
    pub law: FrictionLaw,
    pub branches: &'static [Branch],
    pub elements: ContactElements,
    pub state: SliderState,
}

impl Friction {
    /// `None` for the Unlimited law.
    pub fn new(law: FrictionLaw, elements: ContactElements) -> Option<Self> {
        (law != FrictionLaw::Unlimited).then(|| Friction {
            law,
            branches: law.branches(),
            elements,
            state: SliderState::AT_REST,
        })
    }

    /// The groups this model has, each with whether its elements are damped.
    pub fn groups(&self) -> impl Iterator<Item = Group> + '_ {
        Group::ALL
            .into_iter()
            .filter(|g| g.directions().iter().any(|&d| self.elements[d as usize].is_some()))
    }

    /// Sets every branch deflection of each element to the element's state (at rest, or
    /// after states were set from outside), all sticking.
    pub fn reset_to(&mut self, states: &[f64]) {
        self.state = SliderState::AT_REST;
        for (d, element) in self.elements.iter().enumerate() {
            if let Some(element) = element {
                for i in 0..self.branches.len() {
                    self.state.deflections[d][i] = states[element.state];
                }
            }
        }
    }

    /// The stiffness-weighted deflection `U = sum w_i b_i` of an element.
    pub fn weighted_deflection(&self, direction: usize) -> f64 {
        self.branches
            .iter()
            .zip(&self.state.deflections[direction])
            .map(|(branch, b)| branch.stiffness_fraction * b)
            .sum()
    }
}

/// A bound on a force over a step from its values and rates at both ends. The cubic
/// through them stays within `max(|F0|, |F1|) + 4/27 h (|F0'| + |F1'|)` (the Hermite
/// basis functions of the end rates peak at 4/27); the bound uses 1/4 for a margin. A
/// step stays on the fast path only if this bound is inside the limit, so a force that
/// could have touched its limit within the step goes to [`sliding`], which locates the
/// event.
pub fn force_bound(start: f64, end: f64, start_rate: f64, end_rate: f64, h: f64) -> f64 {
    start.abs().max(end.abs()) + 0.25 * h * (start_rate.abs() + end_rate.abs())
}
