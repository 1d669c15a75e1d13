//! The four-branch split of a contact element for the `Brush` friction law
//! (docs/specification.md 4c).
//!
//! Each contact element is split into four parallel branches. Branch `i` is a spring (and,
//! where the element has one, a damper) with the fraction `w_i` of the element's stiffness
//! (and damping), in series with a rate-independent Coulomb slider whose limit is the
//! fraction `phi_i` of the element's friction limit `Fmax`; `sum w_i = sum phi_i = 1`.
//!
//! # Steady state
//!
//! In steady rolling at slip angle `alpha`, branch `i` carries
//! `min(w_i Calpha |alpha|, phi_i Fmax)`, so with `x = Calpha |alpha| / Fmax`
//!
//! ```text
//! F(x) / Fmax = sum_i min(w_i x, phi_i)
//! ```
//!
//! a concave, piecewise-linear curve with breakpoints `x_i = phi_i / w_i`: `F = x` (all
//! branches stick, the linear model `Calpha alpha`) up to the smallest breakpoint, `F = 1`
//! (all branches slide) beyond the largest.
//!
//! # The fit
//!
//! Target: the brush curve `b(x) = 3t - 3t^2 + t^3`, `t = min(1, x/3)`. Constraints: the
//! smallest breakpoint is `>= 0.2`, so a tire below `0.2 Fmax` is exactly linear, and
//! `|F - b| <= 0.02` for all `x`. The fit is parametrised by the four breakpoints and
//! `F` at the inner two; the slopes between breakpoints give the `w_i`, continuity gives
//! `phi_i = w_i x_i`. The error `F - b` is convex on each linear piece (`b` is concave),
//! so its extrema are at the breakpoints and at the tangent points `b'(x) = slope`.
//!
//! Without the linearity constraint the minimax fit would put the first breakpoint at
//! 0.1907 (max error 0.01186), so the constraint binds: the first breakpoint is exactly
//! 0.2 and the error there, `0.2 - b(0.2) = 0.0130370...`, is the smallest maximum error
//! any admissible fit can have. The other breakpoints (0.78680, 1.45421, 2.32015) make the
//! six remaining extrema equioscillate at +/- 0.0116380.
//!
//! **Achieved: max |F - b| = [`MAX_FIT_ERROR`] = 0.013037 Fmax, at x = 0.2** (requirement:
//! 0.02). Reproduce the constants (printed to 17 digits, with the checks and a plot in
//! `out/brush_fit.png`) with
//!
//! ```text
//! .venv/bin/python scripts/brush_fit.py
//! ```
//!
//! `phi_1` is the double `0.2 * w_1`, so `min(w_1 x, phi_1) = w_1 x` for every `x <= 0.2`,
//! and `w_4`, `phi_4` are 1 minus the other three, so both sums are 1 to rounding.

/// One branch of a contact element: fractions of the element's stiffness (and damping)
/// and of its friction limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Branch {
    /// `w_i`: the branch's share of the element's stiffness and damping.
    pub stiffness_fraction: f64,
    /// `phi_i`: the branch's share of the element's friction limit `Fmax`.
    pub limit_fraction: f64,
}

impl Branch {
    /// `x_i = phi_i / w_i`: the normalised steady-state load `Calpha |alpha| / Fmax` at
    /// which this branch starts to slide.
    pub fn breakpoint(&self) -> f64 {
        self.limit_fraction / self.stiffness_fraction
    }
}

/// The four branches, ordered by breakpoint (0.2, 0.787, 1.454, 2.320).
/// Derived by `scripts/brush_fit.py`; see the module documentation.
pub const BRUSH_BRANCHES: [Branch; 4] = [
    Branch {
        stiffness_fraction: 0.30107885307910187,
        limit_fraction: 0.060215770615820376,
    },
    Branch {
        stiffness_fraction: 0.3022951964290448,
        limit_fraction: 0.23784454409059574,
    },
    Branch {
        stiffness_fraction: 0.2520860011716441,
        limit_fraction: 0.36658544854155134,
    },
    Branch {
        stiffness_fraction: 0.1445399493202093,
        limit_fraction: 0.3353542367520326,
    },
];

/// Below this normalised load (`Calpha |alpha| / Fmax`) every branch sticks and the
/// steady-state force is exactly the linear `Calpha alpha` (docs/specification.md 4c).
pub const LINEAR_LIMIT: f64 = 0.2;

/// The achieved `max_x |F(x) - b(x)|` (in units of `Fmax`), reached at `x = 0.2`:
/// `0.2 - b(0.2)`, the least any fit that is linear below 0.2 can have.
pub const MAX_FIT_ERROR: f64 = 0.013037037037037041;

/// Steady-state force of a four-branch element as a fraction of `Fmax`:
/// `sum_i min(w_i x, phi_i)` with `x = Calpha alpha / Fmax`, odd in `x` (NaN stays NaN).
pub fn steady_state_force_fraction(x: f64) -> f64 {
    let magnitude = x.abs();
    let force: f64 = BRUSH_BRANCHES
        .iter()
        .map(|b| (b.stiffness_fraction * magnitude).min(b.limit_fraction))
        .sum();
    if x.is_nan() { x } else { force.copysign(x) }
}

/// The brush curve `3t - 3t^2 + t^3`, `t = min(1, |x|/3)`, as a fraction of `Fmax`, odd in
/// `x`: the target of the fit.
pub fn brush_curve(x: f64) -> f64 {
    let t = (x.abs() / 3.0).min(1.0);
    let value = 3.0 * t - 3.0 * t * t + t * t * t;
    if x.is_nan() { x } else { value.copysign(x) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform grid on [a, b] with n + 1 points.
    fn grid(a: f64, b: f64, n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |k| a + (b - a) * k as f64 / n as f64)
    }

    fn largest_breakpoint() -> f64 {
        BRUSH_BRANCHES
            .iter()
            .map(Branch::breakpoint)
            .fold(f64::NEG_INFINITY, f64::max)
    }

    #[test]
    fn fractions_are_positive_and_sum_to_one() {
        for b in &BRUSH_BRANCHES {
            assert!(b.stiffness_fraction > 0.0 && b.limit_fraction > 0.0, "{b:?}");
        }
        let w: f64 = BRUSH_BRANCHES.iter().map(|b| b.stiffness_fraction).sum();
        let phi: f64 = BRUSH_BRANCHES.iter().map(|b| b.limit_fraction).sum();
        assert!((w - 1.0).abs() <= 1e-15, "sum w = {w:e}");
        assert!((phi - 1.0).abs() <= 1e-15, "sum phi = {phi:e}");
    }

    #[test]
    fn breakpoints_are_ordered_and_the_smallest_is_at_least_0_2() {
        let x: Vec<f64> = BRUSH_BRANCHES.iter().map(Branch::breakpoint).collect();
        assert!(x.windows(2).all(|p| p[0] < p[1]), "{x:?}");
        assert!(x[0] >= LINEAR_LIMIT, "smallest breakpoint {}", x[0]);
        // The operative form of the same condition: branch 1 still sticks at x = 0.2.
        let b = BRUSH_BRANCHES[0];
        assert!(b.stiffness_fraction * LINEAR_LIMIT <= b.limit_fraction);
    }

    #[test]
    fn exactly_linear_below_0_2() {
        for x in grid(0.0, LINEAR_LIMIT, 200_000).chain([LINEAR_LIMIT, f64::MIN_POSITIVE]) {
            let f = steady_state_force_fraction(x);
            assert!((f - x).abs() <= 1e-15, "F({x}) = {f}");
            assert!(
                (f - x).abs() <= 4.0 * f64::EPSILON * x,
                "F({x}) = {f}, not x to rounding"
            );
        }
        assert_eq!(steady_state_force_fraction(0.0), 0.0);
    }

    #[test]
    fn max_error_against_the_brush_curve_is_within_spec() {
        let (mut worst, mut at) = (0.0_f64, 0.0);
        for x in grid(0.0, 4.0, 400_000).chain(BRUSH_BRANCHES.iter().map(Branch::breakpoint)) {
            let e = (steady_state_force_fraction(x) - brush_curve(x)).abs();
            if e > worst {
                (worst, at) = (e, x);
            }
        }
        assert!(worst <= 0.02, "max error {worst} at x = {at}");
        assert!(worst <= MAX_FIT_ERROR + 1e-15, "max error {worst} at x = {at}");
        // The maximum is the one forced by linearity, at x = 0.2.
        assert!(
            (worst - MAX_FIT_ERROR).abs() <= 1e-15 && (at - 0.2).abs() <= 1e-12,
            "{worst} {at}"
        );
        assert!((LINEAR_LIMIT - brush_curve(LINEAR_LIMIT) - MAX_FIT_ERROR).abs() <= 1e-16);
    }

    #[test]
    fn saturates_at_one_beyond_the_last_breakpoint() {
        let last = largest_breakpoint();
        assert!(last < 3.0);
        for x in grid(last, 10.0, 10_000).chain([1e6, f64::MAX, f64::INFINITY]) {
            let f = steady_state_force_fraction(x);
            assert!((f - 1.0).abs() <= 1e-15, "F({x}) = {f}");
        }
        assert!(steady_state_force_fraction(0.99 * last) < 1.0 - 1e-4);
        assert_eq!(brush_curve(3.0), 1.0);
        assert_eq!(brush_curve(7.0), 1.0);
    }

    #[test]
    fn increasing_and_concave() {
        let xs: Vec<f64> = grid(0.0, 4.0, 4_000).collect();
        let f: Vec<f64> = xs.iter().map(|&x| steady_state_force_fraction(x)).collect();
        assert!(f.windows(2).all(|p| p[1] >= p[0]));
        assert!(f.windows(3).all(|p| p[2] - 2.0 * p[1] + p[0] <= 1e-15));
    }

    #[test]
    fn odd_symmetry_and_nan() {
        for x in grid(0.0, 4.0, 1_000) {
            assert_eq!(steady_state_force_fraction(-x), -steady_state_force_fraction(x));
            assert_eq!(brush_curve(-x), -brush_curve(x));
        }
        assert_eq!(
            steady_state_force_fraction(f64::NEG_INFINITY),
            -steady_state_force_fraction(f64::INFINITY)
        );
        assert!(steady_state_force_fraction(f64::NAN).is_nan());
        assert!(brush_curve(f64::NAN).is_nan());
    }
}
