//! How long a driven substep is: aimed at a share of exprb42's margin, the rest of the
//! step in equal pieces, and the first substep's length carried to the next step.

use super::super::HighOrderSubsteps;
use super::super::exponential::EXPRB42_MARGIN;
use crate::physics::math;

/// The share of exprb42's margin ([`EXPRB42_MARGIN`]) that its substeps' lengths aim at
/// ([`aimed_factor`]).
pub(super) const AIM: f64 = 0.8;

/// How much longer than a substep whose estimate was `error` one would be whose estimate
/// would be [`AIM`] of exprb42's margin (it grows as the length's fourth power). The
/// estimate is of a third-order solution, and exprb42's end was within 0.14 of it over
/// DDT's slides ([`EXPRB42_MARGIN`]), so a substep that meets its aim is inside the
/// tolerance; aimed higher, a force that turns after a group starts sliding needs fewer
/// substeps for the same step (over the slide yardstick's combined case, all exprb42
/// attempts fell from 4941 to 4711 with the step in equal pieces, against aiming at a
/// fifth of the margin as the whole-system path does; none more were thrown away).
pub(super) fn aimed_factor(error: f64) -> f64 {
    let share = (error / EXPRB42_MARGIN).max(1e-10);
    (AIM / share).sqrt().sqrt()
}

/// The next substep's length where `rest` of the step remains and a substep of `allowed`
/// would meet its aim: the rest in equal pieces no longer than that, so that no short
/// piece is left at the end.
pub(super) fn in_equal_pieces(rest: f64, allowed: f64) -> f64 {
    let pieces = pieces_of(rest, allowed);
    if pieces <= 1.0 { rest } else { rest / pieces }
}

/// How many pieces no longer than `allowed` make `rest`: a rest a few roundings past a
/// whole number of them is that number (one more piece would be a substep for nothing).
pub(super) fn pieces_of(rest: f64, allowed: f64) -> f64 {
    (rest / allowed * (1.0 - ROUNDINGS)).ceil()
}

/// The few roundings by which a piece of [`in_equal_pieces`] may be longer than allowed.
pub(super) const ROUNDINGS: f64 = 4.0 * f64::EPSILON;

/// The length exprb42's first substep of a step could have had (at [`aimed_factor`], or
/// longer by its quartic estimate, [`sharper_factor`]), carried to the next step
/// ([`HighOrderSubsteps`]; its second is not carried). A force that turns after a group
/// starts sliding takes tens of steps to settle, its estimate at the step's start
/// falling by a few percent a step; each of those steps would otherwise try the whole
/// step, come back too long and take shorter substeps than it needs. Over 4000 steps of
/// the slide yardstick's combined case (before the quartic estimate), the first attempts
/// that came back too long went from 500 to 12, and all exprb42 attempts from 5312 to
/// 4941 (4812 to 4925 of them taken).
pub(super) fn carried_first_substep(length: f64, factor: f64) -> HighOrderSubsteps {
    [length * factor, f64::INFINITY]
}

/// The most exprb42's third-order estimate may be, in tolerances, for its own error to be
/// estimated from the remainder's quartic part ([`super::groups::quartic_estimate`]): at
/// most 1e-9 of the largest state (an entry's tolerance is at most twice the largest
/// state's), as far as `cargo bench --bench exponential_probe` compares that estimate
/// with the error (beyond, to 2e-9, DDT's error reached 1.19 of it).
pub(super) const SHARPER_WITHIN: f64 = 100.0 * EXPRB42_MARGIN;

/// How many times the tolerance exprb42's error estimated from the remainder's quartic
/// part may be. Over DDT's slides to 3.5 s, past the slip's first reversal (`cargo bench
/// --bench exponential_probe`, columns "42/sharp" and "42 below"), the error was at most
/// 0.84 of that estimate where the estimate was at least a fifth of the tolerance, and
/// at most 0.35 tolerances where it was less: a substep taken by it is within about half
/// the tolerance (0.68 at the largest ratio over every model, RingBody's 1.14), as one
/// taken by the third-order estimate is within 0.7 of it. At 0.4 the passes with a
/// reversal took 0.6 % more instructions.
pub(super) const SHARPER_MARGIN: f64 = 0.6;

/// How much longer than a substep whose quartic estimate was `sharp` one would be whose
/// estimate would be [`AIM`] of [`SHARPER_MARGIN`] (it grows as the length's fifth
/// power), and no longer than the third-order estimate `error` would be within
/// [`SHARPER_WITHIN`] there.
pub(super) fn sharper_factor(error: f64, sharp: f64) -> f64 {
    let by_own_error = math::powf(AIM * SHARPER_MARGIN / sharp.max(1e-10 * SHARPER_MARGIN), 0.2);
    let trusted = (AIM * SHARPER_WITHIN / error.max(1e-10)).sqrt().sqrt();
    by_own_error.min(trusted)
}
