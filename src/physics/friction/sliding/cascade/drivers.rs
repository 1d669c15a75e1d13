//! The drivers: one-member groups, each linear in its mode and stepped in closed form;
//! their element's state as a sum over their modes, and where one reaches its limit.

use super::super::Slot;
use crate::physics::friction::group::GroupInput;
use crate::physics::math;

/// The drivers' element state over the step: `U0 + R . q(t)`, with each mode's rate `mu`,
/// and the `q`s where the step of `step` seconds ends.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct DriverSum {
    pub(super) start: f64,
    pub(super) by_mode: [f64; 2],
    pub(super) rate: [f64; 2],
    pub(super) step: f64,
    pub(super) end: [f64; 2],
}

impl DriverSum {
    /// The sum where the drivers' state is `start` and no time has passed: what a
    /// cascade reads at given states ([`super::super::SlidingStep::shaped_at`]).
    pub(super) fn at(start: f64) -> Self {
        DriverSum {
            start,
            ..DriverSum::default()
        }
    }

    /// The `q`s at `t` into the step: made with the drivers where the step ends.
    pub(super) fn q(&self, t: f64) -> [f64; 2] {
        if t == self.step {
            self.end
        } else {
            self.rate.map(|mu| q_at(mu, t))
        }
    }
}

/// `t phi1(mu t) = (exp(mu t) - 1) / mu`, and `t` where `mu = 0`.
pub(super) fn q_at(mu: f64, t: f64) -> f64 {
    let x = mu * t;
    if x == 0.0 { t } else { t * math::exp_m1(x) / x }
}

/// When a spring-damper driver in mode `sliding` from deflection `b0` at rate `rate`
/// (its mode's rate `mu`) reaches its limit: where its trial force, affine in the
/// deflection `T = (K + Dw A_kk) b + Dw c` (`c` its element's state's rate from the
/// inputs, `drive`), is the limit on the side it leaves from
/// (sliding) or moves to (sticking), and `q(t) = (b - b0) / rate` is solved for `t`.
/// `None` where that is not a time within reach.
pub(super) fn driver_crossing(
    slot: &Slot,
    (b0, rate, mu, drive): (f64, f64, f64, f64),
    start: &GroupInput,
    finish: &GroupInput,
    sliding: bool,
) -> Option<f64> {
    let law = &slot.law;
    let (stiffness, damping) = (law.stiffness[0], law.damping[0]);
    let side = if sliding {
        start.sticking_force()[0]
    } else {
        finish.sticking_force()[0]
    };
    let target = law.limit[0].copysign(side);
    let slope = stiffness + damping * slot.relaxation[0];
    let offset = damping * drive;
    let q = ((target - offset) / slope - b0) / rate;
    let x = mu * q;
    let at = if x == 0.0 { q } else { math::ln_1p(x) / mu };
    (at.is_finite() && at > 0.0).then_some(at)
}

/// A driver's group input at deflection `b`, its element's state's rate from the inputs
/// `drive`: its sticking rate is its element's equation with `b` in place of the state,
/// `A_kk b + c`.
pub(super) fn driver_input(slot: &Slot, b: f64, drive: f64) -> GroupInput<'_> {
    // Each pair made whole (see [`DrivenGroups::inputs`]).
    GroupInput {
        law: &slot.law,
        deflection: [b, 0.0],
        sticking_rate: [slot.relaxation[0] * b + drive, 0.0],
    }
}
