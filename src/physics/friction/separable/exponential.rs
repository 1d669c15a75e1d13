//! A scalar autonomous ODE on an angle, `dtheta/dt = f(theta)`, integrated by an
//! exponential Rosenbrock method (exprb43 of Hochbruck, Ostermann and Schweitzer, SIAM J.
//! Numer. Anal. 47, 2009: order four, with an embedded order-three solution for the error
//! control), with an event located in time.
//!
//! Why this method: each step is exact for the flow linearised at its start, at any step
//! length. Where the flow is mild (a tire sliding in quasi-steady state) one step of the
//! whole length is accurate to 1e-12; where it is stiff (a stiff tire at a light load turns
//! its force within microseconds), a long step is a Newton step onto the equilibrium the
//! angle settles at, which is where the exact solution is. Either way a step costs three
//! evaluations of `f` and one of its slope.
//!
//! The angle is carried with its cosine and sine, and a stage's angle is its start rotated
//! by a small increment, so that evaluations need no trigonometry in quasi-steady sliding.

use crate::physics::math;
use crate::physics::stepper::phi::{scalar_phi_functions, scalar_phi_functions_to_fourth};

/// An angle, as its cosine and sine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Angle {
    pub cos: f64,
    pub sin: f64,
}

impl Angle {
    /// The angle zero.
    pub const ZERO: Angle = Angle { cos: 1.0, sin: 0.0 };

    /// The angle of the direction `(x, y)`, which must not be zero (and is of a size near
    /// one: a point of the ellipse, scaled to the unit circle).
    pub fn of(x: f64, y: f64) -> Self {
        let inverse_norm = (x * x + y * y).sqrt().recip();
        Angle {
            cos: x * inverse_norm,
            sin: y * inverse_norm,
        }
    }

    /// The angle in (-pi, pi].
    pub fn radians(&self) -> f64 {
        math::atan2(self.sin, self.cos)
    }

    /// This angle plus `delta`: a rotation of its cosine and sine (by polynomials for the
    /// small increments of a step, exact to rounding).
    pub fn rotated(&self, delta: f64) -> Self {
        let (sin, cos) = small_sin_cos(delta);
        Angle {
            cos: self.cos * cos - self.sin * sin,
            sin: self.sin * cos + self.cos * sin,
        }
    }
}

/// `(sin x, cos x)`: Taylor polynomials up to |x| = 1/4 (the terms left out are below 1e-20),
/// the library's functions beyond.
fn small_sin_cos(x: f64) -> (f64, f64) {
    if x.abs() > 0.25 {
        return math::sin_cos(x);
    }
    // (-1)^j / (2j + 1)! and (-1)^j / (2j)!, by Horner in x^2 (multiplications only).
    const SIN: [f64; 7] = taylor(1);
    const COS: [f64; 8] = taylor(0);
    // The terms that matter at this size (a quasi-steady step turns by a milliradian),
    // each degree its own straight line of multiply-adds.
    let x2 = x * x;
    match x.abs() {
        a if a < 1e-3 => (x * horner::<3>(&SIN, x2), horner::<4>(&COS, x2)),
        a if a < 3e-2 => (x * horner::<5>(&SIN, x2), horner::<6>(&COS, x2)),
        _ => (x * horner::<7>(&SIN, x2), horner::<8>(&COS, x2)),
    }
}

/// `sum c_j x^j` over the first `N` coefficients.
#[inline(always)]
fn horner<const N: usize>(coefficients: &[f64], x: f64) -> f64 {
    let mut sum = coefficients[N - 1];
    for j in (0..N - 1).rev() {
        sum = sum * x + coefficients[j];
    }
    sum
}

/// `(-1)^j / (2j + first)!` for j = 0..N.
const fn taylor<const N: usize>(first: usize) -> [f64; N] {
    let mut c = [0.0; N];
    let mut factorial = 1.0;
    let mut k = 1;
    while k <= first {
        factorial *= k as f64;
        k += 1;
    }
    let mut j = 0;
    while j < N {
        c[j] = if j % 2 == 0 {
            1.0 / factorial
        } else {
            -1.0 / factorial
        };
        factorial *= ((2 * j + first + 1) * (2 * j + first + 2)) as f64;
        j += 1;
    }
    c
}

/// A scalar flow on an angle.
pub trait AngleFlow {
    /// `f(theta)`, rad/s.
    fn rate(&self, at: &Angle) -> f64;
    /// `f(theta)` and `df/dtheta`, 1/s.
    fn rate_and_slope(&self, at: &Angle) -> (f64, f64);
}

/// One step: the order-four end and the estimate of its error.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    pub end: Angle,
    pub error: f64,
}

impl Step {
    /// Whether the step is within `tolerance` (and finite).
    fn accepted(&self, tolerance: f64) -> bool {
        self.error <= tolerance && self.end.cos.is_finite()
    }
}

/// One exprb43 step of length `h` from `start`, where the flow has rate and slope
/// `(rate, slope)`. With `g(theta) = f(theta) - slope theta`:
/// `U2 = theta + h/2 phi1(z/2) f`, `U3 = theta + h phi1(z) (f + D2)`,
/// `end = theta + h phi1(z) f + h (16 phi3 - 48 phi4)(z) D2 + h (12 phi4 - 2 phi3)(z) D3`,
/// `z = h slope`, `Di = g(Ui) - g(theta)`; the embedded solution drops the `phi4` terms.
pub fn step<F: AngleFlow>(flow: &F, start: &Angle, rate: (f64, f64), h: f64) -> Step {
    steps_together::<F, 1>(
        std::slice::from_ref(flow),
        std::slice::from_ref(start),
        &[rate],
        &[h],
    )[0]
}

/// [`step`] of up to `N` flows at once, each from its start with its rate and slope over
/// its length: the same values, computed stage by stage across the flows, so that one
/// flow's divisions need not wait for another's.
fn steps_together<F: AngleFlow, const N: usize>(
    flows: &[F],
    starts: &[Angle],
    rates: &[(f64, f64)],
    lengths: &[f64],
) -> [Step; N] {
    let count = flows.len().min(N);
    let (mut phi1, mut phi3, mut phi4, mut half_phi1) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for j in 0..count {
        let z = lengths[j] * rates[j].1;
        [phi1[j], _, phi3[j], phi4[j]] = scalar_phi_functions_to_fourth(z);
        half_phi1[j] = scalar_phi_functions(0.5 * z).1;
    }
    let remainder = |j: usize, delta: f64| {
        let (rate, slope) = rates[j];
        flows[j].rate(&starts[j].rotated(delta)) - rate - slope * delta
    };
    let mut d2 = [0.0; N];
    for j in 0..count {
        d2[j] = remainder(j, 0.5 * lengths[j] * half_phi1[j] * rates[j].0);
    }
    let (mut linear, mut d3) = ([0.0; N], [0.0; N]);
    for j in 0..count {
        let h = lengths[j];
        linear[j] = h * phi1[j] * rates[j].0;
        d3[j] = remainder(j, linear[j] + h * phi1[j] * d2[j]);
    }
    let mut steps = [Step {
        end: Angle::ZERO,
        error: 0.0,
    }; N];
    for j in 0..count {
        let (h, p3, p4) = (lengths[j], phi3[j], phi4[j]);
        let delta = linear[j] + h * ((16.0 * p3 - 48.0 * p4) * d2[j] + (12.0 * p4 - 2.0 * p3) * d3[j]);
        steps[j] = Step {
            end: starts[j].rotated(delta),
            error: (h * p4 * (12.0 * d3[j] - 48.0 * d2[j])).abs(),
        };
    }
    steps
}

/// The event function of flow `j` at an angle.
pub type EventOf<'a> = dyn Fn(usize, &Angle) -> f64 + 'a;

/// How the first step of an integration went ([`first_steps_together`]).
#[derive(Clone, Copy, Debug)]
pub enum FirstStep {
    /// It ended the integration, here.
    End(Angle),
    /// It was too long: [`integrate`] goes on as from a first step this long.
    Shorter(f64),
    /// Its end is past the event: the integration is taken again.
    Again,
}

/// The first step of [`integrate`] for up to `N` flows at once, each over the whole of
/// its length from its start, side by side ([`steps_together`]): where [`integrate`] would
/// end with that one step (accurate, and `event` of that flow not past `-threshold` at its
/// end), its end, the same value; else how [`integrate`] goes on.
pub fn first_steps_together<F: AngleFlow, const N: usize>(
    flows: &[F],
    starts: &[Angle],
    lengths: &[f64],
    tolerance: f64,
    (event, threshold): (&EventOf<'_>, f64),
) -> [FirstStep; N] {
    let count = flows.len().min(N);
    let mut rates = [(0.0, 0.0); N];
    for j in 0..count {
        rates[j] = flows[j].rate_and_slope(&starts[j]);
    }
    let steps = steps_together::<F, N>(&flows[..count], &starts[..count], &rates[..count], lengths);
    let mut ends = [FirstStep::Again; N];
    for j in 0..count {
        // At rest on an equilibrium nothing moves (and so no event), as in [`integrate`].
        if rates[j].0 == 0.0 {
            ends[j] = FirstStep::End(starts[j]);
            continue;
        }
        let taken = steps[j];
        ends[j] = if !taken.accepted(tolerance) {
            // Too short to go on: the integration taken again gives up as it would.
            shortened(lengths[j], taken.error, tolerance, lengths[j])
                .map_or(FirstStep::Again, FirstStep::Shorter)
        } else if event(j, &taken.end) >= -threshold {
            FirstStep::End(taken.end)
        } else {
            FirstStep::Again
        };
    }
    ends
}

/// The next length to try after a step of `h` with `error` above `tolerance`, in an
/// integration over `length`; `None` where the steps have shrunk to nothing.
fn shortened(h: f64, error: f64, tolerance: f64, length: f64) -> Option<f64> {
    let next = h * if error.is_finite() {
        (0.9 * (tolerance / error).sqrt().sqrt()).clamp(0.1, 0.5)
    } else {
        0.1
    };
    (next > 1e-15 * length).then_some(next)
}

/// Where an integration ended.
#[derive(Clone, Copy, Debug)]
pub enum Outcome {
    /// At the end of the time asked for.
    End(Angle),
    /// Where the event function crossed from positive to below `-threshold`: the time
    /// from the start and the angle there.
    Event(f64, Angle),
}

/// Integrates from `start` over `length` seconds to an absolute error of `tolerance`
/// radians per step, its first step trying `first_length` (the whole `length` unless a
/// step that long was already found too long), stopping where `event` (positive at the
/// start) falls below `-threshold` (located where it crosses `-threshold / 2`). `None` if
/// the steps shrink to nothing or exceed `max_steps` (the caller takes another way).
pub fn integrate<F: AngleFlow>(
    flow: &F,
    start: Angle,
    (length, first_length): (f64, f64),
    tolerance: f64,
    (event, threshold): (&dyn Fn(&Angle) -> f64, f64),
    max_steps: usize,
) -> Option<Outcome> {
    let mut at = start;
    let mut t = 0.0;
    let mut h = first_length;
    for _ in 0..max_steps {
        if t >= length {
            return Some(Outcome::End(at));
        }
        h = h.min(length - t);
        let start_rate = flow.rate_and_slope(&at);
        if start_rate.0 == 0.0 {
            // At rest on an equilibrium: nothing moves (and so no event).
            return Some(Outcome::End(at));
        }
        let taken = step(flow, &at, start_rate, h);
        if !taken.accepted(tolerance) {
            h = shortened(h, taken.error, tolerance, length)?;
            continue;
        }
        if event(&taken.end) < -threshold {
            let target = -0.5 * threshold;
            let start_value = event(&at) - target;
            let (located, angle) = locate(
                |s| step(flow, &at, start_rate, s).end,
                event,
                (target, start_value),
                h,
            );
            return Some(Outcome::Event(t + located, angle));
        }
        at = taken.end;
        t += h;
        let grow = if taken.error > 0.0 {
            (0.9 * (tolerance / taken.error).sqrt().sqrt()).clamp(0.2, 5.0)
        } else {
            5.0
        };
        h *= grow;
    }
    None
}

/// The time within `(0, h]` where `event(end(s))` crosses `target`, by regula falsi
/// (Illinois), given its value minus `target` at 0 (positive) and that it is below at `h`.
fn locate(
    end: impl Fn(f64) -> Angle,
    event: &dyn Fn(&Angle) -> f64,
    (target, start_value): (f64, f64),
    h: f64,
) -> (f64, Angle) {
    let (mut low, mut high) = (0.0, h);
    let mut high_angle = end(h);
    let (mut f_low, mut f_high) = (start_value, event(&high_angle) - target);
    let mut side = 0;
    for _ in 0..100 {
        if high - low <= 1e-15 * high {
            break;
        }
        let s = (low * f_high - high * f_low) / (f_high - f_low);
        let s = if s > low && s < high {
            s
        } else {
            0.5 * (low + high)
        };
        let angle = end(s);
        let value = event(&angle) - target;
        if value <= 0.0 {
            (high, high_angle, f_high) = (s, angle, value);
            if side == -1 {
                f_low *= 0.5;
            }
            side = -1;
        } else {
            (low, f_low) = (s, value);
            if side == 1 {
                f_high *= 0.5;
            }
            side = 1;
        }
        if value.abs() <= 1e-3 * target.abs() {
            break;
        }
    }
    (high, high_angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `dtheta/dt = -k sin(theta - target)`: `tan((theta - target)/2)` decays as `e^(-k t)`.
    struct Pendulum {
        k: f64,
        target: f64,
    }

    impl Pendulum {
        fn exact(&self, start: f64, t: f64) -> f64 {
            self.target + 2.0 * (((start - self.target) / 2.0).tan() * (-self.k * t).exp()).atan()
        }
    }

    impl AngleFlow for Pendulum {
        fn rate(&self, at: &Angle) -> f64 {
            let (s, c) = self.target.sin_cos();
            -self.k * (at.sin * c - at.cos * s)
        }
        fn rate_and_slope(&self, at: &Angle) -> (f64, f64) {
            let (s, c) = self.target.sin_cos();
            (
                -self.k * (at.sin * c - at.cos * s),
                -self.k * (at.cos * c + at.sin * s),
            )
        }
    }

    #[test]
    fn small_rotations_are_exact_to_rounding() {
        for x in [-0.25, -0.1, -1e-3, 0.0, 1e-8, 0.05, 0.2499] {
            let (s, c) = small_sin_cos(x);
            assert!(
                (s - x.sin()).abs() <= 4e-16 * x.abs() && (c - x.cos()).abs() <= 4e-16,
                "{x}"
            );
        }
    }

    #[test]
    fn a_step_is_of_order_four() {
        let flow = Pendulum { k: 3.0, target: 0.4 };
        let start = Angle::of(2.0_f64.cos(), 2.0_f64.sin());
        let error = |h: f64| {
            let end = step(&flow, &start, flow.rate_and_slope(&start), h).end.radians();
            (end - flow.exact(2.0, h)).abs()
        };
        // A local error of order five: halving the step divides it by about 32.
        let ratio = error(0.1) / error(0.05);
        assert!(ratio > 24.0 && ratio < 40.0, "ratio {ratio}");
    }

    #[test]
    fn integration_is_exact_when_mild_and_when_stiff() {
        let never = |_: &Angle| 1.0;
        for k in [0.5, 30.0, 1e4, 1e9] {
            let flow = Pendulum { k, target: -1.0 };
            for (start, length) in [(2.5_f64, 1e-3), (0.3, 1.0), (-2.9, 10.0)] {
                let outcome = integrate(
                    &flow,
                    Angle::of(start.cos(), start.sin()),
                    (length, length),
                    1e-13,
                    (&never, 1e-12),
                    10_000,
                );
                let Some(Outcome::End(end)) = outcome else {
                    panic!("k {k}: {outcome:?}")
                };
                let exact = flow.exact(start, length);
                let turns = ((end.radians() - exact) / std::f64::consts::TAU).round();
                assert!(
                    (end.radians() - exact - turns * std::f64::consts::TAU).abs() < 1e-11,
                    "k {k} start {start} length {length}: {} vs {exact}",
                    end.radians()
                );
                assert!((end.cos - exact.cos()).abs() < 1e-11 && (end.sin - exact.sin()).abs() < 1e-11);
            }
        }
    }

    #[test]
    fn an_event_is_located_in_time() {
        let flow = Pendulum { k: 2.0, target: -1.0 };
        // The event: theta falls below 0.5, where tan(0.75) = tan(1.1) e^(-2 t).
        let event = |at: &Angle| at.radians() - 0.5;
        let start = 1.2_f64;
        let outcome = integrate(
            &flow,
            Angle::of(start.cos(), start.sin()),
            (5.0, 5.0),
            1e-13,
            (&event, 1e-12),
            10_000,
        );
        let Some(Outcome::Event(t, at)) = outcome else {
            panic!("{outcome:?}")
        };
        let exact = ((1.1_f64).tan() / (0.75_f64).tan()).ln() / 2.0;
        assert!((t - exact).abs() < 1e-10, "{t} vs {exact}");
        assert!((at.radians() - 0.5).abs() < 1e-10);
    }
}
