//! The driven groups of one step: their inputs from the drivers' sum, their rates and
//! event values side by side, the samples of a substep, and their linear part.

use super::super::course::Course;
use super::super::exponential::{LinearPart, largest_size};
use super::super::extrapolation::larger;
use super::super::modes::LimitChanges;
use super::super::{Events, Group, MAX_BRANCHES, Modes, NO_EVENT, SlidingStep, Slot, Vector};
use super::drivers::DriverSum;
use super::samples::{Crossing, Samples, all_clear, clear, peak_clear, peaks_clear};
use super::{Cascade, DRIVEN, Driven, Q, entry};
use crate::physics::friction::group::{GroupInput, GroupOutput, MAX_MEMBERS, Members, evaluate_together};
use crate::physics::friction::{Direction, EVENT_TOLERANCE};
use crate::physics::state_space::MAX_STATES;

/// `end` less exprb42's own error as estimated from the remainder's quartic part, for
/// the error ratio of the two ([`DrivenGroups::quartic_estimate`]). Along the substep,
/// `N(theta) = a theta^2 + b theta^3 + c theta^4` (`N(0)` and its slope zero: `J` is the
/// start's Jacobian); `D2 = N(3/4)`, `D3 = N(1)` and the slope at the end
/// `N'(1) = H (J(end) - J) f(end)` give `c = 256/9 D2 - 24 D3 + 4 N'(1)` and
/// `b = N'(1) - 2 D3 - 2 c`. exprb42 takes the cubic exactly where `X` is small, and
/// leaves about `H (X b - c) / 80` (the first terms of
/// `H ((9/8 phi3 - 24 phi5) c + (3/2 phi3 - 6 phi4) b)`), bounded here entry by entry by
/// `H (|c| + |X b|) / 80`: where the force turns, the third-order estimate is hundreds of
/// times that.
pub(super) fn quartic_estimate(
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

/// `d rate_k / d b_m` of a driven group (through its sticking rates too, with their
/// relaxation), by row `k`, and `d rate_k / d X` of the drivers' state, by member.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Slopes {
    pub(super) by_member: [Members; MAX_MEMBERS],
    pub(super) by_driver: Members,
}

/// The driven groups of one step: their slots, each member's inputs' part of its
/// sticking rate and coupling to the drivers' state, and the drivers' sum.
pub(super) struct DrivenGroups<'s> {
    pub(super) slots: [&'s Slot; MAX_BRANCHES],
    pub(super) count: usize,
    pub(super) modes: Modes,
    pub(super) drive: [Members; MAX_BRANCHES],
    pub(super) coupling: [Members; MAX_BRANCHES],
    pub(super) sum: &'s DriverSum,
    /// The inputs' part of the drivers' state's rate.
    pub(super) driver_drive: f64,
}

impl<'s> DrivenGroups<'s> {
    /// `None` where there are none. (Inlined: made where it is kept, not copied there.)
    #[inline(always)]
    pub(super) fn new(
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

    pub(super) fn count(&self) -> usize {
        self.count
    }

    /// The driven vector at the step's start `z`: each group's pair whole (a missing
    /// member's zero), as its evaluation reads it, and the `q`s zero.
    #[inline(always)]
    pub(super) fn start(&self, z: &Vector) -> Driven {
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
    pub(super) fn decide(&mut self, w: &Driven) {
        let (inputs, _) = self.inputs(w);
        for (n, slot) in self.slots[..self.count].iter().enumerate() {
            self.modes[slot.group][slot.branch] = inputs[n].outside();
        }
    }

    pub(super) fn slots(&self) -> impl Iterator<Item = &'s Slot> + '_ {
        self.slots[..self.count].iter().copied()
    }

    /// Every driven group's inputs at `w`, and its mode. (Inlined: made where they are
    /// used, not copied there.)
    #[inline(always)]
    pub(super) fn inputs(&self, w: &Driven) -> ([GroupInput<'s>; MAX_BRANCHES], [bool; MAX_BRANCHES]) {
        let sum = self.sum;
        self.inputs_with(w, sum.start + sum.by_mode[0] * w[Q[0]] + sum.by_mode[1] * w[Q[1]])
    }

    /// [`DrivenGroups::inputs`] with the drivers' state `driver`.
    #[inline(always)]
    pub(super) fn inputs_with(
        &self,
        w: &Driven,
        driver: f64,
    ) -> ([GroupInput<'s>; MAX_BRANCHES], [bool; MAX_BRANCHES]) {
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
    pub(super) fn events(&self, w: &Driven) -> Events {
        let (inputs, sliding) = self.inputs(w);
        let mut events: Events = [[NO_EVENT; MAX_BRANCHES]; Group::COUNT];
        for (n, slot) in self.slots().enumerate() {
            events[slot.group][slot.branch] = inputs[n].event(sliding[n]);
        }
        events
    }

    /// Every driven group's rates and event value at `w`, evaluated side by side (their
    /// projections' Newton steps overlap).
    pub(super) fn evaluate(&self, w: &Driven) -> (Driven, Events) {
        let (inputs, sliding) = self.inputs(w);
        self.evaluate_inputs(w, (&inputs, &sliding))
    }

    /// [`DrivenGroups::evaluate`] at `w` from its inputs and modes there
    /// ([`DrivenGroups::inputs`]).
    pub(super) fn evaluate_inputs(
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
    pub(super) fn evaluate_with_changes(&self, w: &Driven, driver: f64) -> (Driven, Events, LimitChanges) {
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
    pub(super) fn outputs_into(
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
    pub(super) fn laid_out_from(
        &self,
        w: &Driven,
        output: impl Fn(usize) -> GroupOutput,
    ) -> (Driven, Events) {
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
    pub(super) fn event_rates(&self, w: &Driven, rates: &Driven) -> [f64; MAX_BRANCHES] {
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
    pub(super) fn samples(
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
    pub(super) fn q_rates(&self, w: &Driven) -> [f64; 2] {
        let rate = self.sum.rate;
        [1.0 + rate[0] * w[Q[0]], 1.0 + rate[1] * w[Q[1]]]
    }

    /// Each group's [`Slopes`] at its `inputs` there, whose rates are `rates`
    /// ([`GroupInput::rate_slopes`]).
    pub(super) fn slopes(
        &self,
        inputs: &[GroupInput; MAX_BRANCHES],
        rates: &Driven,
    ) -> [Slopes; MAX_BRANCHES] {
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
    pub(super) fn quartic_estimate(
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
    pub(super) fn linear_part(
        &self,
        slopes: &[Slopes; MAX_BRANCHES],
        length: f64,
        negligible: f64,
    ) -> DrivenLinearPart {
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
    pub(super) fn set_q(&self, w: &mut Driven, t: f64) {
        for (place, q) in Q.into_iter().zip(self.sum.q(t)) {
            w[place] = q;
        }
    }
}

/// The driven groups' `H J`. Each group's members' rates move with its own deflections
/// ([`GroupInput::rate_slopes`], through the sticking rates too, with their relaxation)
/// and with the `q`s (through the drivers' state, `coupling R`); each `q` moves with
/// itself alone (`mu`). Nothing else: a product is a few small blocks.
pub(super) struct DrivenLinearPart {
    /// By group, by column: `H d rate_k / d b_m`.
    pub(super) members: [[Members; MAX_MEMBERS]; MAX_BRANCHES],
    /// By group and `q`: `H d rate_k / d q`.
    pub(super) by_q: [[Members; 2]; MAX_BRANCHES],
    /// `H mu` by `q`.
    pub(super) q_rates: [f64; 2],
    /// By `q`, the most a unit of it moves a group's rates over the substep, `max |H d
    /// rate_k / d q|`: what a `q` entry of a series' term counts as
    /// ([`DrivenLinearPart::size`]).
    pub(super) q_weights: [f64; 2],
    pub(super) count: usize,
    pub(super) length: f64,
    pub(super) negligible: f64,
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
