//! The friction limit (docs/specification.md 4c): a rate-independent slider in series
//! with each contact element of a model.
//!
//! A model names its contact elements ([`ContactElement`]: which state is the element's
//! deflection, its stiffness and damping, and which outputs its force feeds). The law
//! ([`FrictionLaw`]) splits each element into parallel branches ([`crate::physics::brush`]):
//! one for `Coulomb`, four for `Brush`. Branch `i` of every element carries the fractions
//! `w_i` of the stiffness and damping and `phi_i` of the limit, and has its own deflection
//! `b_i`; the model's state is the stiffness-weighted sum `U = sum w_i b_i`, and the
//! branches are stored as their offsets `b_i - U` (zero until a branch slides).
//!
//! Branch `i` of the longitudinal and lateral elements shares one friction ellipse
//! (a planar [`group`]); branch `i` of DDT's yaw element has its own limit. A group sticks
//! (each `b_i` follows the model's equations with `b_i` in place of `U`) or slides (its
//! force stays on the limit, [`group::GroupInput::evaluate`]).
//!
//! How a step is computed ([`crate::physics::Tire::step`]):
//! 1. The limits at the step's load; a spring force outside them is put on them at once.
//!    They are kept with the step map ([`Friction::prepare`], in [`sticking`]), and from
//!    the second step at the same operating point so are each element's force and
//!    force-rate rows.
//! 2. If every group sticks, the exact linear step of the model (the stepper) moves `U`,
//!    and `b_i - U` decays with the element's relaxation rate
//!    ([`Friction::sticking_step`], in [`sticking`]). The step is kept if no branch can
//!    have reached its limit within it. Under held inputs an element whose state nothing
//!    else drives is bounded exactly by its force at the two ends, and one driven only by
//!    such states (DDT's lateral) by a bound from the ends of its drivers; both hold at
//!    any step size. The others, and those when the second bound is too coarse, by
//!    [`force_bound`], trusted only for steps short against the dynamics, so a longer
//!    step is bounded part by part.
//! 3. Otherwise, where every branch moves on its own (RLT) and the driving inputs are
//!    held, [`separable`] steps each branch by itself as a hybrid system: exact while it
//!    sticks, its ellipse angle integrated while it slides, its mode changes located.
//! 4. Otherwise (or where that gives up) [`sliding`] integrates the branches and the
//!    model together, piece by piece between stick/slide events located in time, to 1e-12.
//!
//! Here: the [`Friction`] type; [`vocabulary`]: the law, directions, groups, elements,
//! limits and branch states; [`sticking`]: the check that a step sticks throughout;
//! [`group`]: the law of one group; [`separable`]: a step with sliding, branch by branch;
//! [`sliding`]: a step with sliding, all together.

pub mod group;
pub mod separable;
pub mod sliding;
mod sticking;
mod vocabulary;

/// Event values by group and branch.
pub use sliding::{Events, HighOrderSubsteps, NO_EVENT, NOT_CARRIED};
pub use sticking::{LinearStep, force_bound};
pub use vocabulary::{
    ContactElement, ContactElements, Direction, EVENT_TOLERANCE, Group, InverseLimits, Limits, MAX_BRANCHES,
    SliderState,
};

use super::brush::Branch;
use super::parameters::FrictionLaw;
use super::state_space::{MAX_STATES, StateSpace, StateVector};
use crate::physics::math;
use sticking::{PresentElement, StickingCheck};

/// The friction part of a tire: the law, the model's elements and the branches' states.
#[derive(Clone, Debug, PartialEq)]
pub struct Friction {
    pub law: FrictionLaw,
    pub branches: &'static [Branch],
    /// One over the smallest `phi_i / w_i` (below that fraction of the limit every
    /// branch sticks).
    inverse_first_breakpoint: f64,
    /// The smallest `phi_i / w_i`: the share of an element's limit below which every branch
    /// sticks.
    first_breakpoint: f64,
    /// By group and branch, `1 / (phi_i / w_i)^2`: a sticking branch's utilisation per
    /// unit of its element's; 0 where the model has no such group or the law no such
    /// branch ([`Friction::together_branch_weights`]).
    together_branch_weights: [[f64; MAX_BRANCHES]; Group::COUNT],
    /// Which directions this model has an element in.
    present_directions: [bool; Direction::COUNT],
    /// Which directions each [`Group`] of this model has.
    group_members: [[bool; Direction::COUNT]; Group::COUNT],
    /// The elements the model has, with their directions (the first `present_count`).
    present: [PresentElement; Direction::COUNT],
    /// The same by direction, all zero where the model has none (its force is then zero):
    /// the events while all stick take every direction without a branch.
    by_direction: [PresentElement; Direction::COUNT],
    present_count: usize,
    /// By present element: whether its state is driven by no other state at any operating
    /// point. With held inputs such a state moves monotonically towards its equilibrium,
    /// and so does any force affine in it: the force's values at the ends of a step bound
    /// it exactly.
    undriven: [bool; Direction::COUNT],
    /// Whether every present element is undriven.
    all_undriven: bool,
    /// By present element: whether its state is driven only by undriven states (DDT's
    /// lateral, driven by the yaw lag). With held inputs those move monotonically, so the
    /// element's drive is bounded by its values at the ends of the step, and so is the
    /// element ([`Friction::rigorous_bounds`]).
    lag_bounded: [bool; Direction::COUNT],
    /// Whether every present element is undriven or lag-bounded.
    all_rigorous: bool,
    /// The states whose rates the direct sticking check needs, with inputs held and
    /// ramped: each element bounded through its rates needs its own state's, and a
    /// damper also those of the states that drive it.
    rates_needed: [[bool; MAX_STATES]; 2],
    /// Whether any element has a damper.
    damped: bool,
    /// Where the elements form a cascade (DDT), the state that drives it: the yaw
    /// element's, damped and driven by no other state, while each planar element's state
    /// is driven by its own and that one only, at any operating point
    /// ([`sliding::cascade`]).
    cascade_driver: Option<usize>,
    /// The largest `C / D` of the damped elements (how fast a sliding damper relaxes), 1/s.
    fastest_slide_rate: f64,
    /// For a passive model ([`crate::physics::models::TireLagModel::passive`]), the weights
    /// of its stored energy `sum q_j x_j^2 / 2`: about the equilibrium of held inputs that
    /// energy never grows, which bounds every force at any step size.
    passive_energy: Option<StateVector>,
    pub elements: ContactElements,
    state: SliderState,
    /// Whether `state` has every branch at its element's state ([`SliderState::together`]),
    /// kept with it: the usual case, checked first on every step.
    together: bool,
    /// The sticking check made for the last step map ([`Friction::prepare`]).
    check: StickingCheck,
    /// The branches as the last sliding step laid them out.
    sliding_slots: sliding::SlidingSlots,
    /// How long the eighth-order pair's first two substeps of the last step integrated
    /// with sliding (not by RLT's branch-by-branch step) could have been, s: where the
    /// next such step's first two substeps by the pair start ([`HighOrderSubsteps`]).
    /// Infinite where it took no such substep, and after a reset or a lift-off; steps
    /// that stick throughout leave them.
    high_order_substeps: HighOrderSubsteps,
}

impl Friction {
    /// `None` for the Unlimited law. `coupling` is the pattern of the model's state matrix
    /// over its operating points: entry (i, j) zero where state j never drives state i.
    pub fn new(
        law: FrictionLaw,
        elements: ContactElements,
        coupling: &[[f64; MAX_STATES]; MAX_STATES],
    ) -> Option<Self> {
        let state_undriven: [bool; MAX_STATES] =
            std::array::from_fn(|k| coupling[k].iter().enumerate().all(|(j, &c)| j == k || c == 0.0));
        let mut lag_bounded = [false; Direction::COUNT];
        for (lag_bounded, element) in lag_bounded.iter_mut().zip(elements.iter().flatten()) {
            let k = element.state;
            *lag_bounded = !state_undriven[k]
                && coupling[k]
                    .iter()
                    .enumerate()
                    .all(|(j, &c)| j == k || c == 0.0 || state_undriven[j]);
        }
        let mut undriven = [false; Direction::COUNT];
        let mut rates_needed = [[false; MAX_STATES]; 2];
        for (undriven, element) in undriven.iter_mut().zip(elements.iter().flatten()) {
            let k = element.state;
            *undriven = coupling[k].iter().enumerate().all(|(j, &c)| j == k || c == 0.0);
            // Held inputs bound an undriven element without rates.
            let cases: &[usize] = if *undriven { &[1] } else { &[0, 1] };
            for &case in cases {
                let needed = &mut rates_needed[case];
                needed[k] = true;
                if element.damping > 0.0 {
                    for (j, &c) in coupling[k].iter().enumerate() {
                        needed[j] |= c != 0.0;
                    }
                }
            }
        }
        let cascade_driver = elements[Direction::Yaw as usize]
            .filter(|yaw| yaw.damping > 0.0 && state_undriven[yaw.state])
            .map(|yaw| yaw.state)
            .filter(|&driver| {
                [Direction::Longitudinal, Direction::Lateral]
                    .into_iter()
                    .filter_map(|d| elements[d as usize])
                    .all(|e| {
                        let k = e.state;
                        coupling[k]
                            .iter()
                            .enumerate()
                            .all(|(j, &c)| j == k || j == driver || c == 0.0)
                    })
            });
        let first_breakpoint = law
            .branches()
            .iter()
            .map(Branch::breakpoint)
            .fold(f64::INFINITY, f64::min);
        let by_direction: [PresentElement; Direction::COUNT] = std::array::from_fn(|d| {
            elements[d].map_or(PresentElement::default(), |e| PresentElement {
                direction: d,
                state: e.state,
                stiffness: e.stiffness,
                damping: e.damping,
            })
        });
        let group_members = Group::ALL.map(|g| {
            let mut members = [false; Direction::COUNT];
            for &d in g.directions() {
                members[d as usize] = elements[d as usize].is_some();
            }
            members
        });
        let together_branch_weights = Group::ALL.map(|g| {
            std::array::from_fn(|i| match law.branches().get(i) {
                Some(branch) if group_members[g as usize].contains(&true) => branch.breakpoint().powi(-2),
                _ => 0.0,
            })
        });
        (law != FrictionLaw::Unlimited).then(|| Friction {
            law,
            branches: law.branches(),
            inverse_first_breakpoint: 1.0 / first_breakpoint,
            first_breakpoint,
            together_branch_weights,
            present_directions: elements.map(|e| e.is_some()),
            present: {
                let mut present = [PresentElement::default(); Direction::COUNT];
                let with_element = by_direction.iter().zip(&elements).filter(|(_, e)| e.is_some());
                for (slot, (element, _)) in present.iter_mut().zip(with_element) {
                    *slot = *element;
                }
                present
            },
            by_direction,
            present_count: elements.iter().flatten().count(),
            all_undriven: undriven[..elements.iter().flatten().count()].iter().all(|&u| u),
            all_rigorous: (0..elements.iter().flatten().count()).all(|e| undriven[e] || lag_bounded[e]),
            lag_bounded,
            undriven,
            rates_needed,
            damped: elements.iter().flatten().any(|e| e.damping > 0.0),
            cascade_driver,
            fastest_slide_rate: elements
                .iter()
                .flatten()
                .filter(|e| e.damping > 0.0)
                .map(|e| e.stiffness / e.damping)
                .fold(0.0, f64::max),
            group_members,
            elements,
            passive_energy: None,
            state: SliderState::AT_REST,
            together: true,
            check: StickingCheck::default(),
            sliding_slots: sliding::SlidingSlots::default(),
            high_order_substeps: NOT_CARRIED,
        })
    }

    /// The weights of a passive model's stored energy (`None`: not passive).
    pub fn with_passive_energy(mut self, weights: Option<StateVector>) -> Self {
        self.passive_energy = weights;
        self
    }

    /// The groups this model has, each with whether its elements are damped.
    pub fn groups(&self) -> impl Iterator<Item = Group> + use<> {
        Self::groups_of(&self.group_members)
    }

    /// The groups that have a member in `group_members` ([`Friction::group_members`]).
    fn groups_of(
        group_members: &[[bool; Direction::COUNT]; Group::COUNT],
    ) -> impl Iterator<Item = Group> + use<> {
        let members = *group_members;
        Group::ALL
            .into_iter()
            .filter(move |&g| members[g as usize].contains(&true))
    }

    /// Puts every branch at its element's state (at rest, or after states were set from
    /// outside), all sticking.
    pub fn reset(&mut self) {
        self.set_state(SliderState::AT_REST);
        self.high_order_substeps = NOT_CARRIED;
    }

    /// Each branch's offset and whether its groups slide.
    pub fn state(&self) -> &SliderState {
        &self.state
    }

    /// How long the eighth-order pair's first two substeps of the next sliding step may
    /// be, s ([`HighOrderSubsteps`]). Part of the tire's state, as the FMU state holds
    /// it: a step's substeps depend on it, and so its values to within the tolerance.
    pub fn high_order_substeps(&self) -> HighOrderSubsteps {
        self.high_order_substeps
    }

    /// Replaces [`Friction::high_order_substeps`] (from an FMU state).
    pub fn set_high_order_substeps(&mut self, lengths: HighOrderSubsteps) {
        self.high_order_substeps = lengths;
    }

    pub fn set_state(&mut self, state: SliderState) {
        self.state = state;
        self.together = state.together();
    }

    /// Whether every branch is at its element's state and sticks.
    pub fn together(&self) -> bool {
        self.together
    }

    /// Whether the sticking check takes a step from the current branches. A step that
    /// starts with a branch sliding (on its limit, apart from its element) goes to the
    /// sliding path, which decides at the step's load whether it sticks, and where.
    pub fn may_stick_throughout(&self) -> bool {
        self.together || !self.state.any_sliding()
    }

    /// `1 / limit` at `load` by direction for the elements the model has, zero for the
    /// others; `None` if one of their limits is zero (or too small to invert): that
    /// direction is frictionless and its branches carry no force, which only the law of
    /// each group in its mode says.
    #[inline]
    pub fn inverse_limits(&self, law: &InverseLimits, load: f64) -> Option<[f64; Direction::COUNT]> {
        law.at(load, &self.present_directions)
    }

    /// Each group's utilisation `sum (F_k / L_k)^2` while every branch is with its element
    /// and sticks, at states `x` with rates `x_rates` (the force sticking needs, with a
    /// damper), with the limits given as [`Friction::inverse_limits`]; zero where there is
    /// no such group. Branch `i`'s event value is then `utilisation * weight - 1`
    /// ([`Friction::together_branch_weights`]).
    #[inline]
    pub fn together_utilisation(
        &self,
        inverse_limits: &[f64; Direction::COUNT],
        x: &[f64; MAX_STATES],
        x_rates: &[f64; MAX_STATES],
    ) -> [f64; Group::COUNT] {
        // Every direction, those without an element adding zero: no branch, and the sums
        // stay in registers.
        let mut utilisation = [0.0; Group::COUNT];
        for (direction, (e, inverse_limit)) in Direction::ALL
            .iter()
            .zip(self.by_direction.iter().zip(inverse_limits))
        {
            let ratio = (e.stiffness * x[e.state] + e.damping * x_rates[e.state]) * inverse_limit;
            utilisation[direction.group() as usize] += ratio * ratio;
        }
        utilisation
    }

    /// By group and branch, its utilisation per unit of its group's
    /// [`Friction::together_utilisation`] while every branch sticks: branch `i` carries
    /// `w_i` of its element's force against `phi_i` of its limit, so its utilisation is the
    /// element's over its breakpoint squared. Positive for every branch that exists (its
    /// breakpoint is finite and positive), zero where there is no such group or branch.
    pub fn together_branch_weights(&self) -> &[[f64; MAX_BRANCHES]; Group::COUNT] {
        &self.together_branch_weights
    }

    /// Whether any element has a damper (DDT): its sliding force is then part of the
    /// outputs, not only of the state motion.
    pub fn damped(&self) -> bool {
        self.damped
    }

    /// Whether every branch moves on its own, so that a step with sliding can take each
    /// branch by itself ([`separable`]): every state of the model (of `states`) is an
    /// undriven, undamped element of the ellipse (RLT).
    pub fn separable(&self, states: usize) -> bool {
        self.all_undriven
            && !self.damped
            && !self.present_directions[Direction::Yaw as usize]
            && self.present_count == states
    }

    /// An estimate of the fastest rate in the system with its sliders, 1/s: diagonal
    /// rates, the frequencies of coupled pairs, and a sliding damper's `C / D`.
    pub fn fastest_rate(&self, system: &StateSpace) -> f64 {
        let n = system.states;
        let a = &system.a;
        // The pairs' squared frequencies compared before the one square root (a square
        // root is monotone: the same value), by plain comparisons (NaN passed over).
        let (mut diagonal, mut pair_squared) = (0.0_f64, 0.0_f64);
        for i in 0..n {
            let rate = a[(i, i)].abs();
            if rate > diagonal {
                diagonal = rate;
            }
            for j in 0..i {
                let squared = (a[(i, j)] * a[(j, i)]).abs();
                if squared > pair_squared {
                    pair_squared = squared;
                }
            }
        }
        diagonal.max(pair_squared.sqrt()).max(self.fastest_slide_rate)
    }

    /// Off the ground for `relaxation_times` lift-off relaxation times: the offsets
    /// relax like the states, and every group sticks.
    pub fn lift_off(&mut self, relaxation_times: f64) {
        let decay = math::exp(-relaxation_times);
        let mut state = self.state;
        state.offsets.iter_mut().flatten().for_each(|o| *o *= decay);
        state.sliding = SliderState::AT_REST.sliding;
        self.set_state(state);
        self.high_order_substeps = NOT_CARRIED;
    }
}
