//! Fitting parameters to measurements (docs/specification.md 10): a measured run
//! ([`data`]) and a chosen model, law and set of free parameters with bounds; bounded
//! least squares ([`least_squares`]) over simulations by the FMU's exact step
//! ([`Tire::step`], the core the FMU steps with, in-process: a run of a few thousand
//! samples takes a fraction of a millisecond); the values with confidence intervals from
//! the output sensitivities.
//!
//! A run is simulated as the data are sampled: the inputs of row k are held from its time
//! to the next row's, and row k's outputs are the FMU's at its time with row k's inputs.
//! Each output is weighted by its noise: a first fit weighs them by their measured spread,
//! a second one, from the first's optimum, by the scatter of their residuals there, so
//! that the confidence intervals hold for outputs of different units and noise.

pub mod data;
pub mod least_squares;

use crate::physics::{Input, Parameter, Parameters, Tire};
use data::Measurements;
use least_squares::{Problem, Progress};

/// A free parameter and its bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Free {
    pub parameter: Parameter,
    pub lower: f64,
    pub upper: f64,
}

impl Free {
    /// Bounds a hundred times either side of `value` (from 0 for a parameter that may be
    /// zero), where none are given.
    pub fn around(parameter: Parameter, value: f64) -> Free {
        let (lower, upper) = if parameter.check(-1.0).is_ok() {
            let size = value.abs().max(1.0);
            (value - 100.0 * size, value + 100.0 * size)
        } else if parameter.check(0.0).is_ok() {
            (0.0, 100.0 * value.abs().max(1e-3))
        } else {
            (value.abs() / 100.0, value.abs() * 100.0)
        };
        Free {
            parameter,
            lower,
            upper,
        }
    }
}

/// One fitted parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub parameter: Parameter,
    pub value: f64,
    pub standard_error: f64,
    /// The 95 % confidence interval, `value +- 1.96 standard_error`.
    pub interval: (f64, f64),
}

/// The result of a fit.
#[derive(Clone, Debug)]
pub struct Fit {
    pub estimates: Vec<Estimate>,
    /// Every parameter as fitted (the free ones at their estimates).
    pub parameters: Parameters,
    /// By measured output: the root mean square of its residuals, in its unit.
    pub residual_rms: Vec<f64>,
    /// By measured output: the fitted run at the sample times.
    pub fitted: Vec<Vec<f64>>,
    /// Steps of the least-squares solve, both passes.
    pub iterations: usize,
    pub simulations: usize,
}

/// The outputs of `parameters` over the run of `measurements` (by measured output), or
/// why it cannot be simulated.
pub fn simulate(parameters: &Parameters, measurements: &Measurements) -> Result<Vec<Vec<f64>>, String> {
    let mut tire = Tire::new(parameters.clone()).map_err(|e| e.to_string())?;
    let n = measurements.time.len();
    let mut outputs = vec![Vec::with_capacity(n); measurements.outputs.len()];
    for k in 0..n {
        for input in Input::ALL {
            if let Some(series) = &measurements.inputs[input as usize] {
                tire.set_input(input, series[k]);
            }
        }
        let y = tire.outputs();
        for (series, (output, _)) in outputs.iter_mut().zip(&measurements.outputs) {
            series.push(y[*output as usize]);
        }
        if k + 1 < n {
            tire.step(measurements.time[k + 1] - measurements.time[k])
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(outputs)
}

/// Fits the free parameters of `start` to `measurements`; `progress` sees each step, with
/// its pass (1: outputs weighted by their spread; 2: by their residuals' scatter).
pub fn fit(
    start: &Parameters,
    free: &[Free],
    measurements: &Measurements,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<Fit, String> {
    let with = |values: &[f64]| -> Option<Parameters> {
        let mut p = start.clone();
        for (f, &v) in free.iter().zip(values) {
            p.set(f.parameter, v).ok()?;
        }
        Some(p)
    };
    // First by each output's spread, then by its residuals' scatter at that optimum.
    let spread = |series: &[f64]| {
        let mean = series.iter().sum::<f64>() / series.len() as f64;
        (series.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / series.len() as f64)
            .sqrt()
            .max(1e-12)
    };
    let mut scales: Vec<f64> = measurements.outputs.iter().map(|(_, s)| spread(s)).collect();
    let mut values: Vec<f64> = free.iter().map(|f| start.get(f.parameter)).collect();
    let mut simulations = 0;
    let mut iterations = 0;
    let mut solution = None;
    for pass in 1..=2 {
        let mut residuals = |values: &[f64]| -> Option<Vec<f64>> {
            simulations += 1;
            let outputs = simulate(&with(values)?, measurements).ok()?;
            let mut r = Vec::with_capacity(measurements.len());
            for ((simulated, (_, measured)), scale) in outputs.iter().zip(&measurements.outputs).zip(&scales)
            {
                r.extend(simulated.iter().zip(measured).map(|(s, m)| (s - m) / scale));
            }
            Some(r)
        };
        let mut problem = Problem {
            residuals: &mut residuals,
            start: values.clone(),
            lower: free.iter().map(|f| f.lower).collect(),
            upper: free.iter().map(|f| f.upper).collect(),
        };
        let found = least_squares::solve(&mut problem, &mut |p| progress(pass, p))
            .ok_or("the start cannot be simulated: check the parameters")?;
        iterations += found.iterations;
        values = found.parameters.clone();
        // The scatter of each output's residuals, in its unit.
        let per_output = measurements.time.len();
        for (k, scale) in scales.iter_mut().enumerate() {
            let slice = &found.residuals[k * per_output..(k + 1) * per_output];
            let rms = (slice.iter().map(|r| r * r).sum::<f64>() / per_output as f64).sqrt() * *scale;
            *scale = rms.max(1e-12 * *scale);
        }
        solution = Some(found);
    }
    let solution = solution.expect("two passes");
    let parameters = with(&values).expect("the fit's own values");
    let fitted = simulate(&parameters, measurements)?;
    let residual_rms = fitted
        .iter()
        .zip(&measurements.outputs)
        .map(|(f, (_, m))| {
            (f.iter().zip(m).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / m.len() as f64).sqrt()
        })
        .collect();
    let estimates = free
        .iter()
        .zip(&solution.parameters)
        .zip(&solution.standard_errors)
        .map(|((f, &value), &standard_error)| Estimate {
            parameter: f.parameter,
            value,
            standard_error,
            interval: (value - 1.96 * standard_error, value + 1.96 * standard_error),
        })
        .collect();
    Ok(Fit {
        estimates,
        parameters,
        residual_rms,
        fitted,
        iterations,
        simulations,
    })
}
