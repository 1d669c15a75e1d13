//! Linearly implicit Euler extrapolation of one substep, for a stiff piece: a spring group
//! sliding on the friction ellipse turns its force towards the sliding direction at a rate
//! of about `K |g| / L`, which for a stiff tire at a light load is far faster than
//! anything else in the tire. The explicit midpoint rule would need substeps of that time
//! scale; this method is stable at any.
//!
//! Row `j` takes `n_j` steps of `s = H / n_j`, each solving
//! `(I - s J) (z_{k+1} - z_k) = s f(t_k, z_k)` with the Jacobian `J` of the piece's
//! right-hand side at the substep's start (by differences: the right-hand side is smooth
//! within a piece). The rows have an expansion in powers of `s` for any `J`, so polynomial
//! extrapolation in `s` ([`super::extrapolation`]) raises the order by one a row, to the
//! same relative 1e-12 as the explicit substep.

use super::extrapolation::Row;
use super::{Events, Modes, SIZE, SlidingStep, Vector};
use crate::physics::lu::Factors;

/// Step counts of the rows (the harmonic sequence).
pub(super) const IMPLICIT_SEQUENCE: [usize; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

/// A square matrix over the entries of the coupled vector, by row (only the entries in
/// use are read).
pub(super) type Matrix = [[f64; SIZE]; SIZE];

/// The Jacobian of a piece's right-hand side.
pub(super) type Jacobian = Matrix;

impl SlidingStep<'_> {
    /// The Jacobian of the piece's right-hand side at `z` by forward differences, the
    /// increment of each entry a square root of the rounding unit of its size (at least of
    /// the deflection scale).
    pub(super) fn jacobian(&self, t: f64, z: &Vector, rates: &Vector, modes: &Modes) -> Jacobian {
        let size = self.size();
        let mut jacobian = [[0.0; SIZE]; SIZE];
        for c in 0..size {
            let increment = 1.5e-8 * z[c].abs().max(self.scale);
            let mut moved = *z;
            moved[c] += increment;
            let increment = moved[c] - z[c];
            let (moved_rates, _) = self.rates(t, &moved, modes);
            for r in 0..size {
                jacobian[r][c] = (moved_rates[r] - rates[r]) / increment;
            }
        }
        jacobian
    }

    /// `n` linearly implicit Euler steps over `[t, t + length]`, `I - s J` factored in
    /// `work` (only its entries in use are written); `None` if that matrix is singular.
    /// Also where a limit may have been touched, as the explicit row finds it, and the
    /// sample spacing.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn implicit_row(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        (jacobian, work): (&Jacobian, &mut Matrix),
        length: f64,
        n: usize,
        modes: &Modes,
    ) -> Option<Row> {
        let size = self.size();
        let s = length / n as f64;
        for r in 0..size {
            for c in 0..size {
                work[r][c] = -s * jacobian[r][c];
            }
            work[r][r] += 1.0;
        }
        let lu = Factors::new(work, size)?;
        let row = self.stepped_row(t, z, start, length, n, modes, |scaled_rates| {
            lu.solve(scaled_rates)
        });
        row.0[..size].iter().all(|v| v.is_finite()).then_some(row)
    }
}
