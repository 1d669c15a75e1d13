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

use nalgebra::SMatrix;

use super::events::InteriorSearch;
use super::extrapolation::Row;
use super::{Events, Modes, SIZE, SlidingStep, Vector};

/// Step counts of the rows (the harmonic sequence).
pub(super) const IMPLICIT_SEQUENCE: [usize; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

pub(super) type Jacobian = SMatrix<f64, SIZE, SIZE>;

impl SlidingStep<'_> {
    /// The Jacobian of the piece's right-hand side at `z` by forward differences, the
    /// increment of each entry a square root of the rounding unit of its size (at least of
    /// the deflection scale).
    pub(super) fn jacobian(&self, t: f64, z: &Vector, rates: &Vector, modes: &Modes) -> Jacobian {
        let mut jacobian = Jacobian::zeros();
        for c in 0..SIZE {
            let increment = 1.5e-8 * z[c].abs().max(self.scale);
            let mut moved = *z;
            moved[c] += increment;
            let increment = moved[c] - z[c];
            let (moved_rates, _) = self.rates(t, &moved, modes);
            for r in 0..SIZE {
                jacobian[(r, c)] = (moved_rates[r] - rates[r]) / increment;
            }
        }
        jacobian
    }

    /// `n` linearly implicit Euler steps over `[t, t + length]`; `None` if a matrix
    /// `I - s J` is singular. Also where a limit may have been touched, as the explicit
    /// row finds it, and the sample spacing.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn implicit_row(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        jacobian: &Jacobian,
        length: f64,
        n: usize,
        modes: &Modes,
    ) -> Option<Row> {
        let s = length / n as f64;
        let lu = (Jacobian::identity() - jacobian * s).lu();
        let mut current = nalgebra::SVector::<f64, SIZE>::from_column_slice(z);
        let mut rates = nalgebra::SVector::<f64, SIZE>::from_column_slice(start_rates);
        let mut search = InteriorSearch::new(start_events);
        for k in 0..n {
            if k > 0 {
                let (next_rates, events) = self.rates(t + k as f64 * s, &current.into(), modes);
                search.sample(k, s, &events);
                rates = nalgebra::SVector::<f64, SIZE>::from_column_slice(&next_rates);
            }
            let change = lu.solve(&(rates * s))?;
            current += change;
        }
        let (interior, closest) = search.found();
        let end: Vector = current.into();
        end.iter()
            .all(|v| v.is_finite())
            .then_some((end, interior, closest, s))
    }
}
