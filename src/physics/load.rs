//! Load dependence (docs/specification.md 4b): how the normal load stretches the
//! relaxation lengths.
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

/// Where the tire operates: the quantities its system matrices depend on
/// (docs/specification.md 4, 4b).
///
/// Speed and load enter every model the same way: the relaxation lengths scale with the
/// load, lateral ones by `Calpha(Fz)/Calpha`, longitudinal ones by `Fz/Fz0` (the
/// stiffnesses stay), so a relaxation rate `rho/(sigma factor)` is a nominal length
/// divided into `rho/factor`. With these five coordinates every model's matrices are
/// affine (no product of two, no division by any).
///
/// Stored as the array of coordinates that [`AffineSystem::evaluate`] indexes, so that a
/// point just made is read one coordinate at a time, never copied (a wide load of values
/// just stored one by one waits for them to reach the cache).
///
/// [`AffineSystem::evaluate`]: crate::physics::stepper::AffineSystem::evaluate
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingPoint {
    /// In the order of the accessors below; padded to a power of two so that a masked
    /// index needs no bounds check.
    coordinates: [f64; 8],
}

impl OperatingPoint {
    pub const COORDINATES: usize = 5;
    /// Index of `vx` among the coordinates.
    pub const VX: usize = 0;

    /// The operating point at speed `vx` with the relaxation lengths stretched by the load
    /// (`inverse` = 1 / length factors).
    pub fn new(vx: f64, inverse: InverseLengthFactors) -> Self {
        let rho = vx.abs();
        Self::from_coordinates([
            vx,
            rho * inverse.lateral,
            rho * inverse.longitudinal,
            inverse.lateral,
            inverse.longitudinal,
        ])
    }

    /// Longitudinal speed `vx`, m/s.
    pub const fn vx(&self) -> f64 {
        self.coordinates[0]
    }

    /// `rho / lateral length factor`, m/s: divided by a nominal lateral relaxation length
    /// it is that lag's rate.
    pub const fn lateral_relaxation_speed(&self) -> f64 {
        self.coordinates[1]
    }

    /// `rho / longitudinal length factor`, m/s.
    pub const fn longitudinal_relaxation_speed(&self) -> f64 {
        self.coordinates[2]
    }

    /// `1 / lateral length factor`: turns a nominal lateral length into the loaded one's
    /// inverse (for alphaT).
    pub const fn inverse_lateral_factor(&self) -> f64 {
        self.coordinates[3]
    }

    /// `1 / longitudinal length factor` (for kappaT).
    pub const fn inverse_longitudinal_factor(&self) -> f64 {
        self.coordinates[4]
    }

    pub fn coordinates(&self) -> [f64; Self::COORDINATES] {
        std::array::from_fn(|k| self.coordinates[k])
    }

    pub const fn from_coordinates(c: [f64; Self::COORDINATES]) -> Self {
        Self {
            coordinates: [c[0], c[1], c[2], c[3], c[4], 0.0, 0.0, 0.0],
        }
    }

    /// Coordinate `k & 7` (zero past the fifth).
    #[inline]
    pub(crate) fn coordinate(&self, k: u8) -> f64 {
        self.coordinates[k as usize & 7]
    }

    /// The point whose coordinate `coordinate` is 1 and the others zero.
    pub(crate) fn unit(coordinate: usize) -> Self {
        let mut c = [0.0; Self::COORDINATES];
        c[coordinate] = 1.0;
        Self::from_coordinates(c)
    }

    /// Whether both are the same point to the bit, for caches. (Compared coordinate by
    /// coordinate: an array comparison would become a memcmp call on the hot path.)
    pub fn same_as(&self, other: &OperatingPoint) -> bool {
        let (a, b) = (&self.coordinates, &other.coordinates);
        (0..Self::COORDINATES).all(|k| a[k].to_bits() == b[k].to_bits())
    }
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
