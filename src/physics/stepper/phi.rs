//! The exponential and the first two phi-functions of a small matrix X:
//! `e^X`, `phi1(X) = sum X^j/(j+1)!`, `phi2(X) = sum X^j/(j+2)!`.
//!
//! Over a step of length h, `dx/dt = A x + B (u0 + t du)` has the exact solution
//! `x(h) = e^(hA) x(0) + h phi1(hA) B u0 + h^2 phi2(hA) B du`. The phi-functions are entire,
//! so nothing divides by an eigenvalue: a lag at zero speed (A = 0) gives phi1 = 1, phi2 = 1/2.
//!
//! Method: scale X by 2^-s until its 1-norm is at most [`SCALED_NORM`], sum the Taylor
//! series of phi2 to the degree that leaves a remainder below the unit roundoff, derive
//! phi1 = I + X phi2 and e^X = I + X phi1, then square back s times with
//! `phi2(2X) = (e^X phi2 + phi1 + phi2)/4`, `phi1(2X) = (e^X + I) phi1/2`, `e^(2X) = (e^X)^2`.
//! Callers balance X first (`blocks`), so that the norm reflects the dynamics, not units.
//!
//! A lag (1x1) and a triangular pair (DDT's yaw and lateral lags) have their own forms:
//! where the arguments are small, the same Taylor series summed by Estrin's scheme (a tree
//! a few operations deep instead of a chain as long as the degree: a step waits on these
//! series, not on their arithmetic); elsewhere closed forms.

use crate::physics::math;
use nalgebra::SMatrix;

/// The 1-norm the scaled matrix is brought under before the Taylor series.
const SCALED_NORM: f64 = 0.5;
/// Highest Taylor degree; at 1-norm 0.5 the remainder is below 2^-53 from degree 13.
const MAX_DEGREE: usize = 16;
/// 1/k! for k = 0..=MAX_DEGREE + 3 (a series split into its even and odd parts runs to
/// an odd degree, up to MAX_DEGREE + 1).
const INVERSE_FACTORIAL: [f64; MAX_DEGREE + 4] = inverse_factorials();

/// `1/k!` for `k = 0..N`.
pub const fn inverse_factorials<const N: usize>() -> [f64; N] {
    let mut table = [1.0; N];
    let mut k = 1;
    while k < table.len() {
        table[k] = table[k - 1] / k as f64;
        k += 1;
    }
    table
}

/// `e^X`, `phi1(X)` and `phi2(X)` of one matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhiFunctions<const N: usize> {
    pub exp: SMatrix<f64, N, N>,
    pub phi1: SMatrix<f64, N, N>,
    pub phi2: SMatrix<f64, N, N>,
}

/// The number of halvings that bring `norm` to at most [`SCALED_NORM`]:
/// `ceil(log2(norm / SCALED_NORM))`, read off the bits of the ratio.
fn squarings_for(norm: f64) -> i32 {
    let ratio = norm / SCALED_NORM;
    if ratio <= 1.0 {
        return 0;
    }
    let bits = ratio.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let exact_power = bits & ((1 << 52) - 1) == 0;
    if exact_power { exponent } else { exponent + 1 }
}

/// `DEGREE_THRESHOLDS[m]`: the largest norm theta for which the Taylor remainder bound
/// theta^(m+1)/(m+1)! is at most the unit roundoff 2^-53 (by bisection, at compile time).
const DEGREE_THRESHOLDS: [f64; MAX_DEGREE] = {
    let mut thresholds = [0.0; MAX_DEGREE];
    let mut m = 0;
    while m < MAX_DEGREE {
        let (mut low, mut high) = (0.0, 1.0);
        let mut iteration = 0;
        while iteration < 80 {
            let middle = 0.5 * (low + high);
            let mut bound = 1.0;
            let mut k = 1;
            while k <= m + 1 {
                bound *= middle / k as f64;
                k += 1;
            }
            if bound <= f64::EPSILON / 2.0 {
                low = middle;
            } else {
                high = middle;
            }
            iteration += 1;
        }
        thresholds[m] = low;
        m += 1;
    }
    thresholds
};

/// 2^exponent for exponents in the normal range, built from its bits.
pub fn power_of_two(exponent: i32) -> f64 {
    let exponent = exponent.clamp(-1022, 1023);
    f64::from_bits(((exponent + 1023) as u64) << 52)
}

impl<const N: usize> PhiFunctions<N> {
    /// The phi-functions of the transposed matrix: f(X^T) = f(X)^T.
    pub fn transposed(&self) -> Self {
        PhiFunctions {
            exp: self.exp.transpose(),
            phi1: self.phi1.transpose(),
            phi2: self.phi2.transpose(),
        }
    }
}

fn one_norm<const N: usize>(x: &SMatrix<f64, N, N>) -> f64 {
    x.column_iter()
        .map(|column| column.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// `sum c[j] z^j` over the first eight coefficients by Estrin's scheme: pairs
/// `c[j] + c[j+1] z`, then pairs of pairs with `z^2`, then with `z^4`. A tree three
/// operations deep, where Horner's rule is a chain of seven, each waiting on the last.
#[inline(always)]
fn estrin8(c: &[f64], z: f64, z2: f64, z4: f64) -> f64 {
    let pair = |j: usize| c[j] + c[j + 1] * z;
    let (low, high) = (pair(0) + pair(2) * z2, pair(4) + pair(6) * z2);
    low + high * z4
}

/// [`estrin8`] over the first sixteen coefficients.
#[inline(always)]
fn estrin16(c: &[f64], z: f64, z2: f64, z4: f64, z8: f64) -> f64 {
    estrin8(&c[..8], z, z2, z4) + estrin8(&c[8..16], z, z2, z4) * z8
}

/// A lower-triangular 2x2 matrix `[[first, 0], [corner, second]]`, as the triangular pair's
/// series needs it.
#[derive(Clone, Copy)]
struct LowerTriangular {
    first: f64,
    second: f64,
    corner: f64,
}

impl LowerTriangular {
    fn times(self, other: Self) -> Self {
        Self {
            first: self.first * other.first,
            second: self.second * other.second,
            corner: self.corner * other.first + self.second * other.corner,
        }
    }

    fn plus(self, other: Self) -> Self {
        Self {
            first: self.first + other.first,
            second: self.second + other.second,
            corner: self.corner + other.corner,
        }
    }
}

/// [`estrin8`] of a lower-triangular matrix `x`, with its square and fourth power.
#[inline(always)]
fn estrin8_lower(c: &[f64], x: LowerTriangular, x2: LowerTriangular, x4: LowerTriangular) -> LowerTriangular {
    let pair = |j: usize| LowerTriangular {
        first: c[j] + c[j + 1] * x.first,
        second: c[j] + c[j + 1] * x.second,
        corner: c[j + 1] * x.corner,
    };
    let low = pair(0).plus(x2.times(pair(2)));
    let high = pair(4).plus(x2.times(pair(6)));
    low.plus(x4.times(high))
}

/// `(e^z, phi1(z), phi2(z))` of a scalar: the Taylor series where |z| is small, each to
/// the degree that leaves a remainder below the unit roundoff (7, or 15 up to
/// [`SCALED_NORM`]), summed by Estrin's scheme, the three side by side; the closed forms
/// `(e^z - 1)/z` and `(e^z - 1 - z)/z^2` (with `expm1`, which loses at most two bits
/// there) where it is not.
/// Always inlined: most callers use one or two of the three, and the others' series drop.
#[inline(always)]
pub fn scalar_phi_functions(z: f64) -> (f64, f64, f64) {
    const EXP: &[f64] = &INVERSE_FACTORIAL;
    let (phi1_series, phi2_series) = (&INVERSE_FACTORIAL[1..], &INVERSE_FACTORIAL[2..]);
    if z.abs() <= DEGREE_THRESHOLDS[7] {
        let (z2, z4) = (z * z, z * z * (z * z));
        (
            estrin8(EXP, z, z2, z4),
            estrin8(phi1_series, z, z2, z4),
            estrin8(phi2_series, z, z2, z4),
        )
    } else if z.abs() <= SCALED_NORM {
        let z2 = z * z;
        let z4 = z2 * z2;
        let z8 = z4 * z4;
        (
            estrin16(EXP, z, z2, z4, z8),
            estrin16(phi1_series, z, z2, z4, z8),
            estrin16(phi2_series, z, z2, z4, z8),
        )
    } else if z.is_finite() {
        let expm1 = math::exp_m1(z);
        (math::exp(z), expm1 / z, (expm1 - z) / (z * z))
    } else {
        (f64::NAN, f64::NAN, f64::NAN)
    }
}

/// `[phi1(z), phi2(z), phi3(z), phi4(z)]` of a scalar (`phi_k(z) = sum z^j/(j+k)!`), as an
/// exponential integrator of order four needs them: where |z| is small, phi4's Taylor
/// series (as in [`scalar_phi_functions`]) and the others from it by
/// `phi_k = 1/k! + z phi_(k+1)` (stable in that direction); elsewhere from `expm1` by
/// `phi_(k+1) = (phi_k - 1/k!)/z`.
#[inline]
pub fn scalar_phi_functions_to_fourth(z: f64) -> [f64; 4] {
    let phi4_series = &INVERSE_FACTORIAL[4..];
    let phi4 = if z.abs() <= DEGREE_THRESHOLDS[7] {
        estrin8(phi4_series, z, z * z, z * z * (z * z))
    } else if z.abs() <= SCALED_NORM {
        let z2 = z * z;
        let z4 = z2 * z2;
        estrin16(phi4_series, z, z2, z4, z4 * z4)
    } else {
        let phi1 = math::exp_m1(z) / z;
        let phi2 = (phi1 - 1.0) / z;
        let phi3 = (phi2 - INVERSE_FACTORIAL[2]) / z;
        return [phi1, phi2, phi3, (phi3 - INVERSE_FACTORIAL[3]) / z];
    };
    let phi3 = INVERSE_FACTORIAL[3] + z * phi4;
    let phi2 = INVERSE_FACTORIAL[2] + z * phi3;
    [1.0 + z * phi2, phi2, phi3, phi4]
}

/// The phi-functions of the lower-triangular `[[z1, 0], [c, z2]]` in closed form: the
/// diagonal holds `f(z1)`, `f(z2)` and the corner `c f[z1, z2]`, the divided difference
/// of f. `phi_k[z1, z2]` is the divided difference `exp[z1, z2, 0, ..., 0]` (k zeros),
/// summed as a series where both points are small and formed recursively otherwise,
/// dividing only by the larger point, so that equal or nearly equal points lose nothing.
#[inline]
pub fn lower_triangular_phi_functions(z1: f64, z2: f64, c: f64) -> PhiFunctions<2> {
    let matrix = |diagonal1: f64, diagonal2: f64, corner: f64| {
        SMatrix::<f64, 2, 2>::new(diagonal1, 0.0, corner, diagonal2)
    };
    let large = if z1.abs() >= z2.abs() { z1 } else { z2 };
    if large.abs() <= SCALED_NORM {
        // The Taylor series of phi2 on the three entries; the corner of X^n is
        // c h_(n-1)(z1, z2), |h_(n-1)| <= n |large|^(n-1), so two terms past the diagonal's
        // degree cover it, whatever c is: to degree 7 or 15 (enough up to SCALED_NORM),
        // summed by Estrin's scheme, as for a scalar.
        let x = LowerTriangular {
            first: z1,
            second: z2,
            corner: c,
        };
        let x2 = x.times(x);
        let x4 = x2.times(x2);
        let series = &INVERSE_FACTORIAL[2..];
        let phi2 = if degree_for(large.abs()) + 2 <= 7 {
            estrin8_lower(series, x, x2, x4)
        } else {
            let high = estrin8_lower(&series[8..], x, x2, x4);
            estrin8_lower(series, x, x2, x4).plus(x4.times(x4).times(high))
        };
        let (p1, p2, corner) = (phi2.first, phi2.second, phi2.corner);
        let (y1, y2, yc) = (x2.first, x2.second, x2.corner);
        // phi1 = I + X phi2 and e^X = I + X + X^2 phi2, side by side.
        let phi2 = matrix(p1, p2, corner);
        let phi1 = matrix(1.0 + z1 * p1, 1.0 + z2 * p2, c * p1 + z2 * corner);
        let exp = matrix(
            (1.0 + z1) + y1 * p1,
            (1.0 + z2) + y2 * p2,
            c + (yc * p1 + y2 * corner),
        );
        return PhiFunctions { exp, phi1, phi2 };
    }
    // exp[z1, z2] = e^high phi1(low - high), with high the larger point: phi1 of a
    // non-positive argument lies in (0, 1], so nothing overflows. Then, dividing only by
    // the point of larger magnitude (> SCALED_NORM),
    // phi_k[large, small] = (phi_k(small) - phi_(k-1)[large, small]) / (-large).
    let (e1, p11, p21) = scalar_phi_functions(z1);
    let (e2, p12, p22) = scalar_phi_functions(z2);
    let (phi1_small, phi2_small) = if large == z1 { (p12, p22) } else { (p11, p21) };
    let (high, low, e_high) = if z1 >= z2 { (z1, z2, e1) } else { (z2, z1, e2) };
    let exp_divided = e_high * scalar_phi_functions(low - high).1;
    let phi1_divided = (phi1_small - exp_divided) / -large;
    let phi2_divided = (phi2_small - phi1_divided) / -large;
    PhiFunctions {
        exp: matrix(e1, e2, c * exp_divided),
        phi1: matrix(p11, p12, c * phi1_divided),
        phi2: matrix(p21, p22, c * phi2_divided),
    }
}

/// Smallest Taylor degree whose remainder bound theta^(m+1)/(m+1)! is below the unit
/// roundoff. (A scan: its branches are predicted, so the series need not wait for the
/// degree, as it would for a table lookup.)
fn degree_for(theta: f64) -> usize {
    DEGREE_THRESHOLDS
        .iter()
        .position(|&largest| theta <= largest)
        .unwrap_or(MAX_DEGREE)
}

/// The phi-functions of `x`; NaN everywhere if `x` is not finite.
pub fn phi_functions<const N: usize>(x: &SMatrix<f64, N, N>) -> PhiFunctions<N> {
    let norm = one_norm(x);
    // (f64::max passes NaN over, so the entries are checked, not just the norm.)
    if !(norm.is_finite() && x.iter().all(|v| v.is_finite())) {
        let nan = SMatrix::from_element(f64::NAN);
        return PhiFunctions {
            exp: nan,
            phi1: nan,
            phi2: nan,
        };
    }
    let squarings = squarings_for(norm);
    // A power of two: the scaling itself is exact.
    let scaled = x * power_of_two(-squarings);
    let theta = norm * power_of_two(-squarings);
    // Smallest degree whose remainder bound theta^(m+1)/(m+1)! is below the unit roundoff.
    let degree = degree_for(theta);

    let identity = SMatrix::<f64, N, N>::identity();
    let mut phi2 = identity * INVERSE_FACTORIAL[degree + 2];
    for j in (0..degree).rev() {
        phi2 = scaled * phi2 + identity * INVERSE_FACTORIAL[j + 2];
    }
    let mut phi1 = identity + scaled * phi2;
    let mut exp = identity + scaled * phi1;
    for _ in 0..squarings {
        phi2 = (exp * phi2 + phi1 + phi2) * 0.25;
        phi1 = (exp * phi1 + phi1) * 0.5;
        exp = exp * exp;
    }
    PhiFunctions { exp, phi1, phi2 }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix1, Matrix2, Matrix3};

    use super::*;

    fn inverse_factorial(k: i32) -> f64 {
        (1..=k).fold(1.0, |f, i| f / f64::from(i))
    }

    fn scalar(z: f64) -> (f64, f64, f64) {
        let p = phi_functions(&Matrix1::new(z));
        let matrix = (p.exp[0], p.phi1[0], p.phi2[0]);
        let closed = scalar_phi_functions(z);
        // Squaring rounds a little more than the closed forms.
        let close = |a: f64, b: f64| a == b || (a - b).abs() <= 1e-13 * b.abs() || (a.is_nan() && b.is_nan());
        assert!(
            close(matrix.0, closed.0) && close(matrix.1, closed.1) && close(matrix.2, closed.2),
            "{z}: {matrix:?} {closed:?}"
        );
        closed
    }

    #[test]
    fn the_phi_functions_to_the_fourth_agree_with_their_series_and_closed_forms() {
        for z in [
            -1e4, -3.0, -0.5001, -0.4999, -0.2, -1e-3, 0.0, 1e-6, 0.3, 0.4999, 0.5001, 2.0,
        ] {
            let phi = scalar_phi_functions_to_fourth(z);
            let (_, phi1, phi2) = scalar_phi_functions(z);
            assert!(
                (phi[0] - phi1).abs() <= 1e-14 * phi1.abs() && (phi[1] - phi2).abs() <= 1e-14 * phi2.abs()
            );
            // phi3 and phi4 by their series where it converges fast, else by the recurrence.
            for k in [3, 4] {
                let expected = if z.abs() < 1.0 {
                    (0..40).map(|j| z.powi(j) * inverse_factorial(j + k)).sum::<f64>()
                } else {
                    let mut phi = z.exp_m1() / z;
                    for m in 1..k {
                        phi = (phi - inverse_factorial(m)) / z;
                    }
                    phi
                };
                let got = phi[k as usize - 1];
                assert!(
                    (got - expected).abs() <= 1e-12 * expected.abs(),
                    "z {z} k {k}: {got} vs {expected}"
                );
            }
        }
    }

    #[test]
    fn scalar_phi_functions_match_their_closed_forms() {
        for z in [
            -1e6, -1e3, -40.0, -3.0, -0.7, -0.2, -1e-3, -1e-9, 0.0, 1e-7, 0.3, 2.5,
        ] {
            let (e, p1, p2) = scalar(z);
            // Reference: the series where the closed forms cancel, the closed forms elsewhere.
            let series = |k: i32| (0..40).map(|j| z.powi(j) * inverse_factorial(j + k)).sum::<f64>();
            let (e_ref, p1_ref, p2_ref) = if z.abs() < 1.0 {
                (z.exp(), series(1), series(2))
            } else {
                (z.exp(), z.exp_m1() / z, (z.exp_m1() - z) / (z * z))
            };
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs().max(1e-300);
            assert!(
                close(e, e_ref) || (e - e_ref).abs() < 1e-300,
                "exp({z}) = {e}, want {e_ref}"
            );
            assert!(close(p1, p1_ref), "phi1({z}) = {p1}, want {p1_ref}");
            assert!(close(p2, p2_ref), "phi2({z}) = {p2}, want {p2_ref}");
        }
    }

    #[test]
    fn triangular_matrix_matches_divided_differences() {
        // For [[a, 0], [c, b]] the lower-left entry of f(X) is c f[a, b].
        let (a, b, c) = (-0.8, -2.3, 1.7);
        let p = phi_functions(&Matrix2::new(a, 0.0, c, b));
        let divided = (b.exp() - a.exp()) / (b - a);
        assert!((p.exp[(1, 0)] - c * divided).abs() < 1e-15);
        let phi1 = |z: f64| z.exp_m1() / z;
        let divided1 = (phi1(b) - phi1(a)) / (b - a);
        assert!((p.phi1[(1, 0)] - c * divided1).abs() < 1e-15);
    }

    #[test]
    fn triangular_closed_form_matches_the_series_with_squaring() {
        let cases = [
            (-0.02, -0.01, 0.01),
            (-0.3, -0.3, 2.0),
            (-0.4, -0.4 + 1e-9, -3.0),
            (-0.01, -0.02, 300.0),
            (0.0, 0.0, 1.0),
            (-0.7, -0.2, 5.0),
            (-3.0, -3.0, 0.5),
            (-40.0, -39.999, 7.0),
            (-1e4, -0.1, 1.0),
            (-800.0, 0.0, 1.0),
            (1.5, -2.0, 1.0),
        ];
        for (z1, z2, c) in cases {
            let closed = lower_triangular_phi_functions(z1, z2, c);
            let general = phi_functions(&Matrix2::new(z1, 0.0, c, z2));
            for (a, b) in [
                (closed.exp, general.exp),
                (closed.phi1, general.phi1),
                (closed.phi2, general.phi2),
            ] {
                // Squaring a stiff matrix 2^s times costs about 2^s roundings on its slow
                // mode (15 squarings at -1e4): the closed form is the more exact one.
                let scale = b.amax().max(1e-300);
                assert!((a - b).amax() <= 1e-11 * scale, "{z1} {z2} {c}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn an_undamped_oscillator_rotates_exactly() {
        // X = [[0, w], [-w, 0]]: e^X is a rotation by w, phi1 = sin(w)/w I + (1 - cos w)/w J.
        let w: f64 = 37.0;
        let p = phi_functions(&Matrix2::new(0.0, w, -w, 0.0));
        assert!((p.exp[(0, 0)] - w.cos()).abs() < 1e-13);
        assert!((p.exp[(0, 1)] - w.sin()).abs() < 1e-13);
        assert!((p.phi1[(0, 0)] - w.sin() / w).abs() < 1e-14);
        assert!((p.phi1[(0, 1)] - (1.0 - w.cos()) / w).abs() < 1e-14);
    }

    #[test]
    fn phi_identities_hold_for_a_stiff_matrix() {
        let x = Matrix3::new(-300.0, 2.0, 0.0, 5.0, -0.01, 1.0, 0.0, -40.0, -7.0);
        let p = phi_functions(&x);
        let identity = Matrix3::identity();
        // e^X = I + X phi1 and phi1 = I + X phi2 (within rounding of the large entries).
        assert!((p.exp - (identity + x * p.phi1)).amax() < 1e-12);
        assert!((p.phi1 - (identity + x * p.phi2)).amax() < 1e-12);
    }

    #[test]
    fn non_finite_input_gives_nan() {
        assert!(scalar(f64::NAN).0.is_nan());
        assert!(scalar(f64::INFINITY).1.is_nan());
    }
}
