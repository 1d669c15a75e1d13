//! The driven groups' substeps over a part of a cascade step: exponential Euler or
//! exprb42 where they are mild, linearly implicit Euler extrapolation where they are stiff.

use super::super::course::crossing_search;
use super::super::events::InteriorSearch;
use super::super::exponential::{
    EXPRB42_MARGIN, Exprb42Substep, euler_within, exponential_euler, exprb42, negligible_term, resize,
    resize_euler, resized,
};
use super::super::extrapolation::Row;
use super::super::implicit::{IMPLICIT_SEQUENCE, shifted_inverse};
use super::super::{Events, Group, MAX_BRANCHES, NO_EVENT, NOT_CARRIED, SIZE, SlidingStep, Vector};
use super::groups::{DrivenGroups, Slopes};
use super::lengths::{
    ROUNDINGS, SHARPER_MARGIN, SHARPER_WITHIN, aimed_factor, carried_first_substep, in_equal_pieces,
    pieces_of, sharper_factor,
};
use super::samples::{Samples, all_clear, all_numbers, ends_decided, in_one_direction, none_past};
use super::shaping::EndShaping;
use super::{Cascade, DRIVEN, Driven, MAX_SUBSTEPS, Q, entry};
use crate::physics::friction::EVENT_TOLERANCE;
use crate::physics::friction::group::MAX_MEMBERS;

/// Changes of mode of the driven groups within one step before the whole-system path
/// takes the step.
pub(super) const MAX_DRIVEN_SWITCHES: usize = 2 * MAX_BRANCHES;

/// How a stiff substep of the driven groups ended ([`SlidingStep::driven_implicit_substep`]).
pub(super) enum Implicit {
    /// Accurate: the end, and the factor by which the next substep may grow.
    Taken(Driven, f64),
    /// The rows did not agree, or a solve failed: a shorter substep.
    Shorter,
    /// A group may touch its limit inside: the whole-system path takes the step.
    NearEvent,
}

impl SlidingStep<'_> {
    /// The driven groups over the step, side by side, in substeps of one length: by
    /// exponential Euler where the slide is in one direction and that is within the
    /// tolerance, else by exprb42 ([`super::groups::DrivenLinearPart`]), or for a stiff slide by
    /// linearly implicit Euler extrapolation, whose solves take each group's own two by
    /// two. A group that crosses its event in an explicit substep changes mode there
    /// (in `groups`' modes; see the module's doc). The driven vector at the end, or
    /// `None` where a group's course is not sure, a group at its event moves back from
    /// it, a stiff substep nears an event, or they need more than [`MAX_SUBSTEPS`]. With
    /// the end, what the limits take off the groups' sticking forces there where the last
    /// substep's end was evaluated as the outputs are made (an explicit substep's,
    /// [`SlidingStep::shaped_at`]), and whether every driver ends in the mode deciding
    /// there finds.
    pub(super) fn driven_step(
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
    /// [`super::super::implicit`] takes the whole system), each Euler step solving
    /// `(I - s J) db = s f` group by group with its two by two of the Jacobian at the
    /// substep's start. The `q`s are known: each step sets them where it ends.
    pub(super) fn driven_implicit_substep(
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
