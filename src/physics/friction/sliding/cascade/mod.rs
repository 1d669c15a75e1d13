//! A step with sliding taken group by group where the groups form a cascade (DDT):
//! some elements are driven by the inputs alone and their branches are groups of one
//! member (the yaw deflection's), the others are driven by the inputs and by those
//! (the lateral deflection by the yaw one, through `vx uPsi`), never the other way.
//!
//! - **Drivers.** A one-member group's branch is linear in each mode: sticking,
//!   `db/dt = A_kk b + c`; sliding on its limit, `Dw db/dt = +-L - K b`. Under held
//!   inputs its deflection is `b(t) = b0 + t phi1(mu t) r0` (its start rate `r0`, `mu`
//!   the mode's rate), exact, and its element's state, the weighted sum, is
//!   `U0 + R_stick q_stick(t) + R_slide q_slide(t)` with `q(t) = t phi1(mu t)`.
//! - **Driven groups.** Each depends on the drivers only through that sum, and on no
//!   other driven group: its rates are its members' deflections' and the two `q`s',
//!   which follow `dq/dt = 1 + mu q`. So the driven groups and the `q`s (ten entries at
//!   most, where the whole system has twelve) are stepped together by exponential
//!   methods ([`super::exponential`]), whose linear part is a few small blocks: each
//!   group's own two by two, its column for each `q`, and each `q`'s `mu`. The `q`s are
//!   linear, so a substep carries them exactly, as far as they move the groups
//!   ([`groups::DrivenLinearPart`]'s `size`). Both methods evaluate the rates at the
//!   substep's end, and that evaluation serves twice: as the next substep's start, and
//!   at the step's end as the outputs' shaping. There it is made where the states and
//!   offsets the step writes pack to again ([`SlidingStep::end_point`]), by the
//!   cascade's own equations ([`SlidingStep::shaped_at`]), as the outputs of a cascade
//!   are made on demand ([`SlidingStep::cascade_limit_changes`]): the outputs need no
//!   pass of their own and have the same bits, and the modes it prepares for the next
//!   step are those a step from a restored state decides.
//!   - A slide in one direction (every group outside its ellipse has at most
//!     [`samples::ONE_DIRECTION_SHARE`] of its utilisation across it) turns its force so little
//!     that exponential Euler is within the tolerance: one evaluation a substep, its
//!     error estimated from the end's rates ([`super::exponential::exponential_euler`]),
//!     and the event values sampled half way as well.
//!   - Otherwise (or where Euler is not within it), exprb42: fourth order from a stage
//!     at three quarters and the end ([`super::exponential::exprb42`]). Its estimate is
//!     of a third-order solution, hundreds of times its error where a force turns after
//!     its group starts sliding; where that estimate would not let the rest of the step
//!     be one substep, exprb42's own error is estimated from the remainder's quartic
//!     part as well ([`groups::quartic_estimate`], with the Jacobian at the end, which the next
//!     substep takes), and a substep within either margin is taken.
//!
//!   The groups are evaluated side by side, so that their projections' Newton steps
//!   overlap.
//! - **A stiff slide** (a stiff tire at a light load, whose groups turn their forces far
//!   faster than the step): the driven groups by linearly implicit Euler extrapolation,
//!   as the whole system's stiff substeps, but each Euler step solves each group's own two
//!   by two, and the `q`s are set in closed form where it ends. The drivers' closed form
//!   holds at any stiffness.
//!
//! This takes the usual step: every group keeps its mode throughout. Where the friction
//! is all spring-dampers with every limit above zero, the step decides the modes at its
//! start itself (a group slides where its sticking force is outside its ellipse, as the
//! hybrid system decides it), from the evaluation it starts with ([`Start::Undecided`]).
//! A spring-damper driver's trial force is affine in its deflection, which moves
//! monotonically, so its event values at the ends decide whether it reaches its limit.
//! Where it does, the time is found in closed form (the deflection where the trial force
//! is the limit, and `q(t)` inverted, a logarithm), and the step is split there: the
//! part before it in the modes of the start, the rest with that driver's mode changed
//! ([`Start::Given`]). A driven group's event values are sampled at each explicit
//! substep's start, stage and end; where they and the parabola through them keep clear
//! of the event, it stays in its mode. Where it nears its event, its course over the
//! substep ([`super::course`], from the samples and the event value's rates at the ends)
//! shows whether it stays; where a sample is past the event, the crossing is searched
//! for on exprb42's substeps from the course's guess
//! ([`super::course::crossing_search`]), the substep ends there and the group changes
//! mode (its force is continuous there: its trial force is on its limit). Where a
//! group's course is not sure (a spring's, or a touch between the samples), a group at
//! its event moves back from it, a stiff substep nears an event, or the driven groups
//! need more substeps than a step should, the whole-system path takes the step from its
//! start, its modes prepared ([`super::SlidingStep::integrate`]).
//!
//! How the step is split here:
//! - this module: which slots drive and which are driven ([`Cascade`]), and the step
//!   itself, part by part between the drivers' changes of mode;
//! - [`drivers`]: the drivers' closed form, their sum and where a driver reaches its limit;
//! - [`driven`]: the driven groups' substeps over a part, exponential or stiff;
//! - [`groups`]: the driven groups' rates, event samples and linear part;
//! - [`samples`]: what the event values sampled over a substep say;
//! - [`lengths`]: how long the next substep is;
//! - [`shaping`]: the outputs' shaping at the step's end and at given states.

mod driven;
mod drivers;
mod groups;
mod lengths;
mod samples;
mod shaping;

use super::extrapolation::largest_of;
use super::modes::ShapedEnd;
use super::{Group, Layout, MAX_BRANCHES, Modes, SIZE, STIFF_STEP, SliderState, SlidingStep, Slot};
use crate::physics::friction::EVENT_TOLERANCE;
use crate::physics::friction::group::{GroupLaw, MAX_MEMBERS, MAX_TOGETHER};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateVector};
use drivers::{DriverSum, driver_crossing, driver_input, q_at};
use groups::DrivenGroups;
use samples::clear;

/// The driven groups' vector: each group's members' deflections (one group a branch),
/// then `q_stick` and `q_slide`, which every driven group reads.
const DRIVEN: usize = MAX_MEMBERS * MAX_BRANCHES + 2;
type Driven = [f64; DRIVEN];
/// Where `q_stick` and `q_slide` sit.
const Q: [usize; 2] = [DRIVEN - 2, DRIVEN - 1];

/// Where member `m` of driven group `n` sits.
fn entry(n: usize, m: usize) -> usize {
    n * MAX_MEMBERS + m
}

/// Substeps the driven groups may take in one step before the whole-system path takes
/// the step.
const MAX_SUBSTEPS: usize = 8;

/// The cascade of one step: which slots drive and which are driven, and the drivers'
/// element state.
/// Made with the slots ([`Cascade::of`]), kept with them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Cascade {
    drivers: [u8; MAX_TOGETHER],
    driver_count: usize,
    driven: [u8; MAX_TOGETHER],
    driven_count: usize,
    driver_state: usize,
}

impl Cascade {
    /// The cascade of the slots `slots` laid out in `layout`, where the model's elements
    /// form one (`driver`, the state of the element driven by the inputs alone,
    /// [`crate::physics::friction::Friction::cascade_driver`]) and the layout suits it
    /// (no free states): the driver's branches drive, every other slot is driven.
    pub(super) fn of(slots: &[Slot], layout: &Layout, driver: Option<usize>) -> Option<Cascade> {
        let driver = driver?;
        if layout.free_count != 0 {
            return None;
        }
        let mut cascade = Cascade {
            driver_state: driver,
            ..Cascade::default()
        };
        for (j, slot) in slots.iter().enumerate().take(MAX_TOGETHER) {
            if slot.states[0] == driver {
                cascade.drivers[cascade.driver_count] = j as u8;
                cascade.driver_count += 1;
            } else {
                cascade.driven[cascade.driven_count] = j as u8;
                cascade.driven_count += 1;
            }
        }
        // Driven group `n` is branch `n` of the same elements, member by member (as the
        // slots are laid out: by group, then branch), so that summing member `m` group by
        // group sums an element's branches in their order ([`SlidingStep::end_point`]);
        // or there is none (no limit in either planar direction).
        let same_members = |a: &GroupLaw, b: &GroupLaw| a.direction[..a.count] == b.direction[..b.count];
        let by_branch = cascade.driven().next().is_none_or(|first| {
            cascade.driven_count == layout.branches
                && cascade
                    .driven()
                    .enumerate()
                    .all(|(n, j)| slots[j].branch == n && same_members(&slots[j].law, &slots[first].law))
        });
        // The driven entries within the whole vector's count, which the extrapolation of a
        // stiff substep compares.
        (by_branch && cascade.driven_count <= MAX_BRANCHES && entry(cascade.driven_count, 0) <= layout.size)
            .then_some(cascade)
    }

    /// The drivers' slots.
    fn drivers(&self) -> impl Iterator<Item = usize> + '_ {
        self.drivers[..self.driver_count].iter().map(|&j| usize::from(j))
    }

    /// The driven slots, in the order of the driven groups.
    fn driven(&self) -> impl Iterator<Item = usize> + '_ {
        self.driven[..self.driven_count].iter().map(|&j| usize::from(j))
    }
}

/// How a cascade step starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Start {
    /// From the modes prepared ([`SlidingStep::prepare`]), with the fastest sliding rate
    /// preparing found.
    Prepared,
    /// The step decides the modes: each group's from its sticking force at the start, as
    /// the cascade evaluates it ([`SlidingStep::cascade_decides`]).
    Undecided,
    /// From the modes the sliders carry: a part of a step that a driver's change of mode
    /// splits, before or after it.
    Given,
}

/// The most changes of mode of the drivers within one step: a driver's trial force
/// moves monotonically in each mode, so it reaches its limit at most twice (sliding, in
/// and through zero to the other side's).
const MAX_DRIVER_SWITCHES: usize = 2 * MAX_BRANCHES;

/// Where a driver changes mode within a part of a cascade step: `at` seconds into it,
/// the driver's (group, branch), and the modes of the part (every driver's decided).
#[derive(Clone, Copy, Debug)]
struct DriverSwitch {
    at: f64,
    branch: (usize, usize),
    modes: Modes,
}

/// How a part of a cascade step ended ([`SlidingStep::cascade_part`]).
enum Part {
    /// Taken to its end, with the end's shaping where its last evaluation was there.
    Taken(Option<ShapedEnd>),
    /// A driver changes mode within it: nothing taken.
    Switch(DriverSwitch),
}

impl SlidingStep<'_> {
    /// The step of `h` seconds group by group (see the module's doc): with `x` and
    /// `sliders` at its end, and the outputs' shaping there where its last evaluation was
    /// at its end, made as the outputs make it ([`SlidingStep::shaped_at`],
    /// [`SlidingStep::shaped_end`]); `None` (both unchanged) where it is left to the
    /// whole-system path. A driver that changes mode within the step splits it there
    /// ([`DriverSwitch`]): the part before it in the modes of the start, the rest with
    /// that driver's mode changed.
    pub(super) fn cascade_step(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
        start: Start,
    ) -> Option<Option<ShapedEnd>> {
        let cascade = self.cascade()?;
        if start == Start::Undecided && !self.cascade_decides() {
            return None;
        }
        // The start, kept once a part is taken (a part not taken leaves both unchanged); and
        // the substep lengths carried to the next step as they were, for a step given up:
        // what its substeps found is not the next step's (the path that takes the step
        // instead starts from nothing carried, and sets its own).
        let mut kept = None;
        let carried = self.high_order_found.get();
        let (mut t, mut start) = (0.0, start);
        for _ in 0..=MAX_DRIVER_SWITCHES {
            match self.cascade_part(cascade, x, sliders, h - t, start) {
                Some(Part::Taken(shaped)) => return Some(shaped),
                Some(Part::Switch(switch)) => {
                    kept.get_or_insert((*x, *sliders));
                    // To the switch in the modes the part had (decided, or given).
                    sliders.sliding = switch.modes;
                    let Some(Part::Taken(_)) =
                        self.cascade_part(cascade, x, sliders, switch.at, Start::Given)
                    else {
                        break;
                    };
                    let (g, i) = switch.branch;
                    sliders.sliding[g][i] = !sliders.sliding[g][i];
                    (t, start) = (t + switch.at, Start::Given);
                }
                None => break,
            }
        }
        if let Some(start) = kept {
            (*x, *sliders) = start;
        }
        self.high_order_found.set(carried);
        None
    }

    /// A part of [`SlidingStep::cascade_step`]: `h` seconds in the modes `start` says,
    /// taken (with `x` and `sliders` at its end), or where the first driver changes mode
    /// within it, that change (both unchanged); `None` (unchanged) where the whole-system
    /// path takes the step.
    fn cascade_part(
        &self,
        cascade: &Cascade,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
        start: Start,
    ) -> Option<Part> {
        let deciding = start == Start::Undecided;
        // The start, and where the drivers end as the loop below finds them (each writes
        // only its own entry, after reading it).
        let mut end = [0.0; SIZE];
        self.layout.pack_into(x, sliders, &mut end);
        // Deciding, every slot's mode is decided below (the cascade's slots are all), and
        // a group's branches that have no slot stick, as preparing leaves them.
        let mut modes = if deciding {
            [[false; MAX_BRANCHES]; Group::COUNT]
        } else {
            sliders.sliding
        };
        let states = self.layout.model_states(&end);
        let largest = largest_of(&end);
        let slots = self.slots();
        // Drivers, in closed form; their weighted sum's terms by mode.
        let mut sum = DriverSum {
            start: states[cascade.driver_state],
            step: h,
            ..DriverSum::default()
        };
        // By mode, `q(h)`: the same for every branch in that mode.
        let mut q_end = [None; 2];
        // The inputs' part of each model state's rate, `(B u)_k`: every driver's branch reads
        // its element's, and each driven group's members read theirs.
        let drives = self.input_rates();
        // The first driver to change mode within the part, if one does.
        let mut first_switch: Option<DriverSwitch> = None;
        for j in cascade.drivers() {
            let slot = &slots[j];
            let entry = slot.entries[0];
            let b0 = end[entry];
            let input = driver_input(slot, b0, drives[cascade.driver_state]);
            let given = (!deciding).then_some(modes[slot.group][slot.branch]);
            let (start, sliding) = if input.damped() {
                input.evaluate_one_damped(given)
            } else {
                let sliding = given.unwrap_or_else(|| input.outside());
                (input.evaluate(sliding), sliding)
            };
            modes[slot.group][slot.branch] = sliding;
            let mu = if sliding {
                -slot.law.stiffness[0] / slot.law.damping[0]
            } else {
                slot.relaxation[0]
            };
            let mode = usize::from(sliding);
            // One rate per mode: the branches' `K / Dw = w C / (w D)` and relaxation are
            // their element's (`K / Dw` to the last bits of each branch's quotient).
            let q = match q_end[mode] {
                None => {
                    sum.rate[mode] = mu;
                    *q_end[mode].insert(q_at(mu, h))
                }
                Some(_) if (sum.rate[mode] - mu).abs() > 4.0 * f64::EPSILON * mu.abs() => return None,
                Some(q) => q,
            };
            sum.by_mode[mode] += self.layout.weights[slot.branch] * start.rate[0];
            end[entry] = b0 + q * start.rate[0];
            // At the end its event value, and the trial force, whose side of zero a
            // sliding force has (it is the trial's scaled onto the limit).
            let finish = driver_input(slot, end[entry], drives[cascade.driver_state]);
            let finish_event = finish.event(sliding);
            let same_side = !sliding || start.force[0] * finish.sticking_force()[0] > 0.0;
            if !slot.law.damped() {
                // A spring's event value is its outward cosine: sampled at the ends only,
                // they must keep clear of it.
                if !(clear(start.event) && clear(finish_event) && same_side) {
                    return None;
                }
                continue;
            }
            // A spring-damper's trial force is affine in its deflection, which moves
            // monotonically: its size is largest (or, on one side of zero, least) at an
            // end, so the ends' event values decide whether it crosses its limit.
            if start.event.is_nan() || start.event > EVENT_TOLERANCE {
                return None;
            }
            if same_side && finish_event <= EVENT_TOLERANCE {
                continue;
            }
            let drive = drives[cascade.driver_state];
            let at = driver_crossing(slot, (b0, start.rate[0], mu, drive), &input, &finish, sliding)?;
            // Past the part's end, its end's event value is rounding's.
            if at >= h {
                return None;
            }
            if first_switch.is_none_or(|first| at < first.at) {
                first_switch = Some(DriverSwitch {
                    at,
                    branch: (slot.group, slot.branch),
                    modes,
                });
            }
        }
        // A mode no driver is in has `mu = 0`: `q(h) = h`.
        sum.end = q_end.map(|q| q.unwrap_or(h));
        let mut groups = DrivenGroups::new(self, cascade, (modes, &drives), &sum);
        let w = groups.as_ref().map(|groups| groups.start(&end));
        if let (Some(groups), Some(w), true) = (groups.as_mut(), w, deciding) {
            groups.decide(&w);
            modes = groups.modes;
        }
        if let Some(mut switch) = first_switch {
            // Every group's mode is decided by now.
            switch.modes = modes;
            return Some(Part::Switch(switch));
        }
        // How fast the sliding groups relax, as preparing finds it: whether they crawl
        // through an explicit substep, and what the end's preparation carries.
        let mut fastest = match start {
            Start::Prepared => self.start_sliding_rate.get(),
            Start::Undecided | Start::Given => self.fastest_sliding_rate(&modes),
        };
        let stiff = h * fastest > STIFF_STEP;
        let (driven, shaping) = match (groups.as_mut(), w) {
            (Some(groups), Some(w)) => {
                let stepped = self.driven_step(cascade, groups, w, &end, (h, largest, stiff))?;
                // With the changes of mode the driven groups made on the way, and how fast
                // the groups then slide, as preparing there would find it.
                if groups.modes != modes {
                    modes = groups.modes;
                    fastest = self.fastest_sliding_rate(&modes);
                }
                stepped
            }
            // No planar group has a member (no limit in either direction): nothing to step.
            _ => ([0.0; DRIVEN], None),
        };
        self.whole_end(cascade, (&mut end, &modes), &driven, (x, sliders));
        // The end's shaping (and the step's modes, prepared for the next step) only where
        // every group is in the mode deciding there finds ([`ends_decided`]); otherwise the
        // outputs are made from the end's states, and the modes prepared are those decided
        // there.
        Some(Part::Taken(shaping.filter(|shaping| shaping.decided).and_then(
            |shaping| self.shaped_end(&modes, fastest, shaping.changes),
        )))
    }

    /// Whether the model's elements form a cascade and the step suits it
    /// ([`SlidingStep::cascade`]).
    pub(super) fn cascade_applies(&self) -> bool {
        self.cascade().is_some()
    }

    /// The cascade of this step's slots, if they form one ([`Cascade::of`]) and the step
    /// suits it: held inputs.
    pub(super) fn cascade(&self) -> Option<&Cascade> {
        if self.input_rates != DrivingVector::zeros() {
            return None;
        }
        self.cascade
    }

    /// The inputs' part of each model state's rate, `(B u)_k` (zero past the model's
    /// states).
    fn input_rates(&self) -> [f64; MAX_STATES] {
        let mut rates = [0.0; MAX_STATES];
        for (k, rate) in rates.iter_mut().enumerate().take(self.system.states) {
            *rate = self.system.input_rate(k, &self.inputs);
        }
        rates
    }
}

#[cfg(test)]
mod tests;
