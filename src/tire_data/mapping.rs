//! From a tire property file to TireLag's parameters (docs/specification.md 10): each
//! value at the nominal load, zero camber and nominal pressure, with the scaling factors
//! (`L...`) 1 and PKY4 2 where the file has none. Each mapped value keeps the formula and
//! the keys it came from.

use std::fmt;

use super::tir::TirFile;
use crate::physics::Parameter;
use crate::physics::math::{atan, exp, ln, sin};

/// One parameter the file sets, and where its value came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Mapped {
    pub parameter: Parameter,
    pub value: f64,
    /// The formula, then each key's value and line (or "absent: default").
    pub source: String,
}

/// Everything a file sets, and what the mapping noticed on the way (a fitted load peak).
#[derive(Clone, Debug, PartialEq)]
pub struct Mapping {
    pub values: Vec<Mapped>,
    pub notes: Vec<String>,
}

/// Why a file cannot be mapped: the key (if one is to blame), its line and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct MappingError {
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for MappingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "line {line}: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for MappingError {}

/// Reads keys of a file and records, for the value being mapped, which ones it used.
struct Keys<'a> {
    file: &'a TirFile,
    used: Vec<String>,
}

impl Keys<'_> {
    fn read(&mut self, key: &str) -> Result<Option<f64>, MappingError> {
        let found = self.file.number(key).map_err(|e| MappingError {
            line: Some(e.line),
            message: e.message,
        })?;
        Ok(found.map(|(value, entry)| {
            self.used
                .push(format!("{} = {value} (line {})", entry.key, entry.line));
            value
        }))
    }

    /// A key the mapping cannot do without.
    fn required(&mut self, key: &str, needed_for: &str) -> Result<f64, MappingError> {
        self.read(key)?.ok_or_else(|| MappingError {
            line: None,
            message: format!("the file has no {key}, which {needed_for} needs"),
        })
    }

    /// A key with a default where the file has none (the scaling factors, PKY4).
    fn or(&mut self, key: &str, default: f64) -> Result<f64, MappingError> {
        Ok(match self.read(key)? {
            Some(value) => value,
            None => {
                self.used.push(format!("{key} absent: {default}"));
                default
            }
        })
    }

    fn present(&self, key: &str) -> bool {
        self.file.entry(key).is_some()
    }
}

/// The cornering stiffness of MF at a load ratio `x = Fz/Fz0`, per unit of its value at
/// the nominal load: `sin(PKY4 atan(x / PKY2)) / sin(PKY4 atan(1 / PKY2))`.
fn cornering_stiffness_ratio(x: f64, pky2: f64, pky4: f64) -> f64 {
    sin(pky4 * atan(x / pky2)) / sin(pky4 * atan(1.0 / pky2))
}

/// TireLag's load law per unit of its nominal value: `x (1 + 1/c2^2) / (1 + x^2/c2^2)`.
fn load_law_ratio(x: f64, c2: f64) -> f64 {
    x * (1.0 + 1.0 / (c2 * c2)) / (1.0 + x * x / (c2 * c2))
}

/// The `c2` of TireLag's load law that fits MF's cornering stiffness best, in least
/// squares on load ratios 0.25 to 2 (for PKY4 = 2 it is |PKY2| exactly).
fn fitted_load_peak(pky2: f64, pky4: f64) -> (f64, f64) {
    let samples: Vec<f64> = (0..=70).map(|k| 0.25 + 0.025 * k as f64).collect();
    let error = |log_c2: f64| {
        let c2 = exp(log_c2);
        samples
            .iter()
            .map(|&x| (load_law_ratio(x, c2) - cornering_stiffness_ratio(x, pky2, pky4)).powi(2))
            .sum::<f64>()
    };
    // A scan over c2 from 0.05 to 50, then golden sections around the best point.
    let (low, high) = (ln(0.05), ln(50.0));
    let grid = 400;
    let step = (high - low) / grid as f64;
    let best = (0..=grid)
        .map(|k| low + step * k as f64)
        .min_by(|a, b| error(*a).total_cmp(&error(*b)))
        .expect("a grid");
    let (mut a, mut b) = (best - step, best + step);
    let ratio = 0.5 * (5.0_f64.sqrt() - 1.0);
    for _ in 0..100 {
        let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
        if error(c) < error(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let log_c2 = 0.5 * (a + b);
    let rms = (error(log_c2) / samples.len() as f64).sqrt();
    (exp(log_c2), rms)
}

/// Maps a parsed property file: each parameter the file determines, with its source.
pub fn map(file: &TirFile) -> Result<Mapping, MappingError> {
    match (file.has_section("MDI_HEADER"), file.text("FILE_TYPE")) {
        (true, Some(kind)) if kind.eq_ignore_ascii_case("tir") => {}
        (true, _) => {
            return Err(MappingError {
                line: file.entry("FILE_TYPE").map(|e| e.line),
                message: "[MDI_HEADER] must have FILE_TYPE = 'tir'".into(),
            });
        }
        (false, _) => {
            return Err(MappingError {
                line: None,
                message: "no [MDI_HEADER] section: not a tire property file".into(),
            });
        }
    }
    let mut mapping = Mapping {
        values: Vec::new(),
        notes: Vec::new(),
    };
    let mut keys = Keys {
        file,
        used: Vec::new(),
    };
    let mut set = |keys: &mut Keys, parameter: Parameter, value: f64, formula: &str| {
        let used = std::mem::take(&mut keys.used);
        if let Err(e) = parameter.check(value) {
            return Err(MappingError {
                line: None,
                message: format!("{formula} gives {e} (from {})", used.join(", ")),
            });
        }
        mapping.values.push(Mapped {
            parameter,
            value,
            source: format!("{formula}; {}", used.join(", ")),
        });
        Ok(())
    };

    let nominal_load = keys.required("FNOMIN", "Fz0")? * keys.or("LFZO", 1.0)?;
    set(
        &mut keys,
        Parameter::NominalLoad,
        nominal_load,
        "Fz0 = FNOMIN·LFZO",
    )?;

    let pky1 = keys.required("PKY1", "Calpha")?;
    let pky2 = keys.required("PKY2", "Calpha")?;
    let pky4 = keys.or("PKY4", 2.0)?;
    let calpha = (pky1 * nominal_load * sin(pky4 * atan(1.0 / pky2))).abs() * keys.or("LKY", 1.0)?;
    keys.used.push(format!("Fz0 = {nominal_load}"));
    set(
        &mut keys,
        Parameter::CorneringStiffness,
        calpha,
        "Calpha = |PKY1·Fz0·sin(PKY4·atan(1/PKY2))|·LKY",
    )?;

    let pky2 = keys.required("PKY2", "calphaLoadPeak")?;
    let pky4 = keys.or("PKY4", 2.0)?;
    if pky4 == 2.0 {
        set(
            &mut keys,
            Parameter::CorneringStiffnessPeakLoad,
            pky2.abs(),
            "calphaLoadPeak = |PKY2|",
        )?;
    } else {
        let (c2, rms) = fitted_load_peak(pky2, pky4);
        mapping.notes.push(format!(
            "PKY4 = {pky4} is not 2: calphaLoadPeak = {c2:.6} fits MF's Kya(Fz) best on 0.25-2 Fz0 \
             (rms difference {:.2} % of Calpha)",
            100.0 * rms
        ));
        set(
            &mut keys,
            Parameter::CorneringStiffnessPeakLoad,
            c2,
            "calphaLoadPeak = the c2 that fits Kya(Fz) best on 0.25-2 Fz0",
        )?;
    }

    let ckappa = keys.required("PKX1", "Ckappa")? * nominal_load * keys.or("LKX", 1.0)?;
    keys.used.push(format!("Fz0 = {nominal_load}"));
    set(
        &mut keys,
        Parameter::SlipStiffness,
        ckappa,
        "Ckappa = PKX1·Fz0·LKX",
    )?;

    let mu_x = keys.required("PDX1", "muX")?.abs() * keys.or("LMUX", 1.0)?;
    set(
        &mut keys,
        Parameter::LongitudinalFriction,
        mu_x,
        "muX = |PDX1|·LMUX",
    )?;
    let pdy1 = keys.required("PDY1", "muY")?;
    let mu_y = pdy1.abs() * keys.or("LMUY", 1.0)?;
    set(&mut keys, Parameter::LateralFriction, mu_y, "muY = |PDY1|·LMUY")?;
    let pdy2 = keys.required("PDY2", "muLoadSensitivity")?;
    let pdy1 = keys.required("PDY1", "muLoadSensitivity")?;
    set(
        &mut keys,
        Parameter::FrictionLoadSensitivity,
        pdy2 / pdy1,
        "muLoadSensitivity = PDY2/PDY1",
    )?;

    if keys.present("LATERAL_STIFFNESS") {
        let stiffness = keys.required("LATERAL_STIFFNESS", "sigmaY")?;
        keys.used.push(format!("Calpha = {calpha}"));
        set(
            &mut keys,
            Parameter::LateralRelaxationLength,
            calpha / stiffness,
            "sigmaY = Calpha/LATERAL_STIFFNESS",
        )?;
    } else {
        let pty1 = keys.required("PTY1", "sigmaY (without LATERAL_STIFFNESS)")?;
        let pty2 = keys.required("PTY2", "sigmaY (without LATERAL_STIFFNESS)")?;
        let radius = keys.required("UNLOADED_RADIUS", "sigmaY")?;
        let sigma =
            pty1 * sin(2.0 * atan(1.0 / pty2)) * radius * keys.or("LFZO", 1.0)? * keys.or("LSGAL", 1.0)?;
        set(
            &mut keys,
            Parameter::LateralRelaxationLength,
            sigma,
            "sigmaY = PTY1·sin(2·atan(1/PTY2))·UNLOADED_RADIUS·LFZO·LSGAL",
        )?;
    }
    if keys.present("LONGITUDINAL_STIFFNESS") {
        let stiffness = keys.required("LONGITUDINAL_STIFFNESS", "sigmaX")?;
        keys.used.push(format!("Ckappa = {ckappa}"));
        set(
            &mut keys,
            Parameter::LongitudinalRelaxationLength,
            ckappa / stiffness,
            "sigmaX = Ckappa/LONGITUDINAL_STIFFNESS",
        )?;
    } else {
        let ptx1 = keys.required("PTX1", "sigmaX (without LONGITUDINAL_STIFFNESS)")?;
        let radius = keys.required("UNLOADED_RADIUS", "sigmaX")?;
        let sigma = ptx1 * radius * keys.or("LSGKP", 1.0)?;
        set(
            &mut keys,
            Parameter::LongitudinalRelaxationLength,
            sigma,
            "sigmaX = PTX1·UNLOADED_RADIUS·LSGKP",
        )?;
    }

    let trail =
        keys.required("QDZ1", "trail")? * keys.required("UNLOADED_RADIUS", "trail")? * keys.or("LTR", 1.0)?;
    set(
        &mut keys,
        Parameter::PneumaticTrail,
        trail,
        "trail = QDZ1·UNLOADED_RADIUS·LTR",
    )?;

    let effective = ["FREFF", "DREFF", "BREFF", "VERTICAL_STIFFNESS"];
    if effective.iter().all(|key| keys.present(key)) {
        let radius = keys.required("UNLOADED_RADIUS", "Re")?;
        let (freff, dreff, breff) = (
            keys.required("FREFF", "Re")?,
            keys.required("DREFF", "Re")?,
            keys.required("BREFF", "Re")?,
        );
        let vertical = keys.required("VERTICAL_STIFFNESS", "Re")?;
        let fnomin = keys.required("FNOMIN", "Re")?;
        // The deflection at Fz0 over the one at FNOMIN (linear vertical stiffness).
        let relative = nominal_load / fnomin;
        let re = radius - fnomin / vertical * (dreff * atan(breff * relative) + freff * relative);
        set(
            &mut keys,
            Parameter::RollingRadius,
            re,
            "Re = UNLOADED_RADIUS - FNOMIN/VERTICAL_STIFFNESS·(DREFF·atan(BREFF·rho) + FREFF·rho), rho = Fz0/FNOMIN",
        )?;
    } else {
        let radius = keys.required("UNLOADED_RADIUS", "Re")?;
        set(
            &mut keys,
            Parameter::RollingRadius,
            radius,
            "Re = UNLOADED_RADIUS",
        )?;
    }
    Ok(mapping)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_load_peak_of_pky4_2_is_pky2() {
        for pky2 in [0.8, 1.7, 2.5] {
            assert_eq!(cornering_stiffness_ratio(1.0, pky2, 2.0), 1.0);
            for x in [0.3, 1.0, 1.9] {
                let (mf, law) = (cornering_stiffness_ratio(x, pky2, 2.0), load_law_ratio(x, pky2));
                assert!((mf - law).abs() < 1e-14, "{mf} {law}");
            }
            let (c2, rms) = fitted_load_peak(pky2, 2.0);
            assert!((c2 - pky2).abs() < 1e-6 * pky2 && rms < 1e-9, "{c2} {rms}");
        }
        // Another PKY4: a c2 near the peak, with a small misfit.
        let (c2, rms) = fitted_load_peak(1.7, 1.6);
        assert!(c2 > 1.0 && c2 < 4.0 && rms < 0.05, "{c2} {rms}");
    }
}
