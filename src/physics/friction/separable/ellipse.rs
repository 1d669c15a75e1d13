//! One branch of the friction ellipse whose members move on their own: each member's
//! sticking rate is `g - a b` (its drive from the held inputs, minus its relaxation rate
//! times its deflection), as in RLT.
//!
//! Sliding, the force stays on the ellipse: `b = (P cos theta, Q sin theta)`, with
//! `P = Lx / Kx` and `Q = Ly / Ky` the elastic travels to the limits. The slider moves
//! along the normal in force space, `n = (cos theta / Lx, sin theta / Ly)`, so only the
//! motion across it turns the angle: with `r = g - a b` the sticking rate,
//! `dtheta/dt = (Ly cos r_y - Lx sin r_x) / (Lx P sin^2 + Ly Q cos^2)`.
//! The branch slides while sticking would push the force outward, `n.K r > 0`.

use super::exponential::{Angle, AngleFlow};
use crate::physics::friction::group::outward_cosine_from;

/// Per member (longitudinal, lateral): the constants of the branch, with what follows
/// from them (computed once: a step uses them many times).
#[derive(Clone, Copy, Debug, Default)]
pub struct EllipseBranch {
    /// `K = w_i C`, N/m (or the element's unit).
    pub stiffness: [f64; 2],
    /// `L = phi_i Fmax`, N.
    pub limit: [f64; 2],
    /// `a`: the relaxation rate of the member's state, 1/s.
    pub relaxation: [f64; 2],
    /// `g`: the member's rate from the inputs.
    pub drive: [f64; 2],
    /// `P = L / K`: the elastic travel to the limit.
    pub travel: [f64; 2],
    /// `1 / P` and `1 / P^2`.
    inverse_travel: [f64; 2],
    pub inverse_travel_squared: [f64; 2],
    /// `K / L^2`: the normal `n = K b / L^2` per unit deflection.
    normal_scale: [f64; 2],
}

impl EllipseBranch {
    /// A member with an infinite limit and no drive takes no part: no force, no motion.
    pub fn new(stiffness: [f64; 2], limit: [f64; 2], relaxation: [f64; 2], drive: [f64; 2]) -> Self {
        // Four divisions, not eight: a step makes these for every branch.
        let (inverse_stiffness, inverse_limit) = (stiffness.map(|k| 1.0 / k), limit.map(|l| 1.0 / l));
        let inverse_travel = [stiffness[0] * inverse_limit[0], stiffness[1] * inverse_limit[1]];
        EllipseBranch {
            stiffness,
            limit,
            relaxation,
            drive,
            travel: [limit[0] * inverse_stiffness[0], limit[1] * inverse_stiffness[1]],
            inverse_travel,
            inverse_travel_squared: inverse_travel.map(|p| p * p),
            normal_scale: [0, 1].map(|k| inverse_travel[k] * inverse_limit[k]),
        }
    }

    /// The sticking rate `g - a b` of each member.
    pub fn sticking_rate(&self, b: [f64; 2]) -> [f64; 2] {
        [
            self.drive[0] - self.relaxation[0] * b[0],
            self.drive[1] - self.relaxation[1] * b[1],
        ]
    }

    /// `sum (K b / L)^2`.
    pub fn utilisation(&self, b: [f64; 2]) -> f64 {
        b[0] * b[0] * self.inverse_travel_squared[0] + b[1] * b[1] * self.inverse_travel_squared[1]
    }

    /// The cosine between the normal `n = K b / L^2` and the sticking force rate `K r`:
    /// positive while sticking would push the force out of the ellipse, zero without motion.
    pub fn outward_cosine(&self, b: [f64; 2]) -> f64 {
        let r = self.sticking_rate(b);
        let (mut along, mut normal_norm, mut rate_norm) = (0.0, 0.0, 0.0);
        for k in 0..2 {
            let (normal, force_rate) = (self.normal_scale[k] * b[k], self.stiffness[k] * r[k]);
            along += normal * force_rate;
            normal_norm += normal * normal;
            rate_norm += force_rate * force_rate;
        }
        outward_cosine_from(along, normal_norm, rate_norm)
    }

    /// The deflections at an angle on the ellipse.
    pub fn on_ellipse(&self, at: &Angle) -> [f64; 2] {
        [self.travel[0] * at.cos, self.travel[1] * at.sin]
    }

    /// The angle of deflections on the ellipse.
    pub fn angle_of(&self, b: [f64; 2]) -> Angle {
        Angle::of(b[0] * self.inverse_travel[0], b[1] * self.inverse_travel[1])
    }

    /// The flow of the angle while the branch slides.
    pub fn flow(&self) -> EllipseFlow {
        let [p, q] = self.travel;
        let [lx, ly] = self.limit;
        let [gx, gy] = self.drive;
        let [ax, ay] = self.relaxation;
        EllipseFlow {
            drive_cos: ly * gy,
            drive_sin: -lx * gx,
            relaxation: lx * ax * p - ly * ay * q,
            weight_sin: lx * p,
            weight_cos: ly * q,
        }
    }
}

/// `dtheta/dt = N / D` with `N = drive_cos cos + drive_sin sin + relaxation sin cos` and
/// `D = weight_sin sin^2 + weight_cos cos^2` (see the module's doc).
#[derive(Clone, Copy, Debug, Default)]
pub struct EllipseFlow {
    drive_cos: f64,
    drive_sin: f64,
    relaxation: f64,
    weight_sin: f64,
    weight_cos: f64,
}

impl EllipseFlow {
    fn numerator(&self, c: f64, s: f64) -> f64 {
        self.drive_cos * c + self.drive_sin * s + self.relaxation * s * c
    }

    fn denominator(&self, c: f64, s: f64) -> f64 {
        self.weight_sin * s * s + self.weight_cos * c * c
    }
}

impl AngleFlow for EllipseFlow {
    #[inline]
    fn rate(&self, at: &Angle) -> f64 {
        self.numerator(at.cos, at.sin) / self.denominator(at.cos, at.sin)
    }

    #[inline]
    fn rate_and_slope(&self, at: &Angle) -> (f64, f64) {
        let (c, s) = (at.cos, at.sin);
        let (n, d) = (self.numerator(c, s), self.denominator(c, s));
        let n_slope = -self.drive_cos * s + self.drive_sin * c + self.relaxation * (c * c - s * s);
        let d_slope = 2.0 * (self.weight_sin - self.weight_cos) * s * c;
        let rate = n / d;
        (rate, (n_slope - rate * d_slope) / d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn branch() -> EllipseBranch {
        EllipseBranch::new([2.0e5, 3.5e5], [4.0e3, 5.0e2], [7.0, 11.0], [0.03, -0.2])
    }

    /// The angle's rate is the motion `r - lambda n` (with `lambda` keeping the force on
    /// the ellipse) seen along the ellipse's tangent.
    #[test]
    fn the_angle_turns_with_the_sliding_motion() {
        let branch = branch();
        let flow = branch.flow();
        for theta in [0.3_f64, 1.9, -2.5] {
            let at = Angle::of(theta.cos(), theta.sin());
            let b = branch.on_ellipse(&at);
            let r = branch.sticking_rate(b);
            let n = [0, 1].map(|k| branch.stiffness[k] * b[k] / branch.limit[k].powi(2));
            let kn = [0, 1].map(|k| branch.stiffness[k] * n[k]);
            let lambda = (kn[0] * r[0] + kn[1] * r[1]) / (kn[0] * n[0] + kn[1] * n[1]);
            let motion = [0, 1].map(|k| r[k] - lambda * n[k]);
            let [p, q] = branch.travel;
            let tangent = [-p * at.sin, q * at.cos];
            let rate = flow.rate(&at);
            for k in 0..2 {
                assert!(
                    (motion[k] - tangent[k] * rate).abs() < 1e-12 * motion[k].abs().max(1e-9),
                    "{theta} {k}"
                );
            }
            let (_, slope) = flow.rate_and_slope(&at);
            let dt = 1e-6;
            let numeric = (flow.rate(&at.rotated(dt)) - flow.rate(&at.rotated(-dt))) / (2.0 * dt);
            assert!(
                (slope - numeric).abs() < 1e-6 * slope.abs().max(1.0),
                "{slope} vs {numeric}"
            );
        }
    }
}
