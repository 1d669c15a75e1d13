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

// Members index several arrays together (forces, stiffnesses, limits, deflections).
#![allow(clippy::needless_range_loop)]

use super::Direction;

/// The most directions a group has: the ellipse's two.
pub const MAX_MEMBERS: usize = 2;

/// One group's branch constants over a step: its first `count` directions (by
/// [`Direction`] in `direction`), each with its stiffness, damping and limit. Slots past
/// `count` are zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroupLaw {
    pub count: usize,
    pub direction: [usize; MAX_MEMBERS],
    pub stiffness: [f64; MAX_MEMBERS],
    pub damping: [f64; MAX_MEMBERS],
    pub limit: [f64; MAX_MEMBERS],
    /// Made with each member ([`GroupLaw::with_member`]), so that an evaluation
    /// multiplies where it would divide: `1 / L_k`, the projection's weights
    /// `a_k = Dw_k / L_k^2` and `1 / Dw_k` (zero for a spring).
    inverse_limit: [f64; MAX_MEMBERS],
    weight: [f64; MAX_MEMBERS],
    inverse_damping: [f64; MAX_MEMBERS],
    /// The fastest of its members' `K_k / Dw_k` (1/s): how fast a sliding spring-damper
    /// relaxes ([`GroupInput::sliding_rate`]; not read for springs).
    relaxation_rate: f64,
}

/// A group's law at one state: its constants (by reference: an evaluation copies only
/// what changes), and by member the branch deflection and its sticking rate.
#[derive(Clone, Copy, Debug)]
pub struct GroupInput<'a> {
    pub law: &'a GroupLaw,
    pub deflection: [f64; MAX_MEMBERS],
    pub sticking_rate: [f64; MAX_MEMBERS],
}

impl Default for GroupLaw {
    fn default() -> Self {
        GroupLaw::EMPTY
    }
}

impl Default for GroupInput<'_> {
    fn default() -> Self {
        GroupInput::at_rest(&GroupLaw::EMPTY)
    }
}

impl std::ops::Deref for GroupInput<'_> {
    type Target = GroupLaw;
    fn deref(&self) -> &GroupLaw {
        self.law
    }
}

/// What the group does: deflection rates and forces by member, and the event value.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GroupOutput {
    pub rate: [f64; MAX_MEMBERS],
    pub force: [f64; MAX_MEMBERS],
    pub event: f64,
}

/// Forces (or rates) by member.
pub type Members = [f64; MAX_MEMBERS];

/// How fast a sliding spring group returns its members' forces to the ellipse, 1/s: the
/// least and the largest over its members ([`GroupInput::return_rates`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReturnRates {
    pub least: f64,
    pub largest: f64,
}

impl ReturnRates {
    /// Each the larger of the two.
    pub fn max(self, other: ReturnRates) -> ReturnRates {
        ReturnRates {
            least: self.least.max(other.least),
            largest: self.largest.max(other.largest),
        }
    }
}

/// How a group's deflection rates move with its inputs in a fixed mode, by member `k`
/// and `j`: `d rate_k / d b_j` and `d rate_k / d g_j` (zero rows and columns for a missing
/// member).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RateSlopes {
    pub by_deflection: [Members; MAX_MEMBERS],
    pub by_sticking_rate: [Members; MAX_MEMBERS],
}

/// Newton steps of the damped projection before it falls back to the monotone search.
const NEWTON_STEPS: usize = 12;

/// The multiplier of a damped group's projection onto its ellipse: settled, or searched
/// for from `start`.
#[derive(Clone, Copy, Debug)]
enum Projection {
    Settled(f64),
    Search(Search),
}

/// A search for the projection's multiplier of a group with two members: where it
/// starts (below the multiplier, as the monotone search needs), where Newton's method
/// starts, the group's weights `a_k = Dw_k / L_k^2`, and the trial force's
/// `r_k = (T_k / L_k)^2`.
#[derive(Clone, Copy, Debug)]
struct Search {
    start: f64,
    newton_start: f64,
    weight: Members,
    ratio_squared: Members,
}

impl Search {
    /// A place holder where no search is made.
    const NONE: Search = Search {
        start: 0.0,
        newton_start: 0.0,
        weight: [0.0; MAX_MEMBERS],
        ratio_squared: [0.0; MAX_MEMBERS],
    };
}

/// One Newton step of a search.
enum Step {
    /// The forces moved by rounding only.
    Settled(f64),
    Next(f64),
}

impl Search {
    /// The multiplier by Newton's method on `S(lambda)^(-1/2) = 1`,
    /// `S = sum (T_k / (L_k (1 + lambda a_k)))^2`: linear in lambda where the weights are
    /// equal, and close to it where they differ, so two or three steps reach rounding.
    /// `None` if it leaves the admissible range or does not settle.
    fn lambda_by_norm(&self) -> Option<f64> {
        let mut lambda = self.newton_start;
        for _ in 0..NEWTON_STEPS {
            match self.newton_step(lambda)? {
                Step::Settled(lambda) => return Some(lambda),
                Step::Next(next) => lambda = next,
            }
        }
        None
    }

    /// One step of [`Search::lambda_by_norm`] from `lambda`; `None` if it leaves the
    /// admissible range.
    ///
    /// With `r_k = (T_k / L_k)^2`, `p_k = 1 + lambda a_k`, `n = r_0 p_1^2 + r_1 p_0^2` and
    /// `m = r_0 a_0 p_1^3 + r_1 a_1 p_0^3`, `S = n / (p_0 p_1)^2` and the step
    /// `-h / h'` (`h = S^(-1/2) - 1`) is `-n (p_0 p_1 - sqrt n) / m`: one root and one
    /// division.
    #[inline]
    fn newton_step(&self, lambda: f64) -> Option<Step> {
        let (a, r) = (&self.weight, &self.ratio_squared);
        let (p0, p1) = (1.0 + lambda * a[0], 1.0 + lambda * a[1]);
        if !(p0 > 0.0 && p1 > 0.0) {
            return None;
        }
        let n = r[0] * p1 * p1 + r[1] * p0 * p0;
        let m = r[0] * a[0] * p1 * p1 * p1 + r[1] * a[1] * p0 * p0 * p0;
        let step = -n * (p0 * p1 - n.sqrt()) / m;
        if !step.is_finite() {
            return None;
        }
        // Settled where the step moved the forces `F_k = T_k / p_k` by at most 1e-8 L_k:
        // Newton's error falls to about the square of the step, 1e-16 (rounding), so this
        // step is the last one needed; a further step only confirmed it (the fast and the
        // monotone multipliers agree to 4e-15 L_k in the tests):
        // `|dF_k| / L_k = sqrt(r_k) a_k |step| / p_k^2`.
        let moves = |r: f64, a: f64, p: f64| r * (a * step) * (a * step) > 1e-16 * (p * p) * (p * p);
        let next = lambda + step;
        Some(if moves(r[0], a[0], p0) || moves(r[1], a[1], p1) {
            Step::Next(next)
        } else {
            Step::Settled(next)
        })
    }
}

/// Below this share of the utilisation in its lesser direction, a projection's Newton
/// steps start from a fixed-point step ([`newton_start`]).
const MINOR_SHARE: f64 = 1e-3;

/// Where Newton's method on a projection's multiplier starts, from `start` (the radial
/// multiplier of the largest weight, below the root). Where one member holds nearly all
/// of the utilisation and the largest weight (a slide in about one direction), a step of
/// the fixed point `lambda = (sqrt(r_M / (1 - r_m / p_m^2)) - 1) / a_M` (`M` that member,
/// `m` the other, `p_m = 1 + lambda a_m`): it contracts by about the lesser member's
/// share of the force on the ellipse times `a_m / a_M`, so one step leaves an error of
/// about the square of that share, and the first Newton step settles. (Near the ellipse
/// that share is the trial's, which the guard reads; far outside it with far-apart
/// weights, the lesser member keeps more of its force, the start is looser, and Newton
/// takes a few steps more.) Otherwise `start`.
#[inline]
fn newton_start(start: f64, weight: &Members, ratio_squared: &Members, utilisation: f64) -> f64 {
    let (major, minor) = if ratio_squared[0] >= ratio_squared[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    if !(ratio_squared[minor] <= MINOR_SHARE * utilisation && weight[major] >= weight[minor]) {
        return start;
    }
    // `r_M / (1 - r_m / p_m^2)`, with one division.
    let p_squared = (1.0 + start * weight[minor]).powi(2);
    let major_share = ratio_squared[major] * p_squared / (p_squared - ratio_squared[minor]);
    let guess = (major_share.sqrt() - 1.0) / weight[major];
    // Above the root where `start` is below it; anything else (a NaN, or infinite where
    // `p_m^2 = r_m`) is not taken.
    if guess >= start && guess.is_finite() {
        guess
    } else {
        start
    }
}

/// The most groups [`evaluate_together`] takes: every group and branch of a tire.
pub const MAX_TOGETHER: usize =
    crate::physics::friction::Group::COUNT * crate::physics::friction::MAX_BRANCHES;

/// [`GroupInput::evaluate`] of each of `inputs` (at most `N`) in its mode, the same
/// values: the damped groups that slide take their projections side by side
/// ([`closest_points_where`]). (`N` is the most a caller has: its working arrays are made
/// for every call.)
pub fn evaluate_together<const N: usize>(
    inputs: &[GroupInput],
    sliding: &[bool],
    outputs: &mut [GroupOutput],
) {
    debug_assert!(inputs.len() <= N, "{} groups for arrays of {N}", inputs.len());
    let count = inputs.len().min(N);
    let mut trials = [[0.0; MAX_MEMBERS]; N];
    let mut utilisations = [0.0; N];
    let mut projected = [false; N];
    for j in 0..count {
        let input = &inputs[j];
        if !(input.damped() && sliding[j]) {
            outputs[j] = input.evaluate(sliding[j]);
            continue;
        }
        let trial = input.sticking_force();
        (trials[j], utilisations[j], projected[j]) = (trial, input.utilisation(&trial), true);
    }
    let lambdas = multipliers_together(&inputs[..count], &trials, &utilisations, &projected);
    for j in 0..count {
        if projected[j] {
            let input = &inputs[j];
            let force = input.projected(&trials[j], lambdas[j]);
            outputs[j] = input.damped_sliding(force, utilisations[j]);
        }
    }
}

/// [`GroupInput::closest_point`] of the trial force of each group `j` with `which[j]`
/// (its utilisation above zero), the same values, by slot (zero for the others), side by
/// side: the Newton steps of one group's multiplier need not wait for another's (each
/// waits on the last of its own).
pub fn closest_points_where(
    inputs: &[GroupInput],
    trials: &[Members; MAX_TOGETHER],
    utilisations: &[f64; MAX_TOGETHER],
    which: &[bool; MAX_TOGETHER],
) -> [Members; MAX_TOGETHER] {
    let count = inputs.len().min(MAX_TOGETHER);
    let lambdas = multipliers_together(&inputs[..count], trials, utilisations, which);
    let mut points = [[0.0; MAX_MEMBERS]; MAX_TOGETHER];
    for j in 0..count {
        if which[j] {
            points[j] = inputs[j].projected(&trials[j], lambdas[j]);
        }
    }
    points
}

/// The multipliers of [`GroupInput::closest_point`] of the groups `j` with `which[j]`, by
/// rounds of Newton steps over the searches still going on (zero for the others).
fn multipliers_together<const N: usize>(
    inputs: &[GroupInput],
    trials: &[Members; N],
    utilisations: &[f64; N],
    which: &[bool; N],
) -> [f64; N] {
    let mut lambdas = [0.0; N];
    // The searches, and which of them go on (their indices, the first `pending`): a
    // round of Newton steps visits only those.
    let mut searches = [Search::NONE; N];
    let mut going_on = [0; N];
    let mut pending = 0;
    for j in 0..inputs.len().min(N) {
        if !which[j] {
            continue;
        }
        match inputs[j].projection(&trials[j], utilisations[j]) {
            Projection::Settled(lambda) => lambdas[j] = lambda,
            Projection::Search(search) => {
                (lambdas[j], searches[j]) = (search.newton_start, search);
                going_on[pending] = j;
                pending += 1;
            }
        }
    }
    for _ in 0..NEWTON_STEPS {
        let mut still = 0;
        for p in 0..pending {
            let j = going_on[p];
            match searches[j].newton_step(lambdas[j]) {
                Some(Step::Next(lambda)) => {
                    lambdas[j] = lambda;
                    going_on[still] = j;
                    still += 1;
                }
                Some(Step::Settled(lambda)) => lambdas[j] = lambda,
                // Out of the admissible range: the monotone search from its start.
                None => lambdas[j] = inputs[j].lambda_monotone(&trials[j], &searches[j]),
            }
        }
        pending = still;
        if pending == 0 {
            break;
        }
    }
    // Not settled within the Newton steps.
    for &j in &going_on[..pending] {
        lambdas[j] = inputs[j].lambda_monotone(&trials[j], &searches[j]);
    }
    lambdas
}

/// The sliding spring law at one state ([`GroupInput::flow`]).
#[derive(Default)]
struct Flow {
    normal: Members,
    along: f64,
    stiffness_along: f64,
    cosine: f64,
}

/// A damped group's event value at the `utilisation` of its trial force: sticking, how
/// far the trial is out of the ellipse; sliding, how far it is in.
fn damped_event(utilisation: f64, sliding: bool) -> f64 {
    if sliding {
        1.0 - utilisation
    } else {
        utilisation - 1.0
    }
}

/// The cosine between a group's normal `n = F / L^2` and its sticking force rate `K g`,
/// from `n.K g`, `|n|^2` and `|K g|^2`: positive while sticking would push the force out
/// of the ellipse, zero without motion.
#[inline]
pub fn outward_cosine_from(along: f64, normal_norm: f64, rate_norm: f64) -> f64 {
    let norm = (normal_norm * rate_norm).sqrt();
    if norm > 0.0 { along / norm } else { 0.0 }
}

impl GroupLaw {
    /// A law without members.
    pub const EMPTY: GroupLaw = GroupLaw {
        count: 0,
        direction: [0; MAX_MEMBERS],
        stiffness: [0.0; MAX_MEMBERS],
        damping: [0.0; MAX_MEMBERS],
        limit: [0.0; MAX_MEMBERS],
        inverse_limit: [0.0; MAX_MEMBERS],
        weight: [0.0; MAX_MEMBERS],
        inverse_damping: [0.0; MAX_MEMBERS],
        relaxation_rate: 0.0,
    };

    /// Adds direction `direction` with its constants.
    pub fn with_member(mut self, direction: Direction, stiffness: f64, damping: f64, limit: f64) -> Self {
        let m = self.count;
        self.direction[m] = direction as usize;
        self.stiffness[m] = stiffness;
        self.damping[m] = damping;
        self.inverse_damping[m] = if damping > 0.0 { damping.recip() } else { 0.0 };
        // As the members' `K / Dw` folded by `f64::max`: an undamped member's is infinite
        // (a group damped in one direction only slides stiffly in the other).
        self.relaxation_rate = self.relaxation_rate.max(stiffness / damping);
        self.set_limit(m, limit);
        self.count += 1;
        self
    }

    /// Member `m`'s limit, and the constants made from it.
    pub fn set_limit(&mut self, m: usize, limit: f64) {
        self.set_limit_and_inverse(m, limit, limit.recip());
    }

    /// Member `m`'s limit with its reciprocal made by the caller (from a fraction's and a
    /// direction's, so that the branches of a step share their divisions), and the
    /// constants made from them.
    pub fn set_limit_and_inverse(&mut self, m: usize, limit: f64, inverse_limit: f64) {
        self.limit[m] = limit;
        self.inverse_limit[m] = inverse_limit;
        self.weight[m] = self.damping[m] * (inverse_limit * inverse_limit);
    }

    /// The indices of its members. (The law's own sums take every slot: a missing
    /// member's constants, deflection and rate are zero, so it adds nothing, and the
    /// loops have a fixed length.)
    pub fn members(&self) -> std::ops::Range<usize> {
        0..self.count.min(MAX_MEMBERS)
    }

    /// Damped if its elements have dampers (both or neither: checked with the parameters).
    #[inline]
    pub fn damped(&self) -> bool {
        self.damping.iter().any(|&d| d > 0.0)
    }

    /// `sum (F_k / L_k)^2` for forces `force`.
    #[inline]
    pub fn utilisation(&self, force: &Members) -> f64 {
        let mut sum = 0.0;
        for k in 0..MAX_MEMBERS {
            let ratio = force[k] * self.inverse_limit[k];
            sum += ratio * ratio;
        }
        sum
    }

    /// A spring group's deflection rates and event value in its mode, at deflections
    /// `deflection` and sticking rates `sticking_rate` (the law of the module's doc):
    /// sticking, the sticking rates and the utilisation less one; sliding, the rates
    /// along the ellipse and minus the outward cosine.
    #[inline]
    pub fn spring_rates(
        &self,
        deflection: &Members,
        sticking_rate: &Members,
        sliding: bool,
    ) -> (Members, f64) {
        let mut force = [0.0; MAX_MEMBERS];
        for k in 0..MAX_MEMBERS {
            force[k] = self.stiffness[k] * deflection[k];
        }
        if !sliding {
            return (*sticking_rate, self.utilisation(&force) - 1.0);
        }
        let flow = self.flow(&force, sticking_rate);
        let lambda = if flow.stiffness_along > 0.0 {
            flow.along / flow.stiffness_along
        } else {
            0.0
        };
        let mut rate = [0.0; MAX_MEMBERS];
        for k in 0..MAX_MEMBERS {
            rate[k] = sticking_rate[k] - lambda * flow.normal[k];
        }
        (rate, -flow.cosine)
    }

    /// What the sliding law needs at spring forces `force` and sticking rates
    /// `sticking_rate`: the normal `n = F / L^2`, `n.K g`, `n.K n`, and the cosine of `n`
    /// and `K g`. Sliding, the slider moves along `n` at `lambda = n.K g / n.K n`.
    #[inline]
    fn flow(&self, force: &Members, sticking_rate: &Members) -> Flow {
        let mut flow = Flow::default();
        let (mut normal_norm, mut rate_norm) = (0.0, 0.0);
        for k in 0..MAX_MEMBERS {
            let normal = force[k] * (self.inverse_limit[k] * self.inverse_limit[k]);
            let force_rate = self.stiffness[k] * sticking_rate[k];
            flow.normal[k] = normal;
            flow.along += normal * force_rate;
            flow.stiffness_along += normal * self.stiffness[k] * normal;
            normal_norm += normal * normal;
            rate_norm += force_rate * force_rate;
        }
        flow.cosine = outward_cosine_from(flow.along, normal_norm, rate_norm);
        flow
    }

    /// The rate of a spring group's utilisation `sum (K_k b_k / L_k)^2` where its
    /// deflections `b` move at `rate`.
    pub fn utilisation_rate(&self, deflection: &Members, rate: &Members) -> f64 {
        let mut sum = 0.0;
        for k in 0..MAX_MEMBERS {
            let scale = self.stiffness[k] * self.inverse_limit[k];
            sum += 2.0 * (scale * deflection[k]) * (scale * rate[k]);
        }
        sum
    }
}

impl<'a> GroupInput<'a> {
    /// The law's group with every deflection and rate zero.
    pub const fn at_rest(law: &'a GroupLaw) -> Self {
        GroupInput {
            law,
            deflection: [0.0; MAX_MEMBERS],
            sticking_rate: [0.0; MAX_MEMBERS],
        }
    }

    /// The spring forces `K b`.
    pub fn spring_force(&self) -> Members {
        let mut force = [0.0; MAX_MEMBERS];
        for k in 0..MAX_MEMBERS {
            force[k] = self.stiffness[k] * self.deflection[k];
        }
        force
    }

    /// The force that sticking needs: `K b + Dw g`.
    pub fn sticking_force(&self) -> Members {
        let mut force = self.spring_force();
        for k in 0..MAX_MEMBERS {
            force[k] += self.damping[k] * self.sticking_rate[k];
        }
        force
    }

    /// Whether its sticking force is outside its ellipse: the mode in which a damped group
    /// slides.
    pub fn outside(&self) -> bool {
        self.utilisation(&self.sticking_force()) > 1.0
    }

    /// Whether its sticking force is inside its ellipse, or outside with at most `share` of
    /// its utilisation in its lesser direction (a slide in about one direction).
    pub fn within_share_of_one_direction(&self, share: f64) -> bool {
        let trial = self.sticking_force();
        let shares = [0, 1].map(|k| (trial[k] * self.inverse_limit[k]).powi(2));
        let utilisation = shares[0] + shares[1];
        utilisation <= 1.0 || shares[0].min(shares[1]) <= share * utilisation
    }

    /// How fast the group moves its force while it slides, 1/s: springs turn it across
    /// the ellipse at about their sticking force rate, `sum |K_k g_k| / L_k`; spring-dampers
    /// relax at `max K_k / Dw_k`. (The explicit integration's substeps stay below a few of
    /// its time constants.)
    pub fn sliding_rate(&self) -> f64 {
        if self.damped() {
            self.relaxation_rate
        } else {
            self.members()
                .map(|k| (self.stiffness[k] * self.sticking_rate[k] * self.inverse_limit[k]).abs())
                .sum()
        }
    }

    /// [`GroupInput::evaluate`] of a damped group of one member (a cascade's driver) in
    /// mode `sliding`, or where that is `None`, in the mode deciding finds (sliding where
    /// its sticking force is outside its limit, [`GroupInput::outside`], the same bits);
    /// with that mode. Sliding, its force is on its limit on its trial force's side: a
    /// one-member ellipse's closest point, exactly, with no projection to search.
    #[inline]
    pub fn evaluate_one_damped(&self, sliding: Option<bool>) -> (GroupOutput, bool) {
        debug_assert!(self.count == 1 && self.damped(), "a damped group of one member");
        let trial = self.sticking_force();
        let utilisation = self.utilisation(&trial);
        let sliding = sliding.unwrap_or(utilisation > 1.0);
        let output = if sliding {
            let mut force = [0.0; MAX_MEMBERS];
            force[0] = self.limit[0].copysign(trial[0]);
            self.damped_sliding(force, utilisation)
        } else {
            self.damped_sticking(trial, utilisation)
        };
        (output, sliding)
    }

    /// Rates, forces and event value in the given mode.
    #[inline]
    pub fn evaluate(&self, sliding: bool) -> GroupOutput {
        if self.damped() {
            self.evaluate_damped(sliding)
        } else {
            self.evaluate_springs(sliding)
        }
    }

    /// The event value [`GroupInput::evaluate`] gives, the same bits: a damped group's
    /// without its projection onto the ellipse (it follows from the trial force alone).
    /// (Inlined: a call reads its input back from memory just after it was made, and the
    /// cascade's drivers took 7 % of DDT's slide there.)
    #[inline(always)]
    pub fn event(&self, sliding: bool) -> f64 {
        if !self.damped() {
            return self.evaluate_springs(sliding).event;
        }
        damped_event(self.utilisation(&self.sticking_force()), sliding)
    }

    /// How fast a spring-damper group's event value moves in its mode where its
    /// deflections move at `rate` and its sticking rates at `sticking_rate_rate`: its
    /// trial force `T = K b + Dw g` moves at `K rate + Dw sticking_rate_rate`, and the
    /// utilisation `sum (T_k / L_k)^2` at `2 sum T_k T'_k / L_k^2` ([`damped_event`]).
    pub fn damped_event_rate(&self, sliding: bool, rate: &Members, sticking_rate_rate: &Members) -> f64 {
        let trial = self.sticking_force();
        let mut utilisation_rate = 0.0;
        for k in 0..MAX_MEMBERS {
            let trial_rate = self.stiffness[k] * rate[k] + self.damping[k] * sticking_rate_rate[k];
            let scale = self.inverse_limit[k] * self.inverse_limit[k];
            utilisation_rate += 2.0 * trial[k] * trial_rate * scale;
        }
        if sliding {
            -utilisation_rate
        } else {
            utilisation_rate
        }
    }

    /// [`RateSlopes`] of the rates [`GroupInput::evaluate`] gives in the same mode, in
    /// closed form: for the stiff integration's Jacobian, which takes them through the
    /// chain rule instead of evaluating the whole system once per entry. `rate` is what
    /// that evaluation gave: a sliding spring-damper's force follows from it, with no
    /// second projection onto the ellipse.
    #[inline]
    pub fn rate_slopes(&self, sliding: bool, rate: &Members) -> RateSlopes {
        // Sticking, the deflections move at their sticking rates.
        let mut slopes = RateSlopes::default();
        for k in self.members() {
            slopes.by_sticking_rate[k][k] = 1.0;
        }
        if !sliding {
            return slopes;
        }
        if self.damped() {
            self.damped_sliding_slopes(rate, &mut slopes);
        } else {
            self.spring_sliding_slopes(&mut slopes);
        }
        slopes
    }

    /// A sliding spring group, `db_k/dt = g_k - lambda n_k` with `n = K b / L^2` and
    /// `lambda = A / N`, `A = sum n K g`, `N = sum n K n`: with `c_j = K_j / L_j^2`,
    /// `d lambda / d g_j = n_j K_j / N` and `d lambda / d b_j = c_j K_j (g_j - 2 lambda
    /// n_j) / N`. (Where `N` is not positive, `lambda` is zero, as in the law.)
    fn spring_sliding_slopes(&self, slopes: &mut RateSlopes) {
        let flow = self.flow(&self.spring_force());
        if flow.stiffness_along > 0.0 {
            let inverse_norm = flow.stiffness_along.recip();
            let lambda = flow.along * inverse_norm;
            for j in self.members() {
                let curvature = self.stiffness[j] * self.inverse_limit[j] * self.inverse_limit[j];
                let by_rate = flow.normal[j] * self.stiffness[j] * inverse_norm;
                let by_deflection = curvature
                    * self.stiffness[j]
                    * (self.sticking_rate[j] - 2.0 * lambda * flow.normal[j])
                    * inverse_norm;
                for k in self.members() {
                    slopes.by_sticking_rate[k][j] -= flow.normal[k] * by_rate;
                    slopes.by_deflection[k][j] = -flow.normal[k] * by_deflection;
                }
                slopes.by_deflection[j][j] -= lambda * curvature;
            }
        }
    }

    /// How fast a sliding spring group's slider returns its members' forces to the
    /// ellipse, `|lambda| K_k / L_k^2` (1/s; `lambda` as in [`GroupInput::rate_slopes`]),
    /// the least and the largest over its members (zero sticking, damped, or for one
    /// member: no turn). Where the least is not small against a substep, both members'
    /// sliders move and the force turns along the ellipse as the slip turns: the rates
    /// are bilinear in the deflections and `lambda`. The largest is the fastest mode of
    /// the slide's linearisation.
    pub fn return_rates(&self, sliding: bool) -> ReturnRates {
        if !sliding || self.damped() || self.count < 2 {
            return ReturnRates::default();
        }
        let flow = self.flow(&self.spring_force());
        if flow.stiffness_along <= 0.0 {
            return ReturnRates::default();
        }
        let lambda = (flow.along / flow.stiffness_along).abs();
        let curvature = |j: usize| self.stiffness[j] * self.inverse_limit[j] * self.inverse_limit[j];
        let (first, second) = (curvature(0), curvature(1));
        ReturnRates {
            least: lambda * first.min(second),
            largest: lambda * first.max(second),
        }
    }

    /// A sliding damped group, `Dw_k db_k/dt = F_k - K_k b_k` with `F_k = T_k / q_k`,
    /// `q_k = 1 + lambda a_k`, on the ellipse: from the constraint, `d lambda / d T_j =
    /// (F_j / (L_j^2 q_j)) / S` with `S = sum F_k^2 a_k / (L_k^2 q_k)`, so `d F_k / d T_j =
    /// (delta_kj - F_k a_k d lambda / d T_j) / q_k`; `T = K b + Dw g`.
    ///
    /// Written out over both member slots, so that its loops have a known length: a
    /// missing member's constants, deflection and rate are zero, so its rows and columns
    /// come out zero and its terms add nothing.
    #[inline]
    fn damped_sliding_slopes(&self, rate: &Members, slopes: &mut RateSlopes) {
        let (stiffness, damping, weight) = (&self.stiffness, &self.damping, &self.weight);
        let (inverse_limit, inverse_damping) = (&self.inverse_limit, &self.inverse_damping);
        let trial = self.sticking_force();
        let force = [0, 1].map(|k| stiffness[k] * self.deflection[k] + damping[k] * rate[k]);
        let along = [0, 1].map(|k| (force[k] * inverse_limit[k]).abs());
        // The member farthest along its limit (the first where they tie; none at zero).
        let farthest_of_first = if along[0] > 0.0 { along[0] } else { 0.0 };
        // `(T_k / F_k - 1) / a_k`, with one division.
        let lambda_of = |k: usize| (trial[k] - force[k]) / (force[k] * weight[k]);
        let lambda = if along[1] > farthest_of_first {
            lambda_of(1)
        } else if along[0] > 0.0 {
            lambda_of(0)
        } else {
            0.0
        };
        let inverse_q = [0, 1].map(|k| (1.0 + lambda * weight[k]).recip());
        let normal = [0, 1].map(|k| force[k] * inverse_limit[k] * inverse_limit[k] * inverse_q[k]);
        let sum = 0.0 + normal[0] * force[0] * weight[0] + normal[1] * force[1] * weight[1];
        let inverse_sum = if sum != 0.0 { sum.recip() } else { 0.0 };
        for j in 0..MAX_MEMBERS {
            let multiplier_slope = normal[j] * inverse_sum;
            for k in 0..MAX_MEMBERS {
                let delta = if k == j { 1.0 } else { 0.0 };
                let force_slope = (delta - force[k] * weight[k] * multiplier_slope) * inverse_q[k];
                let per_damping = force_slope * inverse_damping[k];
                slopes.by_deflection[k][j] =
                    per_damping * stiffness[j] - delta * stiffness[k] * inverse_damping[k];
                slopes.by_sticking_rate[k][j] = per_damping * damping[j];
            }
        }
    }

    #[inline]
    fn evaluate_springs(&self, sliding: bool) -> GroupOutput {
        let (rate, event) = self
            .law
            .spring_rates(&self.deflection, &self.sticking_rate, sliding);
        GroupOutput {
            rate,
            force: self.spring_force(),
            event,
        }
    }

    /// The cosine between the normal `n = F / L^2` and the sticking force rate `K g`:
    /// positive while sticking would push the force out of the ellipse. Zero without
    /// motion.
    pub fn outward_cosine(&self, force: &Members) -> f64 {
        self.flow(force).cosine
    }

    /// [`GroupLaw::flow`] at its sticking rates.
    fn flow(&self, force: &Members) -> Flow {
        self.law.flow(force, &self.sticking_rate)
    }

    /// In each mode the formulas continue smoothly past the event (a sticking group
    /// outside its ellipse, a sliding one inside), so that a piece's right-hand side is
    /// smooth up to the event that ends it.
    fn evaluate_damped(&self, sliding: bool) -> GroupOutput {
        let trial = self.sticking_force();
        let utilisation = self.utilisation(&trial);
        if !sliding {
            return self.damped_sticking(trial, utilisation);
        }
        let force = self.closest_point(&trial, utilisation);
        self.damped_sliding(force, utilisation)
    }

    fn damped_sticking(&self, trial: Members, utilisation: f64) -> GroupOutput {
        GroupOutput {
            rate: self.sticking_rate,
            force: trial,
            event: damped_event(utilisation, false),
        }
    }

    /// A sliding damped group whose force is `force` (on the ellipse): the deflection
    /// follows `Dw db/dt = F - K b`.
    fn damped_sliding(&self, force: Members, utilisation: f64) -> GroupOutput {
        let mut rate = [0.0; MAX_MEMBERS];
        for k in 0..MAX_MEMBERS {
            rate[k] = (force[k] - self.stiffness[k] * self.deflection[k]) * self.inverse_damping[k];
        }
        GroupOutput {
            rate,
            force,
            event: damped_event(utilisation, true),
        }
    }

    /// The point of the ellipse `F_k = T_k / (1 + lambda a_k)`, `a_k = Dw_k / L_k^2`, for a
    /// trial force `T` with `utilisation > 0` (outside the ellipse `lambda > 0`; inside, the
    /// same formula continues with `lambda < 0`).
    pub fn closest_point(&self, trial: &Members, utilisation: f64) -> Members {
        let lambda = match self.projection(trial, utilisation) {
            Projection::Settled(lambda) => lambda,
            Projection::Search(search) => search
                .lambda_by_norm()
                .unwrap_or_else(|| self.lambda_monotone(trial, &search)),
        };
        self.projected(trial, lambda)
    }

    /// `F_k = T_k / (1 + lambda a_k)`.
    fn projected(&self, trial: &Members, lambda: f64) -> Members {
        let mut force = [0.0; MAX_MEMBERS];
        for k in 0..MAX_MEMBERS {
            force[k] = trial[k] / (1.0 + lambda * self.weight[k]);
        }
        force
    }

    /// The multiplier of [`GroupInput::closest_point`] where it has a closed form, else
    /// where its search starts.
    #[inline]
    fn projection(&self, trial: &Members, utilisation: f64) -> Projection {
        let weight = self.weight;
        // Which members move (a missing member's trial is zero).
        let moving = [trial[0] != 0.0, trial[1] != 0.0];
        let radial = |k: usize| Projection::Settled((utilisation.sqrt() - 1.0) / weight[k]);
        match moving {
            // One direction (or equal weights): the ellipse scales T radially.
            [true, false] => radial(0),
            [false, true] => radial(1),
            [false, false] => Projection::Settled(0.0),
            [true, true] if weight[0] == weight[1] => radial(0),
            [true, true] => {
                let largest = weight[0].max(weight[1]).max(0.0);
                let ratio_squared = [0, 1].map(|k| (trial[k] * self.inverse_limit[k]).powi(2));
                let start = (utilisation.sqrt() - 1.0) / largest;
                Projection::Search(Search {
                    start,
                    newton_start: newton_start(start, &weight, &ratio_squared, utilisation),
                    weight,
                    ratio_squared,
                })
            }
        }
    }

    /// The multiplier of [`GroupInput::closest_point`] by Newton's method on
    /// `phi(lambda) = S(lambda) - 1`, convex and falling: from the search's start, where
    /// `phi >= 0`, it rises monotonically to the root, with every `1 + lambda a_k > 0`.
    fn lambda_monotone(&self, trial: &Members, search: &Search) -> f64 {
        let (weight, mut lambda) = (&search.weight, search.start);
        for _ in 0..100 {
            let Some((sum, slope)) = self.squared_norm(trial, weight, lambda) else {
                return lambda;
            };
            let next = lambda - (sum - 1.0) / slope;
            if next.partial_cmp(&lambda) != Some(std::cmp::Ordering::Greater)
                || next - lambda <= 1e-16 * next.abs()
            {
                return next.max(lambda);
            }
            lambda = next;
        }
        lambda
    }

    /// `S(lambda) = sum (T_k / (L_k (1 + lambda a_k)))^2` and its slope in `lambda`;
    /// `None` where some `1 + lambda a_k` is not positive.
    fn squared_norm(&self, trial: &Members, weight: &Members, lambda: f64) -> Option<(f64, f64)> {
        let (mut sum, mut slope) = (0.0, 0.0);
        for k in self.members() {
            let shrink = 1.0 / (1.0 + lambda * weight[k]);
            if shrink.is_nan() || shrink <= 0.0 {
                return None;
            }
            let ratio = trial[k] * self.inverse_limit[k] * shrink;
            sum += ratio * ratio;
            slope -= 2.0 * ratio * ratio * weight[k] * shrink;
        }
        Some((sum, slope))
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn planar(b: [f64; 2], g: [f64; 2], damping: f64) -> GroupInput<'static> {
        planar_damped(b, g, [damping, 2.0 * damping])
    }

    /// The longitudinal member of [`planar`] alone.
    fn single(b: f64, g: f64, damping: f64) -> GroupInput<'static> {
        let law = GroupLaw::default().with_member(Direction::Longitudinal, 1000.0, damping, 30.0);
        GroupInput {
            deflection: [b, 0.0],
            sticking_rate: [g, 0.0],
            ..GroupInput::at_rest(Box::leak(Box::new(law)))
        }
    }

    fn planar_damped(b: [f64; 2], g: [f64; 2], damping: [f64; 2]) -> GroupInput<'static> {
        let law = GroupLaw::default()
            .with_member(Direction::Longitudinal, 1000.0, damping[0], 30.0)
            .with_member(Direction::Lateral, 400.0, damping[1], 20.0);
        GroupInput {
            deflection: b,
            sticking_rate: g,
            ..GroupInput::at_rest(Box::leak(Box::new(law)))
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

    /// A group's closed-form rate slopes are its rates' slopes, as central differences
    /// find them: springs and spring-dampers, with one and two members, sliding and
    /// sticking, past the ellipse and inside it.
    #[test]
    fn rate_slopes_are_the_slopes_of_the_rates() {
        for damping in [0.0, 10.0] {
            for (b, g) in [
                ([0.02, 0.03], [5.0, -3.0]),
                ([0.03, 0.0001], [0.01, 0.001]),
                ([-0.04, 0.01], [-1.0, 0.3]),
                ([0.001, 0.002], [0.01, -0.02]),
                ([0.05, 0.0], [0.2, 0.0]),
            ] {
                for (sliding, input) in [true, false].into_iter().flat_map(|sliding| {
                    [
                        (sliding, planar(b, g, damping)),
                        (sliding, single(b[0], g[0], damping)),
                    ]
                }) {
                    let slopes = input.rate_slopes(sliding, &input.evaluate(sliding).rate);
                    for j in input.members() {
                        for (by_rate, delta) in [(false, 1e-9), (true, 1e-6)] {
                            let at = |sign: f64| {
                                let mut moved = input;
                                if by_rate {
                                    moved.sticking_rate[j] += sign * delta;
                                } else {
                                    moved.deflection[j] += sign * delta;
                                }
                                moved.evaluate(sliding).rate
                            };
                            let (plus, minus) = (at(1.0), at(-1.0));
                            for k in input.members() {
                                let difference = (plus[k] - minus[k]) / (2.0 * delta);
                                let slope = if by_rate {
                                    slopes.by_sticking_rate[k][j]
                                } else {
                                    slopes.by_deflection[k][j]
                                };
                                assert!(
                                    (slope - difference).abs() <= 1e-5 * (1.0 + difference.abs()),
                                    "damping {damping}, {b:?} {g:?} sliding {sliding}: d rate {k} / d {} {j}: {slope} vs {difference}",
                                    if by_rate { "g" } else { "b" }
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Groups evaluated together give what each gives by itself, bit for bit, and so
    /// does a group's event value by itself.
    #[test]
    fn groups_evaluated_together_give_their_own_values() {
        let mut inputs = Vec::new();
        for (b, g) in [
            ([0.02, 0.03], [5.0, -3.0]),
            ([0.03, 0.0001], [0.01, 0.001]),
            ([0.0, 0.06], [0.0, 10.0]),
            ([0.001, 0.001], [0.01, 0.01]),
        ] {
            inputs.push(planar(b, g, 10.0));
            inputs.push(planar(b, g, 0.0));
        }
        for sliding in [true, false] {
            let modes = [sliding; MAX_TOGETHER];
            let mut outputs = [GroupOutput::default(); MAX_TOGETHER];
            evaluate_together::<MAX_TOGETHER>(&inputs, &modes, &mut outputs);
            for (input, together) in inputs.iter().zip(outputs) {
                assert_eq!(together, input.evaluate(sliding));
                // The event value alone, the same bits (with no projection).
                assert_eq!(input.event(sliding).to_bits(), together.event.to_bits());
            }
        }
    }

    /// The fast multiplier agrees with the monotone one to rounding, near the ellipse and
    /// far outside it, for weights close together and far apart.
    #[test]
    fn both_multipliers_find_the_same_point() {
        for damping_ratio in [1.001, 2.0, 30.0, 1e4] {
            for (b, g) in [
                ([0.02, 0.03], [5.0, -3.0]),
                ([0.03, 0.0001], [0.01, 0.001]),
                ([-0.04, 0.01], [-1.0, 200.0]),
                ([0.0301, 0.0001], [1e-6, 0.0]),
                // Nearly all of it in the direction of the larger weight: Newton's method
                // starts from a fixed-point step.
                ([0.0001, 0.0301], [0.0, 1e-6]),
                ([1e-6, 0.05], [0.0, 0.01]),
            ] {
                let input = planar_damped(b, g, [10.0, damping_ratio * 10.0]);
                let trial = input.sticking_force();
                let utilisation = input.utilisation(&trial);
                if utilisation <= 1.0 {
                    continue;
                }
                let weight = [0, 1].map(|k| input.damping[k] / (input.limit[k] * input.limit[k]));
                let largest = weight[0].max(weight[1]);
                let start = (utilisation.sqrt() - 1.0) / largest;
                let ratio_squared = [0, 1].map(|k| (trial[k] / input.limit[k]).powi(2));
                let search = Search {
                    start,
                    newton_start: newton_start(start, &weight, &ratio_squared, utilisation),
                    weight,
                    ratio_squared,
                };
                let fast = search.lambda_by_norm().expect("settles");
                let monotone = input.lambda_monotone(&trial, &search);
                for k in 0..2 {
                    let (a, m) = (
                        trial[k] / (1.0 + fast * weight[k]),
                        trial[k] / (1.0 + monotone * weight[k]),
                    );
                    assert!(
                        (a - m).abs() <= 1e-13 * input.limit[k],
                        "{damping_ratio} {b:?}: {a} against {m}"
                    );
                }
            }
        }
    }

    /// [`newton_start`] where one member holds nearly all of the utilisation (its lesser
    /// share `s` of the trial's, 1e-3 down to 1e-7: [`MINOR_SHARE`] and below) and the
    /// larger weight (1 to 1e4 times the other's), against the true multiplier (the root
    /// of `S(lambda) = 1`, by bisection to rounding): the fixed-point step lands within the
    /// square of the lesser member's share of the force on the ellipse, relative (where
    /// that share is at most 1e-2), and within `2 s^2` where the utilisation is at most 4
    /// (there the two shares are close), so the first Newton step settles; it is never
    /// below `start`. Where the guard fails (the lesser share ten times [`MINOR_SHARE`],
    /// or the larger weight on the member with the lesser share) it is `start`, bit for
    /// bit. (Far outside the ellipse with far-apart weights the share on the ellipse is
    /// far above the trial's, up to nearly all of it, and the start no closer.)
    #[test]
    fn the_newton_start_is_within_the_square_of_the_lesser_share() {
        // `S(lambda) = sum r_k / (1 + lambda a_k)^2`, falling in lambda.
        let norm = |weight: &Members, ratio_squared: &Members, lambda: f64| {
            (0..2)
                .map(|k| ratio_squared[k] / (1.0 + lambda * weight[k]).powi(2))
                .sum::<f64>()
        };
        for major in [0, 1] {
            let minor = 1 - major;
            for utilisation in [1.0001_f64, 1.5, 4.0, 100.0, 1e6] {
                for weight_ratio in [1.0, 1.5, 30.0, 1e4] {
                    for share in [1e-3, 1e-4, 1e-5, 1e-7] {
                        let mut weight: Members = [0.0; MAX_MEMBERS];
                        weight[major] = 0.02 * weight_ratio;
                        weight[minor] = 0.02;
                        let mut ratio_squared: Members = [0.0; MAX_MEMBERS];
                        ratio_squared[minor] = share * utilisation;
                        ratio_squared[major] = utilisation - ratio_squared[minor];
                        let largest = weight[0].max(weight[1]);
                        let start = (utilisation.sqrt() - 1.0) / largest;
                        let guess = newton_start(start, &weight, &ratio_squared, utilisation);
                        // The root, bracketed by `start` (S >= 1 there) and the radial
                        // multiplier of the smaller weight (S <= 1), each a little widened
                        // (clear of rounding where the weights are equal).
                        let (mut low, mut high) = (
                            start * (1.0 - 1e-9),
                            (utilisation.sqrt() - 1.0) / weight[minor] * (1.0 + 1e-9),
                        );
                        assert!(norm(&weight, &ratio_squared, low) >= 1.0);
                        assert!(norm(&weight, &ratio_squared, high) <= 1.0);
                        for _ in 0..200 {
                            let middle = 0.5 * (low + high);
                            if norm(&weight, &ratio_squared, middle) >= 1.0 {
                                low = middle;
                            } else {
                                high = middle;
                            }
                        }
                        let root = 0.5 * (low + high);
                        let label = format!(
                            "major {major}, utilisation {utilisation}, weights {weight:?}, share {share}: start {start}, guess {guess}, root {root}"
                        );
                        assert!(guess >= start, "{label}");
                        // The lesser member's share of the force on the ellipse: the trial's
                        // share where the utilisation is near one, larger where it is far
                        // outside and the lesser member's weight smaller (it shrinks less).
                        let on_ellipse = ratio_squared[minor] / (1.0 + root * weight[minor]).powi(2);
                        // Rounding's part: `S` is known to a few roundings, and moves with
                        // the multiplier by `2 (1 - 1 / sqrt(utilisation))` relative (a
                        // utilisation near one leaves its multiplier to fewer bits).
                        let rounding = 8.0 * f64::EPSILON / (1.0 - 1.0 / utilisation.sqrt());
                        let error = (guess - root).abs() / root;
                        if on_ellipse <= 1e-2 {
                            assert!(
                                error <= on_ellipse * on_ellipse + rounding,
                                "{label}: relative error {error:e}, share on the ellipse {on_ellipse:e}"
                            );
                        }
                        if utilisation <= 4.0 {
                            assert!(
                                error <= 2.0 * share * share + rounding,
                                "{label}: relative error {error:e}"
                            );
                        }
                        // The guard fails: the lesser share above the bound, or the larger
                        // weight on the member with the lesser share.
                        let mut shared = ratio_squared;
                        shared[minor] = 10.0 * MINOR_SHARE * utilisation;
                        shared[major] = utilisation - shared[minor];
                        assert_eq!(
                            newton_start(start, &weight, &shared, utilisation).to_bits(),
                            start.to_bits(),
                            "{label}"
                        );
                        if weight_ratio > 1.0 {
                            let swapped = [weight[1], weight[0]];
                            assert_eq!(
                                newton_start(start, &swapped, &ratio_squared, utilisation).to_bits(),
                                start.to_bits(),
                                "{label}"
                            );
                        }
                    }
                }
            }
        }
    }
}
