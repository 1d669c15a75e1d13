//! Where each quantity of a sliding step sits: the coupled vector of the model's states
//! and the branch deflections ([`Layout`], packed from and unpacked to the states and the
//! sliders), and the slots of the groups' branches with their constants at a step
//! ([`Slot`], [`SlidingSlots`]), laid out once per model and refreshed as the load and
//! speed move.

use super::super::group::{GroupInput, GroupLaw, MAX_MEMBERS, Members};
use super::super::{Direction, Friction, Group, Limits, MAX_BRANCHES, SliderState};
use super::cascade::Cascade;
use super::{Modes, SIZE, Vector};
use crate::physics::state_space::{MAX_STATES, StateSpace, StateVector, by_state_count};

/// Where each quantity of a step sits in the coupled vector: first the model's states
/// that carry no contact element (each with its own equation), then every branch
/// deflection of each element. An element's own state is the weighted sum of its branches,
/// so it has no entry: the vector is as short as the model and law make it (two entries
/// for RLT with Coulomb, up to twelve), which is what the substeps, the error control and
/// the stiff method's Jacobian cost in proportion to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Layout {
    /// The model state of each of the first `free_count` entries.
    pub(super) free: [usize; MAX_STATES],
    pub(super) free_count: usize,
    /// By present element.
    pub(super) elements: [ElementEntries; Direction::COUNT],
    pub(super) element_count: usize,
    /// Branches per element, and every branch's `w_i`.
    pub(super) branches: usize,
    pub(super) weights: [f64; MAX_BRANCHES],
    /// Entries in use.
    pub(super) size: usize,
    /// By model state, the entries it is the weighted sum of ([`Layout::model_states`]).
    pub(super) sums: [StateSum; MAX_STATES],
    /// The model's states (zero: not laid out yet).
    pub(super) states: usize,
}

/// A model state as a sum of entries of the coupled vector: from `first` on, with
/// `weights` (1 and zeros for a free state, each branch's `w_i` for an element's state,
/// all zero for a state past the model's). Every sum has [`MAX_BRANCHES`] terms, those of
/// weight zero adding nothing, so that two states are summed side by side.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct StateSum {
    pub(super) first: usize,
    pub(super) weights: [f64; MAX_BRANCHES],
}

impl StateSum {
    /// The sum in `z`.
    #[inline(always)]
    fn of(&self, z: &Vector) -> f64 {
        // One bounds check for the terms, not one a term.
        let terms = &z[self.first..self.first + MAX_BRANCHES];
        let mut sum = 0.0;
        for i in 0..MAX_BRANCHES {
            sum += self.weights[i] * terms[i];
        }
        sum
    }
}

/// Where a present element's branches are: its direction, its model state and its first
/// branch's entry (the others follow).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct ElementEntries {
    pub(super) direction: usize,
    pub(super) state: usize,
    pub(super) first: usize,
}

impl Layout {
    pub(super) fn new(friction: &Friction, states: usize) -> Self {
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

    pub(super) fn elements(&self) -> &[ElementEntries] {
        &self.elements[..self.element_count]
    }

    /// The entry of branch `i` of direction `d`'s element, if the model has one.
    pub(super) fn branch_entry(&self, d: usize, i: usize) -> Option<usize> {
        self.elements()
            .iter()
            .find(|e| e.direction == d)
            .map(|e| e.first + i)
    }

    /// The model's states (or rates) of a coupled vector (or its rates): the free entries,
    /// and each element's state `sum w_i b_i`. Two states at a time, written together:
    /// the product with the state matrix reads them two at a time, at once.
    #[inline]
    pub(super) fn model_states(&self, z: &Vector) -> StateVector {
        by_state_count!(self.states, N => self.model_states_for::<N>(z))
    }

    /// [`Layout::model_states`] of a model of `N` states: the pairs that hold them, the
    /// states past them left zero.
    #[inline]
    pub(super) fn model_states_for<const N: usize>(&self, z: &Vector) -> StateVector {
        let mut x = StateVector::zeros();
        let sum = |s: &StateSum| s.of(z);
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

    /// Model state `k` of a coupled vector: [`Layout::model_states`]' entry `k`, the same
    /// bits.
    #[inline]
    pub(super) fn model_state(&self, z: &Vector, k: usize) -> f64 {
        self.sums[k].of(z)
    }

    /// By entry, the model state it makes and its weight there: 1 for a free state, `w_i`
    /// for a branch deflection (the columns of [`Layout::model_states`] as a matrix, read
    /// from its rows: a weight of zero is no entry of that state).
    pub(super) fn made_states(&self) -> [(usize, f64); SIZE] {
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

    /// The coupled vector of the model's states `x` and the offsets of `sliders`. (Inlined,
    /// as [`Layout::unpack`]: made where it is used, not copied out of a call; DDT's
    /// slide steps are about 1 % faster.)
    #[inline(always)]
    pub(super) fn pack(&self, x: &StateVector, sliders: &SliderState) -> Vector {
        let mut z = [0.0; SIZE];
        self.pack_into(x, sliders, &mut z);
        z
    }

    /// [`Layout::pack`] into `z`, whose entries past the layout's are zero (made where it
    /// is kept: a vector returned is copied by a call).
    #[inline(always)]
    pub(super) fn pack_into(&self, x: &StateVector, sliders: &SliderState, z: &mut Vector) {
        for j in 0..self.free_count {
            z[j] = x[self.free[j]];
        }
        for e in self.elements() {
            let (state, offsets) = (x[e.state], &sliders.offsets[e.direction]);
            if self.branches == MAX_BRANCHES {
                // Pair by pair, as the model states' sums read them (a pair read across
                // two separate stores stalls until both are written).
                for i in (0..MAX_BRANCHES).step_by(2) {
                    z[e.first + i..e.first + i + 2]
                        .copy_from_slice(&[state + offsets[i], state + offsets[i + 1]]);
                }
            } else {
                for i in 0..self.branches {
                    z[e.first + i] = state + offsets[i];
                }
            }
        }
    }

    /// The model's states and the branch offsets of `z` (linear: also rates from rates).
    #[inline(always)]
    pub(super) fn unpack(&self, z: &Vector, sliders: &mut SliderState) -> StateVector {
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
pub(super) struct Slot {
    pub(super) group: usize,
    pub(super) branch: usize,
    pub(super) law: GroupLaw,
    pub(super) entries: [usize; MAX_MEMBERS],
    pub(super) states: [usize; MAX_MEMBERS],
    /// Each member's relaxation rate, the diagonal entry of its element's state.
    pub(super) relaxation: [f64; MAX_MEMBERS],
    /// Its branch's share of each direction's limit, `phi_i`, and `1 / phi_i`: a step's
    /// member limits are `phi_i Fmax` and their reciprocals `(1 / phi_i) (1 / Fmax)`, so
    /// that a refresh divides once a direction, not once a member.
    pub(super) limit_fraction: f64,
    pub(super) inverse_limit_fraction: f64,
}

impl Slot {
    /// Its members' entries of a coupled vector (or of its rates); zero past its members,
    /// as the group's law takes them.
    pub(super) fn of(&self, values: &Vector) -> Members {
        let mut of = [0.0; MAX_MEMBERS];
        for m in self.law.members() {
            of[m] = values[self.entries[m]];
        }
        of
    }

    /// A sticking spring group's event value at `z`: its utilisation less one, a function
    /// of its deflections alone. `None` for a sliding or damped group, whose value needs
    /// the rates.
    pub(super) fn event_from_deflections(&self, z: &Vector, modes: &Modes) -> Option<f64> {
        (!modes[self.group][self.branch] && !self.law.damped()).then(|| self.utilisation(z) - 1.0)
    }

    /// The utilisation of a spring group's forces at its deflections in `z`.
    pub(super) fn utilisation(&self, z: &Vector) -> f64 {
        let input = GroupInput {
            deflection: self.of(z),
            ..GroupInput::at_rest(&self.law)
        };
        input.utilisation(&input.spring_force())
    }

    /// Scales a spring group's deflections in `z`, whose forces have `utilisation`, so
    /// that its force is on the ellipse (along its own direction).
    pub(super) fn put_on_ellipse(&self, z: &mut Vector, utilisation: f64) {
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
    pub(super) made_for: [u64; 2 * Direction::COUNT],
    pub(super) layout: Layout,
    pub(super) slots: [Slot; Group::COUNT * MAX_BRANCHES],
    pub(super) count: usize,
    /// Whether every slot's group is damped (made with the slots).
    pub(super) all_damped: bool,
    /// The slots' cascade, where they form one (made with the slots, [`Cascade::of`]).
    pub(super) cascade: Option<Cascade>,
}

/// Whether `a` and `b` hold the same bits: one pass without a branch (an array
/// comparison is a call to `memcmp`, which stalls on the stores just made).
fn same_bits(a: &[u64], b: &[u64]) -> bool {
    a.iter().zip(b).fold(0, |differ, (x, y)| differ | (x ^ y)) == 0
}

impl Friction {
    /// Makes [`Friction::sliding_slots`] for a step of `system` at `limits`, unless they
    /// were made for the same.
    pub(super) fn lay_out_sliding(&mut self, system: &StateSpace, limits: &Limits) {
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
        } else if same_bits(&made_for, &laid_out.made_for) {
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
    pub(super) fn refresh_sliding_slots(&mut self, system: &StateSpace, limits: &Limits) {
        let inverse_limits = limits.0.map(f64::recip);
        let laid_out = &mut self.sliding_slots;
        for slot in &mut laid_out.slots[..laid_out.count] {
            for m in slot.law.members() {
                let (state, d) = (slot.states[m], slot.law.direction[m]);
                slot.relaxation[m] = system.a[(state, state)];
                slot.law.set_limit_and_inverse(
                    m,
                    slot.limit_fraction * limits.0[d],
                    slot.inverse_limit_fraction * inverse_limits[d],
                );
            }
        }
    }

    /// The slots of [`Friction::lay_out_sliding`], written where they are kept: their
    /// members here, their limits and relaxation rates as every refresh makes them.
    pub(super) fn fill_sliding_slots(&mut self, system: &StateSpace, limits: &Limits) {
        let groups = Self::groups_of(&self.group_members);
        let laid_out = &mut self.sliding_slots;
        laid_out.count = 0;
        for group in groups {
            for (i, branch) in self.branches.iter().enumerate() {
                let slot = &mut laid_out.slots[laid_out.count];
                *slot = Slot {
                    group: group as usize,
                    branch: i,
                    limit_fraction: branch.limit_fraction,
                    inverse_limit_fraction: branch.limit_fraction.recip(),
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
        laid_out.all_damped = laid_out.slots[..laid_out.count]
            .iter()
            .all(|slot| slot.law.damped());
        laid_out.cascade = Cascade::of(
            &laid_out.slots[..laid_out.count],
            &laid_out.layout,
            self.cascade_driver,
        );
        self.refresh_sliding_slots(system, limits);
    }
}
