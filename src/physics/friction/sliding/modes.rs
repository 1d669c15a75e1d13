//! The modes of a sliding step's groups, as the hybrid system decides them: at a step's
//! start (or an event of an importer's solver), which groups stick and which slide, a
//! force past its limit put on it (the reset); the damped forces shaped by their limits
//! for the outputs; and the rates and event values (guards) of the states in their modes,
//! which Model Exchange exposes.

use super::super::group::{GroupInput, GroupLaw, MAX_MEMBERS, MAX_TOGETHER, closest_points_where};
use super::super::{Direction, EVENT_TOLERANCE, Group, MAX_BRANCHES, SliderState};
use super::{Events, Modes, SIZE, SlidingStep, Vector};
use crate::physics::state_space::StateVector;

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

/// What the damped groups' limits take off their sticking forces, by direction: the
/// closest point of the ellipse less the trial force, summed over the branches.
pub type LimitChanges = [f64; Direction::COUNT];

/// The outputs' shaping at a step's end where the step's last evaluation was there (the
/// cascade's, with the step's inputs): what the limits take off the sticking forces, and
/// what preparing a step from there would decide, as
/// [`SlidingStep::prepare_with_damper_force_changes`] would give them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapedEnd {
    pub changes: LimitChanges,
    pub preparation: Preparation,
}

impl<'a> SlidingStep<'a> {
    /// The [`ShapedEnd`] of a step that ended in the modes `sliding`, whose groups slide
    /// as fast as `sliding_rate` ([`SlidingStep::fastest_sliding_rate`]), with `changes`
    /// from its last evaluation, where that is the outputs' whole shaping
    /// ([`SlidingStep::cascade_decides`]). Every group keeps the mode it ended in, clear of
    /// its event: deciding them there would find them again.
    pub(super) fn shaped_end(
        &self,
        sliding: &Modes,
        sliding_rate: f64,
        changes: LimitChanges,
    ) -> Option<ShapedEnd> {
        self.cascade_decides().then_some(ShapedEnd {
            changes,
            preparation: Preparation {
                sliding: *sliding,
                sliding_rate,
            },
        })
    }

    /// Whether the modes follow from the sticking forces alone: every group is damped (it
    /// slides where its sticking force is outside its ellipse, and nothing is put on a
    /// limit) and every limit is above zero (no deflection is dropped), so that preparing
    /// a step moves nothing. Then a cascade step decides the modes at its start itself
    /// (a group it finds near its limit there is not clear of its event, and the step is
    /// left to the prepared path), and the outputs' shaping decides them with the forces.
    pub(super) fn cascade_decides(&self) -> bool {
        self.all_damped && self.limits.0.iter().all(|&limit| limit > 0.0)
    }

    /// The fastest of the sliding groups' [`GroupInput::sliding_rate`] in `modes`, as
    /// preparing finds it.
    pub(super) fn fastest_sliding_rate(&self, modes: &Modes) -> f64 {
        self.slots()
            .iter()
            .filter(|slot| modes[slot.group][slot.branch])
            .map(|slot| GroupInput::at_rest(&slot.law).sliding_rate())
            .fold(0.0, f64::max)
    }

    /// Brings the branches to the step's limits and inputs at its start: a spring force
    /// outside its limit is put on it (the load fell), and each group's mode is decided
    /// from its state. Returns true if every group sticks strictly inside its limit.
    pub fn prepare(&self, x: &mut StateVector, sliders: &mut SliderState) -> bool {
        self.decide_modes(x, sliders, false).inside
    }

    /// [`SlidingStep::prepare`] as `preparation` found it at the same states, inputs,
    /// operating point and limits, where it moved nothing: the same modes, not decided
    /// again.
    pub fn prepare_from(&self, sliders: &mut SliderState, preparation: &Preparation) {
        sliders.sliding = preparation.sliding;
        self.start_sliding_rate.set(preparation.sliding_rate);
    }

    /// [`SlidingStep::prepare`], and then [`SlidingStep::damper_force_changes`] at the
    /// prepared states, with the [`Preparation`] a step from these states would make
    /// where preparing moved no deflection. Where every group is damped and every limit
    /// above zero ([`SlidingStep::cascade_decides`]) preparing moves nothing and each
    /// group slides where its sticking force is outside its ellipse: the modes come from
    /// the same pass that shapes the forces.
    pub fn prepare_with_damper_force_changes(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
    ) -> ([f64; Direction::COUNT], Option<Preparation>) {
        if self.cascade_decides() {
            let (changes, sliding) = self.limit_changes(x, sliders);
            let preparation = Preparation {
                sliding,
                sliding_rate: self.fastest_sliding_rate(&sliding),
            };
            self.prepare_from(sliders, &preparation);
            return (changes, Some(preparation));
        }
        let moved = self.decide_modes(x, sliders, false).moved;
        let preparation = Preparation {
            sliding: sliders.sliding,
            sliding_rate: self.start_sliding_rate.get(),
        };
        (
            self.damper_force_changes(x, sliders),
            (!moved).then_some(preparation),
        )
    }

    /// At an event of the hybrid system ([`crate::physics::tire::hybrid`]): as
    /// [`SlidingStep::prepare`], and a spring group found outside its limit (the load fell
    /// below its force) slides even where nothing moves it (not where its motion turns
    /// inward): its slider slips as the limit falls. (A step holds the load, so it needs no
    /// such rule.)
    pub fn update_modes(&self, x: &mut StateVector, sliders: &mut SliderState) {
        self.decide_modes(x, sliders, true);
    }

    /// The modes at the step's start, a spring force past its limit put on it (see
    /// [`SlidingStep::prepare`]; `pushed_out_slides` as [`SlidingStep::update_modes`]).
    fn decide_modes(
        &self,
        x: &mut StateVector,
        sliders: &mut SliderState,
        pushed_out_slides: bool,
    ) -> Decided {
        let layout = &self.layout;
        let mut z = [0.0; SIZE];
        layout.pack_into(x, sliders, &mut z);
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
    pub fn damper_force_changes(&self, x: &StateVector, sliders: &SliderState) -> LimitChanges {
        self.limit_changes(x, sliders).0
    }

    /// [`SlidingStep::damper_force_changes`], and each damped group's mode as deciding
    /// there finds it: sliding where its sticking force is outside its ellipse. Where the
    /// slots form a cascade and the modes follow from the sticking forces
    /// ([`SlidingStep::cascade_decides`]), by the cascade's own equations, as a cascade
    /// step shapes its end ([`SlidingStep::cascade_limit_changes`]): so the outputs of
    /// such a step have the same bits as those made from its states on demand.
    pub(super) fn limit_changes(&self, x: &StateVector, sliders: &SliderState) -> (LimitChanges, Modes) {
        let z = self.layout.pack(x, sliders);
        if self.cascade_decides()
            && let Some(found) = self
                .cascade()
                .and_then(|cascade| self.cascade_limit_changes(cascade, &z))
        {
            return found;
        }
        self.whole_system_limit_changes(&z)
    }

    /// [`SlidingStep::limit_changes`] at the coupled vector `z` by the whole system's
    /// equations: every slot's trial force from the model states' rates.
    pub(super) fn whole_system_limit_changes(&self, z: &Vector) -> (LimitChanges, Modes) {
        let states = self.layout.model_states(z);
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
        let mut inputs = [GroupInput::at_rest(&GroupLaw::EMPTY); MAX_TOGETHER];
        let mut trials = [[0.0; MAX_MEMBERS]; MAX_TOGETHER];
        let mut utilisations = [0.0; MAX_TOGETHER];
        let mut outside = [false; MAX_TOGETHER];
        let slots = &self.slots()[..self.slots().len().min(MAX_TOGETHER)];
        for (j, slot) in slots.iter().enumerate() {
            let input = self.slot_input(slot, &states, &rates, z);
            if input.damped() {
                let trial = input.sticking_force();
                let utilisation = input.utilisation(&trial);
                (trials[j], utilisations[j]) = (trial, utilisation);
                outside[j] = utilisation > 1.0;
            }
            inputs[j] = input;
        }
        let points = closest_points_where(&inputs[..slots.len()], &trials, &utilisations, &outside);
        let mut modes = [[false; MAX_BRANCHES]; Group::COUNT];
        // In the order of the slots.
        for (j, slot) in slots.iter().enumerate() {
            modes[slot.group][slot.branch] = outside[j];
            if outside[j] {
                let input = &inputs[j];
                for m in input.members() {
                    change[input.direction[m]] += points[j][m] - trials[j][m];
                }
            }
        }
        (change, modes)
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
