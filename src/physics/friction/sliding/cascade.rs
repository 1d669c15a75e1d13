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
//!   ([`DrivenLinearPart::size`]). Both methods evaluate the rates at the
//!   substep's end, and that evaluation serves twice: as the next substep's start, and
//!   at the step's end as the outputs' shaping. There it is made where the states and
//!   offsets the step writes pack to again ([`SlidingStep::end_point`]), by the
//!   cascade's own equations ([`SlidingStep::shaped_at`]), as the outputs of a cascade
//!   are made on demand ([`SlidingStep::cascade_limit_changes`]): the outputs need no
//!   pass of their own and have the same bits, and the modes it prepares for the next
//!   step are those a step from a restored state decides.
//!   - A slide in one direction (every group outside its ellipse has at most
//!     [`ONE_DIRECTION_SHARE`] of its utilisation across it) turns its force so little
//!     that exponential Euler is within the tolerance: one evaluation a substep, its
//!     error estimated from the end's rates ([`super::exponential::exponential_euler`]),
//!     and the event values sampled half way as well.
//!   - Otherwise (or where Euler is not within it), exprb42: fourth order from a stage
//!     at three quarters and the end ([`super::exponential::exprb42`]). Its estimate is
//!     of a third-order solution, hundreds of times its error where a force turns after
//!     its group starts sliding; where that estimate would not let the rest of the step
//!     be one substep, exprb42's own error is estimated from the remainder's quartic
//!     part as well ([`quartic_estimate`], with the Jacobian at the end, which the next
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

use super::course::{Course, crossing_search};
use super::events::{InteriorSearch, NEAR_EVENT};
use super::exponential::{
    EXPRB42_MARGIN, Exprb42Substep, LinearPart, euler_within, exponential_euler, exprb42, largest_size,
    negligible_term, resize, resize_euler, resized,
};
use super::extrapolation::{Row, larger, largest_of};
use super::implicit::{IMPLICIT_SEQUENCE, shifted_inverse};
use super::modes::{LimitChanges, ShapedEnd};
use super::{
    Events, Group, HighOrderSubsteps, Layout, MAX_BRANCHES, Modes, NO_EVENT, NOT_CARRIED, SIZE, STIFF_STEP,
    SliderState, SlidingStep, Slot, Vector,
};
use crate::physics::friction::group::{
    GroupInput, GroupLaw, GroupOutput, MAX_MEMBERS, MAX_TOGETHER, Members, evaluate_together,
};
use crate::physics::friction::{Direction, EVENT_TOLERANCE};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateVector};

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

/// The share of exprb42's margin ([`EXPRB42_MARGIN`]) that its substeps' lengths aim at
/// ([`aimed_factor`]).
const AIM: f64 = 0.8;

/// How much longer than a substep whose estimate was `error` one would be whose estimate
/// would be [`AIM`] of exprb42's margin (it grows as the length's fourth power). The
/// estimate is of a third-order solution, and exprb42's end was within 0.14 of it over
/// DDT's slides ([`EXPRB42_MARGIN`]), so a substep that meets its aim is inside the
/// tolerance; aimed higher, a force that turns after a group starts sliding needs fewer
/// substeps for the same step (over the slide yardstick's combined case, all exprb42
/// attempts fell from 4941 to 4711 with the step in equal pieces, against aiming at a
/// fifth of the margin as the whole-system path does; none more were thrown away).
fn aimed_factor(error: f64) -> f64 {
    let share = (error / EXPRB42_MARGIN).max(1e-10);
    (AIM / share).sqrt().sqrt()
}

/// The next substep's length where `rest` of the step remains and a substep of `allowed`
/// would meet its aim: the rest in equal pieces no longer than that, so that no short
/// piece is left at the end.
fn in_equal_pieces(rest: f64, allowed: f64) -> f64 {
    let pieces = pieces_of(rest, allowed);
    if pieces <= 1.0 { rest } else { rest / pieces }
}

/// How many pieces no longer than `allowed` make `rest`: a rest a few roundings past a
/// whole number of them is that number (one more piece would be a substep for nothing).
fn pieces_of(rest: f64, allowed: f64) -> f64 {
    (rest / allowed * (1.0 - ROUNDINGS)).ceil()
}

/// The few roundings by which a piece of [`in_equal_pieces`] may be longer than allowed.
const ROUNDINGS: f64 = 4.0 * f64::EPSILON;

/// The length exprb42's first substep of a step could have had (at [`aimed_factor`], or
/// longer by its quartic estimate, [`sharper_factor`]), carried to the next step
/// ([`HighOrderSubsteps`]; its second is not carried). A force that turns after a group
/// starts sliding takes tens of steps to settle, its estimate at the step's start
/// falling by a few percent a step; each of those steps would otherwise try the whole
/// step, come back too long and take shorter substeps than it needs. Over 4000 steps of
/// the slide yardstick's combined case (before the quartic estimate), the first attempts
/// that came back too long went from 500 to 12, and all exprb42 attempts from 5312 to
/// 4941 (4812 to 4925 of them taken).
fn carried_first_substep(length: f64, factor: f64) -> HighOrderSubsteps {
    [length * factor, f64::INFINITY]
}

/// The most exprb42's third-order estimate may be, in tolerances, for its own error to be
/// estimated from the remainder's quartic part ([`quartic_estimate`]): at most 1e-9 of
/// the largest state (an entry's tolerance is at most twice the largest state's), as far
/// as `cargo bench --bench exponential_probe` compares that estimate with the error
/// (beyond, to 2e-9, DDT's error reached 1.19 of it).
const SHARPER_WITHIN: f64 = 100.0 * EXPRB42_MARGIN;

/// How many times the tolerance exprb42's error estimated from the remainder's quartic
/// part may be. Over DDT's slides to 3.5 s, past the slip's first reversal (`cargo bench
/// --bench exponential_probe`, columns "42/sharp" and "42 below"), the error was at most
/// 0.84 of that estimate where the estimate was at least a fifth of the tolerance, and
/// at most 0.35 tolerances where it was less: a substep taken by it is within about half
/// the tolerance (0.68 at the largest ratio over every model, RingBody's 1.14), as one
/// taken by the third-order estimate is within 0.7 of it. At 0.4 the passes with a
/// reversal took 0.6 % more instructions.
const SHARPER_MARGIN: f64 = 0.6;

/// How much longer than a substep whose quartic estimate was `sharp` one would be whose
/// estimate would be [`AIM`] of [`SHARPER_MARGIN`] (it grows as the length's fifth
/// power), and no longer than the third-order estimate `error` would be within
/// [`SHARPER_WITHIN`] there.
fn sharper_factor(error: f64, sharp: f64) -> f64 {
    let by_own_error = (AIM * SHARPER_MARGIN / sharp.max(1e-10 * SHARPER_MARGIN)).powf(0.2);
    let trusted = (AIM * SHARPER_WITHIN / error.max(1e-10)).sqrt().sqrt();
    by_own_error.min(trusted)
}

/// `end` less exprb42's own error as estimated from the remainder's quartic part, for
/// the error ratio of the two ([`DrivenGroups::quartic_estimate`]). Along the substep, `N(theta) = a theta^2 + b theta^3 + c
/// theta^4` (`N(0)` and its slope zero: `J` is the start's Jacobian); `D2 = N(3/4)`,
/// `D3 = N(1)` and the slope at the end `N'(1) = H (J(end) - J) f(end)` give
/// `c = 256/9 D2 - 24 D3 + 4 N'(1)` and `b = N'(1) - 2 D3 - 2 c`. exprb42 takes the cubic
/// exactly where `X` is small, and leaves about `H (X b - c) / 80` (the first terms of
/// `H ((9/8 phi3 - 24 phi5) c + (3/2 phi3 - 6 phi4) b)`), bounded here entry by entry by
/// `H (|c| + |X b|) / 80`: where the force turns, the third-order estimate is hundreds of
/// times that.
fn quartic_estimate(
    (linear, end_linear): (&DrivenLinearPart, &DrivenLinearPart),
    (end, end_rates): (&Driven, &Driven),
    [d2, d3]: &[Driven; 2],
) -> Driven {
    let (at_end, at_start) = (end_linear.times(end_rates), linear.times(end_rates));
    let mut cubic = [0.0; DRIVEN];
    let mut quartic = [0.0; DRIVEN];
    for c in 0..DRIVEN {
        let slope = at_end[c] - at_start[c];
        quartic[c] = 256.0 / 9.0 * d2[c] - 24.0 * d3[c] + 4.0 * slope;
        cubic[c] = slope - 2.0 * d3[c] - 2.0 * quartic[c];
    }
    let turned = linear.times(&cubic);
    let length = linear.length();
    std::array::from_fn(|c| end[c] - length / 80.0 * (quartic[c].abs() + turned[c].abs()))
}

/// Changes of mode of the driven groups within one step before the whole-system path
/// takes the step.
const MAX_DRIVEN_SWITCHES: usize = 2 * MAX_BRANCHES;

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

/// The drivers' element state over the step: `U0 + R . q(t)`, with each mode's rate `mu`,
/// and the `q`s where the step of `step` seconds ends.
#[derive(Clone, Copy, Debug, Default)]
struct DriverSum {
    start: f64,
    by_mode: [f64; 2],
    rate: [f64; 2],
    step: f64,
    end: [f64; 2],
}

impl DriverSum {
    /// The sum where the drivers' state is `start` and no time has passed: what a
    /// cascade reads at given states ([`SlidingStep::shaped_at`]).
    fn at(start: f64) -> Self {
        DriverSum {
            start,
            ..DriverSum::default()
        }
    }

    /// The `q`s at `t` into the step: made with the drivers where the step ends.
    fn q(&self, t: f64) -> [f64; 2] {
        if t == self.step {
            self.end
        } else {
            self.rate.map(|mu| q_at(mu, t))
        }
    }
}

/// Whether a group's event value keeps it clear of its event (as a sample of the whole
/// system's exponential substep must be, [`NEAR_EVENT`]); not a NaN.
fn clear(event: f64) -> bool {
    event <= -NEAR_EVENT
}

/// Whether the parabola through each group's event values at a substep's start, its
/// stage (the fraction `c` of it on) and its end keeps as clear of the event within the
/// substep as the samples must be ([`clear`]): a limit touched and left again between
/// them shows.
fn peaks_clear(first: &Events, stage: &Events, last: &Events, c: f64) -> bool {
    first
        .as_flattened()
        .iter()
        .zip(stage.as_flattened())
        .zip(last.as_flattened())
        .all(|((&e0, &e1), &e2)| e0 == NO_EVENT || peak_clear(e0, e1, e2, c))
}

/// [`peaks_clear`] of one group's event values `e0`, `e1` (the fraction `c` on) and `e2`.
fn peak_clear(e0: f64, e1: f64, e2: f64, c: f64) -> bool {
    // `e(s) = e0 + slope s + curvature s^2` through the three samples.
    let curvature = ((e1 - e0) - c * (e2 - e0)) / (c * c - c);
    let slope = (e2 - e0) - curvature;
    if curvature < 0.0 {
        let s = -slope / (2.0 * curvature);
        if (0.0..=1.0).contains(&s) && e0 - slope * slope / (4.0 * curvature) > -NEAR_EVENT {
            return false;
        }
    }
    true
}

/// Whether every event value of `events` keeps clear of its event ([`clear`]).
fn all_clear(events: &Events) -> bool {
    events
        .iter()
        .flatten()
        .all(|&event| event == NO_EVENT || clear(event))
}

/// Whether no event value of `events` is past its event (nor a NaN).
fn none_past(events: &Events) -> bool {
    events.iter().flatten().all(|&event| event <= EVENT_TOLERANCE)
}

/// Whether every group whose event values are `events` is in the mode that deciding
/// there finds (its event value below zero: sliding where its sticking force is outside
/// its ellipse, [`GroupInput::outside`]). A group may end a step within the event
/// tolerance past its event, still in its mode, where a step from a restored state,
/// which decides its modes itself, would find the other (SPEC 7: it must go on the same
/// way): such an end does not prepare its own modes for the next step; the outputs made
/// from its states decide them there, as a restored state's step does (from the same
/// trial forces, the same bits).
fn ends_decided(events: &Events) -> bool {
    events.iter().flatten().all(|&event| event < 0.0)
}

/// Whether no event value of `events` is a NaN.
fn all_numbers(events: &Events) -> bool {
    events.iter().flatten().all(|event| !event.is_nan())
}

/// How the driven groups' event values run over a substep ([`DrivenGroups::samples`]).
enum Samples {
    /// Every group stays in its mode.
    Clear,
    /// A group crosses its event: the first to, as their courses foretell.
    Crossing(Crossing),
}

/// A driven group that crosses its event within a substep: the group, where its course
/// first reaches the event (the substep's fraction), and the first sample past the
/// event (its fraction and value), which bounds the search for the crossing.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    group: usize,
    guess: f64,
    past: (f64, f64),
}

/// Below this share of its utilisation in its lesser direction, a damped group slides
/// in one direction: its force hardly turns on the ellipse, and exponential Euler is
/// within the tolerance (DDT's slide yardstick: the lateral case's shares are 1e-7 to
/// 1e-4, a few up to 1e-3, and Euler is taken; the combined case's mostly 1e-3 to 0.5,
/// where it would not be).
const ONE_DIRECTION_SHARE: f64 = 1e-3;

/// Whether every group of `inputs` whose sticking force is outside its ellipse has at
/// most [`ONE_DIRECTION_SHARE`] of its utilisation in its lesser direction.
fn in_one_direction(inputs: &[GroupInput]) -> bool {
    inputs
        .iter()
        .all(|input| input.within_share_of_one_direction(ONE_DIRECTION_SHARE))
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

/// `t phi1(mu t) = (exp(mu t) - 1) / mu`, and `t` where `mu = 0`.
fn q_at(mu: f64, t: f64) -> f64 {
    let x = mu * t;
    if x == 0.0 { t } else { t * x.exp_m1() / x }
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

    /// The outputs' shaping of the cascade at the coupled vector `z`, the groups in the
    /// modes of `groups` and reading the drivers' state there: the driven groups' rates
    /// (the `q`s' left for the caller) and event values, what the limits take off every
    /// damped group's sticking force, and whether every driver is in the mode deciding
    /// there finds. The same at a step's end as on demand
    /// ([`SlidingStep::cascade_limit_changes`]): the same bits.
    fn shaped_at(&self, cascade: &Cascade, groups: &DrivenGroups, at: &ShapingPoint) -> CascadeShaping {
        let (rates, events, mut changes) = groups.evaluate_with_changes(&at.driven, at.driver_state);
        let mut drivers_decided = true;
        for j in cascade.drivers() {
            let slot = &self.slots()[j];
            let input = driver_input(slot, at.drivers[slot.branch], groups.driver_drive);
            let sliding = groups.modes[slot.group][slot.branch];
            // As the step's drivers are evaluated (every group damped where the end is
            // shaped): a sliding one's force on its limit.
            let (output, _) = input.evaluate_one_damped(Some(sliding));
            drivers_decided &= output.event < 0.0;
            if sliding {
                changes[slot.law.direction[0]] += output.force[0] - input.sticking_force()[0];
            }
        }
        CascadeShaping {
            rates,
            events,
            changes,
            drivers_decided,
        }
    }

    /// The coupled vector `z` as [`SlidingStep::shaped_at`] reads it.
    fn point_of(&self, cascade: &Cascade, groups: &DrivenGroups, z: &Vector) -> ShapingPoint {
        let first = self.layout.sums[cascade.driver_state].first;
        let mut drivers = [0.0; MAX_BRANCHES];
        drivers.copy_from_slice(&z[first..first + MAX_BRANCHES]);
        ShapingPoint {
            driven: groups.start(z),
            drivers,
            driver_state: self.layout.model_state(z, cascade.driver_state),
        }
    }

    /// Where a step ends at the driven vector `u`, the drivers' ends in `z`, as
    /// [`SlidingStep::shaped_at`] reads the coupled vector its states and offsets pack to
    /// ([`SlidingStep::whole_end`] then [`Layout::pack`]; [`SlidingStep::point_of`]), the
    /// same bits: each branch deflection `U + (b - U)`, `U` its element's state, the
    /// weighted sum of the branches in their order ([`Layout::model_states`]). Made from
    /// the pieces (driven group `n` is the driven elements' branch `n`, [`Cascade::of`]):
    /// a vector written entry by entry and read again at once stalls on its stores.
    fn end_point(
        &self,
        cascade: &Cascade,
        groups: &DrivenGroups,
        (z, u): (&Vector, &Driven),
    ) -> ShapingPoint {
        let weights = &self.layout.weights;
        // Member `m` of every group is a branch of one element: its state is the sum over
        // the groups, in the order of the branches (past them, weight and entry are zero,
        // and a sum begun at +0 adds their zeros without a change, as the sums of the
        // packed vector add theirs). Summed over fixed lengths, in registers.
        let mut states = [0.0; MAX_MEMBERS];
        for n in 0..MAX_BRANCHES {
            for m in 0..MAX_MEMBERS {
                states[m] += weights[n] * u[entry(n, m)];
            }
        }
        let members = groups.slots[0].law.count;
        let mut driven = [0.0; DRIVEN];
        for n in 0..groups.count {
            // The pair whole (a missing member's zero), as the groups read it.
            let mut pair = [0.0; MAX_MEMBERS];
            for m in 0..MAX_MEMBERS {
                if m < members {
                    pair[m] = states[m] + (u[entry(n, m)] - states[m]);
                }
            }
            driven[entry(n, 0)..entry(n, MAX_MEMBERS)].copy_from_slice(&pair);
        }
        let first = self.layout.sums[cascade.driver_state].first;
        let entries = &z[first..first + MAX_BRANCHES];
        let state = self.layout.model_state(z, cascade.driver_state);
        let mut drivers = [0.0; MAX_BRANCHES];
        let mut driver_state = 0.0;
        for i in 0..MAX_BRANCHES {
            if i < self.layout.branches {
                drivers[i] = state + (entries[i] - state);
            }
            driver_state += weights[i] * drivers[i];
        }
        ShapingPoint {
            driven,
            drivers,
            driver_state,
        }
    }

    /// What the damped groups' limits take off their sticking forces at the coupled vector
    /// `z` where the slots form a cascade (and the step suits it, [`SlidingStep::cascade`]),
    /// by the cascade's own equations ([`SlidingStep::shaped_at`], as a step's end is
    /// shaped), with each group's mode as deciding there finds it; `None` where there is
    /// no driven group.
    pub(super) fn cascade_limit_changes(
        &self,
        cascade: &Cascade,
        z: &Vector,
    ) -> Option<(LimitChanges, Modes)> {
        let drives = self.input_rates();
        let drive = drives[cascade.driver_state];
        let mut modes = [[false; MAX_BRANCHES]; Group::COUNT];
        for j in cascade.drivers() {
            let slot = &self.slots()[j];
            modes[slot.group][slot.branch] = driver_input(slot, z[slot.entries[0]], drive).outside();
        }
        let sum = DriverSum::at(self.layout.model_state(z, cascade.driver_state));
        let mut groups = DrivenGroups::new(self, cascade, (modes, &drives), &sum)?;
        groups.decide(&groups.start(z));
        let shaping = self.shaped_at(cascade, &groups, &self.point_of(cascade, &groups, z));
        Some((shaping.changes, groups.modes))
    }

    /// The states and branches at the end `driven` of the driven groups, with the
    /// drivers' ends in `end` (which takes the driven groups' too), in the modes `modes`,
    /// written to `x` and `sliders` (in place: copies of either cost a call each).
    fn whole_end(
        &self,
        cascade: &Cascade,
        (end, modes): (&mut Vector, &Modes),
        driven: &Driven,
        (x, sliders): (&mut StateVector, &mut SliderState),
    ) {
        self.set_driven_end(cascade, (end, modes), driven);
        *x = self.layout.unpack(end, sliders);
        sliders.sliding = *modes;
    }

    /// Writes the end `driven` of the driven groups into the coupled vector `end`, in the
    /// modes `modes` ([`SlidingStep::whole_end`] unpacks it).
    #[inline(always)]
    fn set_driven_end(&self, cascade: &Cascade, (end, modes): (&mut Vector, &Modes), driven: &Driven) {
        for (n, j) in cascade.driven().enumerate() {
            let slot = &self.slots()[j];
            for m in slot.law.members() {
                end[slot.entries[m]] = driven[entry(n, m)];
            }
        }
        self.hold_on_limits(end, modes);
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

    /// The driven groups over the step, side by side, in substeps of one length: by
    /// exponential Euler where the slide is in one direction and that is within the
    /// tolerance, else by exprb42 ([`DrivenLinearPart`]), or for a stiff slide by
    /// linearly implicit Euler extrapolation, whose solves take each group's own two by
    /// two. A group that crosses its event in an explicit substep changes mode there
    /// (in `groups`' modes; see the module's doc). The driven vector at the end, or
    /// `None` where a group's course is not sure, a group at its event moves back from
    /// it, a stiff substep nears an event, or they need more than [`MAX_SUBSTEPS`]. With
    /// the end, what the limits take off the groups' sticking forces there where the last
    /// substep's end was evaluated as the outputs are made (an explicit substep's,
    /// [`SlidingStep::shaped_at`]), and whether every driver ends in the mode deciding
    /// there finds.
    fn driven_step(
        &self,
        cascade: &Cascade,
        groups: &mut DrivenGroups,
        mut w: Driven,
        z: &Vector,
        (h, largest, stiff): (f64, f64, bool),
    ) -> Option<(Driven, Option<EndShaping>)> {
        // The explicit substeps stay as short as the whole system's exponential ones, so
        // that their samples of the event values are as close; the implicit ones try the
        // whole step first, as there.
        let longest = if stiff { h } else { 0.25 * self.longest_substep() };
        // Its pieces may be a few roundings longer ([`pieces_of`]): no sliver is left.
        let longest_piece = longest * (1.0 + ROUNDINGS);
        // An explicit first substep as long as the last step's could have been, in equal
        // pieces of the step ([`carried_first_substep`]).
        let carried = self.high_order_carried[0];
        // (Where it would take more pieces than a step may, it came from a far shorter
        // step: it tells this one nothing, and the step starts as with nothing carried.)
        let ignored = pieces_of(h, carried) > MAX_SUBSTEPS as f64;
        let first = if stiff || ignored {
            h
        } else {
            in_equal_pieces(h, carried)
        };
        let (mut t, mut length, mut taken) = (0.0, first.min(longest), 0);
        // Exponential Euler is tried where a slide is in one direction, unless the last
        // step's first high-order substep (exprb42's, or the whole-system path's) could not
        // have been the whole step: the force turns fast, and Euler, an order short of
        // exprb42, is thrown away (as the slip reverses, its estimates were hundreds of
        // times its margin). Nor again within the step once it has been thrown away.
        let mut euler_may_do = carried >= h || ignored;
        // The Jacobian where the next substep starts, where the quartic estimate made it.
        let mut next_slopes = None;
        // Over the groups' deflections: the `q`s are exact.
        let deflections = entry(groups.count(), 0);
        let negligible = negligible_term(self.scale, largest);
        // The rates and event values where each substep starts: made there, or kept from
        // the last substep's end where an explicit one evaluated it (in place, as the
        // pieces of an evaluation are not moved); and what the limits take off the forces
        // where that end was the step's.
        let (mut rates, mut events) = ([0.0; DRIVEN], [[NO_EVENT; MAX_BRANCHES]; Group::COUNT]);
        let (mut end_rates, mut end_events) = (rates, events);
        let mut kept = false;
        // Whether `rates` are not yet made where `w` is: at the start, and after a substep
        // whose end was not evaluated (a stiff one's) or where a group changed mode.
        let mut stale = true;
        let mut changes = None;
        let mut switches = 0;
        // Each pass evaluates where the last substep ended (the last pass only the event
        // values there), so the loop has a pass more than the substeps.
        for _ in 0..=MAX_SUBSTEPS + MAX_DRIVEN_SWITCHES {
            if t >= h {
                // An explicit substep's end was evaluated, its events followed there.
                if kept {
                    let shaping = changes.map(|(changes, drivers_decided)| EndShaping {
                        changes,
                        decided: drivers_decided && ends_decided(&end_events),
                    });
                    return Some((w, shaping));
                }
                return all_clear(&groups.events(&w)).then_some((w, None));
            }
            // The inputs at `w` (made where they are used, not carried with the rates):
            // for the slopes, and for the evaluation there where none was kept.
            let (inputs, sliding) = groups.inputs(&w);
            if kept {
                (rates, events) = (end_rates, end_events);
            } else if stale {
                (rates, events) = groups.evaluate_inputs(&w, (&inputs, &sliding));
            }
            (kept, stale, changes) = (false, false, None);
            // The explicit substeps follow a group near its event ([`Course`]); the
            // implicit ones keep clear of it.
            if !(if stiff {
                all_clear(&events)
            } else {
                none_past(&events)
            }) {
                return None;
            }
            // Substeps that cannot finish the step within the rest at the length the error
            // control allows: the whole-system path takes it, known early.
            length = length.min(h - t).min(longest_piece);
            let pieces_left = (MAX_SUBSTEPS - taken) as f64 * (1.0 + ROUNDINGS);
            if taken == MAX_SUBSTEPS || h - t > length * pieces_left {
                return None;
            }
            let slopes = next_slopes
                .take()
                .unwrap_or_else(|| groups.slopes(&inputs, &rates));
            if stiff {
                let (end, factor) =
                    match self.driven_implicit_substep(groups, (t, &w), (&rates, &events), &slopes, length) {
                        Implicit::Taken(end, growth) => (Some(end), growth),
                        Implicit::Shorter => (None, 0.25),
                        Implicit::NearEvent => return None,
                    };
                if let Some(end) = end {
                    (w, t, taken, stale) = (end, t + length, taken + 1, true);
                }
                length *= factor;
                continue;
            }
            let error_of = |best: &Driven, previous: &Driven| {
                self.error_ratio_of(
                    (&w[..deflections], &best[..deflections], &previous[..deflections]),
                    largest,
                )
            };
            let crossing = {
                let groups = &*groups;
                let linear = groups.linear_part(&slopes, length, negligible);
                // The rates and event values at the substep's end, into `end_rates` and
                // `end_events`: at the step's end from its states and branches, as the
                // outputs are made, so that they come from this evaluation.
                let last = t + length >= h;
                let mut end_changes = None;
                let shapes = last && self.cascade_decides();
                let end_evaluation = |u: &Driven,
                                      (rates, events): (&mut Driven, &mut Events),
                                      made: &mut Option<_>| {
                    if !shapes {
                        (*rates, *events) = groups.evaluate(u);
                        return;
                    }
                    // As the states and branches there pack again.
                    let shaped = self.shaped_at(cascade, groups, &self.end_point(cascade, groups, (z, u)));
                    (*rates, *events) = (shaped.rates, shaped.events);
                    // The `q`s' rates where they are (the shaping reads them at zero).
                    rates[Q[0]..=Q[1]].copy_from_slice(&groups.q_rates(u));
                    *made = Some((shaped.changes, shaped.drivers_decided));
                };
                let mut course = None;
                if euler_may_do && in_one_direction(&inputs[..groups.count()]) {
                    let mut middle_events = events;
                    let middle = |u: &Driven| {
                        middle_events = groups.events(u);
                        all_numbers(&middle_events).then_some(())
                    };
                    let end_rates_of = |u: &Driven| {
                        end_evaluation(u, (&mut end_rates, &mut end_events), &mut end_changes);
                        all_numbers(&end_events).then_some(end_rates)
                    };
                    let (end, error) =
                        exponential_euler(&linear, &w, &rates, middle, end_rates_of, &error_of)?;
                    let samples = groups.samples(
                        (&w, &rates, &events),
                        (0.5, &middle_events),
                        (&end, &end_rates, &end_events),
                        length,
                    )?;
                    // The estimate is of the end taken, and grows as the substep's cube.
                    // The last substep's growth is not used, and not made (a cube root).
                    let growth = if last {
                        euler_within(error).then_some(1.0)
                    } else {
                        let (accepted, factor) = resize_euler(error);
                        accepted.then_some(factor)
                    };
                    if let (Samples::Clear, Some(factor)) = (&samples, growth) {
                        if t == 0.0 {
                            // Euler's first substep carries no length: the next step tries
                            // the whole step.
                            self.high_order_found.set(NOT_CARRIED);
                        }
                        (w, t, taken) = (end, t + length, taken + 1);
                        (kept, changes) = (true, end_changes);
                        length *= factor;
                        continue;
                    }
                    euler_may_do = growth.is_some();
                    course = Some(samples);
                }
                // Where Euler is not within the tolerance, or a group crosses its event
                // (then searched for by exprb42's substeps, which is accurate enough).
                let crossing = match course {
                    Some(Samples::Crossing(crossing)) => crossing,
                    _ => {
                        let mut stage_events = events;
                        let stage_rates = |stage: usize, u: &Driven| {
                            let rates = if stage == 1 {
                                let rates;
                                (rates, stage_events) = groups.evaluate(u);
                                all_numbers(&stage_events).then_some(())?;
                                rates
                            } else {
                                end_evaluation(u, (&mut end_rates, &mut end_events), &mut end_changes);
                                all_numbers(&end_events).then_some(())?;
                                end_rates
                            };
                            Some(rates)
                        };
                        let Exprb42Substep {
                            end,
                            third,
                            remainders,
                        } = exprb42(&linear, &w, &rates, stage_rates)?;
                        let samples = groups.samples(
                            (&w, &rates, &events),
                            (0.75, &stage_events),
                            (&end, &end_rates, &end_events),
                            length,
                        )?;
                        match samples {
                            Samples::Crossing(crossing) => crossing,
                            Samples::Clear => {
                                let error = error_of(&end, &third);
                                let mut factor = aimed_factor(error);
                                // Where the third-order estimate would not let the rest of
                                // the step be one substep (a force that turns), exprb42's own
                                // error from the remainder's quartic part, with the Jacobian
                                // at the end, which the next substep takes.
                                let sharper = (length * factor < h - t && error <= SHARPER_WITHIN)
                                    .then(|| {
                                        groups.quartic_estimate(&linear, (&end, &end_rates), &remainders)
                                    })
                                    .flatten()
                                    .map(|(estimate, end_slopes)| (error_of(&end, &estimate), end_slopes));
                                let sharply_within = sharper
                                    .as_ref()
                                    .is_some_and(|(sharp, _)| *sharp <= SHARPER_MARGIN);
                                if let Some((sharp, _)) = &sharper {
                                    factor = factor.max(sharper_factor(error, *sharp));
                                }
                                if t == 0.0 {
                                    self.high_order_found.set(carried_first_substep(length, factor));
                                }
                                // Within either margin, taken; the next at its aim, in the
                                // bounds of any resizing.
                                let within = if sharply_within {
                                    0.0
                                } else {
                                    error / EXPRB42_MARGIN
                                };
                                let (accepted, factor) = resized(within, factor);
                                let allowed = length * factor;
                                if accepted {
                                    (w, t, taken) = (end, t + length, taken + 1);
                                    (kept, changes) = (true, end_changes);
                                    next_slopes = sharper.map(|(_, slopes)| slopes);
                                }
                                length = in_equal_pieces(h - t, allowed.min(longest));
                                continue;
                            }
                        }
                    }
                };
                let n = crossing.group;
                let slot = groups.slots[n];
                let (g, i) = (slot.group, slot.branch);
                if events[g][i] >= 0.5 * EVENT_TOLERANCE {
                    // At its event already (within the tolerance): moving past it, it
                    // changes mode here; moving back, it would cross later from past where
                    // the search starts, and the whole-system path takes the step.
                    if groups.event_rates(&w, &rates)[n] > 0.0 {
                        (crossing, None)
                    } else {
                        return None;
                    }
                } else {
                    // The crossing searched for on exprb42's substeps from the start: where
                    // the event value is within the tolerance past the event.
                    let substep_to = |s: f64| {
                        let linear = groups.linear_part(&slopes, s * length, negligible);
                        let mut at_end = events;
                        let stage_rates = |_: usize, u: &Driven| {
                            let (rates, events);
                            (rates, events) = groups.evaluate(u);
                            at_end = events;
                            Some(rates)
                        };
                        let Exprb42Substep { end, third, .. } = exprb42(&linear, &w, &rates, stage_rates)?;
                        Some((end, error_of(&end, &third), at_end))
                    };
                    let found = crossing_search(
                        |s| substep_to(s).map(|(end, error, at_end)| (at_end[g][i], (end, error, at_end))),
                        events[g][i],
                        crossing.past,
                        crossing.guess,
                    )?;
                    let (s, (end, error, at_end)) = found;
                    if !(resize(error, EXPRB42_MARGIN).0 && none_past(&at_end)) {
                        return None;
                    }
                    (crossing, Some((s, end)))
                }
            };
            // The group changes mode where it crossed (its force is continuous there: its
            // trial force is on its limit), and the next substep starts from there.
            let (crossing, reached) = crossing;
            if let Some((s, end)) = reached {
                (w, t, taken) = (end, t + s * length, taken + 1);
            }
            let slot = groups.slots[crossing.group];
            let mode = &mut groups.modes[slot.group][slot.branch];
            *mode = !*mode;
            (stale, switches) = (true, switches + 1);
            if switches > MAX_DRIVEN_SWITCHES {
                return None;
            }
        }
        None
    }

    /// One substep of the driven groups by linearly implicit Euler extrapolation (as
    /// [`super::implicit`] takes the whole system), each Euler step solving
    /// `(I - s J) db = s f` group by group with its two by two of the Jacobian at the
    /// substep's start. The `q`s are known: each step sets them where it ends.
    fn driven_implicit_substep(
        &self,
        groups: &DrivenGroups,
        (t, w): (f64, &Driven),
        (rates, events): (&Driven, &Events),
        slopes: &[Slopes; MAX_BRANCHES],
        length: f64,
    ) -> Implicit {
        let whole = |d: &Driven| {
            let mut v = [0.0; SIZE];
            v[..DRIVEN].copy_from_slice(d);
            v
        };
        let q_end = groups.sum.q(t + length);
        let row = |n: usize| -> Option<Row> {
            let s = length / n as f64;
            // Each group's `(I - s J)^-1`, for every Euler step of the row.
            let mut inverses = [[[0.0; MAX_MEMBERS]; MAX_MEMBERS]; MAX_BRANCHES];
            for (g, slot) in groups.slots().enumerate() {
                inverses[g] = shifted_inverse(&slopes[g].by_member, s, slot.law.count)?;
            }
            let mut current = *w;
            let mut at_rates = *rates;
            let mut search = InteriorSearch::new(events);
            for k in 0..n {
                if k > 0 {
                    let at_events;
                    (at_rates, at_events) = groups.evaluate(&current);
                    search.sample(k, s, &at_events);
                }
                for (g, inverse) in inverses[..groups.count()].iter().enumerate() {
                    let v = [at_rates[entry(g, 0)], at_rates[entry(g, 1)]];
                    for m in 0..MAX_MEMBERS {
                        current[entry(g, m)] += s * (inverse[m][0] * v[0] + inverse[m][1] * v[1]);
                    }
                }
                // Every row ends where the substep does: the `q`s there are made once.
                if k + 1 == n {
                    for (mode, &q) in Q.iter().enumerate() {
                        current[q] = q_end[mode];
                    }
                } else {
                    groups.set_q(&mut current, t + (k + 1) as f64 * s);
                }
            }
            let (interior, closest) = search.found();
            Some((whole(&current), interior, closest, s))
        };
        match self.extrapolate(&whole(w), &IMPLICIT_SEQUENCE, 1, true, row) {
            None => Implicit::Shorter,
            Some((_, _, Some(_), _)) => Implicit::NearEvent,
            Some((end, growth, None, _)) => Implicit::Taken(std::array::from_fn(|c| end[c]), growth),
        }
    }
}

/// What the limits take off the groups' sticking forces at a step's end, where its last
/// evaluation was there, and whether every driven group there is in the mode deciding
/// there finds ([`ends_decided`]).
struct EndShaping {
    changes: LimitChanges,
    decided: bool,
}

/// Where [`SlidingStep::shaped_at`] shapes: the driven vector (the `q`s zero), the drivers'
/// deflections by branch, and the drivers' state, the weighted sum of those.
struct ShapingPoint {
    driven: Driven,
    drivers: [f64; MAX_BRANCHES],
    driver_state: f64,
}

/// The outputs' shaping of a cascade at given states ([`SlidingStep::shaped_at`]).
struct CascadeShaping {
    rates: Driven,
    events: Events,
    changes: LimitChanges,
    drivers_decided: bool,
}

/// `d rate_k / d b_m` of a driven group (through its sticking rates too, with their
/// relaxation), by row `k`, and `d rate_k / d X` of the drivers' state, by member.
#[derive(Clone, Copy, Debug, Default)]
struct Slopes {
    by_member: [Members; MAX_MEMBERS],
    by_driver: Members,
}

/// How a stiff substep of the driven groups ended ([`SlidingStep::driven_implicit_substep`]).
enum Implicit {
    /// Accurate: the end, and the factor by which the next substep may grow.
    Taken(Driven, f64),
    /// The rows did not agree, or a solve failed: a shorter substep.
    Shorter,
    /// A group may touch its limit inside: the whole-system path takes the step.
    NearEvent,
}

/// When a spring-damper driver in mode `sliding` from deflection `b0` at rate `rate`
/// (its mode's rate `mu`) reaches its limit: where its trial force, affine in the
/// deflection `T = (K + Dw A_kk) b + Dw c` (`c` its element's state's rate from the
/// inputs, `drive`), is the limit on the side it leaves from
/// (sliding) or moves to (sticking), and `q(t) = (b - b0) / rate` is solved for `t`.
/// `None` where that is not a time within reach.
fn driver_crossing(
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
    let at = if x == 0.0 { q } else { x.ln_1p() / mu };
    (at.is_finite() && at > 0.0).then_some(at)
}

/// A driver's group input at deflection `b`, its element's state's rate from the inputs
/// `drive`: its sticking rate is its element's equation with `b` in place of the state,
/// `A_kk b + c`.
fn driver_input(slot: &Slot, b: f64, drive: f64) -> GroupInput<'_> {
    // Each pair made whole (see [`DrivenGroups::inputs`]).
    GroupInput {
        law: &slot.law,
        deflection: [b, 0.0],
        sticking_rate: [slot.relaxation[0] * b + drive, 0.0],
    }
}

/// The driven groups of one step: their slots, each member's inputs' part of its
/// sticking rate and coupling to the drivers' state, and the drivers' sum.
struct DrivenGroups<'s> {
    slots: [&'s Slot; MAX_BRANCHES],
    count: usize,
    modes: Modes,
    drive: [Members; MAX_BRANCHES],
    coupling: [Members; MAX_BRANCHES],
    sum: &'s DriverSum,
    /// The inputs' part of the drivers' state's rate.
    driver_drive: f64,
}

impl<'s> DrivenGroups<'s> {
    /// `None` where there are none. (Inlined: made where it is kept, not copied there.)
    #[inline(always)]
    fn new(
        step: &'s SlidingStep,
        cascade: &Cascade,
        (modes, drives): (Modes, &[f64; MAX_STATES]),
        sum: &'s DriverSum,
    ) -> Option<Self> {
        let all = step.slots();
        let mut groups = DrivenGroups {
            slots: [all.get(cascade.driven().next()?)?; MAX_BRANCHES],
            count: cascade.driven_count,
            modes,
            drive: [[0.0; MAX_MEMBERS]; MAX_BRANCHES],
            coupling: [[0.0; MAX_MEMBERS]; MAX_BRANCHES],
            sum,
            driver_drive: drives[cascade.driver_state],
        };
        for (n, j) in cascade.driven().enumerate() {
            let slot = &all[j];
            groups.slots[n] = slot;
            for m in slot.law.members() {
                let k = slot.states[m];
                groups.drive[n][m] = drives[k];
                groups.coupling[n][m] = step.system.a[(k, cascade.driver_state)];
            }
        }
        Some(groups)
    }

    fn count(&self) -> usize {
        self.count
    }

    /// The driven vector at the step's start `z`: each group's pair whole (a missing
    /// member's zero), as its evaluation reads it, and the `q`s zero.
    #[inline(always)]
    fn start(&self, z: &Vector) -> Driven {
        let mut w = [0.0; DRIVEN];
        for (n, slot) in self.slots().enumerate() {
            let second = if slot.law.count > 1 {
                z[slot.entries[1]]
            } else {
                0.0
            };
            w[entry(n, 0)..entry(n, MAX_MEMBERS)].copy_from_slice(&[z[slot.entries[0]], second]);
        }
        w
    }

    /// Each group's mode at `w` as the hybrid system decides a damped group's: sliding
    /// where its sticking force is outside its ellipse ([`SlidingStep::cascade_decides`]).
    fn decide(&mut self, w: &Driven) {
        let (inputs, _) = self.inputs(w);
        for (n, slot) in self.slots[..self.count].iter().enumerate() {
            self.modes[slot.group][slot.branch] = inputs[n].outside();
        }
    }

    fn slots(&self) -> impl Iterator<Item = &'s Slot> + '_ {
        self.slots[..self.count].iter().copied()
    }

    /// Every driven group's inputs at `w`, and its mode. (Inlined: made where they are
    /// used, not copied there.)
    #[inline(always)]
    fn inputs(&self, w: &Driven) -> ([GroupInput<'s>; MAX_BRANCHES], [bool; MAX_BRANCHES]) {
        let sum = self.sum;
        self.inputs_with(w, sum.start + sum.by_mode[0] * w[Q[0]] + sum.by_mode[1] * w[Q[1]])
    }

    /// [`DrivenGroups::inputs`] with the drivers' state `driver`.
    #[inline(always)]
    fn inputs_with(&self, w: &Driven, driver: f64) -> ([GroupInput<'s>; MAX_BRANCHES], [bool; MAX_BRANCHES]) {
        let mut inputs = [GroupInput::default(); MAX_BRANCHES];
        let mut sliding = [false; MAX_BRANCHES];
        for (n, slot) in self.slots().enumerate() {
            // Over both member slots, each pair made whole: a missing member's entries
            // and constants are zero, so its deflection and rate come out zero, and the
            // law reads each pair back at once (a store of each half would stall it).
            let deflection = [w[entry(n, 0)], w[entry(n, 1)]];
            let sticking_rate = [0, 1].map(|m| {
                slot.relaxation[m] * deflection[m] + self.drive[n][m] + self.coupling[n][m] * driver
            });
            inputs[n] = GroupInput {
                law: &slot.law,
                deflection,
                sticking_rate,
            };
            sliding[n] = self.modes[slot.group][slot.branch];
        }
        (inputs, sliding)
    }

    /// Every driven group's event value at `w`, as [`DrivenGroups::evaluate`] gives it
    /// (with no projection onto the ellipses).
    fn events(&self, w: &Driven) -> Events {
        let (inputs, sliding) = self.inputs(w);
        let mut events: Events = [[NO_EVENT; MAX_BRANCHES]; Group::COUNT];
        for (n, slot) in self.slots().enumerate() {
            events[slot.group][slot.branch] = inputs[n].event(sliding[n]);
        }
        events
    }

    /// Every driven group's rates and event value at `w`, evaluated side by side (their
    /// projections' Newton steps overlap).
    fn evaluate(&self, w: &Driven) -> (Driven, Events) {
        let (inputs, sliding) = self.inputs(w);
        self.evaluate_inputs(w, (&inputs, &sliding))
    }

    /// [`DrivenGroups::evaluate`] at `w` from its inputs and modes there
    /// ([`DrivenGroups::inputs`]).
    fn evaluate_inputs(
        &self,
        w: &Driven,
        (inputs, sliding): (&[GroupInput; MAX_BRANCHES], &[bool; MAX_BRANCHES]),
    ) -> (Driven, Events) {
        let mut outputs = [GroupOutput::default(); MAX_BRANCHES];
        self.outputs_into((inputs, sliding), &mut outputs);
        self.laid_out_from(w, |n| outputs[n])
    }

    /// [`DrivenGroups::evaluate`] at the step's end `w`, and what the limits take off
    /// the driven groups' sticking forces there, by direction: each sliding group's force
    /// (the closest point of its ellipse) less its trial force. (A damped group's: where
    /// the step's end shapes the outputs, every group is one.)
    fn evaluate_with_changes(&self, w: &Driven, driver: f64) -> (Driven, Events, LimitChanges) {
        let (inputs, sliding) = self.inputs_with(w, driver);
        let mut outputs = [GroupOutput::default(); MAX_BRANCHES];
        self.outputs_into((&inputs, &sliding), &mut outputs);
        let mut changes = [0.0; Direction::COUNT];
        for n in 0..self.count {
            let input = &inputs[n];
            if sliding[n] && input.damped() {
                let trial = input.sticking_force();
                for m in input.members() {
                    changes[input.direction[m]] += outputs[n].force[m] - trial[m];
                }
            }
        }
        let (rates, events) = self.laid_out_from(w, |n| outputs[n]);
        (rates, events, changes)
    }

    /// Every driven group's [`GroupInput::evaluate`] in its mode into `outputs`, side by
    /// side (their projections' Newton steps overlap). (Written where they are kept: an
    /// array returned is copied by a call.)
    #[inline(always)]
    fn outputs_into(
        &self,
        (inputs, sliding): (&[GroupInput; MAX_BRANCHES], &[bool; MAX_BRANCHES]),
        outputs: &mut [GroupOutput; MAX_BRANCHES],
    ) {
        let count = self.count;
        evaluate_together::<MAX_BRANCHES>(&inputs[..count], &sliding[..count], &mut outputs[..count]);
    }

    /// The driven groups' rates and event values at `w` laid out from each group's
    /// `output(n)` (rates, forces and event value), and the `q`s' rates.
    #[inline(always)]
    fn laid_out_from(&self, w: &Driven, output: impl Fn(usize) -> GroupOutput) -> (Driven, Events) {
        let mut rates = [0.0; DRIVEN];
        let mut events: Events = [[NO_EVENT; MAX_BRANCHES]; Group::COUNT];
        for (n, slot) in self.slots().enumerate() {
            let output = output(n);
            rates[entry(n, 0)..entry(n, MAX_MEMBERS)].copy_from_slice(&output.rate);
            events[slot.group][slot.branch] = output.event;
        }
        rates[Q[0]..=Q[1]].copy_from_slice(&self.q_rates(w));
        (rates, events)
    }

    /// How fast each driven group's event value moves at `w`, where the driven vector
    /// moves at `rates`, by group: a spring-damper's ([`GroupInput::damped_event_rate`];
    /// its sticking rates move with its deflections and, through the coupling, with the
    /// drivers' state, `R . dq/dt`), NaN for a spring's.
    fn event_rates(&self, w: &Driven, rates: &Driven) -> [f64; MAX_BRANCHES] {
        let (inputs, sliding) = self.inputs(w);
        let sum = self.sum;
        let driver_rate = sum.by_mode[0] * rates[Q[0]] + sum.by_mode[1] * rates[Q[1]];
        let mut event_rates = [f64::NAN; MAX_BRANCHES];
        for (n, slot) in self.slots().enumerate() {
            if !slot.law.damped() {
                continue;
            }
            let rate = [rates[entry(n, 0)], rates[entry(n, 1)]];
            let sticking_rate_rate =
                [0, 1].map(|m| slot.relaxation[m] * rate[m] + self.coupling[n][m] * driver_rate);
            event_rates[n] = inputs[n].damped_event_rate(sliding[n], &rate, &sticking_rate_rate);
        }
        event_rates
    }

    /// How the driven groups' event values run over an explicit substep of `length`
    /// seconds from `start` (with its rates and event values) through a stage the
    /// fraction `c` on (its event values) to `end` (with its rates and event values).
    /// Clear where every sample keeps clear of its event and so does the parabola through
    /// them (the usual case, [`peaks_clear`]); otherwise each group near its event is
    /// followed on its [`Course`]: it stays, or a sample is past its event and the
    /// crossing is searched for. `None` where a group nears its event and does not
    /// surely stay (a spring's, or a touch between the samples).
    fn samples(
        &self,
        (start, start_rates, start_events): (&Driven, &Driven, &Events),
        (c, stage_events): (f64, &Events),
        (end, end_rates, end_events): (&Driven, &Driven, &Events),
        length: f64,
    ) -> Option<Samples> {
        if [start_events, stage_events, end_events]
            .iter()
            .all(|events| all_clear(events))
            && peaks_clear(start_events, stage_events, end_events, c)
        {
            return Some(Samples::Clear);
        }
        let (rates_at_start, rates_at_end) = (
            self.event_rates(start, start_rates),
            self.event_rates(end, end_rates),
        );
        let mut first: Option<Crossing> = None;
        for (n, slot) in self.slots().enumerate() {
            let at = |events: &Events| events[slot.group][slot.branch];
            let (e0, e_stage, e1) = (at(start_events), at(stage_events), at(end_events));
            if e0 == NO_EVENT || (clear(e0) && clear(e_stage) && clear(e1) && peak_clear(e0, e_stage, e1, c))
            {
                continue;
            }
            // A spring's event value (its outward cosine) has no course here.
            if !slot.law.damped() {
                return None;
            }
            let course = Course::new(
                (e0, rates_at_start[n] * length),
                (c, e_stage),
                (e1, rates_at_end[n] * length),
            );
            // The first sample past the event bounds the search for the crossing.
            let past = if e_stage > EVENT_TOLERANCE {
                (c, e_stage)
            } else if e1 > EVENT_TOLERANCE {
                (1.0, e1)
            } else if course.stays() {
                continue;
            } else {
                return None;
            };
            let guess = course.first_reaching(0.5 * EVENT_TOLERANCE, past.0);
            if first.is_none_or(|first| guess < first.guess) {
                first = Some(Crossing {
                    group: n,
                    guess,
                    past,
                });
            }
        }
        Some(first.map_or(Samples::Clear, Samples::Crossing))
    }

    /// The `q`s' rates at `w`, `dq/dt = 1 + mu q`, the pair whole (as
    /// [`DrivenLinearPart::times`] reads it).
    fn q_rates(&self, w: &Driven) -> [f64; 2] {
        let rate = self.sum.rate;
        [1.0 + rate[0] * w[Q[0]], 1.0 + rate[1] * w[Q[1]]]
    }

    /// Each group's [`Slopes`] at its `inputs` there, whose rates are `rates`
    /// ([`GroupInput::rate_slopes`]).
    fn slopes(&self, inputs: &[GroupInput; MAX_BRANCHES], rates: &Driven) -> [Slopes; MAX_BRANCHES] {
        let mut all = [Slopes::default(); MAX_BRANCHES];
        for (n, slot) in self.slots().enumerate() {
            let sliding = self.modes[slot.group][slot.branch];
            let slopes = inputs[n].rate_slopes(sliding, &[rates[entry(n, 0)], rates[entry(n, 1)]]);
            for k in slot.law.members() {
                for m in slot.law.members() {
                    all[n].by_member[k][m] =
                        slopes.by_deflection[k][m] + slopes.by_sticking_rate[k][m] * slot.relaxation[m];
                }
                all[n].by_driver[k] = slot
                    .law
                    .members()
                    .map(|m| slopes.by_sticking_rate[k][m] * self.coupling[n][m])
                    .sum();
            }
        }
        all
    }

    /// [`quartic_estimate`] of an exprb42 substep with the linear part `linear` that ended
    /// at `end` (its rates `end_rates`) with the remainders `D2` and `D3`, and the groups'
    /// Jacobian there (the next substep's, where it is taken); `None` where a value is not
    /// finite (the third-order estimate alone decides). (Inlined: its Jacobian is made
    /// where it is kept, not copied out of a call.)
    #[inline(always)]
    fn quartic_estimate(
        &self,
        linear: &DrivenLinearPart,
        (end, end_rates): (&Driven, &Driven),
        remainders: &[Driven; 2],
    ) -> Option<(Driven, [Slopes; MAX_BRANCHES])> {
        let (end_inputs, _) = self.inputs(end);
        let end_slopes = self.slopes(&end_inputs, end_rates);
        let end_linear = self.linear_part(&end_slopes, linear.length(), linear.negligible());
        let estimate = quartic_estimate((linear, &end_linear), (end, end_rates), remainders);
        estimate
            .iter()
            .all(|v| v.is_finite())
            .then_some((estimate, end_slopes))
    }

    /// `H J` of the groups and the `q`s over a substep of `length` ([`DrivenLinearPart`]).
    fn linear_part(&self, slopes: &[Slopes; MAX_BRANCHES], length: f64, negligible: f64) -> DrivenLinearPart {
        let mut linear = DrivenLinearPart {
            members: [[[0.0; MAX_MEMBERS]; MAX_MEMBERS]; MAX_BRANCHES],
            by_q: [[[0.0; MAX_MEMBERS]; 2]; MAX_BRANCHES],
            q_rates: self.sum.rate.map(|mu| length * mu),
            q_weights: [0.0; 2],
            count: self.count,
            length,
            negligible,
        };
        for n in 0..self.count {
            for k in 0..MAX_MEMBERS {
                for m in 0..MAX_MEMBERS {
                    linear.members[n][m][k] = length * slopes[n].by_member[k][m];
                }
                for mode in 0..2 {
                    let by_q = length * slopes[n].by_driver[k] * self.sum.by_mode[mode];
                    linear.by_q[n][mode][k] = by_q;
                    linear.q_weights[mode] = larger(linear.q_weights[mode], by_q.abs());
                }
            }
        }
        linear
    }

    /// The `q`s of `w` at `t` into the step, in closed form.
    fn set_q(&self, w: &mut Driven, t: f64) {
        for (place, q) in Q.into_iter().zip(self.sum.q(t)) {
            w[place] = q;
        }
    }
}

/// The driven groups' `H J`. Each group's members' rates move with its own deflections
/// ([`GroupInput::rate_slopes`], through the sticking rates too, with their relaxation)
/// and with the `q`s (through the drivers' state, `coupling R`); each `q` moves with
/// itself alone (`mu`). Nothing else: a product is a few small blocks.
struct DrivenLinearPart {
    /// By group, by column: `H d rate_k / d b_m`.
    members: [[Members; MAX_MEMBERS]; MAX_BRANCHES],
    /// By group and `q`: `H d rate_k / d q`.
    by_q: [[Members; 2]; MAX_BRANCHES],
    /// `H mu` by `q`.
    q_rates: [f64; 2],
    /// By `q`, the most a unit of it moves a group's rates over the substep, `max |H d
    /// rate_k / d q|`: what a `q` entry of a series' term counts as
    /// ([`DrivenLinearPart::size`]).
    q_weights: [f64; 2],
    count: usize,
    length: f64,
    negligible: f64,
}

impl LinearPart<DRIVEN> for DrivenLinearPart {
    /// Pair by pair (a group's members, the two `q`s), each read and written whole: the
    /// series feeds each product back in at once, and a pair read across two separate
    /// stores would stall it.
    #[inline(always)]
    fn times(&self, v: &Driven) -> Driven {
        let mut product = [0.0; DRIVEN];
        let q = [v[Q[0]], v[Q[1]]];
        for n in 0..self.count {
            let b = [v[entry(n, 0)], v[entry(n, 1)]];
            let (members, by_q) = (&self.members[n], &self.by_q[n]);
            let pair = [0, 1]
                .map(|k| members[0][k] * b[0] + members[1][k] * b[1] + by_q[0][k] * q[0] + by_q[1][k] * q[1]);
            product[entry(n, 0)..entry(n, MAX_MEMBERS)].copy_from_slice(&pair);
        }
        let q_product = [self.q_rates[0] * q[0], self.q_rates[1] * q[1]];
        product[Q[0]..=Q[1]].copy_from_slice(&q_product);
        product
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn negligible(&self) -> f64 {
        self.negligible
    }

    /// A term's `q` entries count by how much they move the groups' rates
    /// ([`DrivenLinearPart::q_weights`]), not as deflections: a `q` is a time, and
    /// `dq/dt = 1 + mu q` is near one where the deflections move by millimetres a second,
    /// so counted as a deflection its terms would go on long after they no longer move
    /// anything (the series of the start's rates took 9.3 terms on average in the slide
    /// yardstick's combined case, and take 7). What is left of them moves the groups'
    /// rates as little as the terms left of the deflections do. A sliding group's rate
    /// may hardly move with a `q` where its trial force does (its event value, and its
    /// rate once it sticks): there the `q`s end short of their closed form, by at most
    /// 2e-13 s in the slide yardstick's lateral, combined and mixed cases, also with the
    /// steering 5 and 20 times faster, which moves the drivers' sum the groups read by
    /// at most 6e-16. Counting those moves as well cost 2 % more instructions a step.
    #[inline(always)]
    fn size(&self, v: &Driven) -> f64 {
        let deflections: &[f64; DRIVEN - 2] = v[..DRIVEN - 2].try_into().expect("the groups' entries");
        let deflections = largest_size(deflections);
        let q = [0, 1].map(|mode| self.q_weights[mode] * v[Q[mode]].abs());
        larger(larger(deflections, q[0]), q[1])
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::{with_prepared_step, with_settled_slide};
    use crate::physics::friction::{FrictionLaw, SliderState};
    use crate::physics::parameters::STIFF_TREAD;
    use crate::physics::state_space::StateVector;
    use crate::physics::{ModelKind, Parameter, Parameters};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Where the cascade takes a step, it ends where the whole-system path does by the
        /// same kind of method (explicit, or linearly implicit for a stiff slide; each to a
        /// relative 1e-12, here within 1e-10 of the largest state or offset), in the same
        /// modes: DDT sliding laterally or in both directions with either law, from a
        /// slide as the tire meets it, over steps of 0.1 to 20 ms; and the stiff light
        /// tire (Calpha = Ckappa = 1e7, sigma 0.05 m, a load of 50 to 200 N) the same.
        /// What it finds the limits take off the forces at its end is what the outputs'
        /// projections there find, bit for bit.
        #[test]
        fn a_cascade_step_ends_where_the_whole_system_path_does(
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            combined in any::<bool>(),
            stiff_light in any::<bool>(),
            vx in -20.0..20.0f64,
            load_ratio in 0.2..2.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform3(-1.5..1.5f64),
            h in prop::sample::select(vec![1e-4, 1e-3, 5e-3, 2e-2]),
        ) {
            let mut p = Parameters::default().with_model(ModelKind::Ddt).with_friction(law);
            let mut load = load_ratio * p.get(Parameter::NominalLoad);
            if stiff_light {
                for (parameter, value) in STIFF_TREAD {
                    p.set(parameter, value).unwrap();
                }
                load = 100.0 * load_ratio;
            } else {
                p.set(Parameter::LateralFriction, 0.01).unwrap();
                if combined {
                    p.set(Parameter::LongitudinalFriction, 0.01).unwrap();
                }
            }
            with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
            let stiff = h * step.start_sliding_rate.get() > super::super::STIFF_STEP;
            let (mut x_cascade, mut sliders_cascade) = (x, sliders);
            let carried = step.high_order_found.get();
            let shaped = step.cascade_step(&mut x_cascade, &mut sliders_cascade, h, super::Start::Prepared);
            // A step given up carries nothing of its substeps to the next step: the path
            // that takes it instead decides that, as it does from a restored state.
            if shaped.is_none() {
                prop_assert_eq!(step.high_order_found.get(), carried);
            }
            prop_assume!(shaped.is_some());
            // What the limits take off the sticking forces at the end, where the step's
            // last evaluation was there: the outputs' own projections there, the same bits.
            if let Some(Some(shaped)) = shaped {
                prop_assert_eq!(shaped.changes, step.damper_force_changes(&x_cascade, &sliders_cascade));
                // And within rounding of the whole system's projections there.
                let (whole, _) = step.whole_system_limit_changes(&step.layout.pack(&x_cascade, &sliders_cascade));
                let limit = step.limits.0.iter().fold(0.0_f64, |m, &l| m.max(l));
                for (a, b) in shaped.changes.iter().zip(&whole) {
                    prop_assert!((a - b).abs() <= 1e-9 * limit, "{a} vs the whole system's {b}");
                }
            }
            let (mut x_whole, mut sliders_whole) = (x, sliders);
            step.stiff.set(stiff);
            step.exponential_declined.set(false);
            step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h).expect("a valid step");
            prop_assert_eq!(sliders_cascade.sliding, sliders_whole.sliding);
            let values = |x: &StateVector, s: &SliderState| {
                let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
                all.extend(s.offsets.iter().flatten());
                all
            };
            let (cascade, whole) = (values(&x_cascade, &sliders_cascade), values(&x_whole, &sliders_whole));
            let largest = cascade.iter().chain(&whole).fold(travel, |m, v| m.max(v.abs()));
            for (c, (a, b)) in cascade.iter().zip(&whole).enumerate() {
                prop_assert!(
                    (a - b).abs() <= 1e-10 * largest,
                    "{law:?} combined {combined} stiff {stiff}, value {c}: {a} vs {b} (largest {largest})"
                );
            }
            Ok(())
            })?;
        }

        /// The point a step's end is shaped at ([`SlidingStep::end_point`], made from its
        /// pieces) is, bit for bit, where the states and offsets the step writes there pack
        /// to again ([`SlidingStep::point_of`]), as the outputs are made on demand: DDT with
        /// either law, sliding laterally or in both directions, the driven groups anywhere
        /// within twice the elastic travel of their start.
        #[test]
        fn a_steps_end_is_shaped_where_its_states_and_offsets_pack_to(
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            combined in any::<bool>(),
            vx in -20.0..20.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform3(-1.5..1.5f64),
            moves in prop::array::uniform8(-2.0..2.0f64),
        ) {
            let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
            let load = p.get(Parameter::NominalLoad);
            with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                let cascade = step.cascade().expect("DDT's slots form a cascade");
                let z = step.layout.pack(&x, &sliders);
                let drives = step.input_rates();
                let sum = super::DriverSum::at(step.layout.model_state(&z, cascade.driver_state));
                let groups = super::DrivenGroups::new(step, cascade, (sliders.sliding, &drives), &sum)
                    .expect("driven groups");
                let mut u = groups.start(&z);
                for (n, slot) in groups.slots().enumerate() {
                    for m in slot.law.members() {
                        u[super::entry(n, m)] += moves[super::entry(n, m)] * travel;
                    }
                }
                let made = step.end_point(cascade, &groups, (&z, &u));
                let (mut end, mut x_end, mut sliders_end) = (z, x, sliders);
                step.whole_end(cascade, (&mut end, &sliders.sliding), &u, (&mut x_end, &mut sliders_end));
                let packed = step.point_of(cascade, &groups, &step.layout.pack(&x_end, &sliders_end));
                let bits = |values: &[f64]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                prop_assert_eq!(bits(&made.driven), bits(&packed.driven));
                prop_assert_eq!(bits(&made.drivers[..step.layout.branches]), bits(&packed.drivers[..step.layout.branches]));
                prop_assert_eq!(made.driver_state.to_bits(), packed.driver_state.to_bits());
                Ok(())
            })?;
        }
    }

    /// Where a group changes mode within a step, the cascade takes the step in the modes
    /// the whole-system path ends in, and ends within 1e-10 of the largest state or offset
    /// where it does (the count of such steps: at least one).
    fn changes_of_mode_agree(
        group: crate::physics::friction::Group,
        cases: impl Iterator<Item = ([f64; 3], [f64; 3])>,
    ) -> usize {
        changes_of_mode_agree_at(group, 10.0, cases)
    }

    /// [`changes_of_mode_agree`] at the speed `vx`.
    fn changes_of_mode_agree_at(
        group: crate::physics::friction::Group,
        vx: f64,
        cases: impl Iterator<Item = ([f64; 3], [f64; 3])>,
    ) -> usize {
        let mut p = Parameters::default()
            .with_model(ModelKind::Ddt)
            .with_friction(FrictionLaw::Brush);
        p.set(Parameter::LateralFriction, 0.01).unwrap();
        let load = p.get(Parameter::NominalLoad);
        let mut changed = 0;
        for (states, inputs) in cases {
            with_prepared_step(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                let h = 1e-3;
                let (mut x_cascade, mut sliders_cascade) = (x, sliders);
                let taken =
                    step.cascade_step(&mut x_cascade, &mut sliders_cascade, h, super::Start::Prepared);
                let g = group as usize;
                if taken.is_none() || sliders_cascade.sliding[g] == sliders.sliding[g] {
                    return;
                }
                changed += 1;
                let (mut x_whole, mut sliders_whole) = (x, sliders);
                step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h)
                    .expect("a valid step");
                assert_eq!(
                    sliders_cascade.sliding, sliders_whole.sliding,
                    "{states:?} {inputs:?}"
                );
                let values = |x: &StateVector, s: &SliderState| {
                    let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
                    all.extend(s.offsets.iter().flatten());
                    all
                };
                let (cascade, whole) = (
                    values(&x_cascade, &sliders_cascade),
                    values(&x_whole, &sliders_whole),
                );
                let largest = cascade.iter().chain(&whole).fold(travel, |m, v| m.max(v.abs()));
                for (c, (a, b)) in cascade.iter().zip(&whole).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-10 * largest,
                        "{states:?} {inputs:?} value {c}: {a} vs {b} (largest {largest})"
                    );
                }
            });
        }
        changed
    }

    /// A step from a restored state (its modes decided at its start) goes on bit for bit
    /// as a step from the end of the last one does (prepared with the modes its outputs
    /// decided there), also where a driven group is on its limit to rounding, which the
    /// cascade leaves to the whole-system path, and where the whole system's trial forces
    /// (rounded otherwise) would decide its mode otherwise: DDT with either law, sliding
    /// laterally and in both directions, a lateral branch's offset set where its mode
    /// changes by the cascade's decision and by the whole system's, steps of 1 and 20 ms.
    #[test]
    fn a_step_from_a_restored_state_at_a_limit_goes_on_as_a_prepared_one() {
        let mut decided_otherwise = 0;
        for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
            for combined in [false, true] {
                let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
                let load = p.get(Parameter::NominalLoad);
                for (k, vx) in (0..8).zip([10.0, -5.0, 0.5, 20.0].into_iter().cycle()) {
                    let states = [0.3 * k as f64 - 0.6, 0.5, -0.2 * k as f64];
                    let inputs = [0.0, 0.2 - 0.05 * k as f64, 0.1];
                    decided_otherwise +=
                        with_settled_slide(&p, (vx, load), (&states, inputs), |step, x, sliders, travel| {
                            let driven = step.cascade().expect("DDT's slots form a cascade").driven_count;
                            (0..driven)
                                .flat_map(|n| (0..2).map(move |m| (n, m)))
                                .map(|member| {
                                    on_a_limit_restored_and_prepared_agree(step, (x, sliders), travel, member)
                                })
                                .sum::<usize>()
                        });
                }
            }
        }
        assert!(
            decided_otherwise > 0,
            "no start where the whole system decides otherwise"
        );
    }

    /// [`a_step_from_a_restored_state_at_a_limit_goes_on_as_a_prepared_one`] from one
    /// settled slide: how many of its starts the whole system's trial forces decide
    /// otherwise than the cascade's.
    fn on_a_limit_restored_and_prepared_agree(
        step: &super::SlidingStep,
        (x, sliders): (StateVector, SliderState),
        travel: f64,
        (n, m): (usize, usize),
    ) -> usize {
        let cascade = step.cascade().expect("DDT's slots form a cascade");
        let slot = step.slots()[cascade.driven().nth(n).expect("a driven group")];
        if m >= slot.law.count {
            return 0;
        }
        let (d, i) = (slot.law.direction[m], slot.branch);
        let with_offset = |offset: f64| {
            let mut s = sliders;
            s.offsets[d][i] = offset;
            s
        };
        // The branch's mode by the cascade's decision (the outputs'), and by the whole
        // system's (preparing from its trial forces).
        let by_cascade =
            |offset: f64| step.limit_changes(&x, &with_offset(offset)).1[slot.group][slot.branch];
        let by_whole_system = |offset: f64| {
            let mut s = with_offset(offset);
            step.prepare(&mut x.clone(), &mut s);
            s.sliding[slot.group][slot.branch]
        };
        // Where each changes along the offset: bracketed, then halved down to two
        // neighbouring values.
        let start = sliders.offsets[d][i];
        let Some(bracket) = (1..=40).map(|k| k as f64 * 0.25 * travel).find_map(|reach| {
            [start - reach, start + reach]
                .into_iter()
                .find(|&o| by_cascade(o) != by_cascade(start))
                .map(|o| if by_cascade(start) { (o, start) } else { (start, o) })
        }) else {
            return 0;
        };
        let change = |sliding: &dyn Fn(f64) -> bool| {
            let (mut inside, mut outside) = bracket;
            for _ in 0..2000 {
                let middle = 0.5 * (inside + outside);
                if middle == inside || middle == outside {
                    break;
                }
                if sliding(middle) {
                    outside = middle;
                } else {
                    inside = middle;
                }
            }
            [inside, outside]
        };
        let mut offsets = change(&by_cascade).to_vec();
        offsets.extend(change(&by_whole_system));
        let decided_otherwise = offsets
            .iter()
            .filter(|&&o| by_cascade(o) != by_whole_system(o))
            .count();
        for offset in offsets {
            let at = with_offset(offset);
            for h in [1e-3, 2e-2] {
                // Restored: the modes decided at the step's start.
                let (mut x_restored, mut restored) = (x, at);
                let restored_end = step.prepare_and_integrate(&mut x_restored, &mut restored, h);
                // Prepared with the modes the outputs there decide.
                let (mut x_prepared, mut prepared) = (x, at);
                let (_, preparation) =
                    step.prepare_with_damper_force_changes(&mut x.clone(), &mut at.clone());
                step.prepare_from(
                    &mut prepared,
                    &preparation.expect("the cascade decides the modes"),
                );
                let prepared_end = step.integrate(&mut x_prepared, &mut prepared, h);
                assert_eq!(restored_end.is_ok(), prepared_end.is_ok(), "{offset} at {h} s");
                let bits = |x: &StateVector, s: &SliderState| {
                    let mut all: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
                    all.extend(s.offsets.iter().flatten().map(|v| v.to_bits()));
                    (all, s.sliding)
                };
                assert_eq!(
                    bits(&x_restored, &restored),
                    bits(&x_prepared, &prepared),
                    "offset {offset} (branch {i}), step {h} s"
                );
            }
        }
        decided_otherwise
    }

    /// A yaw branch (a driver) that reaches its limit within a step splits the cascade's
    /// step there, in closed form. The yaw deflections start about their limit, the steer
    /// rates move them across it; the lateral branches slide (muY 0.01).
    #[test]
    fn a_driver_that_reaches_its_limit_splits_the_step() {
        let cases = [-0.5, -0.1, 0.1, 0.5].into_iter().flat_map(|steer_rate| {
            (-20..=20).map(move |k| ([0.002 * f64::from(k), 0.3, 0.05], [0.05, steer_rate, 0.01]))
        });
        let changed = changes_of_mode_agree(crate::physics::friction::Group::Yaw, cases);
        assert!(changed > 0, "no step had a yaw branch change mode");
    }

    /// A lateral and longitudinal branch pair (a driven group) that reaches its limit
    /// within a step changes mode where its course crosses its event, found by exprb42's
    /// substeps. The lateral deflections start about the lateral limit (1/80 of the
    /// travel), the lateral speeds move them across it.
    #[test]
    fn a_driven_group_that_reaches_its_limit_changes_mode_within_the_step() {
        let cases = [-0.2, -0.05, -0.01, 0.01, 0.05, 0.2].into_iter().flat_map(|vy| {
            (-50..=50).map(move |k| {
                (
                    [0.0, 0.0125 * (1.0 + 0.002 * f64::from(k)), 0.001],
                    [vy, 0.0, 0.0],
                )
            })
        });
        let changed = changes_of_mode_agree(crate::physics::friction::Group::Planar, cases);
        assert!(changed > 0, "no step had a planar group change mode");
    }

    /// The rest of a step in equal pieces: no piece longer than allowed, as few as that
    /// takes, and a rest a rounding past a whole number of pieces is that number.
    #[test]
    fn the_rest_is_cut_into_as_few_equal_pieces_as_allowed() {
        use super::{in_equal_pieces, pieces_of};
        for (rest, allowed, pieces) in [
            (1e-3, 2e-3, 1.0),
            (1e-3, 1e-3, 1.0),
            (1e-3, 0.5e-3, 2.0),
            (1e-3, 0.49e-3, 3.0),
            (1e-3, 0.999e-3, 2.0),
            (0.3, 0.1, 3.0),
            (1e-3, 1e-3 / 3.0, 3.0),
        ] {
            assert_eq!(
                pieces_of(rest, allowed),
                pieces,
                "{rest} in pieces of at most {allowed}"
            );
            let piece = in_equal_pieces(rest, allowed);
            assert!(
                piece <= allowed * (1.0 + 1e-15),
                "{rest}: {piece} longer than {allowed}"
            );
            assert!(
                (piece * pieces - rest).abs() <= 1e-15 * rest,
                "{rest}: {pieces} x {piece}"
            );
        }
        // A rest a rounding past three pieces is three, not four.
        let allowed = 0.1;
        let rest = 3.0 * allowed * (1.0 + 2.0 * f64::EPSILON);
        assert_eq!(pieces_of(rest, allowed), 3.0);
    }

    /// An end prepares the next step's modes only where every group is in the mode that
    /// deciding there finds: each event value below zero (none is, for a missing group).
    #[test]
    fn an_end_past_an_event_within_the_tolerance_prepares_nothing() {
        use super::super::{EVENT_TOLERANCE, NO_EVENT};
        use super::ends_decided;
        let mut events =
            [[NO_EVENT; crate::physics::friction::MAX_BRANCHES]; crate::physics::friction::Group::COUNT];
        assert!(ends_decided(&events));
        events[0][1] = -1e-3;
        assert!(ends_decided(&events));
        // Within the tolerance past its event, still in its mode: deciding there finds the other.
        events[1][2] = 0.5 * EVENT_TOLERANCE;
        assert!(!ends_decided(&events));
        // On the limit: a sliding group's utilisation is one, which decides sticking.
        events[1][2] = 0.0;
        assert!(!ends_decided(&events));
        events[1][2] = f64::NAN;
        assert!(!ends_decided(&events));
    }

    /// A yaw branch (a driver) that reaches its limit within a step at standstill and
    /// rolling backwards splits the cascade's step there too: the closed form's crossing
    /// (the deflection where the trial force is on its limit, and `q(t)` inverted) holds
    /// where the relaxation rates are those of vx = 0 or of a negative vx, and the step
    /// ends where the whole-system path ends, in its modes (as at 10 m/s, above).
    #[test]
    fn a_driver_that_reaches_its_limit_splits_the_step_at_standstill_and_backwards() {
        for vx in [0.0, -0.5, -10.0] {
            let cases = [-0.5, -0.1, 0.1, 0.5].into_iter().flat_map(|steer_rate| {
                (-20..=20).map(move |k| ([0.002 * f64::from(k), 0.3, 0.05], [0.05, steer_rate, 0.01]))
            });
            let changed = changes_of_mode_agree_at(crate::physics::friction::Group::Yaw, vx, cases);
            assert!(changed > 0, "vx {vx}: no step had a yaw branch change mode");
        }
    }

    /// The states and branch offsets of a step's end, for comparing ends.
    fn end_values(x: &StateVector, sliders: &SliderState) -> Vec<f64> {
        let mut all: Vec<f64> = x.as_slice()[..3].to_vec();
        all.extend(sliders.offsets.iter().flatten());
        all
    }

    /// The largest difference between two ends' values, relative to the largest of them
    /// (or the elastic `travel`, where that is larger).
    fn end_difference(a: &[f64], b: &[f64], travel: f64) -> f64 {
        let largest = a.iter().chain(b).fold(travel, |m, v| m.max(v.abs()));
        a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / largest
    }

    /// Several changes of mode within one long step (20 ms): the yaw deflections start up
    /// to 0.06 of the travel either side (past the yaw limits), the steer rates drive them
    /// back through zero, the lateral deflections start about their limit and vy moves
    /// them, so that drivers and driven groups stop and start sliding, some more than once
    /// (the slip reverses within the step). Where the cascade takes such a step it ends in
    /// the modes the whole-system path ends in and within 1e-10 of the largest state or
    /// offset of where it ends (as the single changes above); the changes are counted on a
    /// reference of 80 pieces by the whole-system path, and steps with at least two, and
    /// with at least three, must be among those the cascade took.
    #[test]
    fn several_changes_of_mode_within_a_long_step_end_where_the_whole_system_path_does() {
        let h = 0.02;
        let (mut several, mut three_or_more) = (0, 0);
        for (law, combined) in [
            (FrictionLaw::Coulomb, false),
            (FrictionLaw::Coulomb, true),
            (FrictionLaw::Brush, false),
        ] {
            let mut p = Parameters::default()
                .with_model(ModelKind::Ddt)
                .with_friction(law);
            p.set(Parameter::LateralFriction, 0.01).unwrap();
            if combined {
                p.set(Parameter::LongitudinalFriction, 0.01).unwrap();
            }
            let load = p.get(Parameter::NominalLoad);
            for vx in [3.0, 10.0] {
                for yaw in (-3..=3).map(|k| 0.02 * f64::from(k)) {
                    for lateral in (-3..=3).map(|k| 0.01 * f64::from(k)) {
                        for (steer_rate, vy) in [-0.5, -0.1, 0.1, 0.5]
                            .into_iter()
                            .flat_map(|r| [-0.1, -0.03, 0.03, 0.1].map(|vy| (r, vy)))
                        {
                            let states = [yaw, lateral, 0.001];
                            let inputs = [vy, steer_rate, 0.005];
                            with_prepared_step(
                                &p,
                                (vx, load),
                                (&states, inputs),
                                |step, x, sliders, travel| {
                                    let (mut x_cascade, mut sliders_cascade) = (x, sliders);
                                    let taken = step.cascade_step(
                                        &mut x_cascade,
                                        &mut sliders_cascade,
                                        h,
                                        super::Start::Prepared,
                                    );
                                    if taken.is_none() {
                                        return;
                                    }
                                    let (mut x_fine, mut sliders_fine) = (x, sliders);
                                    let mut changes = 0;
                                    for _ in 0..80 {
                                        let before = sliders_fine.sliding;
                                        step.integrate_by_current_method(
                                            &mut x_fine,
                                            &mut sliders_fine,
                                            h / 80.0,
                                        )
                                        .expect("a valid step");
                                        changes += before
                                            .iter()
                                            .flatten()
                                            .zip(sliders_fine.sliding.iter().flatten())
                                            .filter(|(a, b)| a != b)
                                            .count();
                                    }
                                    let (mut x_whole, mut sliders_whole) = (x, sliders);
                                    step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h)
                                        .expect("a valid step");
                                    let label =
                                        format!("{law:?} combined {combined} vx {vx} {states:?} {inputs:?}");
                                    assert_eq!(sliders_cascade.sliding, sliders_whole.sliding, "{label}");
                                    let difference = end_difference(
                                        &end_values(&x_cascade, &sliders_cascade),
                                        &end_values(&x_whole, &sliders_whole),
                                        travel,
                                    );
                                    assert!(
                                        difference <= 1e-10,
                                        "{label}: {changes} changes, {difference:e}"
                                    );
                                    several += usize::from(changes >= 2);
                                    three_or_more += usize::from(changes >= 3);
                                },
                            );
                        }
                    }
                }
            }
        }
        assert!(
            several > 0 && three_or_more > 0,
            "too few steps with several changes taken: {several} with two or more, {three_or_more} with three or more"
        );
    }

    /// A slide as [`with_settled_slide`] meets it (from `states` under driving `inputs`
    /// held, settled for 20 ms), its cascade step of `h` seconds taken from there by a
    /// step whose friction carries `carried` ([`super::super::HighOrderSubsteps`], as
    /// [`crate::physics::Tire::set_high_order_substeps`] or an FMU state sets it): the end's
    /// values where the cascade takes the step, the lengths it carries to the next step,
    /// and the elastic travel.
    fn settled_cascade_step(
        p: &Parameters,
        (vx, load): (f64, f64),
        (states, inputs): (&[f64; 3], [f64; 3]),
        h: f64,
        carried: super::super::HighOrderSubsteps,
    ) -> (Option<Vec<f64>>, super::super::HighOrderSubsteps, f64) {
        use super::super::{SlidingStep, tire_at};
        use crate::physics::state_space::DrivingVector;
        let (system, mut friction, limits, travel) = tire_at(p, vx, load);
        let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
        let mut x = StateVector::zeros();
        for (k, state) in states.iter().enumerate() {
            x[k] = state * travel;
        }
        let mut sliders = SliderState::AT_REST;
        {
            let step = SlidingStep::new(
                &system,
                &mut friction,
                limits,
                (u, DrivingVector::zeros()),
                travel,
            );
            step.prepare(&mut x, &mut sliders);
            step.integrate(&mut x, &mut sliders, 0.02).expect("a valid step");
        }
        friction.set_high_order_substeps(carried);
        let step = SlidingStep::new(
            &system,
            &mut friction,
            limits,
            (u, DrivingVector::zeros()),
            travel,
        );
        assert_eq!(step.high_order_carried, carried);
        step.prepare(&mut x, &mut sliders);
        let taken = step
            .cascade_step(&mut x, &mut sliders, h, super::Start::Prepared)
            .map(|_| end_values(&x, &sliders));
        (taken, step.high_order_found.get(), travel)
    }

    /// A settled slide's parameters, speed and load, states and driving inputs.
    type SettledSlide = (Parameters, (f64, f64), [f64; 3], [f64; 3]);

    /// Settled DDT slides, laterally (muY 0.01) and in both directions (muX = muY = 0.01),
    /// with either law, at 10 and -10 m/s, from a few starts and inputs: for each, its
    /// parameters, speed and load, states and inputs.
    fn settled_slides() -> Vec<SettledSlide> {
        let mut cases = Vec::new();
        for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
            for combined in [false, true] {
                let p = super::super::slide_parameters(ModelKind::Ddt, law, combined);
                let load = p.get(Parameter::NominalLoad);
                for vx in [10.0, -10.0] {
                    for (states, inputs) in [
                        ([0.2, 0.5, 0.3], [0.1, 0.05, 0.01]),
                        ([-0.4, 0.1, -0.6], [-0.05, 0.02, -0.02]),
                        ([0.0, -0.8, 0.2], [0.3, -0.1, 0.05]),
                        ([0.5, 0.5, 0.5], [-0.2, 0.3, -0.1]),
                    ] {
                        cases.push((p.clone(), (vx, load), states, inputs));
                    }
                }
            }
        }
        cases
    }

    /// A carried first substep shorter than the step: the length the same step found
    /// with nothing carried (as the next step would carry it), nine tenths of it, and a
    /// third, 0.45 and 0.7 of the step. The step's first exprb42 substep is that length
    /// in equal pieces of the step (`in_equal_pieces`: three, three and two pieces for the
    /// shares), and the step, taken by the cascade, ends where the same step with nothing
    /// carried ends (by the cascade too), within 1e-10 of the largest state or offset:
    /// the carried length is the error control's first try, which moves the end by no
    /// more than the tolerance. (Some ends differ in their bits: the carried length was
    /// used, not ignored.)
    #[test]
    fn a_carried_first_substep_shorter_than_the_step_ends_where_nothing_carried_does() {
        let (mut compared, mut differing) = (0, 0);
        for (p, point, states, inputs) in settled_slides() {
            for h in [1e-3, 2e-3] {
                let (nothing, found, travel) =
                    settled_cascade_step(&p, point, (&states, inputs), h, super::super::NOT_CARRIED);
                let Some(nothing) = nothing else {
                    continue;
                };
                for (share, pieces) in [(1.0 / 3.0, 3.0), (0.45, 3.0), (0.7, 2.0)] {
                    assert_eq!(super::in_equal_pieces(h, share * h), h / pieces);
                }
                let lengths = [found[0], 0.9 * found[0], h / 3.0, 0.45 * h, 0.7 * h];
                for carried in lengths.into_iter().filter(|&length| length < h) {
                    let label = format!(
                        "{:?} {point:?} {states:?} {inputs:?} h {h} carried {carried}",
                        p.friction
                    );
                    let (with_carried, ..) =
                        settled_cascade_step(&p, point, (&states, inputs), h, [carried, f64::INFINITY]);
                    let Some(with_carried) = with_carried else {
                        continue;
                    };
                    compared += 1;
                    differing += usize::from(with_carried != nothing);
                    let difference = end_difference(&nothing, &with_carried, travel);
                    assert!(difference <= 1e-10, "{label}: {difference:e}");
                }
            }
        }
        assert!(
            compared > 0 && differing > 0,
            "{compared} steps compared, {differing} differing"
        );
    }

    /// A carried first substep so short that the step would need more pieces than it may
    /// take ([`super::MAX_SUBSTEPS`]: a length from a far shorter step) tells the step
    /// nothing: it is ignored and the whole step tried first, so the cascade still takes
    /// every step it takes with nothing carried (were the length used, the step would
    /// need more substeps than allowed and be given up), and ends where that step does:
    /// within 1e-10 of the largest state or offset, and, ignored as if none were carried,
    /// in the same bits.
    #[test]
    fn a_carried_first_substep_too_short_for_the_step_is_ignored() {
        let mut compared = 0;
        for (p, point, states, inputs) in settled_slides() {
            for h in [1e-3, 2e-3] {
                let (nothing, _, travel) =
                    settled_cascade_step(&p, point, (&states, inputs), h, super::super::NOT_CARRIED);
                let Some(nothing) = nothing else {
                    continue;
                };
                for pieces in [super::MAX_SUBSTEPS as f64 + 0.5, 20.0, 1e3] {
                    let carried = h / pieces;
                    let label = format!(
                        "{:?} {point:?} {states:?} {inputs:?} h {h} carried {carried}",
                        p.friction
                    );
                    let (with_carried, ..) =
                        settled_cascade_step(&p, point, (&states, inputs), h, [carried, f64::INFINITY]);
                    let with_carried = with_carried.unwrap_or_else(|| panic!("{label}: given up"));
                    compared += 1;
                    let difference = end_difference(&nothing, &with_carried, travel);
                    assert!(difference <= 1e-10, "{label}: {difference:e}");
                    // Ignored as if none were carried: the same substeps, the same bits.
                    assert!(
                        with_carried == nothing,
                        "{label}: not the same bits ({difference:e})"
                    );
                }
            }
        }
        assert!(
            compared > 0,
            "no step was taken by the cascade with nothing carried"
        );
    }

    /// SPEC 7, with a carried length: a DDT tire sliding in both directions (muX = muY =
    /// 0.01, either law) under the slide yardstick's inputs in 2 ms steps, its states,
    /// branches, inputs and carried substep lengths saved every tenth step where the
    /// cascade's first substep length is carried (finite), continues bit for bit when
    /// they are restored (as `Instance::restore` restores an FMU state) onto a fresh tire
    /// and onto one that has been stepping elsewhere: its states, outputs and carried
    /// lengths after each of the next ten steps, under the yardstick's inputs, and under
    /// the saved inputs held (where the saved tire starts each step from what its last
    /// step's outputs prepared, which the state does not hold, and the restored one
    /// decides the modes anew). Restored without the carried lengths, some continue
    /// otherwise: the lengths are in play here.
    #[test]
    fn a_restored_state_with_a_carried_length_continues_bit_for_bit() {
        use crate::physics::Tire;
        let h = 2e-3;
        let inputs_at = |k: usize| {
            let t = k as f64 * h;
            [10.0, 0.1 * t.sin(), 0.05 * t.cos(), 0.01 * t.sin(), 50_000.0]
        };
        let (mut restores, mut without_differs) = (0, 0);
        for law in [FrictionLaw::Coulomb, FrictionLaw::Brush] {
            let p = super::super::slide_parameters(ModelKind::Ddt, law, true);
            let mut other = Tire::new(p.clone()).unwrap();
            for j in 0..50 {
                other.set_inputs([-5.0, 0.2, -0.1, 0.02, 30_000.0 + 100.0 * j as f64]);
                other.step(h).unwrap();
            }
            let mut tire = Tire::new(p.clone()).unwrap();
            for k in 0..100 {
                tire.set_inputs(inputs_at(k));
                tire.step(h).unwrap();
                let carried = tire.high_order_substeps();
                if k % 10 != 9 || !carried[0].is_finite() {
                    continue;
                }
                let (states, sliders, inputs) =
                    (tire.states().to_vec(), *tire.sliders().unwrap(), tire.inputs());
                let restore = |onto: &Tire, lengths: Option<super::super::HighOrderSubsteps>| {
                    let mut restored = onto.clone();
                    restored.set_states(&states).unwrap();
                    restored.set_sliders(&sliders).unwrap();
                    if let Some(lengths) = lengths {
                        restored.set_high_order_substeps(lengths);
                    }
                    restored.set_inputs(inputs);
                    restored
                };
                for held in [false, true] {
                    let run = |mut tire: Tire| -> Vec<u64> {
                        let mut bits = Vec::new();
                        for j in k + 1..k + 11 {
                            tire.set_inputs(if held { inputs } else { inputs_at(j) });
                            tire.step(h).unwrap();
                            bits.extend(tire.states().iter().map(|v| v.to_bits()));
                            bits.extend(tire.outputs().iter().map(|v| v.to_bits()));
                            bits.extend(tire.high_order_substeps().map(f64::to_bits));
                        }
                        bits
                    };
                    let first = run(tire.clone());
                    let fresh = Tire::new(p.clone()).unwrap();
                    for (name, onto) in [("fresh", &fresh), ("other", &other)] {
                        restores += 1;
                        assert!(
                            run(restore(onto, Some(carried))) == first,
                            "{law:?}, saved after step {k} (carrying {carried:?}), held {held}: the {name} tire continues otherwise"
                        );
                    }
                    without_differs += usize::from(run(restore(&fresh, None)) != first);
                }
            }
        }
        assert!(
            restores > 0 && without_differs > 0,
            "{restores} restores, {without_differs} continuing otherwise without the carried lengths"
        );
    }
}
