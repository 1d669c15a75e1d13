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
//! extrapolation in `s` raises the order by one a row, to the same relative 1e-12 as the
//! explicit substep ([`super::extrapolation`]).

use nalgebra::SMatrix;

use super::events::{Interior, InteriorSearch};
use super::{Events, Modes, SIZE, SlidingStep, Vector};

/// Step counts of the rows (the harmonic sequence).
const SEQUENCE: [usize; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

type Jacobian = SMatrix<f64, SIZE, SIZE>;

/// One row's end, and where a limit may have been touched inside it.
type Row = (Vector, Option<Interior>, Option<Interior>, f64);

impl SlidingStep<'_> {
    /// The Jacobian of the piece's right-hand side at `z` by forward differences, the
    /// increment of each entry a square root of the rounding unit of its size (at least of
    /// the deflection scale).
    fn jacobian(&self, t: f64, z: &Vector, rates: &Vector, modes: &Modes) -> Jacobian {
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
    fn implicit_row(
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

    /// One extrapolated substep by the linearly implicit rows; as
    /// [`SlidingStep::extrapolate`] for the explicit ones.
    pub(super) fn extrapolate_implicit(
        &self,
        t: f64,
        z: &Vector,
        length: f64,
        modes: &Modes,
        look_inside: bool,
    ) -> Option<(Vector, f64, Option<Interior>, f64)> {
        let (start_rates, start_events) = self.rates(t, z, modes);
        let jacobian = self.jacobian(t, z, &start_rates, modes);
        let mut table = [[0.0; SIZE]; SEQUENCE.len()];
        for j in 0..SEQUENCE.len() {
            let mut row = [[0.0; SIZE]; SEQUENCE.len()];
            let (interior, closest, spacing);
            (row[0], interior, closest, spacing) = self.implicit_row(
                t,
                z,
                (&start_rates, &start_events),
                &jacobian,
                length,
                SEQUENCE[j],
                modes,
            )?;
            for k in 1..=j {
                let ratio = SEQUENCE[j] as f64 / SEQUENCE[j - k] as f64 - 1.0;
                for c in 0..SIZE {
                    row[k][c] = row[k - 1][c] + (row[k - 1][c] - table[k - 1][c]) / ratio;
                }
            }
            if j >= 2 {
                let error = self.error_ratio(z, &row[j], &row[j - 1]);
                if error <= 1.0 {
                    // Error ~ length^(j + 1): aim at a third of the tolerance next time.
                    let growth = 0.9 * (3.0 * error).max(1e-10).powf(-1.0 / (j + 1) as f64);
                    let interior = if look_inside { interior.or(closest) } else { None };
                    return Some((row[j], growth.clamp(0.2, 4.0), interior, spacing));
                }
            }
            table = row;
        }
        None
    }
}
