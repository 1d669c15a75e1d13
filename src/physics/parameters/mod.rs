//! Tire parameters, their documented defaults and their validity rules.
//!
//! Names follow docs/specification.md 3 (`Calpha`, `sigmaY`, ...): they are the
//! parameters' public names, used in error messages so that a user can find the value
//! they set.

mod selectors;

use std::fmt;

pub use selectors::{FrictionLaw, ModelKind};

/// One real-valued tire parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Parameter {
    /// Cornering stiffness `Calpha`, N/rad.
    CorneringStiffness,
    /// Longitudinal slip stiffness `Ckappa`, N.
    SlipStiffness,
    /// Lateral relaxation length `sigmaY`, m.
    LateralRelaxationLength,
    /// Longitudinal relaxation length `sigmaX`, m.
    LongitudinalRelaxationLength,
    /// Effective rolling radius `Re`, m.
    RollingRadius,
    /// Pneumatic trail `trail`, m.
    PneumaticTrail,
    /// Nominal normal load `Fz0`, N.
    NominalLoad,
    /// Lateral tread damping `dampingY` (DDT), N.s/m.
    LateralDamping,
    /// Longitudinal tread damping `dampingX` (DDT), N.s/m.
    LongitudinalDamping,
    /// Yaw relaxation length `sigmaPsi` (DDT), m.
    YawRelaxationLength,
    /// Yaw stiffness `stiffnessPsi` (DDT), N.m/rad.
    YawStiffness,
    /// Yaw damping `dampingPsi` (DDT), N.m.s/rad.
    YawDamping,
    /// Contact mass `contactMass` (SecondOrder), kg.
    ContactMass,
    /// Lateral carcass damping `carcassDampingY` (SecondOrder), N.s/m.
    CarcassLateralDamping,
    /// Ring mass `ringMass` (RingBody), kg.
    RingMass,
    /// Ring inertia about the spin axis `ringInertia` (RingBody), kg.m2.
    RingInertia,
    /// Ring lateral damping `ringDampingY` (RingBody), N.s/m.
    RingLateralDamping,
    /// Ring circumferential damping `ringDampingX` (RingBody), N.s/m.
    RingCircumferentialDamping,
    /// Tread relaxation length `sigmaTread` (SecondOrder, RingBody), m.
    TreadRelaxationLength,
    /// Load ratio `calphaLoadPeak` = c2 at which the cornering stiffness peaks, 1.
    CorneringStiffnessPeakLoad,
    /// Longitudinal friction coefficient at Fz0 `muX`, 1.
    LongitudinalFriction,
    /// Lateral friction coefficient at Fz0 `muY`, 1.
    LateralFriction,
    /// Load sensitivity of the friction coefficients `muLoadSensitivity`, 1.
    FrictionLoadSensitivity,
    /// Lever arm of the yaw moment's friction limit `boreRadius` (DDT), m.
    BoreRadius,
}

/// What a parameter's value must satisfy on its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bound {
    Positive,
    NonNegative,
    Finite,
}

impl Parameter {
    pub const COUNT: usize = 24;
    pub const ALL: [Parameter; Parameter::COUNT] = [
        Parameter::CorneringStiffness,
        Parameter::SlipStiffness,
        Parameter::LateralRelaxationLength,
        Parameter::LongitudinalRelaxationLength,
        Parameter::RollingRadius,
        Parameter::PneumaticTrail,
        Parameter::NominalLoad,
        Parameter::LateralDamping,
        Parameter::LongitudinalDamping,
        Parameter::YawRelaxationLength,
        Parameter::YawStiffness,
        Parameter::YawDamping,
        Parameter::ContactMass,
        Parameter::CarcassLateralDamping,
        Parameter::RingMass,
        Parameter::RingInertia,
        Parameter::RingLateralDamping,
        Parameter::RingCircumferentialDamping,
        Parameter::TreadRelaxationLength,
        Parameter::CorneringStiffnessPeakLoad,
        Parameter::LongitudinalFriction,
        Parameter::LateralFriction,
        Parameter::FrictionLoadSensitivity,
        Parameter::BoreRadius,
    ];

    /// The parameter's public name (docs/specification.md 3).
    pub const fn name(self) -> &'static str {
        self.describe().0
    }

    /// SI unit, for messages.
    pub const fn unit(self) -> &'static str {
        self.describe().1
    }

    const fn bound(self) -> Bound {
        self.describe().2
    }

    const fn describe(self) -> (&'static str, &'static str, Bound) {
        use Bound::*;
        use Parameter::*;
        match self {
            CorneringStiffness => ("Calpha", "N/rad", Positive),
            SlipStiffness => ("Ckappa", "N", Positive),
            LateralRelaxationLength => ("sigmaY", "m", Positive),
            LongitudinalRelaxationLength => ("sigmaX", "m", Positive),
            RollingRadius => ("Re", "m", Positive),
            PneumaticTrail => ("trail", "m", Finite),
            NominalLoad => ("Fz0", "N", Positive),
            LateralDamping => ("dampingY", "N.s/m", NonNegative),
            LongitudinalDamping => ("dampingX", "N.s/m", NonNegative),
            YawRelaxationLength => ("sigmaPsi", "m", Positive),
            YawStiffness => ("stiffnessPsi", "N.m/rad", NonNegative),
            YawDamping => ("dampingPsi", "N.m.s/rad", NonNegative),
            ContactMass => ("contactMass", "kg", Positive),
            CarcassLateralDamping => ("carcassDampingY", "N.s/m", NonNegative),
            RingMass => ("ringMass", "kg", Positive),
            RingInertia => ("ringInertia", "kg.m2", Positive),
            RingLateralDamping => ("ringDampingY", "N.s/m", NonNegative),
            RingCircumferentialDamping => ("ringDampingX", "N.s/m", NonNegative),
            TreadRelaxationLength => ("sigmaTread", "m", Positive),
            CorneringStiffnessPeakLoad => ("calphaLoadPeak", "1", Positive),
            LongitudinalFriction => ("muX", "1", NonNegative),
            LateralFriction => ("muY", "1", NonNegative),
            FrictionLoadSensitivity => ("muLoadSensitivity", "1", Finite),
            BoreRadius => ("boreRadius", "m", NonNegative),
        }
    }

    /// Checks a value against this parameter's own range.
    pub fn check(self, value: f64) -> Result<(), ParameterError> {
        let (ok, rule) = match self.bound() {
            Bound::Positive => (value > 0.0 && value.is_finite(), "must be finite and > 0"),
            Bound::NonNegative => (value >= 0.0 && value.is_finite(), "must be finite and >= 0"),
            Bound::Finite => (value.is_finite(), "must be finite"),
        };
        if ok {
            Ok(())
        } else {
            Err(ParameterError::new(self, value, rule.to_owned()))
        }
    }
}

/// A parameter value that is not allowed, with the rule it breaks.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterError {
    pub parameter: Parameter,
    pub value: f64,
    pub rule: String,
}

impl ParameterError {
    fn new(parameter: Parameter, value: f64, rule: String) -> Self {
        Self {
            parameter,
            value,
            rule,
        }
    }
}

impl fmt::Display for ParameterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} = {} {} is out of range: {}",
            self.parameter.name(),
            self.value,
            self.parameter.unit(),
            self.rule
        )
    }
}

impl std::error::Error for ParameterError {}

/// A complete parameter set: the model and friction choices and every real parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameters {
    pub model: ModelKind,
    pub friction: FrictionLaw,
    values: [f64; Parameter::COUNT],
}

impl Default for Parameters {
    /// The snowblower tire of Koo & Tan Table 1 (per tire) where the paper gives a value:
    /// Calpha 350000 N/rad, sigmaY 1.0 m, D_lat 9000 N.s/m, sigmaPsi 0.45 m,
    /// C_yaw 40000 N.m/rad. The others are plausible values for a 5 t wheel load on a
    /// large tire: Ckappa 500 kN, sigmaX 0.5 m, Re 0.6 m, trail 5 cm, D_long 9000 N.s/m,
    /// D_yaw 400 N.m.s/rad, contact mass 20 kg, ring 30 kg and 8 kg.m2, carcass and ring
    /// dampings 9000 N.s/m, tread relaxation length (contact half-length) 0.1 m, and the
    /// cornering stiffness peaking at twice the nominal load (calphaLoadPeak 2,
    /// docs/specification.md 4b). Friction (docs/specification.md 4c): the Brush law with
    /// mu 0.8 both ways at Fz0, falling by 10 % per Fz0 of extra load (muLoadSensitivity
    /// -0.1), and a bore radius of 0.1 m.
    fn default() -> Self {
        let mut p = Parameters {
            model: ModelKind::Ddt,
            friction: FrictionLaw::Brush,
            values: [0.0; Parameter::COUNT],
        };
        for (parameter, value) in [
            (Parameter::CorneringStiffness, 350_000.0),
            (Parameter::SlipStiffness, 500_000.0),
            (Parameter::LateralRelaxationLength, 1.0),
            (Parameter::LongitudinalRelaxationLength, 0.5),
            (Parameter::RollingRadius, 0.6),
            (Parameter::PneumaticTrail, 0.05),
            (Parameter::NominalLoad, 50_000.0),
            (Parameter::LateralDamping, 9_000.0),
            (Parameter::LongitudinalDamping, 9_000.0),
            (Parameter::YawRelaxationLength, 0.45),
            (Parameter::YawStiffness, 40_000.0),
            (Parameter::YawDamping, 400.0),
            (Parameter::ContactMass, 20.0),
            (Parameter::CarcassLateralDamping, 9_000.0),
            (Parameter::RingMass, 30.0),
            (Parameter::RingInertia, 8.0),
            (Parameter::RingLateralDamping, 9_000.0),
            (Parameter::RingCircumferentialDamping, 9_000.0),
            (Parameter::TreadRelaxationLength, 0.1),
            (Parameter::CorneringStiffnessPeakLoad, 2.0),
            (Parameter::LongitudinalFriction, 0.8),
            (Parameter::LateralFriction, 0.8),
            (Parameter::FrictionLoadSensitivity, -0.1),
            (Parameter::BoreRadius, 0.1),
        ] {
            p.values[parameter as usize] = value;
        }
        p
    }
}

/// The stiff tread of the stiff light tire the tests slide (Calpha = Ckappa = 1e7,
/// sigmaY = sigmaX = 0.05 m: 2e8 N/m), which a light load makes turn its force within
/// microseconds.
#[cfg(test)]
pub(crate) const STIFF_TREAD: [(Parameter, f64); 4] = [
    (Parameter::CorneringStiffness, 1e7),
    (Parameter::SlipStiffness, 1e7),
    (Parameter::LateralRelaxationLength, 0.05),
    (Parameter::LongitudinalRelaxationLength, 0.05),
];

impl Parameters {
    /// The same parameters with another model.
    pub fn with_model(mut self, model: ModelKind) -> Self {
        self.model = model;
        self
    }

    /// The same parameters with another friction law.
    pub fn with_friction(mut self, friction: FrictionLaw) -> Self {
        self.friction = friction;
        self
    }

    pub fn get(&self, parameter: Parameter) -> f64 {
        self.values[parameter as usize]
    }

    /// Sets one parameter after checking it against its own range; on error nothing changes.
    pub fn set(&mut self, parameter: Parameter, value: f64) -> Result<(), ParameterError> {
        parameter.check(value)?;
        self.values[parameter as usize] = value;
        Ok(())
    }

    /// Checks every value and the rules between parameters that the selected model uses.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for parameter in Parameter::ALL {
            parameter.check(self.get(parameter))?;
        }
        let tread = self.get(Parameter::TreadRelaxationLength);
        let limits: &[Parameter] = match self.model {
            ModelKind::Rlt | ModelKind::Ddt => &[],
            ModelKind::SecondOrder => &[Parameter::LateralRelaxationLength],
            ModelKind::RingBody => &[
                Parameter::LateralRelaxationLength,
                Parameter::LongitudinalRelaxationLength,
            ],
        };
        // A damped element's slider holds C u + D du/dt on the ellipse, a spring's holds
        // C u: the two directions of one ellipse must be alike.
        let (lateral, longitudinal) = (
            self.get(Parameter::LateralDamping),
            self.get(Parameter::LongitudinalDamping),
        );
        if self.model == ModelKind::Ddt
            && self.friction != FrictionLaw::Unlimited
            && (lateral > 0.0) != (longitudinal > 0.0)
        {
            let (zero, other) = if lateral > 0.0 {
                (Parameter::LongitudinalDamping, Parameter::LateralDamping)
            } else {
                (Parameter::LateralDamping, Parameter::LongitudinalDamping)
            };
            return Err(ParameterError::new(
                zero,
                0.0,
                format!(
                    "must be > 0 like {} for DDT with a friction limit (or set both to 0)",
                    other.name()
                ),
            ));
        }
        for &limit in limits {
            if tread >= self.get(limit) {
                return Err(ParameterError::new(
                    Parameter::TreadRelaxationLength,
                    tread,
                    format!(
                        "must be below {} = {} m for the {} model",
                        limit.name(),
                        self.get(limit),
                        self.model.name()
                    ),
                ));
            }
        }
        Ok(())
    }

    // Named accessors for the model equations.
    pub fn cornering_stiffness(&self) -> f64 {
        self.get(Parameter::CorneringStiffness)
    }
    pub fn slip_stiffness(&self) -> f64 {
        self.get(Parameter::SlipStiffness)
    }
    pub fn lateral_relaxation_length(&self) -> f64 {
        self.get(Parameter::LateralRelaxationLength)
    }
    pub fn longitudinal_relaxation_length(&self) -> f64 {
        self.get(Parameter::LongitudinalRelaxationLength)
    }
    pub fn tread_relaxation_length(&self) -> f64 {
        self.get(Parameter::TreadRelaxationLength)
    }

    /// Lateral deflection stiffness of the relaxation-length models, `C_y = Calpha/sigmaY`, N/m.
    pub fn lateral_stiffness(&self) -> f64 {
        self.cornering_stiffness() / self.lateral_relaxation_length()
    }
    /// Longitudinal deflection stiffness `C_x = Ckappa/sigmaX`, N/m.
    pub fn longitudinal_stiffness(&self) -> f64 {
        self.slip_stiffness() / self.longitudinal_relaxation_length()
    }
    /// Lateral carcass stiffness `k_y = Calpha/(sigmaY - sigmaTread)`, N/m.
    pub fn carcass_lateral_stiffness(&self) -> f64 {
        self.cornering_stiffness() / (self.lateral_relaxation_length() - self.tread_relaxation_length())
    }
    /// Circumferential carcass stiffness `k_x = Ckappa/(sigmaX - sigmaTread)`, N/m.
    pub fn carcass_longitudinal_stiffness(&self) -> f64 {
        self.slip_stiffness() / (self.longitudinal_relaxation_length() - self.tread_relaxation_length())
    }
    /// Lateral tread stiffness `kT_y = Calpha/sigmaTread`, N/m.
    pub fn tread_lateral_stiffness(&self) -> f64 {
        self.cornering_stiffness() / self.tread_relaxation_length()
    }
    /// Longitudinal tread stiffness `kT_x = Ckappa/sigmaTread`, N/m.
    pub fn tread_longitudinal_stiffness(&self) -> f64 {
        self.slip_stiffness() / self.tread_relaxation_length()
    }
}
