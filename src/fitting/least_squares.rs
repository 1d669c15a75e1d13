//! Bounded nonlinear least squares by Levenberg-Marquardt: the step solves
//! `(J^T J + mu diag(J^T J)) dp = -J^T r` (Marquardt's scaling, so the parameters' units
//! do not matter), is cut back to the bounds, and is kept if it lowers the sum of squares.
//! At the optimum the covariance is `s^2 (J^T J)^-1`, `s^2 = |r|^2 / (n - p)`.

use nalgebra::{DMatrix, DVector};

/// A problem: `residuals(p)` (length n, `None` where p cannot be simulated), the start,
/// and the bounds of each parameter.
pub struct Problem<'a> {
    pub residuals: &'a mut dyn FnMut(&[f64]) -> Option<Vec<f64>>,
    pub start: Vec<f64>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

/// The optimum and what it says about the parameters.
#[derive(Clone, Debug)]
pub struct Solution {
    pub parameters: Vec<f64>,
    /// Standard error of each parameter (the square root of the covariance's diagonal).
    pub standard_errors: Vec<f64>,
    /// `|r|^2 / (n - p)`: the residual variance.
    pub residual_variance: f64,
    pub residuals: Vec<f64>,
    pub iterations: usize,
    pub evaluations: usize,
}

/// How a step of the solve went, for a progress display.
pub struct Progress<'a> {
    pub iteration: usize,
    pub sum_of_squares: f64,
    pub parameters: &'a [f64],
}

fn sum_of_squares(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// The Jacobian by central differences, each parameter moved by 1e-6 of its size (at least
/// 1e-6 of its bound interval), kept inside its bounds.
fn jacobian(problem: &mut Problem, p: &[f64], evaluations: &mut usize) -> Option<DMatrix<f64>> {
    let mut columns = Vec::with_capacity(p.len());
    for j in 0..p.len() {
        let span = (problem.upper[j] - problem.lower[j]).abs();
        let delta = (1e-6 * p[j].abs()).max(1e-9 * span.min(1e12)).max(1e-12);
        let (mut plus, mut minus) = (p.to_vec(), p.to_vec());
        plus[j] = (p[j] + delta).min(problem.upper[j]);
        minus[j] = (p[j] - delta).max(problem.lower[j]);
        let high = (problem.residuals)(&plus)?;
        let low = (problem.residuals)(&minus)?;
        *evaluations += 2;
        let width = plus[j] - minus[j];
        columns.push(DVector::from_iterator(
            high.len(),
            high.iter().zip(&low).map(|(h, l)| (h - l) / width),
        ));
    }
    Some(DMatrix::from_columns(&columns))
}

/// Solves `problem`; `progress` is told of every accepted step. `None` if the start cannot
/// be simulated.
pub fn solve(problem: &mut Problem, progress: &mut dyn FnMut(Progress)) -> Option<Solution> {
    let n_parameters = problem.start.len();
    let mut p: Vec<f64> = (problem.start.iter().enumerate())
        .map(|(j, &v)| v.clamp(problem.lower[j], problem.upper[j]))
        .collect();
    let mut r = (problem.residuals)(&p)?;
    let mut evaluations = 1;
    let mut cost = sum_of_squares(&r);
    let mut mu = 1e-3;
    let mut iterations = 0;
    let mut j = jacobian(problem, &p, &mut evaluations)?;
    progress(Progress {
        iteration: 0,
        sum_of_squares: cost,
        parameters: &p,
    });
    while iterations < 200 {
        iterations += 1;
        let jtj = j.transpose() * &j;
        let gradient = j.transpose() * DVector::from_vec(r.clone());
        let mut accepted = false;
        for _ in 0..30 {
            let mut damped = jtj.clone();
            for k in 0..n_parameters {
                damped[(k, k)] += mu * jtj[(k, k)].max(1e-300);
            }
            let Some(step) = damped.cholesky().map(|c| c.solve(&(-&gradient))) else {
                mu *= 10.0;
                continue;
            };
            let trial: Vec<f64> = (0..n_parameters)
                .map(|k| (p[k] + step[k]).clamp(problem.lower[k], problem.upper[k]))
                .collect();
            evaluations += 1;
            match (problem.residuals)(&trial) {
                Some(trial_r) if sum_of_squares(&trial_r) < cost => {
                    let new_cost = sum_of_squares(&trial_r);
                    let moved =
                        (0..n_parameters).any(|k| (trial[k] - p[k]).abs() > 1e-12 * p[k].abs().max(1e-300));
                    let relative_gain = (cost - new_cost) / cost.max(f64::MIN_POSITIVE);
                    p = trial;
                    r = trial_r;
                    cost = new_cost;
                    mu = (mu * 0.3).max(1e-12);
                    accepted = moved && relative_gain > 1e-12;
                    break;
                }
                _ => mu *= 10.0,
            }
        }
        if !accepted {
            break;
        }
        progress(Progress {
            iteration: iterations,
            sum_of_squares: cost,
            parameters: &p,
        });
        j = jacobian(problem, &p, &mut evaluations)?;
    }
    let dof = (r.len() as f64 - n_parameters as f64).max(1.0);
    let residual_variance = cost / dof;
    let covariance = (j.transpose() * &j).try_inverse();
    let standard_errors = (0..n_parameters)
        .map(|k| {
            covariance
                .as_ref()
                .map_or(f64::INFINITY, |c| (residual_variance * c[(k, k)]).max(0.0).sqrt())
        })
        .collect();
    Some(Solution {
        parameters: p,
        standard_errors,
        residual_variance,
        residuals: r,
        iterations,
        evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a exp(-b t) with noise-free data: the fit returns a and b; with known noise
    /// the standard errors match the ones of the linearised problem.
    #[test]
    fn fits_an_exponential_decay_within_bounds() {
        let t: Vec<f64> = (0..50).map(|k| 0.1 * k as f64).collect();
        let data: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
        let mut residuals = |p: &[f64]| -> Option<Vec<f64>> {
            Some(
                t.iter()
                    .zip(&data)
                    .map(|(t, y)| p[0] * (-p[1] * t).exp() - y)
                    .collect(),
            )
        };
        let mut problem = Problem {
            residuals: &mut residuals,
            start: vec![1.0, 2.0],
            lower: vec![0.0, 0.0],
            upper: vec![10.0, 10.0],
        };
        let solution = solve(&mut problem, &mut |_| {}).unwrap();
        assert!(
            (solution.parameters[0] - 3.0).abs() < 1e-8,
            "{:?}",
            solution.parameters
        );
        assert!(
            (solution.parameters[1] - 0.7).abs() < 1e-8,
            "{:?}",
            solution.parameters
        );
        // A bound that excludes the optimum holds.
        let mut problem = Problem {
            residuals: &mut residuals,
            start: vec![1.0, 2.0],
            lower: vec![0.0, 1.0],
            upper: vec![10.0, 10.0],
        };
        let solution = solve(&mut problem, &mut |_| {}).unwrap();
        assert_eq!(solution.parameters[1], 1.0);
    }
}
