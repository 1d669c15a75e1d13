//! The outputs' shaping of a cascade: at the step's end, where its states and offsets
//! pack to, and on demand at given states, by the cascade's own equations.

use super::super::modes::LimitChanges;
use super::super::{Events, Group, MAX_BRANCHES, Modes, SliderState, SlidingStep, Vector};
use super::drivers::{DriverSum, driver_input};
use super::groups::DrivenGroups;
use super::{Cascade, DRIVEN, Driven, entry};
use crate::physics::friction::group::MAX_MEMBERS;
use crate::physics::state_space::StateVector;

/// What the limits take off the groups' sticking forces at a step's end, where its last
/// evaluation was there, and whether every driven group there is in the mode deciding
/// there finds ([`super::samples::ends_decided`]).
pub(super) struct EndShaping {
    pub(super) changes: LimitChanges,
    pub(super) decided: bool,
}

/// Where [`SlidingStep::shaped_at`] shapes: the driven vector (the `q`s zero), the drivers'
/// deflections by branch, and the drivers' state, the weighted sum of those.
pub(super) struct ShapingPoint {
    pub(super) driven: Driven,
    pub(super) drivers: [f64; MAX_BRANCHES],
    pub(super) driver_state: f64,
}

/// The outputs' shaping of a cascade at given states ([`SlidingStep::shaped_at`]).
pub(super) struct CascadeShaping {
    pub(super) rates: Driven,
    pub(super) events: Events,
    pub(super) changes: LimitChanges,
    pub(super) drivers_decided: bool,
}

impl SlidingStep<'_> {
    /// The outputs' shaping of the cascade at the coupled vector `z`, the groups in the
    /// modes of `groups` and reading the drivers' state there: the driven groups' rates
    /// (the `q`s' left for the caller) and event values, what the limits take off every
    /// damped group's sticking force, and whether every driver is in the mode deciding
    /// there finds. The same at a step's end as on demand
    /// ([`SlidingStep::cascade_limit_changes`]): the same bits.
    pub(super) fn shaped_at(
        &self,
        cascade: &Cascade,
        groups: &DrivenGroups,
        at: &ShapingPoint,
    ) -> CascadeShaping {
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
    pub(super) fn point_of(&self, cascade: &Cascade, groups: &DrivenGroups, z: &Vector) -> ShapingPoint {
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
    /// ([`SlidingStep::whole_end`] then [`super::super::Layout::pack`];
    /// [`SlidingStep::point_of`]), the same bits: each branch deflection `U + (b - U)`,
    /// `U` its element's state, the weighted sum of the branches in their order
    /// ([`super::super::Layout::model_states`]). Made from the pieces (driven group `n`
    /// is the driven elements' branch `n`, [`Cascade::of`]): a vector written entry by
    /// entry and read again at once stalls on its stores.
    pub(super) fn end_point(
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
    pub(in crate::physics::friction::sliding) fn cascade_limit_changes(
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
    pub(super) fn whole_end(
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
    pub(super) fn set_driven_end(
        &self,
        cascade: &Cascade,
        (end, modes): (&mut Vector, &Modes),
        driven: &Driven,
    ) {
        for (n, j) in cascade.driven().enumerate() {
            let slot = &self.slots()[j];
            for m in slot.law.members() {
                end[slot.entries[m]] = driven[entry(n, m)];
            }
        }
        self.hold_on_limits(end, modes);
    }
}
