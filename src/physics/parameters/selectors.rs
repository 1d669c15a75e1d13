//! The selectors: which model and which friction law a parameter set chooses (the FMI
//! enumerations `TireLagModel` and `TireFriction`). Defined with the parameters, which
//! hold them; what each selects (a model's equations, a law's branches) is with the
//! models and the friction limit.

/// Which tire-lag model the tire uses; the values are those of the FMI enumeration
/// `TireLagModel`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModelKind {
    Rlt = 1,
    Ddt = 2,
    SecondOrder = 3,
    RingBody = 4,
}

impl ModelKind {
    pub const ALL: [ModelKind; 4] = [
        ModelKind::Rlt,
        ModelKind::Ddt,
        ModelKind::SecondOrder,
        ModelKind::RingBody,
    ];

    pub fn from_value(value: i64) -> Option<Self> {
        Self::ALL.into_iter().find(|m| *m as i64 == value)
    }

    pub const fn name(self) -> &'static str {
        match self {
            ModelKind::Rlt => "RLT",
            ModelKind::Ddt => "DDT",
            ModelKind::SecondOrder => "SecondOrder",
            ModelKind::RingBody => "RingBody",
        }
    }
}

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
}
