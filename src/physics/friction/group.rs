//! The law of one group of branches that share a limit: branch `i` of the longitudinal
//! and lateral elements on the friction ellipse, or branch `i` of the yaw element.
//!
//! Inputs per direction: the branch deflection `b`, its sticking rate `g` (the model's
//! equation with `b` in place of `U`), the branch stiffness `K = w_i C` and damping
//! `Dw = w_i D`, and the branch limit `L = phi_i Fmax`. The ellipse is
//! `sum (F_k / L_k)^2 <= 1`.
//!
//! - **Springs** (`Dw = 0`): `F = K b`. Sliding, the force stays on the ellipse and the
//!   slider moves along its normal `n = F / L^2` (maximum dissipation):
//!   `db/dt = g - lambda n` with `lambda = n.K g / n.K n`. The group sticks again when
//!   `lambda` turns negative (the sticking motion would take the force inside).
//! - **Spring-dampers** (`Dw > 0`, DDT): the force that sticking needs is
//!   `T = K b + Dw g`. Inside the ellipse the group sticks; outside, the force is the
//!   point of the ellipse `F_k = T_k / (1 + lambda Dw_k / L_k^2)` (the closest point in
//!   the damping metric), and the deflection follows `Dw db/dt = F - K b`.
//!
//! Each evaluation also gives an event value: negative while the group stays in its mode
//! (stick or slide), crossing zero where it changes.

use super::Direction;

/// One group's branch quantities, by [`Direction`]; directions outside the group are
/// ignored (`present` false).
#[derive(Clone, Copy, Debug, Default)]
pub struct GroupInput {
    pub present: [bool; Direction::COUNT],
    pub deflection: [f64; Direction::COUNT],
    pub sticking_rate: [f64; Direction::COUNT],
    pub stiffness: [f64; Direction::COUNT],
    pub damping: [f64; Direction::COUNT],
    pub limit: [f64; Direction::COUNT],
}

/// What the group does: deflection rates, forces, and the event value.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GroupOutput {
    pub rate: [f64; Direction::COUNT],
    pub force: [f64; Direction::COUNT],
    pub event: f64,
}

impl GroupInput {
    fn directions(&self) -> impl Iterator<Item = usize> + '_ {
        (0..Direction::COUNT).filter(|&k| self.present[k])
    }

    /// Damped if its elements have dampers (both or neither: checked with the parameters).
    pub fn damped(&self) -> bool {
        self.directions().any(|k| self.damping[k] > 0.0)
    }

    /// `sum (F_k / L_k)^2` for forces `force`.
    pub fn utilisation(&self, force: &[f64; Direction::COUNT]) -> f64 {
        self.directions()
            .map(|k| (force[k] / self.limit[k]).powi(2))
            .sum()
    }

    /// The spring forces `K b`.
    pub fn spring_force(&self) -> [f64; Direction::COUNT] {
        let mut force = [0.0; Direction::COUNT];
        for k in self.directions() {
            force[k] = self.stiffness[k] * self.deflection[k];
        }
        force
    }

    /// The force that sticking needs: `K b + Dw g`.
    pub fn sticking_force(&self) -> [f64; Direction::COUNT] {
        let mut force = self.spring_force();
        for k in self.directions() {
            force[k] += self.damping[k] * self.sticking_rate[k];
        }
        force
    }

    /// Rates, forces and event value in the given mode.
    pub fn evaluate(&self, sliding: bool) -> GroupOutput {
        if self.damped() {
            self.evaluate_damped(sliding)
        } else {
            self.evaluate_springs(sliding)
        }
    }

    fn evaluate_springs(&self, sliding: bool) -> GroupOutput {
        let force = self.spring_force();
        if !sliding {
            return GroupOutput {
                rate: self.sticking_rate,
                force,
                event: self.utilisation(&force) - 1.0,
            };
        }
        let (numerator, denominator) = self.flow_projection(&force);
        let lambda = if denominator > 0.0 {
            numerator / denominator
        } else {
            0.0
        };
        let mut rate = [0.0; Direction::COUNT];
        for k in self.directions() {
            rate[k] = self.sticking_rate[k] - lambda * force[k] / self.limit[k].powi(2);
        }
        GroupOutput {
            rate,
            force,
            event: -self.outward_cosine(&force),
        }
    }

    /// `n.K g` and `n.K n` for the normal `n = F / L^2`.
    fn flow_projection(&self, force: &[f64; Direction::COUNT]) -> (f64, f64) {
        let (mut numerator, mut denominator) = (0.0, 0.0);
        for k in self.directions() {
            let normal = force[k] / self.limit[k].powi(2);
            numerator += normal * self.stiffness[k] * self.sticking_rate[k];
            denominator += normal * self.stiffness[k] * normal;
        }
        (numerator, denominator)
    }

    /// The cosine between the normal and the sticking force rate `K g`: positive while
    /// sticking would push the force out of the ellipse. Zero without motion.
    pub fn outward_cosine(&self, force: &[f64; Direction::COUNT]) -> f64 {
        let (mut dot, mut normal_norm, mut rate_norm) = (0.0, 0.0, 0.0);
        for k in self.directions() {
            let normal = force[k] / self.limit[k].powi(2);
            let force_rate = self.stiffness[k] * self.sticking_rate[k];
            dot += normal * force_rate;
            normal_norm += normal * normal;
            rate_norm += force_rate * force_rate;
        }
        let norm = (normal_norm * rate_norm).sqrt();
        if norm > 0.0 { dot / norm } else { 0.0 }
    }

    /// In each mode the formulas continue smoothly past the event (a sticking group
    /// outside its ellipse, a sliding one inside), so that a piece's right-hand side is
    /// smooth up to the event that ends it.
    fn evaluate_damped(&self, sliding: bool) -> GroupOutput {
        let trial = self.sticking_force();
        let utilisation = self.utilisation(&trial);
        if !sliding {
            return GroupOutput {
                rate: self.sticking_rate,
                force: trial,
                event: utilisation - 1.0,
            };
        }
        let force = self.closest_point(&trial, utilisation);
        let mut rate = [0.0; Direction::COUNT];
        for k in self.directions() {
            rate[k] = (force[k] - self.stiffness[k] * self.deflection[k]) / self.damping[k];
        }
        GroupOutput {
            rate,
            force,
            event: 1.0 - utilisation,
        }
    }

    /// The point of the ellipse `F_k = T_k / (1 + lambda a_k)`, `a_k = Dw_k / L_k^2`, for a
    /// trial force `T` with `utilisation > 0` (outside the ellipse `lambda > 0`; inside, the
    /// same formula continues with `lambda < 0`).
    pub fn closest_point(
        &self,
        trial: &[f64; Direction::COUNT],
        utilisation: f64,
    ) -> [f64; Direction::COUNT] {
        let mut weight = [0.0; Direction::COUNT];
        for k in self.directions() {
            weight[k] = self.damping[k] / self.limit[k].powi(2);
        }
        let mut directions = self.directions().filter(|&k| trial[k] != 0.0);
        let first = directions.next();
        let lambda = match (first, directions.next()) {
            // One direction (or equal weights): the ellipse scales T radially.
            (Some(k), None) => (utilisation.sqrt() - 1.0) / weight[k],
            (Some(k), Some(j)) if weight[k] == weight[j] => (utilisation.sqrt() - 1.0) / weight[k],
            (None, _) => 0.0,
            // phi(lambda) = sum (T_k / (L_k (1 + lambda a_k)))^2 - 1 is convex and falls.
            // At lambda0 = (sqrt(u) - 1) / max a it is >= 0, so Newton from there rises
            // monotonically to the root, with every 1 + lambda a_k > 0.
            _ => {
                let largest = self.directions().map(|k| weight[k]).fold(0.0, f64::max);
                let mut lambda = (utilisation.sqrt() - 1.0) / largest;
                for _ in 0..100 {
                    let (mut phi, mut slope) = (-1.0, 0.0);
                    for k in self.directions() {
                        let shrink = 1.0 / (1.0 + lambda * weight[k]);
                        let ratio = trial[k] / self.limit[k] * shrink;
                        phi += ratio * ratio;
                        slope -= 2.0 * ratio * ratio * weight[k] * shrink;
                    }
                    let next = lambda - phi / slope;
                    if next.partial_cmp(&lambda) != Some(std::cmp::Ordering::Greater)
                        || next - lambda <= 1e-16 * next.abs()
                    {
                        lambda = next.max(lambda);
                        break;
                    }
                    lambda = next;
                }
                lambda
            }
        };
        let mut force = [0.0; Direction::COUNT];
        for k in self.directions() {
            force[k] = trial[k] / (1.0 + lambda * weight[k]);
        }
        force
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn planar(b: [f64; 2], g: [f64; 2], damping: f64) -> GroupInput {
        GroupInput {
            present: [true, true, false],
            deflection: [b[0], b[1], 0.0],
            sticking_rate: [g[0], g[1], 0.0],
            stiffness: [1000.0, 400.0, 0.0],
            damping: [damping, 2.0 * damping, 0.0],
            limit: [30.0, 20.0, 1.0],
        }
    }

    #[test]
    fn a_sliding_spring_group_keeps_its_force_on_the_ellipse() {
        // On the ellipse: F = (30 cos t, 20 sin t).
        let t: f64 = 0.7;
        let input = planar(
            [30.0 * t.cos() / 1000.0, 20.0 * t.sin() / 400.0],
            [0.3, -0.2],
            0.0,
        );
        assert!((input.utilisation(&input.spring_force()) - 1.0).abs() < 1e-14);
        let out = input.evaluate(true);
        // d/dt sum (K b / L)^2 = 2 sum F K db/dt / L^2 = 0.
        let rate_of_utilisation: f64 = (0..2)
            .map(|k| 2.0 * out.force[k] * input.stiffness[k] * out.rate[k] / input.limit[k].powi(2))
            .sum();
        assert!(rate_of_utilisation.abs() < 1e-12, "{rate_of_utilisation}");
    }

    #[test]
    fn a_spring_group_moving_inward_wants_to_stick() {
        let input = planar([0.03, 0.0], [-0.1, 0.0], 0.0);
        assert!(input.evaluate(true).event > 0.0);
        let input = planar([0.03, 0.0], [0.1, 0.0], 0.0);
        assert!(input.evaluate(true).event < 0.0);
        // One direction at the limit: the sliding direction holds still.
        let out = input.evaluate(true);
        assert!(out.rate[0].abs() < 1e-15);
    }

    #[test]
    fn a_damped_group_projects_its_trial_force_onto_the_ellipse() {
        for (b, g) in [
            ([0.02, 0.03], [5.0, -3.0]),
            ([0.0, 0.06], [0.0, 10.0]),
            ([-0.04, 0.01], [-1.0, 0.0]),
        ] {
            let input = planar(b, g, 10.0);
            let trial = input.sticking_force();
            let utilisation = input.utilisation(&trial);
            assert!(utilisation > 1.0);
            let out = input.evaluate(true);
            assert!(
                (input.utilisation(&out.force) - 1.0).abs() < 1e-12,
                "{:?}",
                out.force
            );
            // The force is the trial force moved along the damping-weighted normal.
            for k in 0..2 {
                assert!(out.force[k].abs() <= trial[k].abs() && out.force[k] * trial[k] >= 0.0);
                let damper = input.damping[k] * out.rate[k];
                assert!((input.stiffness[k] * input.deflection[k] + damper - out.force[k]).abs() < 1e-10);
            }
        }
    }
}
