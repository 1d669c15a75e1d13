//! What the driven groups' event values, sampled over a substep, say: clear of every
//! event, or a crossing to look for.

use super::super::events::NEAR_EVENT;
use super::super::{Events, NO_EVENT};
use crate::physics::friction::EVENT_TOLERANCE;
use crate::physics::friction::group::GroupInput;

/// Whether a group's event value keeps it clear of its event (as a sample of the whole
/// system's exponential substep must be, [`NEAR_EVENT`]); not a NaN.
pub(super) fn clear(event: f64) -> bool {
    event <= -NEAR_EVENT
}

/// Whether the parabola through each group's event values at a substep's start, its
/// stage (the fraction `c` of it on) and its end keeps as clear of the event within the
/// substep as the samples must be ([`clear`]): a limit touched and left again between
/// them shows.
pub(super) fn peaks_clear(first: &Events, stage: &Events, last: &Events, c: f64) -> bool {
    first
        .as_flattened()
        .iter()
        .zip(stage.as_flattened())
        .zip(last.as_flattened())
        .all(|((&e0, &e1), &e2)| e0 == NO_EVENT || peak_clear(e0, e1, e2, c))
}

/// [`peaks_clear`] of one group's event values `e0`, `e1` (the fraction `c` on) and `e2`.
pub(super) fn peak_clear(e0: f64, e1: f64, e2: f64, c: f64) -> bool {
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
pub(super) fn all_clear(events: &Events) -> bool {
    events
        .iter()
        .flatten()
        .all(|&event| event == NO_EVENT || clear(event))
}

/// Whether no event value of `events` is past its event (nor a NaN).
pub(super) fn none_past(events: &Events) -> bool {
    events.iter().flatten().all(|&event| event <= EVENT_TOLERANCE)
}

/// Whether every group whose event values are `events` is in the mode that deciding
/// there finds (its event value below zero: sliding where its sticking force is outside
/// its ellipse, [`GroupInput::outside`]). A group may end a step within the event
/// tolerance past its event, still in its mode, where a step from a restored state,
/// which decides its modes itself, would find the other (docs/specification.md 7: it must
/// go on the same way): such an end does not prepare its own modes for the next step; the
/// outputs made from its states decide them there, as a restored state's step does (from
/// the same trial forces, the same bits).
pub(super) fn ends_decided(events: &Events) -> bool {
    events.iter().flatten().all(|&event| event < 0.0)
}

/// Whether no event value of `events` is a NaN.
pub(super) fn all_numbers(events: &Events) -> bool {
    events.iter().flatten().all(|event| !event.is_nan())
}

/// How the driven groups' event values run over a substep
/// ([`super::groups::DrivenGroups::samples`]).
pub(super) enum Samples {
    /// Every group stays in its mode.
    Clear,
    /// A group crosses its event: the first to, as their courses foretell.
    Crossing(Crossing),
}

/// A driven group that crosses its event within a substep: the group, where its course
/// first reaches the event (the substep's fraction), and the first sample past the
/// event (its fraction and value), which bounds the search for the crossing.
#[derive(Clone, Copy, Debug)]
pub(super) struct Crossing {
    pub(super) group: usize,
    pub(super) guess: f64,
    pub(super) past: (f64, f64),
}

/// Below this share of its utilisation in its lesser direction, a damped group slides
/// in one direction: its force hardly turns on the ellipse, and exponential Euler is
/// within the tolerance (DDT's slide yardstick: the lateral case's shares are 1e-7 to
/// 1e-4, a few up to 1e-3, and Euler is taken; the combined case's mostly 1e-3 to 0.5,
/// where it would not be).
pub(super) const ONE_DIRECTION_SHARE: f64 = 1e-3;

/// Whether every group of `inputs` whose sticking force is outside its ellipse has at
/// most [`ONE_DIRECTION_SHARE`] of its utilisation in its lesser direction.
pub(super) fn in_one_direction(inputs: &[GroupInput]) -> bool {
    inputs
        .iter()
        .all(|input| input.within_share_of_one_direction(ONE_DIRECTION_SHARE))
}
