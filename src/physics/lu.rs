//! Small dense linear systems on fixed-size arrays, by Gaussian elimination with partial
//! pivoting: [`Factors`] keep the LU factors for many right-hand sides (a stiff substep
//! solves with one matrix once per step of a row); [`solve`] eliminates on a single
//! right-hand side as it goes, without storing factors (the sticking check's equilibrium,
//! where it is most of the check's work: factors and a separate solve made the stiff light
//! tire's sticking step a quarter to a third slower).

// Rows and columns index the factors and the vectors together.
#![allow(clippy::needless_range_loop)]

/// The LU factors of an `N`x`N` matrix over its first `size` rows and columns (the rest
/// unused), with partial pivoting, made in the matrix's own storage (a stiff substep
/// factors one matrix per row: copies of the whole array would cost more than the
/// elimination of its few entries in use). The pivots' reciprocals are kept: a solve
/// then multiplies, where its divisions, one per row in a chain, were most of its time.
pub struct Factors<'m, const N: usize> {
    lu: &'m [[f64; N]; N],
    pivots: [usize; N],
    inverse_diagonal: [f64; N],
    size: usize,
}

impl<'m, const N: usize> Factors<'m, N> {
    /// Factors `lu` in place; `None` if it is singular (or not finite).
    pub fn new(lu: &'m mut [[f64; N]; N], size: usize) -> Option<Self> {
        let size = size.min(N);
        let mut pivots = [0; N];
        let mut inverse_diagonal = [0.0; N];
        for k in 0..size {
            let p = (k..size).fold(k, |best, r| {
                if lu[r][k].abs() > lu[best][k].abs() {
                    r
                } else {
                    best
                }
            });
            let pivot = lu[p][k];
            if !(pivot != 0.0 && pivot.is_finite()) {
                return None;
            }
            if p != k {
                let (upper, lower) = lu.split_at_mut(p);
                upper[k][..size].swap_with_slice(&mut lower[0][..size]);
            }
            pivots[k] = p;
            inverse_diagonal[k] = pivot.recip();
            // The pivot row apart from the rows below it: the updates of a row are then
            // independent of each other, and go two at a time.
            let (upper, lower) = lu.split_at_mut(k + 1);
            let pivot_row = &upper[k][k + 1..size];
            for row in &mut lower[..size - k - 1] {
                let factor = row[k] * inverse_diagonal[k];
                row[k] = factor;
                for (entry, &above) in row[k + 1..size].iter_mut().zip(pivot_row) {
                    *entry -= factor * above;
                }
            }
        }
        Some(Self {
            lu,
            pivots,
            inverse_diagonal,
            size,
        })
    }

    /// The solution `x` of `A x = b`. By columns: once an entry is known, it is taken
    /// out of every row still to solve, so that the rows' updates do not wait on each
    /// other (by rows, each entry waits on a sum as long as its row).
    pub fn solve(&self, mut b: [f64; N]) -> [f64; N] {
        let (lu, size) = (&self.lu, self.size);
        // P A = L U: the row exchanges in order, then L and U.
        for k in 0..size {
            b.swap(k, self.pivots[k]);
        }
        for k in 0..size {
            let known = b[k];
            for r in k + 1..size {
                b[r] -= lu[r][k] * known;
            }
        }
        for k in (0..size).rev() {
            let known = b[k] * self.inverse_diagonal[k];
            b[k] = known;
            for r in 0..k {
                b[r] -= lu[r][k] * known;
            }
        }
        b
    }
}

/// The solution of `m x = rhs` over the first `size` rows and columns; `None` if `m` is
/// singular there or the solution is not finite.
pub fn solve<const N: usize>(mut m: [[f64; N]; N], mut rhs: [f64; N], size: usize) -> Option<[f64; N]> {
    for col in 0..size {
        let pivot = (col..size).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[pivot][col] == 0.0 {
            return None;
        }
        m.swap(col, pivot);
        rhs.swap(col, pivot);
        for row in col + 1..size {
            let factor = m[row][col] / m[col][col];
            for j in col..size {
                m[row][j] -= factor * m[col][j];
            }
            rhs[row] -= factor * rhs[col];
        }
    }
    let mut x = [0.0; N];
    for row in (0..size).rev() {
        let mut sum = rhs[row];
        for j in row + 1..size {
            sum -= m[row][j] * x[j];
        }
        x[row] = sum / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIZE: usize = 6;

    /// The factors and the elimination solve a system that needs row exchanges, to
    /// rounding, and refuse a singular one.
    #[test]
    fn factors_solve_with_row_exchanges() {
        let size = 4;
        let rows = [
            [0.0, 2.0, 1.0, -1.0],
            [3.0, 0.5, 0.0, 2.0],
            [1.0, 1.0, 4.0, 0.0],
            [-2.0, 0.0, 1.0, 5.0],
        ];
        let mut matrix = [[0.0; SIZE]; SIZE];
        for r in 0..size {
            matrix[r][..size].copy_from_slice(&rows[r]);
        }
        let solution = [1.0, -2.0, 0.5, 3.0];
        let mut b = [0.0; SIZE];
        for r in 0..size {
            b[r] = (0..size).map(|c| rows[r][c] * solution[c]).sum();
        }
        let factored = Factors::new(&mut matrix.clone(), size).expect("regular").solve(b);
        let eliminated = solve(matrix, b, size).expect("regular");
        for r in 0..size {
            assert!((factored[r] - solution[r]).abs() < 1e-14, "{r}: {}", factored[r]);
            assert!(
                (eliminated[r] - solution[r]).abs() < 1e-14,
                "{r}: {}",
                eliminated[r]
            );
        }
        let mut singular = matrix;
        singular[3] = [0.0; SIZE];
        assert!(Factors::new(&mut singular.clone(), size).is_none());
        assert!(solve(singular, b, size).is_none());
    }
}
