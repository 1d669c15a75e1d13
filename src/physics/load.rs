//! Load dependence (SPEC 4b): how the normal load stretches the relaxation lengths.
//!
//! With `x = Fz/Fz0` and `c2 = calphaLoadPeak`, the slip stiffnesses follow the load,
//! `Calpha(Fz) = Calpha x (1 + 1/c2^2)/(1 + x^2/c2^2)` (Pacejka's sin(2 atan) law,
//! normalised to Calpha at Fz0) and `Ckappa(Fz) = Ckappa x`, while the stiffnesses stay:
//! so the lateral relaxation lengths stretch by `Calpha(Fz)/Calpha` and the longitudinal
//! ones by `x` (as in MF-Tyre, sigma = K/C). The standstill stiffness is then the same at
//! every load, and at Fz0 every model is the nominal one.

use super::parameters::{Parameter, Parameters};

/// `1 / length factor`, lateral and longitudinal: what a nominal relaxation rate is
/// multiplied by at a load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseLengthFactors {
    pub lateral: f64,
    pub longitudinal: f64,
}

impl InverseLengthFactors {
    pub const NOMINAL: Self = Self {
        lateral: 1.0,
        longitudinal: 1.0,
    };
}

/// The load law of one parameter set, with its constants worked out once: a load costs
/// one division.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadLaw {
    inverse_nominal_load: f64,
    /// `1/c2^2`.
    inverse_peak_squared: f64,
    /// `1/(1 + 1/c2^2)`: normalises Calpha(Fz0) to Calpha.
    inverse_normalisation: f64,
}

impl LoadLaw {
    pub fn new(p: &Parameters) -> Self {
        let c2 = p.get(Parameter::CorneringStiffnessPeakLoad);
        let inverse_peak_squared = 1.0 / (c2 * c2);
        Self {
            inverse_nominal_load: 1.0 / p.get(Parameter::NominalLoad),
            inverse_peak_squared,
            inverse_normalisation: 1.0 / (1.0 + inverse_peak_squared),
        }
    }

    /// The inverse length factors at normal load `load`. Off the ground (`load <= 0`) the
    /// nominal lengths are kept: there is no load to scale them by.
    pub fn inverse_factors(&self, load: f64) -> InverseLengthFactors {
        if load <= 0.0 {
            return InverseLengthFactors::NOMINAL;
        }
        let x = load * self.inverse_nominal_load;
        let inverse_x = 1.0 / x;
        InverseLengthFactors {
            // Calpha/Calpha(Fz) = (1 + x^2/c2^2) / ((1 + 1/c2^2) x)
            lateral: (1.0 + x * x * self.inverse_peak_squared) * self.inverse_normalisation * inverse_x,
            longitudinal: inverse_x,
        }
    }

    /// `Calpha(Fz)/Calpha`, the lateral length factor (for checks and documentation).
    pub fn lateral_factor(&self, load: f64) -> f64 {
        1.0 / self.inverse_factors(load).lateral
    }

    /// d(inverse factor)/dFz, lateral and longitudinal, 1/N; zero off the ground, where
    /// the factors are fixed.
    pub fn inverse_factor_slopes(&self, load: f64) -> InverseLengthFactors {
        if load <= 0.0 {
            return InverseLengthFactors {
                lateral: 0.0,
                longitudinal: 0.0,
            };
        }
        let x = load * self.inverse_nominal_load;
        // 1/lateral factor = (1/x + x/c2^2) / (1 + 1/c2^2)
        let per_x = InverseLengthFactors {
            lateral: (-1.0 / (x * x) + self.inverse_peak_squared) * self.inverse_normalisation,
            longitudinal: -1.0 / (x * x),
        };
        InverseLengthFactors {
            lateral: per_x.lateral * self.inverse_nominal_load,
            longitudinal: per_x.longitudinal * self.inverse_nominal_load,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cornering_stiffness_law_has_its_documented_values() {
        let p = Parameters::default();
        let law = LoadLaw::new(&p);
        let nominal = p.get(Parameter::NominalLoad);
        assert_eq!(law.inverse_factors(nominal), InverseLengthFactors::NOMINAL);
        assert!((law.lateral_factor(2.0 * nominal) - 1.25).abs() < 1e-15);
        assert!((law.lateral_factor(0.5 * nominal) - 0.588).abs() < 5e-4);
        assert!((1.0 / law.inverse_factors(3.0 * nominal).longitudinal - 3.0).abs() < 1e-15);
        assert_eq!(law.inverse_factors(-1.0), InverseLengthFactors::NOMINAL);
    }

    #[test]
    fn slopes_match_central_differences() {
        let p = Parameters::default();
        let law = LoadLaw::new(&p);
        for load in [5_000.0, 50_000.0, 170_000.0] {
            let delta = 1.0;
            let plus = law.inverse_factors(load + delta);
            let minus = law.inverse_factors(load - delta);
            let slope = law.inverse_factor_slopes(load);
            let fd_lateral = (plus.lateral - minus.lateral) / (2.0 * delta);
            let fd_longitudinal = (plus.longitudinal - minus.longitudinal) / (2.0 * delta);
            assert!((slope.lateral - fd_lateral).abs() <= 1e-6 * fd_lateral.abs().max(1e-12));
            assert!((slope.longitudinal - fd_longitudinal).abs() <= 1e-6 * fd_longitudinal.abs());
        }
    }
}
