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
//! The result is a function of the states, inputs and step size only (nothing is carried
//! from one step to the next), so a restored FMU state continues bit-identically.
//!
//! Where the groups form a cascade (DDT: the yaw branches drive the lateral ones and
//! nothing drives them) and none changes mode, [`cascade`] takes the step first: the
//! drivers in closed form, the driven groups by an integration of their own
//! (exponential, or linearly implicit for a stiff slide).
//!
//! Here: the coupled system and the loop over pieces; [`extrapolation`]: one substep,
//! and the extrapolated one; [`exponential`]: the exponential one; [`dormand_prince`]:
//! the eighth-order one; [`implicit`]: one substep of a stiff piece; [`events`]: where
//! within a substep a group changes mode; [`cascade`]: the cascade's step.

// Groups and branches index several arrays together (modes, events, offsets).
#![allow(clippy::needless_range_loop)]
mod cascade;
mod dormand_prince;
mod events;
mod exponential;
mod extrapolation;
mod implicit;

use std::cell::Cell;

use super::group::{
    GroupInput, GroupLaw, GroupOutput, MAX_MEMBERS, MAX_TOGETHER, Members, evaluate_together,
};
use super::{Direction, EVENT_TOLERANCE, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use crate::physics::state_space::{DrivingVector, MAX_STATES, StateSpace, StateVector, by_state_count};
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

/// Where each quantity of a step sits in the coupled vector: first the model's states
/// that carry no contact element (each with its own equation), then every branch
/// deflection of each element. An element's own state is the weighted sum of its branches,
/// so it has no entry: the vector is as short as the model and law make it (two entries
/// for RLT with Coulomb, up to twelve), which is what the substeps, the error control and
/// the stiff method's Jacobian cost in proportion to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Layout {
    /// The model state of each of the first `free_count` entries.
    free: [usize; MAX_STATES],
    free_count: usize,
    /// By present element.
    elements: [ElementEntries; Direction::COUNT],
    element_count: usize,
    /// Branches per element, and every branch's `w_i`.
    branches: usize,
    weights: [f64; MAX_BRANCHES],
    /// Entries in use.
    size: usize,
    /// By model state, the entries it is the weighted sum of ([`Layout::model_states`]).
    sums: [StateSum; MAX_STATES],
    /// The model's states (zero: not laid out yet).
    states: usize,
}

/// A model state as a sum of entries of the coupled vector: from `first` on, with
/// `weights` (1 and zeros for a free state, each branch's `w_i` for an element's state,
/// all zero for a state past the model's). Every sum has [`MAX_BRANCHES`] terms, those of
/// weight zero adding nothing, so that two states are summed side by side.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct StateSum {
    first: usize,
    weights: [f64; MAX_BRANCHES],
}

/// Where a present element's branches are: its direction, its model state and its first
/// branch's entry (the others follow).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ElementEntries {
    direction: usize,
    state: usize,
    first: usize,
}

impl Layout {
    fn new(friction: &Friction, states: usize) -> Self {
        let mut layout = Layout {
            branches: friction.branches.len(),
            states,
            ..Layout::default()
        };
        for (i, branch) in friction.branches.iter().enumerate() {
            layout.weights[i] = branch.stiffness_fraction;
        }
        let carries_element = |k: usize| friction.elements.iter().flatten().any(|e| e.state == k);
        for k in (0..states).filter(|&k| !carries_element(k)) {
            layout.free[layout.free_count] = k;
            layout.free_count += 1;
        }
        let mut next = layout.free_count;
        for (d, element) in friction.elements.iter().enumerate() {
            if let Some(element) = element {
                layout.elements[layout.element_count] = ElementEntries {
                    direction: d,
                    state: element.state,
                    first: next,
                };
                layout.element_count += 1;
                next += layout.branches;
            }
        }
        layout.size = next;
        // A sum of MAX_BRANCHES terms from any first entry stays within the vector.
        debug_assert!(next + MAX_BRANCHES <= SIZE + 1);
        for j in 0..layout.free_count {
            let mut weights = [0.0; MAX_BRANCHES];
            weights[0] = 1.0;
            layout.sums[layout.free[j]] = StateSum { first: j, weights };
        }
        for e in &layout.elements[..layout.element_count] {
            layout.sums[e.state] = StateSum {
                first: e.first,
                weights: layout.weights,
            };
        }
        layout
    }

    fn elements(&self) -> &[ElementEntries] {
        &self.elements[..self.element_count]
    }

    /// The entry of branch `i` of direction `d`'s element, if the model has one.
    fn branch_entry(&self, d: usize, i: usize) -> Option<usize> {
        self.elements()
            .iter()
            .find(|e| e.direction == d)
            .map(|e| e.first + i)
    }

    /// The model's states (or rates) of a coupled vector (or its rates): the free entries,
    /// and each element's state `sum w_i b_i`. Two states at a time, written together:
    /// the product with the state matrix reads them two at a time, at once.
    #[inline]
    fn model_states(&self, z: &Vector) -> StateVector {
        by_state_count!(self.states, N => self.model_states_for::<N>(z))
    }

    /// [`Layout::model_states`] of a model of `N` states: the pairs that hold them, the
    /// states past them left zero.
    #[inline]
    fn model_states_for<const N: usize>(&self, z: &Vector) -> StateVector {
        let mut x = StateVector::zeros();
        let sum = |s: &StateSum| {
            // One bounds check for the terms, not one a term.
            let terms = &z[s.first..s.first + MAX_BRANCHES];
            let mut sum = 0.0;
            for i in 0..MAX_BRANCHES {
                sum += s.weights[i] * terms[i];
            }
            sum
        };
        let pairs = N.div_ceil(2);
        for (pair, sums) in x
            .as_mut_slice()
            .chunks_exact_mut(2)
            .zip(self.sums.chunks_exact(2))
            .take(pairs)
        {
            pair.copy_from_slice(&[sum(&sums[0]), sum(&sums[1])]);
        }
        x
    }

    /// By entry, the model state it makes and its weight there: 1 for a free state, `w_i`
    /// for a branch deflection (the columns of [`Layout::model_states`] as a matrix, read
    /// from its rows: a weight of zero is no entry of that state).
    fn made_states(&self) -> [(usize, f64); SIZE] {
        let mut made = [(0, 0.0); SIZE];
        for (state, sum) in self.sums.iter().enumerate() {
            for (i, &weight) in sum.weights.iter().enumerate() {
                if weight != 0.0 {
                    made[sum.first + i] = (state, weight);
                }
            }
        }
        made
    }

    fn pack(&self, x: &StateVector, sliders: &SliderState) -> Vector {
        let mut z = [0.0; SIZE];
        for j in 0..self.free_count {
            z[j] = x[self.free[j]];
        }
        for e in self.elements() {
            for i in 0..self.branches {
                z[e.first + i] = x[e.state] + sliders.offsets[e.direction][i];
            }
        }
        z
    }

    /// The model's states and the branch offsets of `z` (linear: also rates from rates).
    fn unpack(&self, z: &Vector, sliders: &mut SliderState) -> StateVector {
        let x = self.model_states(z);
        for e in self.elements() {
            for i in 0..self.branches {
                sliders.offsets[e.direction][i] = z[e.first + i] - x[e.state];
            }
        }
        x
    }
}

/// One group's branch `i` in the coupled vector: its law's constants, and for each
/// member the entry of its deflection and its element's model state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Slot {
    group: usize,
    branch: usize,
    law: GroupLaw,
    entries: [usize; MAX_MEMBERS],
    states: [usize; MAX_MEMBERS],
    /// Each member's relaxation rate, the diagonal entry of its element's state.
    relaxation: [f64; MAX_MEMBERS],
}

impl Slot {
    /// Its members' entries of a coupled vector (or of its rates); zero past its members,
    /// as the group's law takes them.
    fn of(&self, values: &Vector) -> Members {
        let mut of = [0.0; MAX_MEMBERS];
        for m in self.law.members() {
            of[m] = values[self.entries[m]];
        }
        of
    }

    /// A sticking spring group's event value at `z`: its utilisation less one, a function
    /// of its deflections alone. `None` for a sliding or damped group, whose value needs
    /// the rates.
    fn event_from_deflections(&self, z: &Vector, modes: &Modes) -> Option<f64> {
        (!modes[self.group][self.branch] && !self.law.damped()).then(|| self.utilisation(z) - 1.0)
    }

    /// The utilisation of a spring group's forces at its deflections in `z`.
    fn utilisation(&self, z: &Vector) -> f64 {
        let input = GroupInput {
            deflection: self.of(z),
            ..GroupInput::at_rest(&self.law)
        };
        input.utilisation(&input.spring_force())
    }

    /// Scales a spring group's deflections in `z`, whose forces have `utilisation`, so
    /// that its force is on the ellipse (along its own direction).
    fn put_on_ellipse(&self, z: &mut Vector, utilisation: f64) {
        let shrink = utilisation.sqrt().recip();
        for m in self.law.members() {
            z[self.entries[m]] *= shrink;
        }
    }
}

/// The branches of a sliding step laid out in its coupled vector: each group and branch
/// with a member (a present direction with a limit), its constants filled in at the
/// step's limits and relaxation rates. A direction with a zero limit is left out: its
/// branch deflections stay at zero ([`SlidingStep::prepare`] puts them there). The
/// friction keeps them ([`Friction::lay_out_sliding`]): a slide at a held operating point
/// makes them once, not at every step and every output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlidingSlots {
    /// The bits of the limits and of each direction's relaxation rate they were made for
    /// (the layout itself is made for the model's states, [`Layout::states`]).
    made_for: [u64; 2 * Direction::COUNT],
    layout: Layout,
    slots: [Slot; Group::COUNT * MAX_BRANCHES],
    count: usize,
}

impl Friction {
    /// Makes [`Friction::sliding_slots`] for a step of `system` at `limits`, unless they
    /// were made for the same.
    fn lay_out_sliding(&mut self, system: &StateSpace, limits: &Limits) {
        let mut made_for = [0; 2 * Direction::COUNT];
        for (d, element) in self.elements.iter().enumerate() {
            made_for[d] = limits.0[d].to_bits();
            if let Some(element) = element {
                made_for[Direction::COUNT + d] = system.a[(element.state, element.state)].to_bits();
            }
        }
        // The entries depend on the model alone: laid out at the first sliding step.
        let laid_out = &self.sliding_slots;
        if laid_out.layout.states != system.states {
            self.sliding_slots.layout = Layout::new(self, system.states);
        } else if made_for == laid_out.made_for {
            return;
        } else if (0..Direction::COUNT)
            .all(|d| (f64::from_bits(laid_out.made_for[d]) > 0.0) == (limits.0[d] > 0.0))
        {
            // The same members (a vehicle's load moves every step, and the speed with
            // it): only the constants the limits and relaxation rates make change.
            self.sliding_slots.made_for = made_for;
            self.refresh_sliding_slots(system, limits);
            return;
        }
        self.sliding_slots.made_for = made_for;
        self.fill_sliding_slots(system, limits);
    }

    /// The slots' limits and relaxation rates at `limits` and `system`, their members
    /// kept (as [`Friction::fill_sliding_slots`] makes them).
    fn refresh_sliding_slots(&mut self, system: &StateSpace, limits: &Limits) {
        let laid_out = &mut self.sliding_slots;
        for slot in &mut laid_out.slots[..laid_out.count] {
            let limit_fraction = self.branches[slot.branch].limit_fraction;
            for m in slot.law.members() {
                let state = slot.states[m];
                slot.relaxation[m] = system.a[(state, state)];
                slot.law
                    .set_limit(m, limit_fraction * limits.0[slot.law.direction[m]]);
            }
        }
    }

    /// The slots of [`Friction::lay_out_sliding`], written where they are kept.
    fn fill_sliding_slots(&mut self, system: &StateSpace, limits: &Limits) {
        let groups = Self::groups_of(&self.group_members);
        let laid_out = &mut self.sliding_slots;
        laid_out.count = 0;
        for group in groups {
            for (i, branch) in self.branches.iter().enumerate() {
                let slot = &mut laid_out.slots[laid_out.count];
                *slot = Slot {
                    group: group as usize,
                    branch: i,
                    ..Slot::default()
                };
                for &direction in group.directions() {
                    let d = direction as usize;
                    let Some(element) = self.elements[d].filter(|_| limits.0[d] > 0.0) else {
                        continue;
                    };
                    let m = slot.law.count;
                    slot.entries[m] = laid_out.layout.branch_entry(d, i).expect("a present element");
                    slot.states[m] = element.state;
                    slot.relaxation[m] = system.a[(element.state, element.state)];
                    slot.law = slot.law.with_member(
                        direction,
                        branch.stiffness_fraction * element.stiffness,
                        branch.stiffness_fraction * element.damping,
                        branch.limit_fraction * limits.0[d],
                    );
                }
                if slot.law.count > 0 {
                    laid_out.count += 1;
                }
            }
        }
    }
}

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
            stiff: Cell::new(false),
            exponential_declined: Cell::new(false),
            high_order_declined: Cell::new(false),
            exponential_misses: Cell::new(0),
            high_order_misses: Cell::new(0),
            high_order_carried,
            high_order_found: Cell::new([f64::INFINITY; 2]),
            high_order_pending: Cell::new(None),
            start_sliding_rate: Cell::new(0.0),
        }
    }

    /// Entries of the coupled vector in use.
    fn size(&self) -> usize {
        self.layout.size
    }

    /// `z + dt * rates` over the entries in use: an explicit Euler step, or a stage's
    /// state.
    fn advanced(&self, z: &Vector, rates: &Vector, dt: f64) -> Vector {
        let mut moved = *z;
        for c in 0..self.size() {
            moved[c] += dt * rates[c];
        }
        moved
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
            evaluate_together(&inputs[..slots.len()], &sliding, &mut outputs);
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
    /// of the step. By the cascade where it takes the step ([`cascade`]); otherwise
    /// explicitly first. A step the explicit method cannot finish (a stiff slide) is
    /// taken again from its start by the linearly implicit method, and one whose sliding
    /// groups move their forces within a fraction of the step (as
    /// [`SlidingStep::prepare`] found them) is taken by it from the start.
    pub fn integrate(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        self.stiff.set(false);
        self.exponential_declined.set(false);
        self.high_order_declined.set(false);
        self.high_order_misses.set(0);
        self.high_order_found.set([f64::INFINITY; 2]);
        self.exponential_misses.set(0);
        // A sliding group that turns its force far faster than the step (a stiff tire at
        // a light load): the explicit method would crawl.
        let crawls = h * self.start_sliding_rate.get() > STIFF_STEP;
        if self.cascade_step(x, sliders, h, crawls) {
            return Ok(());
        }
        if !crawls && self.integrate_by_current_method(x, sliders, h).is_ok() {
            return Ok(());
        }
        // The explicit substeps were given up: their lengths tell the next step nothing.
        self.high_order_found.set([f64::INFINITY; 2]);
        self.stiff.set(true);
        self.integrate_by_current_method(x, sliders, h)
    }

    /// [`SlidingStep::integrate`] by the method [`SlidingStep::stiff`] says.
    fn integrate_by_current_method(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        h: f64,
    ) -> Result<(), NotConverged> {
        let mut z = self.layout.pack(x, sliders);
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

/// Adds to `change` (by direction) what a damped group's limit does to its force: where
/// the sticking force `trial` is outside the ellipse (`utilisation > 1`), the closest
/// point of the ellipse less the trial.
fn add_damper_force_change(
    input: &GroupInput,
    trial: &Members,
    utilisation: f64,
    change: &mut [f64; Direction::COUNT],
) {
    if utilisation > 1.0 {
        let force = input.closest_point(trial, utilisation);
        for m in input.members() {
            change[input.direction[m]] += force[m] - trial[m];
        }
    }
}

/// How long the eighth-order pair's first and second substeps of a step could have been,
/// s: each the length at which the pair's estimate from the same start would have been
/// its aim for them (3 tolerances); infinite where the step took no such substep.
/// The next step starts its first two substeps by the pair with them: a combined slide's
/// error is largest where its force turns, at a step's start, so its first substep is
/// its shortest, and the second may be longer than the first's error would allow.
pub type HighOrderSubsteps = [f64; 2];

/// An evaluation's rates and event values.
type Evaluation = (Vector, Events);

/// A place for an [`Evaluation`], before one is written there ([`SlidingStep::rates_into`]).
const UNEVALUATED: Evaluation = ([0.0; SIZE], [[0.0; MAX_BRANCHES]; Group::COUNT]);

/// What deciding the modes at a step's start found.
struct Decided {
    /// Every group sticks strictly inside its limit.
    inside: bool,
    /// A deflection was moved (onto its limit, or to zero in a frictionless direction),
    /// and the states and offsets written back.
    moved: bool,
}

/// What preparing a step decided where it moved no deflection: each group's mode, and
/// how fast the sliding ones move their forces. The same states, inputs, operating point
/// and limits decide the same again ([`SlidingStep::prepare_from`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preparation {
    sliding: Modes,
    sliding_rate: f64,
}

impl<'a> SlidingStep<'a> {
    /// Brings the branches to the step's limits and inputs at its start: a spring force
    /// outside its limit is put on it (the load fell), and each group's mode is decided
    /// from its state. Returns true if every group sticks strictly inside its limit.
    pub fn prepare(&self, x: &mut StateVector, sliders: &mut SliderState) -> bool {
        self.decide_modes(x, sliders, false, None).inside
    }

    /// [`SlidingStep::prepare`] as `preparation` found it at the same states, inputs,
    /// operating point and limits, where it moved nothing: the same modes, not decided
    /// again.
    pub fn prepare_from(&self, sliders: &mut SliderState, preparation: &Preparation) {
        sliders.sliding = preparation.sliding;
        self.start_sliding_rate.set(preparation.sliding_rate);
    }

    /// [`SlidingStep::prepare`], and then [`SlidingStep::damper_force_changes`] at the
    /// prepared states: from the same evaluation where preparing moved no deflection,
    /// which also gives the [`Preparation`] a step from these states would make.
    pub fn prepare_with_damper_force_changes(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
    ) -> ([f64; Direction::COUNT], Option<Preparation>) {
        let mut change = [0.0; Direction::COUNT];
        // Where a deflection was moved (a frictionless direction's too, whose damper's
        // share goes), the changes are made at the prepared states.
        if self.decide_modes(x, sliders, false, Some(&mut change)).moved {
            (self.damper_force_changes(x, sliders), None)
        } else {
            let preparation = Preparation {
                sliding: sliders.sliding,
                sliding_rate: self.start_sliding_rate.get(),
            };
            (change, Some(preparation))
        }
    }

    /// At an event of the hybrid system ([`crate::physics::tire::hybrid`]): as
    /// [`SlidingStep::prepare`], and a spring group found outside its limit (the load fell
    /// below its force) slides even where nothing moves it (not where its motion turns
    /// inward): its slider slips as the limit falls. (A step holds the load, so it needs no
    /// such rule.)
    pub fn update_modes(&self, x: &mut StateVector, sliders: &mut SliderState) {
        self.decide_modes(x, sliders, true, None);
    }

    /// With `damper_changes`, also adds up [`SlidingStep::damper_force_changes`] at the
    /// states as they come (the prepared ones where nothing was moved).
    fn decide_modes(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        pushed_out_slides: bool,
        mut damper_changes: Option<&mut [f64; Direction::COUNT]>,
    ) -> Decided {
        let layout = &self.layout;
        let mut z = layout.pack(x, sliders);
        let mut inside = true;
        // Whether a deflection was moved: only then are the states and offsets written
        // back (through the coupled vector they would round), so that the outputs at
        // states within every limit are exactly the linear model's.
        let mut moved = false;
        for e in layout.elements() {
            if self.limits.0[e.direction] <= 0.0 {
                z[e.first..e.first + layout.branches].fill(0.0);
                inside = false;
                moved = true;
            }
        }
        for group in self.friction.groups() {
            sliders.sliding[group as usize] = [false; MAX_BRANCHES];
        }
        let states = layout.model_states(&z);
        let rates = self.system.state_rates(&states, &self.inputs);
        let mut fastest = 0.0_f64;
        for slot in self.slots() {
            let input = self.slot_input(slot, &states, &rates, &z);
            let sliding = if input.damped() {
                let trial = input.sticking_force();
                let utilisation = input.utilisation(&trial);
                inside &= utilisation < 1.0;
                if let Some(change) = damper_changes.as_deref_mut() {
                    add_damper_force_change(&input, &trial, utilisation, change);
                }
                utilisation > 1.0
            } else {
                let force = input.spring_force();
                let utilisation = input.utilisation(&force);
                inside &= utilisation < 1.0;
                // On its limit to within the event tolerance (as a step leaves a group
                // that slides, or ends at its event), a force stays where it is.
                if utilisation > 1.0 + EVENT_TOLERANCE {
                    slot.put_on_ellipse(&mut z, utilisation);
                    moved = true;
                }
                let cosine = input.outward_cosine(&force);
                (pushed_out_slides && utilisation > 1.0 + 0.5 * EVENT_TOLERANCE && cosine >= 0.0)
                    || utilisation >= 1.0 - EVENT_TOLERANCE && cosine > 0.0
            };
            sliders.sliding[slot.group][slot.branch] = sliding;
            if sliding {
                fastest = fastest.max(input.sliding_rate());
            }
        }
        self.start_sliding_rate.set(fastest);
        if moved {
            *x = layout.unpack(&z, sliders);
        }
        Decided { inside, moved }
    }

    /// The change of the element forces (by direction) that the damped groups' limits
    /// make at these states and inputs: the sticking force where it is inside the limit,
    /// the closest point of the ellipse where it is not.
    pub fn damper_force_changes(&self, x: &StateVector, sliders: &SliderState) -> [f64; Direction::COUNT] {
        let z = self.layout.pack(x, sliders);
        let states = self.layout.model_states(&z);
        let rates = self.system.state_rates(&states, &self.inputs);
        let mut change = [0.0; Direction::COUNT];
        // A frictionless direction carries no force: its damper's share goes too.
        for (d, element) in self.friction.elements.iter().enumerate() {
            if let Some(element) = element
                && self.limits.0[d] <= 0.0
            {
                let k = element.state;
                change[d] -= element.stiffness * states[k] + element.damping * rates[k];
            }
        }
        for slot in self.slots() {
            let input = self.slot_input(slot, &states, &rates, &z);
            if !input.damped() {
                continue;
            }
            let trial = input.sticking_force();
            add_damper_force_change(&input, &trial, input.utilisation(&trial), &mut change);
        }
        change
    }

    /// The tire as a hybrid system in the modes of `sliders` (an importer's solver
    /// integrates it): the rates of the model's states and of the branch offsets, and each
    /// group's event value by group and branch (negative while it keeps its mode; `-inf`
    /// where there is no such group). A sliding spring group's force stays on its
    /// ellipse only while the limit holds still; where the load moves the limit, its
    /// deflections are also drawn back to the ellipse at [`SlidingStep::RETURN_RATE`] or
    /// faster, so the force follows the limit: down as the load falls, and up as it rises
    /// while the slider moves outward (a group inside its limit that nothing moves keeps
    /// its force, as it would sticking).
    pub fn mode_rates(&self, x: &StateVector, sliders: &SliderState) -> (StateVector, SliderState, Events) {
        self.unpacked_rates(x, sliders, true)
    }

    /// The rates of the model's states and of the branch offsets, and the event values,
    /// at these states in their modes; with `follow_limit`, a sliding spring group is
    /// drawn back to its ellipse as [`SlidingStep::mode_rates`] says.
    fn unpacked_rates(
        &self,
        x: &StateVector,
        sliders: &SliderState,
        follow_limit: bool,
    ) -> (StateVector, SliderState, Events) {
        let z = self.layout.pack(x, sliders);
        let (rates, events) =
            self.rates_adjusted(0.0, &z, &sliders.sliding, |slot, input, sliding, rates| {
                if !(follow_limit && sliding) || input.damped() {
                    return;
                }
                let force = input.spring_force();
                let utilisation = input.utilisation(&force);
                if utilisation > 1.0 || utilisation > 0.0 && input.outward_cosine(&force) > 0.0 {
                    let rate = input.sliding_rate().max(Self::RETURN_RATE);
                    let pull = rate * (1.0 - utilisation.sqrt().recip());
                    for m in input.members() {
                        rates[slot.entries[m]] -= pull * z[slot.entries[m]];
                    }
                }
            });
        let mut offset_rates = SliderState::AT_REST;
        let x_rates = self.layout.unpack(&rates, &mut offset_rates);
        (x_rates, offset_rates, events)
    }

    /// The slowest rate, 1/s, at which a sliding spring group's deflections return to the
    /// ellipse in [`SlidingStep::mode_rates`]: a load that changes by 1 % per second
    /// leaves the force about 1e-5 of the limit behind it.
    pub const RETURN_RATE: f64 = 1000.0;

    /// The rates of the model's states and of the branch offsets at these states (the
    /// state rates with the limits acting).
    pub fn rates_at(&self, x: &StateVector, sliders: &SliderState) -> (StateVector, SliderState) {
        let (x_rates, offset_rates, _) = self.unpacked_rates(x, sliders, false);
        (x_rates, offset_rates)
    }
}

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
    let (system, mut friction, limits, travel) = tire_at(p, vx, load);
    let mut x = StateVector::zeros();
    for (k, state) in states.iter().enumerate().take(system.states) {
        x[k] = state * travel;
    }
    let mut sliders = SliderState::AT_REST;
    let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
    let step = SlidingStep::new(
        &system,
        &mut friction,
        limits,
        (u, DrivingVector::zeros()),
        travel,
    );
    step.prepare(&mut x, &mut sliders);
    step.integrate(&mut x, &mut sliders, 0.02).expect("a valid step");
    step.prepare(&mut x, &mut sliders);
    then(&step, x, sliders, travel)
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
/// `travel`) where the extrapolation does, in as many equal pieces (1 to 16) as its
/// error control takes (as the stepping loop would shorten it); `label` names the case
/// where it does not. A case where it takes none of them (a limit is near: the
/// extrapolation's) is rejected.
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
    let extrapolated = [1, 2, 4, 8, 16]
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
        .expect("the extrapolation takes a substep within its longest in 16 pieces");
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
