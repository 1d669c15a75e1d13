//! A step in which a branch slides, or may start to: the model's states and every branch
//! deflection integrated together, piece by piece between stick/slide events. (Where
//! every branch moves on its own, [`super::separable`] takes the step branch by branch.)
//!
//! Within a piece every group keeps its mode, so the right-hand side is smooth, and over
//! a millisecond nearly linear. Where no event is near, a substep is an exponential
//! Rosenbrock step (exprb43): the linear part exact, the small remainder to fourth
//! order, three evaluations ([`exponential`]). Where a force turns on its ellipse within
//! the substep (a slide in two directions), or that step comes back too long twice in a
//! row, the eighth-order Runge-Kutta pair of Dormand and Prince takes it: twelve
//! evaluations ([`dormand_prince`]). Near an event, or where both come back too long
//! twice in a row (then for the rest of the step), it is integrated by
//! Gragg-Bulirsch-Stoer extrapolation (modified midpoint rule, polynomial extrapolation
//! in h^2), whose samples locate events; all to a relative 1e-12. A substep whose rows
//! stop converging is shortened, not left to a row that agrees with its neighbour by
//! chance. A step that the explicit method cannot finish
//! within a few hundred substeps (a stiff tire at a light load sliding on its ellipse
//! turns its force within microseconds; a light load makes the tire's own relaxation
//! that fast) is taken again from its start by linearly implicit Euler extrapolation,
//! which is stable at any stiffness. Every step the explicit method finishes is its
//! result, unchanged. Where the event values and their rates at the start of a substep
//! predict a crossing within it (a straight line), the substep ends there; if it ends a
//! little short of the crossing or past it, a few short steps on or back (a Taylor
//! polynomial with the rates' change over the substep, or Heun's), each within the
//! tolerance by its own error estimate, reach it. Otherwise, after each
//! substep the groups' event values are checked; where one crosses zero, the crossing
//! time is found by Newton's method on the accurate solution, kept in a bracket by regula
//! falsi (Illinois). Either way the state is taken there, the group changes mode, and
//! integration goes on. A spring group that slides is kept on its ellipse to
//! rounding after every substep, so the ellipse is never exceeded.
//!
//! The result is a function of the states, inputs and step size, and of how long the
//! last step's first two substeps by the eighth-order pair could have been
//! ([`HighOrderSubsteps`], carried in the friction state and the FMU state), so a
//! restored FMU state continues bit-identically.
//!
//! Where the groups form a cascade (DDT: the yaw branches drive the lateral ones and
//! nothing drives them) and none changes mode, [`cascade`] takes the step first: the
//! drivers in closed form, the driven groups by an integration of their own
//! (exponential, or linearly implicit for a stiff slide).
//!
//! Where no branch can carry a force (every limit zero), the tire is linear again:
//! [`frictionless`] takes the step by its exact map.
//!
//! Here: the coupled system's rates and event values, and the loop over pieces;
//! [`layout`]: where each state and branch deflection sits in the coupled vector, and
//! the groups' slots; [`modes`]: which groups stick and which slide (at a step's start,
//! or an importer's event), the damped forces' limits in the outputs, and the rates in
//! the modes that Model Exchange exposes; [`extrapolation`]: one substep, and the
//! extrapolated one; [`exponential`]: the exponential one; [`dormand_prince`]: the
//! eighth-order one; [`implicit`]: one substep of a stiff piece; [`events`]: where
//! within a substep a group changes mode; [`cascade`]: the cascade's step.

// Groups and branches index several arrays together (modes, events, offsets).
#![allow(clippy::needless_range_loop)]
mod cascade;
mod course;
mod dormand_prince;
mod events;
mod exponential;
mod extrapolation;
mod frictionless;
mod implicit;
mod layout;
mod modes;

pub use layout::SlidingSlots;
use layout::{Layout, Slot};
pub use modes::{LimitChanges, Preparation, ShapedEnd};

use std::cell::Cell;

use super::group::{GroupInput, GroupOutput, MAX_TOGETHER, ReturnRates, evaluate_together};
use super::{Direction, EVENT_TOLERANCE, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateSpace, StateVector};
use events::{MAX_CHANGES_AT_AN_INSTANT, first_past_tolerance};
use extrapolation::{End, SHORTER, Toward};

/// `$call` with `$e` the entry count `$size` rounded up to even (4 to 12), or [`SIZE`]:
/// a substep's arrays of that many entries, so that its loops have a known length.
macro_rules! by_entry_count {
    ($size:expr, $e:ident => $call:expr) => {
        match $size {
            0..=4 => {
                const $e: usize = 4;
                $call
            }
            5..=6 => {
                const $e: usize = 6;
                $call
            }
            7..=8 => {
                const $e: usize = 8;
                $call
            }
            9..=10 => {
                const $e: usize = 10;
                $call
            }
            11..=12 => {
                const $e: usize = 12;
                $call
            }
            _ => {
                const $e: usize = SIZE;
                $call
            }
        }
    };
}
use by_entry_count;

/// Room for the coupled vector: the model's states, then the branch deflections.
const SIZE: usize = MAX_STATES + Direction::COUNT * MAX_BRANCHES;
type Vector = [f64; SIZE];

/// At most this many substeps and events per step: a safeguard against a step that makes
/// no progress, not a limit on valid tires. A step usually takes a handful; a long step of
/// an extreme tire (a load of a few newtons on a tread of 1e8 N/m for seconds) takes up to
/// about 1e5, a fraction of a second of CPU.
const MAX_SUBSTEPS: usize = 1_000_000;

/// The substeps and events the explicit method may take beyond two per longest substep
/// before a step goes to the stiff method.
const EXPLICIT_MARGIN: usize = 64;

/// The most substeps the explicit method may take in one step. Where the tire's own
/// dynamics are fast against the step (a light load shortens the relaxation lengths, so
/// their rates reach 1e6/s), the explicit method would need two substeps per longest
/// substep, up to millions; the stiff method is stable at any substep length and takes a
/// few per time scale of the motion instead.
const EXPLICIT_CAP: usize = 256;

/// A substep to a predicted event no longer than this fraction of the longest substep
/// (`SHORT / 4` of the fastest time constant) is tried by Kutta's third-order step first
/// ([`SlidingStep::substep`]): a stick that ends within microseconds of the step's
/// start, as a rising load makes every sliding branch do.
const SHORT: f64 = 0.01;

/// A step longer than this many time constants of its fastest sliding group
/// ([`GroupInput::sliding_rate`]) goes to the stiff method at once: the explicit one, whose
/// substeps stay below two of them, would need more than eight substeps for stability
/// alone, where the stiff one takes a few. (A millisecond step of a tire at its nominal
/// load is below 4, and stays explicit.)
const STIFF_STEP: f64 = 16.0;

type Modes = [[bool; MAX_BRANCHES]; Group::COUNT];
/// Mode changes by group and branch at the current instant.
type Changes = [[u32; MAX_BRANCHES]; Group::COUNT];
/// Event values by group and branch.
pub type Events = [[f64; MAX_BRANCHES]; Group::COUNT];
/// The event value of a group or branch that does not exist: it never crosses.
pub const NO_EVENT: f64 = f64::NEG_INFINITY;

/// The coupled system of one step: the model at its operating point with held or ramped
/// driving inputs, and its branches at the step's limits.
pub struct SlidingStep<'a> {
    pub system: &'a StateSpace,
    pub friction: &'a Friction,
    pub limits: Limits,
    pub inputs: DrivingVector,
    pub input_rates: DrivingVector,
    /// The deflection scale of the error tolerance ([`SlidingStep::deflection_scale`]).
    scale: f64,
    layout: &'a Layout,
    /// Each group and branch with a member ([`SlidingSlots`]).
    slots: &'a [Slot],
    /// Whether every slot's group is damped.
    all_damped: bool,
    /// The slots' cascade, where they form one ([`cascade`]).
    cascade: Option<&'a cascade::Cascade>,
    /// Whether substeps are linearly implicit ([`implicit`]): for a step the explicit
    /// method could not finish. Event location integrates by the same method as the
    /// substeps it searches.
    stiff: Cell<bool>,
    /// Whether exponential substeps of this step came back too long twice in a row, or a
    /// force turns on its ellipse within one ([`exponential`]): the piece is further from
    /// linear than its fourth order takes, and the eighth-order pair or the
    /// extrapolation takes the rest of the step.
    exponential_declined: Cell<bool>,
    /// Whether substeps of this step by the eighth-order pair came back too long twice in
    /// a row ([`dormand_prince`]): the extrapolation takes the rest of the step.
    high_order_declined: Cell<bool>,
    /// Exponential substeps that came back too long in a row.
    exponential_misses: Cell<u8>,
    /// Substeps by the eighth-order pair that came back too long in a row.
    high_order_misses: Cell<u8>,
    /// How long the pair's first two substeps may be, as the last sliding step found
    /// ([`HighOrderSubsteps`]).
    high_order_carried: HighOrderSubsteps,
    /// The same as this step finds them, as its substeps by the pair are accepted
    /// ([`SlidingStep::high_order_substeps`]; infinite until then).
    high_order_found: Cell<HighOrderSubsteps>,
    /// The length a substep just taken by the pair could have had, until the step accepts
    /// it ([`SlidingStep::high_order_substep_accepted`]).
    high_order_pending: Cell<Option<f64>>,
    /// How fast the groups found sliding at the start move their forces, 1/s
    /// ([`GroupInput::sliding_rate`], the fastest; made by [`SlidingStep::prepare`]).
    start_sliding_rate: Cell<f64>,
}

/// The coupled vector whose entry `c` is `entry(c)`, every entry: a sum of vectors over
/// the entries in use leaves those past them zero (each vector's are), so they are
/// summed whole, not copied from one and then added to entry by entry (a copy of a whole
/// vector is a call, and the stores one by one after it stall the next wide read).
#[inline(always)]
pub(super) fn made_whole(entry: impl Fn(usize) -> f64) -> Vector {
    let mut made = [0.0; SIZE];
    for (c, value) in made.iter_mut().enumerate() {
        *value = entry(c);
    }
    made
}

/// A substep by a method that came back too long (`misses` in a row before it, kept in
/// the step): the factor to try it again by, shorter; after the second miss in a row
/// the method is `declined` for the rest of the step and `None`.
fn retry_shorter(misses: &Cell<u8>, declined: &Cell<bool>, factor: f64) -> Option<f64> {
    let missed = misses.get() + 1;
    misses.set(missed);
    if missed < 2 {
        return Some(factor);
    }
    declined.set(true);
    None
}

/// Why the integration gave up (the tire is left unchanged).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotConverged;

impl<'a> SlidingStep<'a> {
    /// The step's branches are laid out in `friction`'s [`SlidingSlots`], made anew only
    /// where the limits or the relaxation rates changed since its last sliding step.
    pub fn new(
        system: &'a StateSpace,
        friction: &'a mut Friction,
        limits: Limits,
        (inputs, input_rates): (DrivingVector, DrivingVector),
        start_scale: f64,
    ) -> Self {
        friction.lay_out_sliding(system, &limits);
        let high_order_carried = friction.high_order_substeps();
        let friction: &'a Friction = friction;
        let laid_out = &friction.sliding_slots;
        Self {
            system,
            friction,
            limits,
            inputs,
            input_rates,
            scale: Self::deflection_scale(friction, &limits, start_scale),
            layout: &laid_out.layout,
            slots: &laid_out.slots[..laid_out.count],
            all_damped: laid_out.all_damped,
            cascade: laid_out.cascade.as_ref(),
            stiff: Cell::new(false),
            exponential_declined: Cell::new(false),
            high_order_declined: Cell::new(false),
            exponential_misses: Cell::new(0),
            high_order_misses: Cell::new(0),
            high_order_carried,
            high_order_found: Cell::new(NOT_CARRIED),
            high_order_pending: Cell::new(None),
            start_sliding_rate: Cell::new(0.0),
        }
    }

    /// Entries of the coupled vector in use.
    fn size(&self) -> usize {
        self.layout.size
    }

    /// `z + dt * rates`: an explicit Euler step, or a stage's state.
    fn advanced(&self, z: &Vector, rates: &Vector, dt: f64) -> Vector {
        made_whole(|c| z[c] + dt * rates[c])
    }

    fn slots(&self) -> &'a [Slot] {
        self.slots
    }

    /// A slot's group input at deflections `z`, with the model's states `x` and their
    /// rates `x_rates` (whose element rows hold the sticking rate of `U`): each member's
    /// sticking rate is the model's rate of `U` with `b` in its own relaxation term.
    #[inline]
    fn slot_input<'s>(
        &self,
        slot: &'s Slot,
        x: &StateVector,
        x_rates: &StateVector,
        z: &Vector,
    ) -> GroupInput<'s> {
        let mut input = GroupInput::at_rest(&slot.law);
        for m in slot.law.members() {
            let (b, k) = (z[slot.entries[m]], slot.states[m]);
            input.deflection[m] = b;
            input.sticking_rate[m] = x_rates[k] + slot.relaxation[m] * (b - x[k]);
        }
        input
    }

    /// The fastest returns of the sliding spring groups' members to their ellipses at `z`
    /// (1/s, [`GroupInput::return_rates`], each the largest over the groups): the least
    /// is how fast a force sliding in two directions turns on its ellipse (where the
    /// exponential substep is not tried); the largest, the slide's fastest mode (how far
    /// the eighth-order pair reaches).
    fn return_rates(&self, t: f64, z: &Vector, modes: &Modes) -> ReturnRates {
        let x = self.layout.model_states(z);
        let x_rates = self.system.state_rates(&x, &self.inputs_at(t));
        self.slots()
            .iter()
            .filter(|slot| modes[slot.group][slot.branch])
            .map(|slot| self.slot_input(slot, &x, &x_rates, z).return_rates(true))
            .fold(ReturnRates::default(), ReturnRates::max)
    }

    fn inputs_at(&self, t: f64) -> DrivingVector {
        self.inputs + self.input_rates * t
    }

    /// Rates of every entry, and the groups' event values.
    #[inline]
    fn rates(&self, t: f64, z: &Vector, modes: &Modes) -> Evaluation {
        let mut made = UNEVALUATED;
        self.rates_into(t, z, modes, &mut made);
        made
    }

    /// [`SlidingStep::rates`] where every group is of springs (the integration's
    /// evaluation, many times a step), written into `rates` and `events` (every entry):
    /// each slot's spring law ([`crate::physics::friction::group::GroupLaw::spring_rates`])
    /// without the forces and the adjustment of [`SlidingStep::rates_adjusted`], the same
    /// values.
    #[inline(never)]
    fn spring_rates_into(&self, t: f64, z: &Vector, modes: &Modes, (rates, events): &mut Evaluation) {
        let layout = &self.layout;
        let x = layout.model_states(z);
        let x_rates = self.system.state_rates(&x, &self.inputs_at(t));
        rates.fill(0.0);
        for j in 0..layout.free_count {
            rates[j] = x_rates[layout.free[j]];
        }
        *events = [[NO_EVENT; MAX_BRANCHES]; Group::COUNT];
        for slot in self.slots() {
            let input = self.slot_input(slot, &x, &x_rates, z);
            let sliding = modes[slot.group][slot.branch];
            let (rate, event) = slot
                .law
                .spring_rates(&input.deflection, &input.sticking_rate, sliding);
            for m in slot.law.members() {
                rates[slot.entries[m]] = rate[m];
            }
            events[slot.group][slot.branch] = event;
        }
    }

    /// [`SlidingStep::rates`] written into `made` (every entry): where an evaluation's
    /// place is the caller's, a tire of spring groups' 200 bytes are not copied there
    /// (a damped one's still are).
    #[inline]
    fn rates_into(&self, t: f64, z: &Vector, modes: &Modes, made: &mut Evaluation) {
        if self.friction.damped() {
            *made = self.rates_adjusted(t, z, modes, |_, _, _, _| {});
        } else {
            self.spring_rates_into(t, z, modes, made);
        }
    }

    /// [`SlidingStep::rates`], each slot's rates then passed to `adjust` with its group
    /// input and mode (an empty `adjust` compiles away).
    #[inline]
    fn rates_adjusted(
        &self,
        t: f64,
        z: &Vector,
        modes: &Modes,
        mut adjust: impl FnMut(&Slot, &GroupInput, bool, &mut Vector),
    ) -> (Vector, Events) {
        let layout = &self.layout;
        let x = layout.model_states(z);
        let u = self.inputs_at(t);
        let x_rates = self.system.state_rates(&x, &u);
        let mut rates = [0.0; SIZE];
        for j in 0..layout.free_count {
            rates[j] = x_rates[layout.free[j]];
        }
        let mut events = [[NO_EVENT; MAX_BRANCHES]; Group::COUNT];
        let mut write = |slot: &Slot, input: &GroupInput, sliding: bool, out: &GroupOutput| {
            for m in input.members() {
                rates[slot.entries[m]] = out.rate[m];
            }
            events[slot.group][slot.branch] = out.event;
            adjust(slot, input, sliding, &mut rates);
        };
        let slots = self.slots();
        if self.friction.damped() {
            // Damped groups project onto their ellipses by Newton steps: all side by side.
            let mut inputs = [GroupInput::default(); MAX_TOGETHER];
            let mut sliding = [false; MAX_TOGETHER];
            for (j, slot) in slots.iter().enumerate() {
                inputs[j] = self.slot_input(slot, &x, &x_rates, z);
                sliding[j] = modes[slot.group][slot.branch];
            }
            let mut outputs = [GroupOutput::default(); MAX_TOGETHER];
            evaluate_together::<MAX_TOGETHER>(&inputs[..slots.len()], &sliding, &mut outputs);
            for (j, slot) in slots.iter().enumerate() {
                write(slot, &inputs[j], sliding[j], &outputs[j]);
            }
        } else {
            for slot in slots {
                let input = self.slot_input(slot, &x, &x_rates, z);
                let sliding = modes[slot.group][slot.branch];
                write(slot, &input, sliding, &input.evaluate(sliding));
            }
        }
        (rates, events)
    }

    fn events(&self, t: f64, z: &Vector, modes: &Modes) -> Events {
        self.rates(t, z, modes).1
    }

    /// Puts each sliding spring group back on its ellipse (it drifts by rounding).
    fn hold_on_limits(&self, z: &mut Vector, modes: &Modes) {
        if self.all_damped {
            return;
        }
        for slot in self.slots() {
            if !modes[slot.group][slot.branch] || slot.law.damped() {
                continue;
            }
            let utilisation = slot.utilisation(z);
            if utilisation > 0.0 {
                slot.put_on_ellipse(z, utilisation);
            }
        }
    }

    /// Integrates over `h` seconds from `x` and `sliders`; on success both hold the end
    /// of the step, and where the step's last evaluation was at its end, what shapes the
    /// outputs there ([`ShapedEnd`]). By the cascade where it takes the step ([`cascade`]); otherwise
    /// explicitly first. A step the explicit method cannot finish (a stiff slide) is
    /// taken again from its start by the linearly implicit method, and one whose sliding
    /// groups move their forces within a fraction of the step (as
    /// [`SlidingStep::prepare`] found them) is taken by it from the start.
    pub fn integrate(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<Option<ShapedEnd>, NotConverged> {
        self.integrate_from(x, sliders, h, true)
    }

    /// [`SlidingStep::integrate`], trying the cascade first where `by_cascade`.
    fn integrate_from(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
        by_cascade: bool,
    ) -> Result<Option<ShapedEnd>, NotConverged> {
        self.stiff.set(false);
        self.exponential_declined.set(false);
        self.high_order_declined.set(false);
        self.high_order_misses.set(0);
        self.high_order_found.set(NOT_CARRIED);
        self.exponential_misses.set(0);
        if self.frictionless() {
            return self.frictionless_step(x, h).map(|()| None);
        }
        // A sliding group that turns its force far faster than the step (a stiff tire at
        // a light load): the explicit method would crawl.
        let crawls = h * self.start_sliding_rate.get() > STIFF_STEP;
        if by_cascade && let Some(shaped) = self.cascade_step(x, sliders, h, cascade::Start::Prepared) {
            return Ok(shaped);
        }
        if !crawls && self.integrate_by_current_method(x, sliders, h).is_ok() {
            return Ok(None);
        }
        // The explicit substeps were given up: their lengths tell the next step nothing.
        self.high_order_found.set(NOT_CARRIED);
        self.stiff.set(true);
        self.integrate_by_current_method(x, sliders, h).map(|()| None)
    }

    /// [`SlidingStep::prepare`] and [`SlidingStep::integrate`]: where the cascade may
    /// decide the modes at the start itself ([`SlidingStep::cascade_decides`]), it takes
    /// the step from them, and preparing, which would find the same modes, is left to the
    /// steps it does not take.
    pub fn prepare_and_integrate(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<Option<ShapedEnd>, NotConverged> {
        if let Some(shaped) = self.cascade_step(x, sliders, h, cascade::Start::Undecided) {
            return Ok(shaped);
        }
        // Where the cascade decided the modes and gave the step up, it would again from
        // the prepared ones (the same, or a group at its limit, where it gives up). They
        // are prepared as it decided them, by its own equations (preparing moves nothing
        // there): as the outputs at the end of the last step decided them, which a step
        // from there is prepared with, so that a step from a restored state takes the
        // same modes to the last bit (a group at its limit to rounding may be decided
        // otherwise by the whole system's trial forces).
        let tried = self.cascade_decides() && self.cascade_applies();
        if tried {
            self.prepare_with_damper_force_changes(x, sliders);
        } else {
            self.prepare(x, sliders);
        }
        self.integrate_from(x, sliders, h, !tried)
    }

    /// [`SlidingStep::integrate`] by the method [`SlidingStep::stiff`] says.
    fn integrate_by_current_method(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        let mut z = [0.0; SIZE];
        self.layout.pack_into(x, sliders, &mut z);
        let mut modes = sliders.sliding;
        let mut t = 0.0;
        // The midpoint rule's parasitic solution grows where a substep of the finest row
        // is long against the fastest time constant; its error estimate can then miss
        // it (near an equilibrium): substeps stay below a few time constants. The
        // linearly implicit substeps have no such bound: they try the whole step first
        // (a stiff slide is smooth once its force has turned, within microseconds, so one
        // substep usually takes the step), and the error control shortens them.
        let longest = self.longest_substep();
        let mut length = if self.stiff.get() { h } else { h.min(0.5 * longest) };
        let mut changes: Changes = [[0; MAX_BRANCHES]; Group::COUNT];
        // The rates and event values at each substep's start and end, made in place.
        let (mut start_evaluation, mut end_evaluation) = (UNEVALUATED, UNEVALUATED);
        // The explicit method crawls where a group sliding on its ellipse turns its force
        // far faster than anything it knows of (a stiff tire at a light load): past the
        // substeps the step's length needs, and a margin for events (never more than
        // `EXPLICIT_CAP`), or as soon as the substeps the error control allows could not
        // finish within that, the step is handed to the stiff method.
        let budget = if self.stiff.get() {
            MAX_SUBSTEPS
        } else {
            (EXPLICIT_MARGIN as f64 + 2.0 * (h / longest).ceil()).min(EXPLICIT_CAP as f64) as usize
        };
        for substep in 0..budget {
            if t >= h {
                break;
            }
            // The implicit substeps are stable at any length. The explicit ones stay
            // below `longest`: the extrapolated ones for stability, the exponential ones
            // so that their samples of the event values are as close (a limit touched
            // and left again inside a substep shows between them).
            length = length.min(h - t);
            if !self.stiff.get() {
                length = length.min(longest);
            }
            if self.exponential_suited() {
                length = length.min(0.25 * longest);
            }
            // A substep the pair took but the step did not accept whole does not count.
            self.high_order_pending.set(None);
            self.rates_into(t, &z, &modes, &mut start_evaluation);
            let (start_rates, start_events) = (&start_evaluation.0, &start_evaluation.1);
            let start = (start_rates, start_events);
            // A group the motion brings to its event within the substep: the substep ends
            // where its crossing is predicted, so that it locates the crossing itself.
            let planned = length;
            let mut predicted = self.predicted_crossing(t, &z, start, length, &modes, |g, i| {
                changes[g][i] < MAX_CHANGES_AT_AN_INSTANT
            });
            if let Some((at, g, i)) = predicted {
                if at <= 0.0 {
                    self.switch_mode(&mut z, &mut modes, &mut changes, (g, i));
                    continue;
                }
                length = at;
            }
            let toward = match predicted {
                None => Toward::NoEvent,
                Some(_) if length <= SHORT * longest => Toward::NearEvent,
                Some(_) => Toward::Event,
            };
            let ((mut z_end, growth, interior, spacing), end) =
                match self.substep(t, &z, start, &mut length, &modes, toward) {
                    Ok(taken) => taken,
                    Err(shorter) => {
                        length *= shorter;
                        if length <= 1e-15 * h {
                            return Err(NotConverged);
                        }
                        continue;
                    }
                };
            // A substep to the step's end whose end was sampled clear of every event: the
            // end's evaluation would only look for events there.
            if matches!(end, End::Clear) && t + length >= h {
                self.high_order_substep_accepted();
                z = z_end;
                t = h;
                self.hold_on_limits(&mut z, &modes);
                break;
            }
            // A short substep to a sticking spring group's predicted crossing, nothing else
            // near inside it: settled from its last stage, with no evaluation of its end.
            let may_change = |g: usize, i: usize| changes[g][i] < MAX_CHANGES_AT_AN_INSTANT;
            if let End::Staged(stage_rates, stage_events) = &end
                && let Some((_, g, i)) = predicted
                && interior.is_none_or(|(_, ig, ii)| (ig, ii) == (g, i))
                && let Some((dt, z_at)) = self.settle_from_stage(
                    t + length,
                    &z_end,
                    start,
                    (stage_rates, stage_events),
                    (g, i),
                    &modes,
                    (length, h - t - length),
                    may_change,
                )
            {
                z = z_at;
                t += length + dt;
                changes = [[0; MAX_BRANCHES]; Group::COUNT];
                length = planned;
                self.switch_mode(&mut z, &mut modes, &mut changes, (g, i));
                continue;
            }
            self.rates_into(t + length, &z_end, &modes, &mut end_evaluation);
            let (end_rates, end_events) = (&end_evaluation.0, &mut end_evaluation.1);
            // A limit touched and left again inside the substep: end the substep at the
            // sample past the tolerance, if an accurate solution confirms it there.
            if first_past_tolerance(end_events).is_none()
                && let Some((sample, g, i)) = interior
                && start_events[g][i] <= EVENT_TOLERANCE
                // The predicted group nears its limit towards the end, as it should.
                && predicted.is_none_or(|(_, pg, pi)| (pg, pi) != (g, i))
                && let Some(at) = self.touches_near(
                    t,
                    &z,
                    &modes,
                    length,
                    (sample - spacing, sample + spacing),
                    (g, i),
                )
                && let Some(z_at) = self.substep_plain(t, &z, at, &modes)
            {
                length = at;
                z_end = z_at;
                predicted = None;
                *end_events = self.events(t + at, &z_at, &modes);
            }
            let candidate = |g: usize, i: usize| {
                end_events[g][i] > EVENT_TOLERANCE && changes[g][i] < MAX_CHANGES_AT_AN_INSTANT
            };
            // The predicted crossing reached (within the tolerance, before any other):
            // the group changes mode at the end of the substep; missed by a little, a
            // short step on from there (or back) reaches it.
            let settled = predicted.and_then(|(_, g, i)| {
                if self
                    .other_past_tolerance(end_events, (g, i), may_change)
                    .is_some()
                {
                    return None;
                }
                let rate_change = self.rate_change(start_rates, end_rates, length);
                self.settle_on_event(
                    t + length,
                    &z_end,
                    (start_events, end_rates, end_events, &rate_change),
                    (g, i),
                    &modes,
                    (length, h - t - length),
                    may_change,
                )
                .map(|(dt, z_at)| (length + dt, g, i, Some(z_at)))
            });
            let first = match settled {
                Some(event) => Ok(Some(event)),
                None => self.earliest_crossing(
                    (t, &z, length, &modes),
                    (start_rates, start_events, end_events),
                    candidate,
                ),
            };
            // An event inside the substep that could not be located (a point inside it
            // not reached to the tolerance): a shorter substep.
            let Ok(first) = first else {
                length *= SHORTER;
                if length <= 1e-15 * h {
                    return Err(NotConverged);
                }
                continue;
            };
            match first {
                None => {
                    self.high_order_substep_accepted();
                    z = z_end;
                    t += length;
                    changes = [[0; MAX_BRANCHES]; Group::COUNT];
                    self.hold_on_limits(&mut z, &modes);
                    length = if predicted.is_some() {
                        planned
                    } else {
                        length * growth
                    };
                    // Substeps that cannot finish the step within the budget at the
                    // length the error control allows: crawling, known early.
                    let left = budget.saturating_sub(substep + 1);
                    if !self.stiff.get() && substep >= 8 && h - t > length * left as f64 {
                        return Err(NotConverged);
                    }
                }
                Some((at, g, i, z_at)) => {
                    if at > 0.0 {
                        let Some(z_at) = z_at.or_else(|| self.substep_plain(t, &z, at, &modes)) else {
                            return Err(NotConverged);
                        };
                        z = z_at;
                        t += at;
                        changes = [[0; MAX_BRANCHES]; Group::COUNT];
                    }
                    if predicted.is_some() {
                        length = planned;
                    }
                    self.switch_mode(&mut z, &mut modes, &mut changes, (g, i));
                }
            }
        }
        if t < h {
            return Err(NotConverged);
        }
        *x = self.layout.unpack(&z, sliders);
        sliders.sliding = modes;
        Ok(())
    }

    /// Group `g`, branch `i` changes mode at the current instant, on its limit before
    /// and after the change (a spring group that stops sliding sticks from the limit,
    /// not from just outside it).
    fn switch_mode(&self, z: &mut Vector, modes: &mut Modes, changes: &mut Changes, (g, i): (usize, usize)) {
        self.hold_on_limits(z, modes);
        modes[g][i] = !modes[g][i];
        changes[g][i] += 1;
        self.hold_on_limits(z, modes);
    }

    /// A deflection typical of the elements: the largest elastic travel to a limit.
    /// Without friction (zero limits) the states' own size at the start of the step
    /// takes its place, so that the tolerance is never far below rounding.
    fn deflection_scale(friction: &Friction, limits: &Limits, start_scale: f64) -> f64 {
        let elastic = friction
            .elements
            .iter()
            .enumerate()
            .filter_map(|(d, e)| e.map(|e| limits.0[d] / e.stiffness.max(f64::MIN_POSITIVE)))
            .fold(0.0, f64::max);
        if elastic > 0.0 {
            elastic
        } else {
            start_scale.max(1e-9)
        }
    }

    /// The longest substep: four of the fastest time constants (a quarter of one per
    /// midpoint step of the finest row).
    pub(super) fn longest_substep(&self) -> f64 {
        let fastest = self.friction.fastest_rate(self.system);
        if fastest > 0.0 {
            4.0 / fastest
        } else {
            f64::INFINITY
        }
    }
}

/// How long the first and second substeps of a step by its explicit method could have
/// been, s; infinite where the step took no such substep. The eighth-order pair's (the
/// whole-system path): each the length at which the pair's estimate from the same start
/// would have been its aim for them (3 tolerances). The next step starts its first two
/// substeps by the pair with them: a combined slide's error is largest where its force
/// turns, at a step's start, so its first substep is its shortest, and the second may be
/// longer than the first's error would allow. DDT's cascade carries its first exprb42
/// substep's the same way (`cascade::lengths::carried_first_substep`), and no second. Either
/// method reads what the other carried as a first try, which its error control corrects.
pub type HighOrderSubsteps = [f64; 2];

/// No lengths carried: the next step's first two substeps by the pair are as long as
/// asked (at the start, after a reset or a lift-off, or a step the pair did not take).
pub const NOT_CARRIED: HighOrderSubsteps = [f64::INFINITY; 2];

/// An evaluation's rates and event values.
type Evaluation = (Vector, Events);

/// A place for an [`Evaluation`], before one is written there ([`SlidingStep::rates_into`]).
const UNEVALUATED: Evaluation = ([0.0; SIZE], [[0.0; MAX_BRANCHES]; Group::COUNT]);

/// What the sliding path's tests step: a tire of parameters `p` at `vx` and `load`, its
/// friction, its limits, and the elastic travel to its largest limit.
#[cfg(test)]
fn tire_at(p: &crate::physics::Parameters, vx: f64, load: f64) -> (StateSpace, Friction, Limits, f64) {
    use crate::physics::{Parameter, Tire, stepper::AffineSystem};
    let equations = p.model.equations();
    let affine = AffineSystem::from_samples(|at| equations.system(p, &at));
    let friction = Friction::new(
        p.friction,
        equations.contact_elements(p),
        &affine.state_coupling(),
    )
    .unwrap();
    let system = Tire::new(p.clone()).unwrap().system_at(vx, load);
    let limits = Limits::at(p, load);
    let travel = limits.0.iter().copied().fold(0.0, f64::max) / p.get(Parameter::CorneringStiffness);
    (system, friction, limits, travel)
}

/// A step of a tire of parameters `p` at `vx` and `load`, prepared from `states` (in
/// units of the elastic travel, as far as the model has states; of a centimetre where
/// every limit is zero and there is no travel) under driving `inputs` held; passed to
/// `then` with that unit.
#[cfg(test)]
fn with_prepared_step<R>(
    p: &crate::physics::Parameters,
    (vx, load): (f64, f64),
    (states, inputs): (&[f64], [f64; 3]),
    then: impl FnOnce(&SlidingStep, StateVector, SliderState, f64) -> R,
) -> R {
    let (system, mut friction, limits, travel) = tire_at(p, vx, load);
    let unit = if travel > 0.0 { travel } else { 0.01 };
    let mut x = StateVector::zeros();
    for (k, state) in states.iter().enumerate().take(system.states) {
        x[k] = state * unit;
    }
    let mut sliders = SliderState::AT_REST;
    let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
    let step = SlidingStep::new(&system, &mut friction, limits, (u, DrivingVector::zeros()), unit);
    step.prepare(&mut x, &mut sliders);
    then(&step, x, sliders, unit)
}

/// A slide as a tire of parameters `p` meets it at `vx` and `load`: from `states` (in
/// units of the elastic travel, as far as the model has states) under driving `inputs`
/// held, settled for 20 ms and prepared; passed to `then` with its step and travel.
#[cfg(test)]
fn with_settled_slide<R>(
    p: &crate::physics::Parameters,
    (vx, load): (f64, f64),
    (states, inputs): (&[f64], [f64; 3]),
    then: impl FnOnce(&SlidingStep, StateVector, SliderState, f64) -> R,
) -> R {
    with_prepared_step(
        p,
        (vx, load),
        (states, inputs),
        |step, mut x, mut sliders, travel| {
            step.integrate(&mut x, &mut sliders, 0.02).expect("a valid step");
            step.prepare(&mut x, &mut sliders);
            then(step, x, sliders, travel)
        },
    )
}

/// The parameters of a slide of `model` with `law` at the slide yardstick's friction:
/// muY 0.01, and muX 0.01 too where `combined`.
#[cfg(test)]
fn slide_parameters(
    model: crate::physics::ModelKind,
    law: crate::physics::friction::FrictionLaw,
    combined: bool,
) -> crate::physics::Parameters {
    use crate::physics::Parameter;
    let mut p = crate::physics::Parameters::default()
        .with_model(model)
        .with_friction(law);
    p.set(Parameter::LateralFriction, 0.01).unwrap();
    if combined {
        p.set(Parameter::LongitudinalFriction, 0.01).unwrap();
    }
    p
}

/// Whether the longest of 4 ms, 1 ms, 0.1 ms and 10 us that `substep` (another method's,
/// from the start of `x` and `sliders` with its rates and event values) takes, within
/// the longest substep, ends within 1e-10 of the largest entry (or of the elastic
/// `travel`) where the extrapolation does, in as many equal pieces (1 to 64) as its
/// error control takes (as the stepping loop would shorten it); `label` names the case
/// where it does not. A case where it takes none of them (a limit is near: the
/// extrapolation's) is rejected. (The extrapolation is the step's: where settling the
/// slide ended in the linearly implicit method, its rows, which a RingBody sliding in
/// two directions at 19 m/s needed in 32 pieces of a 4 ms substep.)
#[cfg(test)]
fn longest_taken_ends_where_extrapolated(
    step: &SlidingStep,
    (x, sliders): (&StateVector, &SliderState),
    travel: f64,
    label: &str,
    substep: impl Fn(&Vector, (&Vector, &Events), f64, &Modes) -> Option<Vector>,
) -> Result<(), proptest::test_runner::TestCaseError> {
    let (z, modes) = (&step.layout.pack(x, sliders), &sliders.sliding);
    let (rates, events) = step.rates(0.0, z, modes);
    let taken = [4e-3, 1e-3, 1e-4, 1e-5]
        .into_iter()
        .find_map(|length| substep(z, (&rates, &events), length, modes).map(|end| (length, end)));
    proptest::prop_assume!(taken.is_some());
    let (length, end) = taken.unwrap();
    proptest::prop_assume!(length <= step.longest_substep());
    let extrapolated = [1, 2, 4, 8, 16, 32, 64]
        .into_iter()
        .find_map(|pieces| {
            let piece = length / pieces as f64;
            (0..pieces).try_fold(*z, |at, k| {
                let t = k as f64 * piece;
                let (rates, events) = step.rates(t, &at, modes);
                step.substep_by(t, &at, (&rates, &events), piece, modes, false)
                    .map(|(end, ..)| end)
            })
        })
        .expect("the extrapolation takes a substep within its longest in 64 pieces");
    let size = step.size();
    let largest = z[..size]
        .iter()
        .chain(&extrapolated[..size])
        .fold(travel, |m, v| m.max(v.abs()));
    for c in 0..size {
        proptest::prop_assert!(
            (end[c] - extrapolated[c]).abs() <= 1e-10 * largest,
            "{label}, entry {c} of {size}: {} vs {} (largest {largest})",
            end[c],
            extrapolated[c]
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::{SlidingStep, tire_at};
    use crate::physics::friction::{FrictionLaw, SliderState};
    use crate::physics::state_space::{DrivingVector, StateVector};
    use crate::physics::{ModelKind, Parameter, Parameters};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Slots kept from a step at another load and speed, their limits and relaxation
        /// rates refreshed, are the slots laid out anew; and the outputs' damper force
        /// changes made with the mode decision are those made after it.
        #[test]
        fn kept_slots_and_fused_damper_changes_are_the_same_as_made_anew(
            model in prop::sample::select(ModelKind::ALL.to_vec()),
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            vx in prop::array::uniform2(-20.0..20.0f64),
            load_ratio in prop::array::uniform2(0.05..2.0f64),
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform4(-1.5..1.5f64),
        ) {
            let mut p = Parameters::default().with_model(model).with_friction(law);
            p.set(Parameter::LateralFriction, 0.02).unwrap();
            let nominal = p.get(Parameter::NominalLoad);
            let (system, mut kept, limits, travel) = tire_at(&p, vx[0], load_ratio[0] * nominal);
            let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
            SlidingStep::new(&system, &mut kept, limits, (u, DrivingVector::zeros()), travel);
            // The next step, at another point: kept slots refreshed, or made anew.
            let (system, mut fresh, limits, travel) = tire_at(&p, vx[1], load_ratio[1] * nominal);
            let inputs = (u, DrivingVector::zeros());
            SlidingStep::new(&system, &mut kept, limits, inputs, travel);
            SlidingStep::new(&system, &mut fresh, limits, inputs, travel);
            prop_assert_eq!(&kept.sliding_slots, &fresh.sliding_slots);

            let step = SlidingStep::new(&system, &mut fresh, limits, inputs, travel);
            let mut x = StateVector::zeros();
            for k in 0..system.states.min(4) {
                x[k] = states[k] * travel;
            }
            let (mut x_fused, mut sliders_fused) = (x, SliderState::AT_REST);
            let (fused, preparation) = step.prepare_with_damper_force_changes(&mut x_fused, &mut sliders_fused);
            let mut sliders = SliderState::AT_REST;
            step.prepare(&mut x, &mut sliders);
            prop_assert_eq!(x_fused, x);
            prop_assert_eq!(sliders_fused, sliders);
            prop_assert_eq!(fused, step.damper_force_changes(&x, &sliders));
            // Where nothing moved, the preparation found decides as preparing again does.
            if let Some(preparation) = preparation {
                let sliding_rate = step.start_sliding_rate.get();
                step.start_sliding_rate.set(f64::NAN);
                let mut adopted = SliderState::AT_REST;
                step.prepare_from(&mut adopted, &preparation);
                prop_assert_eq!(adopted, sliders);
                prop_assert_eq!(step.start_sliding_rate.get().to_bits(), sliding_rate.to_bits());
            }
        }
    }
}
