//! The words of the friction limit: the law, the directions and groups of a model's
//! contact elements, their limits at a load, and the state of their branches.

use crate::physics::brush::{BRUSH_BRANCHES, Branch};
use crate::physics::parameters::{FrictionLaw, Parameter, Parameters};
use crate::physics::signals::Output;

/// The single branch of the Coulomb law.
const COULOMB_BRANCH: [Branch; 1] = [Branch {
    stiffness_fraction: 1.0,
    limit_fraction: 1.0,
}];

impl FrictionLaw {
    /// The branches each element is split into (none without a limit).
    pub fn branches(self) -> &'static [Branch] {
        match self {
            FrictionLaw::Unlimited => &[],
            FrictionLaw::Coulomb => &COULOMB_BRANCH,
            FrictionLaw::Brush => &BRUSH_BRANCHES,
        }
    }
}

/// A stick/slide event value (a utilisation above 1, an outward cosine below 0) past
/// this has crossed; below it, rounding. An event is located where its value crosses half
/// of this, clear of the rounding noise around zero (a group that starts on its limit
/// sits at zero).
pub const EVENT_TOLERANCE: f64 = 1e-12;

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
    pub const ALL: [Direction; Direction::COUNT] =
        [Direction::Longitudinal, Direction::Lateral, Direction::Yaw];

    /// The group whose limit this direction shares.
    pub const fn group(self) -> Group {
        match self {
            Direction::Longitudinal | Direction::Lateral => Group::Planar,
            Direction::Yaw => Group::Yaw,
        }
    }
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
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Limits(pub [f64; Direction::COUNT]);

impl Limits {
    /// `mu(Fz) = mu (1 + muLoadSensitivity (Fz/Fz0 - 1))`, never below 0;
    /// `Fmax = mu(Fz) Fz`; the yaw moment's limit is `boreRadius muY(Fz) Fz`. A zero limit
    /// makes its direction frictionless: the branch force is zero.
    pub fn at(p: &Parameters, load: f64) -> Self {
        let nominal = p.get(Parameter::NominalLoad);
        let load = load.max(0.0);
        let factor = load_factor(p.get(Parameter::FrictionLoadSensitivity), load / nominal);
        let limit = |mu: f64, lever: f64| mu * factor * load * lever;
        let (mu_x, mu_y) = (
            p.get(Parameter::LongitudinalFriction),
            p.get(Parameter::LateralFriction),
        );
        let bore = p.get(Parameter::BoreRadius);
        Limits([limit(mu_x, 1.0), limit(mu_y, 1.0), limit(mu_y, bore)])
    }
}

/// `mu(Fz) / mu = 1 + muLoadSensitivity (Fz/Fz0 - 1)`, never below 0, at the relative
/// load `Fz/Fz0`.
#[inline]
fn load_factor(sensitivity: f64, relative_load: f64) -> f64 {
    (1.0 + sensitivity * (relative_load - 1.0)).max(0.0)
}

/// The friction limits' inverses as the load changes: what [`Limits::at`] needs of the
/// parameters, inverted once per tire, so that a load costs one division, not one per
/// direction (a solver changes the load at every evaluation, and divisions queue).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseLimits {
    inverse_nominal_load: f64,
    sensitivity: f64,
    /// `1 / (mu lever)` by direction: the limit over `mu(Fz)/mu Fz`.
    inverse_levers: [f64; Direction::COUNT],
}

impl InverseLimits {
    pub fn new(p: &Parameters) -> Self {
        let (mu_x, mu_y) = (
            p.get(Parameter::LongitudinalFriction),
            p.get(Parameter::LateralFriction),
        );
        let levers = [mu_x, mu_y, mu_y * p.get(Parameter::BoreRadius)];
        InverseLimits {
            inverse_nominal_load: 1.0 / p.get(Parameter::NominalLoad),
            sensitivity: p.get(Parameter::FrictionLoadSensitivity),
            inverse_levers: levers.map(|lever| 1.0 / lever),
        }
    }

    /// `1 / limit` at `load` of the directions in `present` (zero for the others), as
    /// [`Limits::at`] up to rounding, or `None` if one of them is not finite and positive
    /// (a zero limit, or one too small to invert).
    #[inline]
    pub fn at(&self, load: f64, present: &[bool; Direction::COUNT]) -> Option<[f64; Direction::COUNT]> {
        let load = load.max(0.0);
        let factor = load_factor(self.sensitivity, load * self.inverse_nominal_load);
        let inverse_scale = 1.0 / (factor * load);
        let mut inverse = [0.0; Direction::COUNT];
        let (mut positive, mut zeroed) = (true, 0.0);
        for ((inverse, &present), inverse_lever) in inverse.iter_mut().zip(present).zip(self.inverse_levers) {
            // Selects, not branches: a solver asks at every evaluation. NaN is not
            // positive; `0 v` is NaN for an infinite or NaN `v`, so their sum is zero only
            // if every one is finite. (One test of `0 < v < inf` by value compiles to a
            // bit test of each, three times the instructions.)
            let value = inverse_lever * inverse_scale;
            *inverse = if present { value } else { 0.0 };
            let checked = if present { value } else { 1.0 };
            positive &= checked > 0.0;
            zeroed += 0.0 * checked;
        }
        (positive & (zeroed == 0.0)).then_some(inverse)
    }
}

/// Each branch's deflection and whether its groups slide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliderState {
    /// `b_i - U` by [`Direction`] and branch, in the unit of the element's state `U`: zero
    /// until a branch slides (always, for one branch), and relaxing while all stick.
    pub offsets: [[f64; MAX_BRANCHES]; Direction::COUNT],
    /// By [`Group`] and branch.
    pub sliding: [[bool; MAX_BRANCHES]; Group::COUNT],
}

impl SliderState {
    pub const AT_REST: SliderState = SliderState {
        offsets: [[0.0; MAX_BRANCHES]; Direction::COUNT],
        sliding: [[false; MAX_BRANCHES]; Group::COUNT],
    };

    /// Whether every branch sticks at its element's state (no offsets, nothing sliding).
    pub fn together(&self) -> bool {
        // Branch-free folds: every offset +-0 and no flag set.
        let offsets = self
            .offsets
            .iter()
            .flatten()
            .fold(0, |any, o| any | (o.to_bits() << 1));
        let sliding = self.sliding.iter().flatten().fold(false, |any, &s| any | s);
        offsets == 0 && !sliding
    }

    pub fn any_sliding(&self) -> bool {
        self.sliding.iter().flatten().any(|&s| s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_limits_are_the_limits_inverted() {
        let mut p = Parameters::default();
        for (sensitivity, bore) in [(0.0, 0.1), (-0.3, 0.05), (0.2, 0.3)] {
            p.set(Parameter::FrictionLoadSensitivity, sensitivity).unwrap();
            p.set(Parameter::BoreRadius, bore).unwrap();
            let law = InverseLimits::new(&p);
            for load in [1e-3, 1.0, 350.0, 4000.0, 12_345.6, 1e6] {
                let limits = Limits::at(&p, load);
                let inverse = law.at(load, &[true; Direction::COUNT]);
                if limits.0[0] == 0.0 {
                    // The load sensitivity took mu(Fz) to zero.
                    assert_eq!(inverse, None, "{load} N");
                    continue;
                }
                let inverse = inverse.expect("every limit acts");
                for (inverse, limit) in inverse.iter().zip(limits.0) {
                    assert!(
                        (inverse * limit - 1.0).abs() < 1e-15,
                        "{load} N: {inverse} * {limit}"
                    );
                }
                // A direction the model lacks is zero, whatever its limit.
                let lateral_only = law.at(load, &[false, true, false]).expect("the lateral acts");
                assert_eq!(lateral_only[0], 0.0);
                assert_eq!(lateral_only[2], 0.0);
                assert!((lateral_only[1] * limits.0[1] - 1.0).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn a_limit_that_cannot_be_inverted_gives_none() {
        let p = Parameters::default();
        let law = InverseLimits::new(&p);
        for load in [0.0, -5.0, 1e-320] {
            assert_eq!(law.at(load, &[true; Direction::COUNT]), None, "{load} N");
        }
        let mut frictionless = p.clone();
        frictionless.set(Parameter::LongitudinalFriction, 0.0).unwrap();
        let law = InverseLimits::new(&frictionless);
        assert_eq!(law.at(4000.0, &[true, true, false]), None);
        // The longitudinal direction absent, its zero limit does not matter.
        assert!(law.at(4000.0, &[false, true, true]).is_some());
    }
}
