//! Stick/slide events inside a piece: where a group's event value crosses zero (regula
//! falsi, Illinois), and whether a limit is touched and left again between samples (a
//! parabola through three samples, then a golden-section search on the accurate solution).

use super::{Events, Modes, NO_EVENT, NotConverged, SIZE, SlidingStep, Vector, made_whole};
use crate::physics::friction::EVENT_TOLERANCE;
use crate::physics::friction::{Group, MAX_BRANCHES};

/// A sampled event value above minus this is close enough to its limit that the limit
/// may be touched between samples; the accurate solution is then maximised there.
pub(super) const NEAR_EVENT: f64 = 1e-3;
/// A group whose event value is above minus this at the start of a substep may reach its
/// event within it: its crossing is predicted.
const PREDICT_NEAR: f64 = 0.1;
/// An event is placed where its value is past zero by half the event tolerance or more,
/// and by the tolerance at most ([`at_event`]); searches aim at the middle of that band.
const LEVEL: f64 = 0.5 * EVENT_TOLERANCE;
const AIM: f64 = 1.5 * LEVEL;

/// Whether an event value is in the band where its event is placed.
fn at_event(value: f64) -> bool {
    value > LEVEL && value <= EVENT_TOLERANCE
}

/// Newton steps that may settle a predicted crossing missed by a little.
const SETTLE_STEPS: usize = 3;
/// How many times its mean rate over a substep another group's event value is allowed
/// to move at over a settling step taken without evaluating the rates
/// ([`SlidingStep::reached_without_rates`]).
const SETTLE_GUARD: f64 = 16.0;
/// The fraction of a short substep by which its last stage's event values stand for
/// those at its end ([`SlidingStep::settle_from_stage`]): the stage is within about the
/// tolerance of the end, far less.
const STAGE_REACH: f64 = 1e-3;
/// How far within the tolerance the second-order term of a settling step's Taylor
/// polynomial is to be ([`SlidingStep::short_step`]): its rate of change is an estimate.
const TAYLOR_MARGIN: f64 = 4.0;

/// Every group and branch of a friction with `branches` branches, group by group. (From a
/// table: a nested range's `any` and `find` were a call each, several a substep.)
fn candidates(branches: usize) -> impl Iterator<Item = (usize, usize)> {
    EVERY_GROUP_AND_BRANCH
        .iter()
        .copied()
        .filter(move |&(_, i)| i < branches)
}

/// Every group and branch there can be, group by group.
static EVERY_GROUP_AND_BRANCH: [(usize, usize); Group::COUNT * MAX_BRANCHES] = {
    let mut all = [(0, 0); Group::COUNT * MAX_BRANCHES];
    let mut k = 0;
    while k < all.len() {
        all[k] = (k / MAX_BRANCHES, k % MAX_BRANCHES);
        k += 1;
    }
    all
};
/// How often a group may change mode at one instant before its events wait for time to
/// move on (a motion exactly along the limit, where rounding decides).
pub(super) const MAX_CHANGES_AT_AN_INSTANT: u32 = 3;

/// A point inside a substep (time from its start) where group `g`, branch `i` is past
/// its event tolerance.
pub(super) type Interior = (f64, usize, usize);

/// A peak past the tolerance of the parabola through event values at three equally
/// spaced samples `s = -1, 0, 1`: its position `s` and the group and branch.
pub(super) fn peak_between(first: &Events, middle: &Events, last: &Events) -> Option<(f64, usize, usize)> {
    for g in 0..Group::COUNT {
        for i in 0..MAX_BRANCHES {
            let (e0, e1, e2) = (first[g][i], middle[g][i], last[g][i]);
            if !(e0.is_finite() && e1.is_finite() && e2.is_finite()) {
                continue;
            }
            let curvature = 0.5 * (e0 - 2.0 * e1 + e2);
            let slope = 0.5 * (e2 - e0);
            if curvature < 0.0 {
                let s = -slope / (2.0 * curvature);
                if s.abs() <= 1.0 && e1 - slope * slope / (4.0 * curvature) > EVENT_TOLERANCE {
                    return Some((s, g, i));
                }
            }
        }
    }
    None
}

/// Where within a substep a limit may have been touched, from the event values at the
/// samples of one integration row: the first sample past the tolerance, or a peak past it
/// between three consecutive samples, else the sample closest to its limit (within
/// [`NEAR_EVENT`]).
pub(super) struct InteriorSearch {
    interior: Option<Interior>,
    closest: Option<(f64, usize, usize, f64)>,
    /// The event values of the last two samples, the older at `older`: each sample
    /// takes the older's place.
    recent: [Events; 2],
    older: usize,
    samples: usize,
}

impl InteriorSearch {
    /// A search from the event values at the start of the substep.
    pub(super) fn new(start_events: &Events) -> Self {
        Self {
            interior: None,
            closest: None,
            recent: [*start_events, *start_events],
            older: 0,
            samples: 0,
        }
    }

    /// The event values at sample `index` (from 1), at `index spacing` from the start of
    /// the substep.
    pub(super) fn sample(&mut self, index: usize, spacing: f64, events: &Events) {
        self.samples += 1;
        let at = index as f64 * spacing;
        let (first, middle) = (&self.recent[self.older], &self.recent[1 - self.older]);
        // Usually no value is near its limit, nor can a peak between the last three
        // samples pass it: one pass without a branch each shows that. The parabola's
        // peak within the samples is at most `e1 + |e2 - e0| / 4` above the middle one
        // (at `|s| <= 1` its rise is `|slope| |s| / 2`). A group that does not exist
        // (NaN or minus infinity) gives no bound.
        let (mut highest, mut peak_bound) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for ((&e2, &e1), &e0) in events
            .as_flattened()
            .iter()
            .zip(middle.as_flattened())
            .zip(first.as_flattened())
        {
            // Plain comparisons (a NaN is never above): `f64::max` orders NaN in five
            // instructions where one does.
            let bound = e1 + 0.25 * (e2 - e0).abs();
            highest = if e2 > highest { e2 } else { highest };
            peak_bound = if bound > peak_bound { bound } else { peak_bound };
        }
        if self.interior.is_none() && highest > EVENT_TOLERANCE {
            self.interior = first_past_tolerance(events).map(|(g, i)| (at, g, i));
        }
        if self.interior.is_none() && self.samples >= 2 && peak_bound > EVENT_TOLERANCE {
            self.interior = peak_between(first, middle, events)
                .map(|(s, g, i)| ((index as f64 - 1.0 + s) * spacing, g, i));
        }
        // The closest sample is the first group and branch at the highest value.
        if highest > -NEAR_EVENT
            && self.closest.is_none_or(|(_, _, _, best)| highest > best)
            && let Some(k) = events.as_flattened().iter().position(|&e| e == highest)
        {
            self.closest = Some((at, k / MAX_BRANCHES, k % MAX_BRANCHES, highest));
        }
        self.recent[self.older] = *events;
        self.older = 1 - self.older;
    }

    /// The first interior point past the tolerance, and the sample closest to its limit.
    pub(super) fn found(&self) -> (Option<Interior>, Option<Interior>) {
        (self.interior, self.closest.map(|(at, g, i, _)| (at, g, i)))
    }
}

/// The first group and branch whose event value is past the tolerance.
pub(super) fn first_past_tolerance(events: &Events) -> Option<(usize, usize)> {
    (0..Group::COUNT)
        .flat_map(|g| (0..MAX_BRANCHES).map(move |i| (g, i)))
        .find(|&(g, i)| events[g][i] > EVENT_TOLERANCE)
}

impl SlidingStep<'_> {
    /// The time in `window` (clipped to the substep) at which group `g`, branch `i` has
    /// its largest event value, if that is past the tolerance: a search on the accurate
    /// solution ([`largest_past`]; each value it asks for is a substep from `t`).
    pub(super) fn touches_near(
        &self,
        t: f64,
        z: &Vector,
        modes: &Modes,
        length: f64,
        window: (f64, f64),
        (g, i): (usize, usize),
    ) -> Option<f64> {
        let value = |tau: f64| {
            if tau <= 0.0 {
                return self.events(t, z, modes)[g][i];
            }
            self.substep_plain(t, z, tau, modes)
                .map_or(f64::NEG_INFINITY, |z_tau| {
                    self.events(t + tau, &z_tau, modes)[g][i]
                })
        };
        largest_past(value, (window.0.max(0.0), window.1.min(length)), 1e-6 * length)
    }

    /// The earliest mode change within the substep `(t, z, length, modes)` among the
    /// `candidate` groups and branches (those whose event value ends past the tolerance):
    /// its time from `t`, group, branch, and the state there where it was computed. A
    /// candidate past its tolerance at the start changes at once. Otherwise each candidate's
    /// crossing is estimated from its event value and rate at the start (one difference
    /// for all), the earliest estimate is located, and a candidate already past its
    /// tolerance there crossed before it and is located in turn. `NotConverged` where a
    /// point inside the substep cannot be reached to the tolerance: the caller shortens
    /// the substep.
    #[allow(clippy::type_complexity)]
    pub(super) fn earliest_crossing(
        &self,
        (t, z, length, modes): (f64, &Vector, f64, &Modes),
        (start_rates, start_events, end_events): (&Vector, &Events, &Events),
        candidate: impl Fn(usize, usize) -> bool,
    ) -> Result<Option<(f64, usize, usize, Option<Vector>)>, NotConverged> {
        let branches = self.friction.branches.len();
        let mut any = false;
        for (g, i) in candidates(branches).filter(|&(g, i)| candidate(g, i)) {
            if start_events[g][i] > EVENT_TOLERANCE {
                return Ok(Some((0.0, g, i, None)));
            }
            any = true;
        }
        if !any {
            return Ok(None);
        }
        let slopes = self.event_rates(t, z, start_rates, start_events, modes, length, &candidate);
        let estimate = |g: usize, i: usize, end: f64, length: f64| {
            let (start, slope) = (start_events[g][i], slopes[g][i]);
            let newton = (slope > 0.0).then(|| (AIM - start) / slope);
            newton
                .filter(|&tau| tau > 0.0 && tau < length)
                .unwrap_or_else(|| length * (LEVEL - start) / (end - start))
        };
        let Some((mut g, mut i)) = candidates(branches)
            .filter(|&(g, i)| candidate(g, i))
            .min_by(|a, b| {
                let (ea, eb) = (
                    estimate(a.0, a.1, end_events[a.0][a.1], length),
                    estimate(b.0, b.1, end_events[b.0][b.1], length),
                );
                ea.total_cmp(&eb)
            })
        else {
            return Ok(None);
        };
        let (mut hi, mut end) = (length, end_events[g][i]);
        for _ in 0..Group::COUNT * MAX_BRANCHES {
            let guess = estimate(g, i, end, hi);
            let (at, reached) = self.crossing(t, z, hi, modes, (g, i), (start_events[g][i], end), guess)?;
            let Some((z_at, events_at)) = reached else {
                return Ok(Some((at, g, i, None)));
            };
            match self.other_past_tolerance(&events_at, (g, i), &candidate) {
                None => return Ok(Some((at, g, i, Some(z_at)))),
                Some((h, j)) => {
                    (g, i, hi, end) = (h, j, at, events_at[h][j]);
                }
            }
        }
        let at = self
            .crossing(t, z, hi, modes, (g, i), (start_events[g][i], end), hi)?
            .0;
        Ok(Some((at, g, i, None)))
    }

    /// The earliest crossing within `length` that the event values and their rates at
    /// the start predict (a straight line to the middle of the accepted band) among the
    /// `candidate` groups and branches close to their events: its time from `t`, group
    /// and branch. At or below zero where one is already at its event.
    pub(super) fn predicted_crossing(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        length: f64,
        modes: &Modes,
        candidate: impl Fn(usize, usize) -> bool,
    ) -> Option<(f64, usize, usize)> {
        let branches = self.friction.branches.len();
        let near = |g: usize, i: usize| start_events[g][i] > -PREDICT_NEAR && candidate(g, i);
        if !candidates(branches).any(|(g, i)| near(g, i)) {
            return None;
        }
        let slopes = self.event_rates(t, z, start_rates, start_events, modes, length, near);
        candidates(branches)
            .filter(|&(g, i)| near(g, i) && slopes[g][i] > 0.0)
            .map(|(g, i)| {
                let at = if start_events[g][i] > LEVEL {
                    0.0
                } else {
                    (AIM - start_events[g][i]) / slopes[g][i]
                };
                (at, g, i)
            })
            .filter(|&(at, _, _)| at < length)
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Where the predicted crossing of group `g`, branch `i` is reached, at `z` (the end of
    /// the substep) or a little from it (the substep ended just short of it or just past
    /// it): short steps on (or back), by Newton's method on its event value, each taken
    /// only where its error estimate is within the tolerance (`rate_change`: how fast the
    /// rates changed over the substep, per second). The time from `t` (within `room`: back
    /// by less than the first, on by less than the second) and the state there, if it is
    /// reached with no other `candidate` group past its tolerance.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn settle_on_event(
        &self,
        t: f64,
        z: &Vector,
        (start_events, rates, events, rate_change): (&Events, &Vector, &Events, &Vector),
        (g, i): (usize, usize),
        modes: &Modes,
        (back, on): (f64, f64),
        candidate: impl Fn(usize, usize) -> bool,
    ) -> Option<(f64, Vector)> {
        let (mut z_at, mut rates_at, mut events_at, mut moved) = (*z, *rates, *events, 0.0);
        for steps in 0..=SETTLE_STEPS {
            if at_event(events_at[g][i]) {
                let others = self.other_past_tolerance(&events_at, (g, i), &candidate);
                return others.is_none().then_some((moved, z_at));
            }
            if steps == SETTLE_STEPS {
                break;
            }
            let this = |h: usize, j: usize| (h, j) == (g, i);
            let slope = self.event_rates(t + moved, &z_at, &rates_at, &events_at, modes, back, this)[g][i];
            if slope.is_nan() || slope <= 0.0 {
                return None;
            }
            let dt = (AIM - events_at[g][i]) / slope;
            if !(moved + dt > -back && moved + dt < on) {
                return None;
            }
            z_at = self.short_step(t + moved, &z_at, (&rates_at, rate_change), dt, modes)?;
            moved += dt;
            if steps == 0
                && self.reached_without_rates(
                    &z_at,
                    (start_events, events),
                    (moved / back).abs(),
                    (g, i),
                    modes,
                    &candidate,
                )
            {
                return Some((moved, z_at));
            }
            (rates_at, events_at) = self.rates(t + moved, &z_at, modes);
        }
        None
    }

    /// A predicted crossing of a sticking spring group `(g, i)` reached after a short
    /// substep to it ([`SlidingStep::short_substep`]) from its last stage's rates and
    /// event values (`stage`, at a point within about the tolerance of the end `z`),
    /// with no evaluation at the end: its event value there follows from its
    /// deflections, a Taylor step on (or back) settles it as
    /// [`SlidingStep::settle_on_event`] does, and [`SlidingStep::reached_without_rates`]
    /// checks the point reached. The time from `t` and the state there; `None` where any
    /// of that does not hold (the end is then evaluated).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn settle_from_stage(
        &self,
        t: f64,
        z: &Vector,
        (start_rates, start_events): (&Vector, &Events),
        (stage_rates, stage_events): (&Vector, &Events),
        (g, i): (usize, usize),
        modes: &Modes,
        (back, on): (f64, f64),
        candidate: impl Fn(usize, usize) -> bool,
    ) -> Option<(f64, Vector)> {
        let slot = self.slots().iter().find(|s| (s.group, s.branch) == (g, i))?;
        let value = slot.event_from_deflections(z, modes)?;
        let (moved, z_at) = if at_event(value) {
            (0.0, *z)
        } else {
            let slope = slot.law.utilisation_rate(&slot.of(z), &slot.of(stage_rates));
            if slope.is_nan() || slope <= 0.0 {
                return None;
            }
            let dt = (AIM - value) / slope;
            if !(dt > -back && dt < on) {
                return None;
            }
            let rate_change = self.rate_change(start_rates, stage_rates, back);
            (dt, self.short_step(t, z, (stage_rates, &rate_change), dt, modes)?)
        };
        // The other groups' values are the stage's, a point about the tolerance from the
        // end: a thousandth of the substep more than the step's own reach covers it.
        let reach = (moved / back).abs() + STAGE_REACH;
        self.reached_without_rates(
            &z_at,
            (start_events, stage_events),
            reach,
            (g, i),
            modes,
            &candidate,
        )
        .then_some((moved, z_at))
    }

    /// Whether a step `reach` times a substep's length from the substep's end to `z_at`
    /// (the first of [`SlidingStep::settle_on_event`]) put the sticking spring group
    /// `(g, i)` on its event with no other `candidate` group past its tolerance, known
    /// without evaluating the rates there (the mode changes at that point, so the next
    /// substep's start evaluates them anyway). A sticking spring group's event value is a
    /// function of its deflections alone. Any other group's value moved from its value
    /// at the end by at most [`SETTLE_GUARD`] times its mean rate over the substep
    /// (`start` to `end`) times the reach, some ten-thousand times shorter; where that
    /// could reach half its tolerance, the rates are evaluated after all.
    fn reached_without_rates(
        &self,
        z_at: &Vector,
        (start, end): (&Events, &Events),
        reach: f64,
        (g, i): (usize, usize),
        modes: &Modes,
        candidate: impl Fn(usize, usize) -> bool,
    ) -> bool {
        let mut reached = false;
        for slot in self.slots() {
            let (h, j) = (slot.group, slot.branch);
            let this = (h, j) == (g, i);
            if !this && !candidate(h, j) {
                continue;
            }
            match slot.event_from_deflections(z_at, modes) {
                Some(value) if this => reached = at_event(value),
                Some(value) => {
                    if value > EVENT_TOLERANCE {
                        return false;
                    }
                }
                None => {
                    if this || end[h][j] + SETTLE_GUARD * (end[h][j] - start[h][j]).abs() * reach > LEVEL {
                        return false;
                    }
                }
            }
        }
        reached
    }

    /// How fast the rates changed over a substep of `length` from `start` to `end`, per
    /// second: the second-order term of a settling step ([`SlidingStep::short_step`]).
    pub(super) fn rate_change(&self, start: &Vector, end: &Vector, length: f64) -> Vector {
        let mut change = [0.0; SIZE];
        for c in 0..self.size() {
            change[c] = (end[c] - start[c]) / length;
        }
        change
    }

    /// The first `candidate` group and branch other than `(g, i)` past its tolerance in
    /// `events`: its event came first, or at the same time.
    pub(super) fn other_past_tolerance(
        &self,
        events: &Events,
        (g, i): (usize, usize),
        candidate: impl Fn(usize, usize) -> bool,
    ) -> Option<(usize, usize)> {
        candidates(self.friction.branches.len())
            .find(|&(h, j)| (h, j) != (g, i) && candidate(h, j) && events[h][j] > EVENT_TOLERANCE)
    }

    /// A step of `dt` seconds (either way) from `z` with its `rates`, which change at about
    /// `rate_change` per second. A step to a predicted crossing misses it by a few parts
    /// in 1e4 of its length, so the step back or on is that short: its Taylor polynomial
    /// to second order, with no evaluation, where even the second-order term is a
    /// fraction of the tolerance (so that neither its estimate nor the terms past it
    /// matter). Otherwise by Heun's method, if its difference from Euler's (the error of
    /// the cruder) is within the tolerance. (Inlined: the step returned was copied out by a
    /// call, and again by its caller's.)
    #[inline(always)]
    fn short_step(
        &self,
        t: f64,
        z: &Vector,
        (rates, rate_change): (&Vector, &Vector),
        dt: f64,
        modes: &Modes,
    ) -> Option<Vector> {
        let size = self.size();
        let euler = self.advanced(z, rates, dt);
        let taylor = made_whole(|c| euler[c] + 0.5 * dt * dt * rate_change[c]);
        if TAYLOR_MARGIN * self.error_ratio(z, &taylor, &euler) <= 1.0
            && taylor[..size].iter().all(|v| v.is_finite())
        {
            return Some(taylor);
        }
        let (end_rates, _) = self.rates(t + dt, &euler, modes);
        let heun = made_whole(|c| z[c] + 0.5 * dt * (rates[c] + end_rates[c]));
        (self.error_ratio(z, &heun, &euler) <= 1.0).then_some(heun)
    }

    /// The rates of the groups' event values along the motion at the start of a substep,
    /// at least of those `needed`. A sticking spring group's event value is its
    /// utilisation less one, a function of its deflections alone: its rate follows from
    /// theirs. Where a needed one is another's, every rate comes from one forward
    /// difference over a time short against the substep's `length` (an evaluation more).
    #[allow(clippy::too_many_arguments)]
    fn event_rates(
        &self,
        t: f64,
        z: &Vector,
        rates: &Vector,
        events: &Events,
        modes: &Modes,
        length: f64,
        needed: impl Fn(usize, usize) -> bool,
    ) -> Events {
        let mut slopes = [[f64::NAN; MAX_BRANCHES]; Group::COUNT];
        let mut known = [[false; MAX_BRANCHES]; Group::COUNT];
        for slot in self.slots() {
            let (g, i) = (slot.group, slot.branch);
            if modes[g][i] || slot.law.damped() || !needed(g, i) {
                continue;
            }
            slopes[g][i] = slot.law.utilisation_rate(&slot.of(z), &slot.of(rates));
            known[g][i] = true;
        }
        let branches = self.friction.branches.len();
        if candidates(branches).all(|(g, i)| known[g][i] || !(needed(g, i) && events[g][i] > NO_EVENT)) {
            return slopes;
        }
        let delta = 1e-8 * length;
        let moved = self.advanced(z, rates, delta);
        let moved_events = self.events(t + delta, &moved, modes);
        for g in 0..Group::COUNT {
            for i in 0..MAX_BRANCHES {
                slopes[g][i] = (moved_events[g][i] - events[g][i]) / delta;
            }
        }
        slopes
    }

    /// The time in `(0, length]` at which `event` of group `g`, branch `i` crosses half the
    /// event tolerance, and the state and event values there if they were computed:
    /// Newton's method on the accurate solution (from `guess`, the event's rate along the
    /// motion by a difference), kept inside a shrinking bracket (regula falsi, Illinois,
    /// where a Newton step would leave it). `NotConverged` if a trial point cannot be
    /// reached to the tolerance.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn crossing(
        &self,
        t: f64,
        z: &Vector,
        length: f64,
        modes: &Modes,
        (g, i): (usize, usize),
        (start, end): (f64, f64),
        guess: f64,
    ) -> Result<(f64, Option<(Vector, Events)>), NotConverged> {
        let (mut lo, mut hi, mut reached) = (0.0, length, None);
        let (mut e_lo, mut e_hi) = (start.min(LEVEL) - LEVEL, end - LEVEL);
        let mut guess = Some(guess);
        let mut side = 0;
        for _ in 0..80 {
            if hi - lo <= 1e-14 * length.max(f64::MIN_POSITIVE) {
                break;
            }
            let mut tau = match guess {
                Some(tau) if tau > lo && tau < hi => tau,
                _ => (lo * e_hi - hi * e_lo) / (e_hi - e_lo),
            };
            if !(tau > lo && tau < hi) {
                tau = 0.5 * (lo + hi);
            }
            // A point inside the substep that the method cannot reach to the tolerance:
            // the event cannot be placed within this substep (not at its end either).
            let z_tau = self.substep_plain(t, z, tau, modes).ok_or(NotConverged)?;
            let (rates, events) = self.rates(t + tau, &z_tau, modes);
            let value = events[g][i];
            let e = value - LEVEL;
            // Past the crossing by less than the event tolerance itself: as close as
            // the event is defined.
            if e > 0.0 && e <= LEVEL {
                return Ok((tau, Some((z_tau, events))));
            }
            let this = |h: usize, j: usize| (h, j) == (g, i);
            let slope = self.event_rates(t + tau, &z_tau, &rates, &events, modes, length, this)[g][i];
            guess = (slope > 0.0).then(|| tau + (AIM - value) / slope);
            if e > 0.0 {
                (hi, reached) = (tau, Some((z_tau, events)));
                e_hi = e;
                if side == 1 {
                    e_lo *= 0.5;
                }
                side = 1;
            } else {
                lo = tau;
                e_lo = e;
                if side == -1 {
                    e_hi *= 0.5;
                }
                side = -1;
            }
        }
        Ok((hi, reached))
    }
}

/// Where in `window` the smooth `value` is past [`EVENT_TOLERANCE`], searched for about
/// its largest value (taken to have one peak there, or to be largest at an end): the first
/// point tried that is past it, or `None` once the largest is bracketed within
/// `resolution`.
///
/// The ends first: a value that falls from an end of the window to just inside it and to
/// the point where the search inside would start (as a group's does that starts at its
/// limit and moves away) is largest there, which three values show. Otherwise the peak
/// is inside, and Brent's search brackets it: a parabola through the three best points
/// so far proposes the next, a golden section where it would not shrink the bracket fast
/// enough. Near a smooth peak the parabolas converge superlinearly. Either way a handful
/// of values (each an accurate substep) do what a golden section did in thirty.
fn largest_past(mut value: impl FnMut(f64) -> f64, window: (f64, f64), resolution: f64) -> Option<f64> {
    let (lo, hi) = window;
    let inner = lo + GOLDEN * (hi - lo);
    let inner_value = value(inner);
    if inner_value > EVENT_TOLERANCE {
        return Some(inner);
    }
    let nudge = resolution.min(0.25 * (hi - lo));
    for (end, inward) in [(lo, nudge), (hi, -nudge)] {
        let at_end = value(end);
        if at_end > EVENT_TOLERANCE {
            return Some(end);
        }
        let inside = value(end + inward);
        if inside > EVENT_TOLERANCE {
            return Some(end + inward);
        }
        if inside <= at_end && inner_value <= at_end {
            return None;
        }
    }
    peak_past(value, window, resolution, (inner, inner_value))
}

/// The smaller golden-section fraction, `(3 - sqrt 5) / 2`.
const GOLDEN: f64 = 0.381_966_011_250_105_1;

/// [`largest_past`] with the peak inside `window`: Brent's search, from the point `start`
/// and its value.
fn peak_past(
    mut value: impl FnMut(f64) -> f64,
    window: (f64, f64),
    resolution: f64,
    start: (f64, f64),
) -> Option<f64> {
    /// At most this many values: a safeguard, the bracket shrinks by the golden ratio
    /// at least every other one.
    const MOST_VALUES: usize = 80;
    let (mut lo, mut hi) = window;
    // The best point so far, the second best, and the one before it, with their values.
    let (mut best, mut best_value) = start;
    let (mut second, mut second_value) = (best, best_value);
    let (mut third, mut third_value) = (best, best_value);
    // The last move, and the one before it.
    let (mut moved, mut moved_before) = (0.0_f64, 0.0_f64);
    let tolerance = 0.25 * resolution;
    // Every value is below the tolerance: one past it ends the search where it is had.
    for _ in 0..MOST_VALUES {
        let middle = 0.5 * (lo + hi);
        if (best - middle).abs() <= 2.0 * tolerance - 0.5 * (hi - lo) {
            return None;
        }
        // A parabola's vertex, if it lies inside the bracket and the step to it is less
        // than half the one before last (otherwise the parabolas are not converging).
        let mut parabolic = None;
        if moved_before.abs() > tolerance {
            let r = (best - second) * (best_value - third_value);
            let q = (best - third) * (best_value - second_value);
            let p = (best - third) * q - (best - second) * r;
            let step = -p / (2.0 * (q - r));
            let to = best + step;
            // A NaN step (a value that could not be had) fails every test: golden.
            if step.abs() < 0.5 * moved_before.abs() && to > lo && to < hi {
                parabolic = Some(if to - lo < 2.0 * tolerance || hi - to < 2.0 * tolerance {
                    tolerance.copysign(middle - best)
                } else {
                    step
                });
            }
        }
        let step = match parabolic {
            Some(step) => {
                moved_before = moved;
                step
            }
            None => {
                moved_before = if best >= middle { lo - best } else { hi - best };
                GOLDEN * moved_before
            }
        };
        moved = step;
        let at = best
            + if step.abs() >= tolerance {
                step
            } else {
                tolerance.copysign(step)
            };
        let at_value = value(at);
        if at_value > EVENT_TOLERANCE {
            return Some(at);
        }
        if at_value >= best_value {
            if at >= best {
                lo = best;
            } else {
                hi = best;
            }
            (third, third_value) = (second, second_value);
            (second, second_value) = (best, best_value);
            (best, best_value) = (at, at_value);
        } else {
            if at < best {
                lo = at;
            } else {
                hi = at;
            }
            if at_value >= second_value || second == best {
                (third, third_value) = (second, second_value);
                (second, second_value) = (at, at_value);
            } else if at_value >= third_value || third == best || third == second {
                (third, third_value) = (at, at_value);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::{EVENT_TOLERANCE, largest_past};

    /// Smooth peaks inside a window: one past the tolerance is found at a point past it;
    /// one below is ruled out once bracketed within the resolution. Either takes at most
    /// twenty values (ends included) where a golden section takes about thirty.
    #[test]
    fn a_touch_is_found_or_ruled_out_in_a_handful_of_values() {
        // (peak's place, its height, its curvature): parabolic and not.
        let peaks = [
            (0.3, -1e-9, 1.0),
            (0.71, -1e-6, 40.0),
            (0.5, 1e-9, 1.0),
            (0.05, 5e-11, 2.0),
            (0.93, -2e-12, 0.3),
            (0.62, 3e-12, 0.01),
        ];
        for (place, height, curvature) in peaks {
            for shape in ["parabola", "cosine"] {
                let value = |tau: f64| {
                    let d: f64 = tau - place;
                    match shape {
                        "parabola" => height - 0.5 * curvature * d * d,
                        _ => height - curvature * (1.0 - (d / (1.0 + d)).cos()),
                    }
                };
                let mut values = 0;
                let curve = |tau: f64| {
                    values += 1;
                    value(tau)
                };
                let found = largest_past(curve, (0.0, 1.0), 1e-6);
                if height > EVENT_TOLERANCE {
                    let at = found.unwrap_or_else(|| panic!("{shape} peak {height} at {place} missed"));
                    assert!(
                        value(at) > EVENT_TOLERANCE,
                        "{shape} peak at {place}: {at} is not past"
                    );
                } else {
                    assert_eq!(found, None, "{shape} peak {height} at {place}");
                }
                assert!(values <= 20, "{shape} peak at {place}: {values} values");
            }
        }
    }

    /// The largest value at an end of the window (the value still rising there) is
    /// bracketed there too; a value that falls from an end and then peaks inside is
    /// searched inside.
    #[test]
    fn a_peak_at_the_window_end_is_bracketed() {
        for (window, rising) in [((0.0, 1.0), 1.0), ((0.2, 0.4), -1.0)] {
            let mut values = 0;
            let curve = |tau: f64| {
                values += 1;
                -1e-3 + rising * 1e-4 * tau
            };
            assert_eq!(largest_past(curve, window, 1e-6), None);
            assert!(values <= 60, "{values} values");
        }
        let touching = |tau: f64| -1e-9 + 1e-8 * tau;
        let at = largest_past(touching, (0.0, 1.0), 1e-6).expect("past the tolerance near the end");
        assert!(touching(at) > EVENT_TOLERANCE);
        // Falling from the start, and then a peak inside past the tolerance: found.
        let dip_then_peak = |tau: f64| -1e-10 - 1e-8 * tau + 5e-9 * (-((tau - 0.4) / 0.15f64).powi(2)).exp();
        assert!(dip_then_peak(1e-6) < dip_then_peak(0.0));
        let at = largest_past(dip_then_peak, (0.0, 1.0), 1e-6).expect("the peak inside");
        assert!(dip_then_peak(at) > EVENT_TOLERANCE);
    }
}
