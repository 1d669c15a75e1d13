//! Linearly implicit Euler extrapolation of one substep, for a stiff piece: a spring group
//! sliding on the friction ellipse turns its force towards the sliding direction at a rate
//! of about `K |g| / L`, which for a stiff tire at a light load is far faster than
//! anything else in the tire. The explicit midpoint rule would need substeps of that time
//! scale; this method is stable at any.
//!
//! Row `j` takes `n_j` steps of `s = H / n_j`, each solving
//! `(I - s J) (z_{k+1} - z_k) = s f(t_k, z_k)` with the Jacobian `J` of the piece's
//! right-hand side at the substep's start (in closed form: the right-hand side is smooth
//! within a piece). The rows have an expansion in powers of `s` for any `J`, so polynomial
//! extrapolation in `s` ([`super::extrapolation`]) raises the order by one a row, to the
//! same relative 1e-12 as the explicit substep.
//!
//! The Jacobian has a structure the solves use: `J = D + P M`. `M` (states x entries)
//! makes the model's states from the entries; `P` (entries x states) is how each rate
//! moves with them (the model's own rows, and each group's through its sticking rates);
//! `D` holds each group's slopes in its own entries, blocks of at most two. So
//! `I - s J = B - s P M` with `B = I - s D` block diagonal, and by the
//! Sherman-Morrison-Woodbury identity a solve takes `B`'s blocks and a system of the
//! model's few states (`C = I - s M B^-1 P`), not the elimination of all the entries
//! (where the entries are few, at most twice the states, the whole is eliminated).

use super::extrapolation::Row;
use super::{Events, Layout, Modes, SIZE, SlidingStep, Slot, Vector};
#[cfg(doc)]
use crate::physics::friction::group::GroupInput;
use crate::physics::friction::group::{MAX_MEMBERS, MAX_TOGETHER, Members};
use crate::physics::lu;
use crate::physics::state_space::{MAX_STATES, by_state_count};

/// The most entries a Jacobian solved whole has.
const DENSE: usize = 2 * MAX_STATES;

/// Step counts of the rows (the harmonic sequence).
pub(super) const IMPLICIT_SEQUENCE: [usize; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

/// The Jacobian of a piece's right-hand side as `D + P M` (see the module's doc).
pub(super) struct Jacobian<'s> {
    /// Where the entries sit (how many, and the model's states they make): `M` is
    /// [`Layout::model_states`].
    layout: &'s Layout,
    /// `M` by column ([`Layout::made_states`]): the model state an entry makes, and its
    /// weight there.
    makes: [(usize, f64); SIZE],
    /// `P` by entry: how its rate moves with the model's states.
    by_state: [[f64; MAX_STATES]; SIZE],
    /// `M P`, states by states: what every row's `C` starts from.
    made_by_state: [[f64; MAX_STATES]; MAX_STATES],
    /// `D` by slot: the slopes of its members' rates in its members' entries.
    blocks: [[Members; MAX_MEMBERS]; MAX_TOGETHER],
    /// The step's slots, whose entries the blocks are over.
    slots: &'s [Slot],
}

/// What a step of length `s` solves with: `B^-1` by slot, and `C^-1`.
pub(super) struct Factored<'j> {
    jacobian: &'j Jacobian<'j>,
    s: f64,
    inverse_blocks: [[Members; MAX_MEMBERS]; MAX_TOGETHER],
    inverse_capacitance: [[f64; MAX_STATES]; MAX_STATES],
}

impl SlidingStep<'_> {
    /// The Jacobian of the piece's right-hand side at `z`, where its rates are `rates`,
    /// in closed form: the model's rates are linear in the entries (`x = M z`, rates
    /// `A x + B u`); each group's rates are its law's in its inputs
    /// ([`GroupInput::rate_slopes`]), whose deflections are entries and whose sticking
    /// rates `g = (A x)_k + r (b - x_k)` are linear in them. (By differences it took one
    /// evaluation of the whole system per entry.)
    pub(super) fn jacobian(&self, t: f64, z: &Vector, rates: &Vector, modes: &Modes) -> Jacobian<'_> {
        let (layout, a) = (&self.layout, &self.system.a);
        let states = layout.states;
        let mut jacobian = Jacobian {
            layout,
            makes: layout.made_states(),
            by_state: [[0.0; MAX_STATES]; SIZE],
            made_by_state: [[0.0; MAX_STATES]; MAX_STATES],
            blocks: [[[0.0; MAX_MEMBERS]; MAX_MEMBERS]; MAX_TOGETHER],
            slots: self.slots(),
        };
        for j in 0..layout.free_count {
            for l in 0..states {
                jacobian.by_state[j][l] = a[(layout.free[j], l)];
            }
        }
        let x = layout.model_states(z);
        let x_rates = self.system.state_rates(&x, &self.inputs_at(t));
        for (slot_index, slot) in self.slots().iter().enumerate() {
            let input = self.slot_input(slot, &x, &x_rates, z);
            let slopes = input.rate_slopes(modes[slot.group][slot.branch], &slot.of(rates));
            for m in slot.law.members() {
                // Member m's sticking rate moves with the states by `A_k - r e_k` and with
                // its own entry by `r`.
                let (state, relaxation) = (slot.states[m], slot.relaxation[m]);
                for k in slot.law.members() {
                    let by_rate = slopes.by_sticking_rate[k][m];
                    let row = &mut jacobian.by_state[slot.entries[k]];
                    for l in 0..states {
                        row[l] += by_rate * a[(state, l)];
                    }
                    row[state] -= by_rate * relaxation;
                    jacobian.blocks[slot_index][k][m] = by_rate * relaxation + slopes.by_deflection[k][m];
                }
            }
        }
        for c in 0..jacobian.size() {
            let (state, weight) = jacobian.makes[c];
            for l in 0..states {
                jacobian.made_by_state[state][l] += weight * jacobian.by_state[c][l];
            }
        }
        jacobian
    }

    /// `n` linearly implicit Euler steps over `[t, t + length]`; `None` if `I - s J` is
    /// singular or a step is not finite. Also where a limit may have been touched, as the
    /// explicit row finds it, and the sample spacing.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn implicit_row(
        &self,
        t: f64,
        z: &Vector,
        start: (&Vector, &Events),
        jacobian: &Jacobian,
        length: f64,
        n: usize,
        modes: &Modes,
    ) -> Option<Row> {
        let (s, size) = (length / n as f64, jacobian.size());
        let row = if jacobian.worth_structure() {
            let factored = jacobian.factor(s)?;
            self.stepped_row(t, z, start, length, n, modes, |scaled_rates| {
                factored.solve(&scaled_rates)
            })
        } else {
            // In arrays as large as the entries need: the matrix is made, factored and
            // solved with in its own size, not in the largest one's.
            let piece = (t, z, start, length, n, modes);
            match size {
                0..=2 => self.dense_row::<2>(piece, jacobian, s)?,
                3 => self.dense_row::<3>(piece, jacobian, s)?,
                4 => self.dense_row::<4>(piece, jacobian, s)?,
                _ => self.dense_row::<DENSE>(piece, jacobian, s)?,
            }
        };
        row.0[..size].iter().all(|v| v.is_finite()).then_some(row)
    }
}

/// A row's piece: its start time and state, start rates and event values, length, step
/// count and modes.
type Piece<'p> = (f64, &'p Vector, (&'p Vector, &'p Events), f64, usize, &'p Modes);

impl SlidingStep<'_> {
    /// [`SlidingStep::implicit_row`] with `I - s J` eliminated whole, in `N`x`N` arrays
    /// (`N` at least the entries in use); `None` if it is singular.
    fn dense_row<const N: usize>(&self, piece: Piece, jacobian: &Jacobian, s: f64) -> Option<Row> {
        let (t, z, start, length, n, modes) = piece;
        let size = jacobian.size().min(N);
        let mut matrix = jacobian.implicit_matrix::<N>(s);
        let factors = lu::Factors::new(&mut matrix, size)?;
        Some(self.stepped_row(t, z, start, length, n, modes, |scaled_rates| {
            let mut short = [0.0; N];
            short[..size].copy_from_slice(&scaled_rates[..size]);
            let mut solution = [0.0; SIZE];
            solution[..size].copy_from_slice(&factors.solve(short)[..size]);
            solution
        }))
    }
}

impl Jacobian<'_> {
    /// The entries in use.
    fn size(&self) -> usize {
        self.layout.size
    }

    /// Whether the structured solve is the cheaper: where the entries are more than twice
    /// the model's states (DDT's and SecondOrder's Brush, whose branches multiply the
    /// entries). Otherwise `I - s J` is small and eliminated whole.
    fn worth_structure(&self) -> bool {
        self.size() > DENSE.min(2 * self.layout.states)
    }

    /// `s J` by column (its first `size` rows and columns): column `c` is entry `c`'s
    /// weight in the state it makes times that state's column of `P`, and its slot's
    /// block.
    pub(super) fn scaled_columns<const N: usize>(&self, s: f64) -> [[f64; N]; N] {
        let mut columns = [[0.0; N]; N];
        let size = self.size().min(N);
        for (c, column) in columns.iter_mut().enumerate().take(size) {
            let (state, weight) = self.makes[c];
            let factor = s * weight;
            for r in 0..size {
                column[r] = factor * self.by_state[r][state];
            }
        }
        for (j, slot) in self.slots.iter().enumerate() {
            let (entries, count) = (slot.entries, slot.law.count);
            for k in 0..count {
                for m in 0..count {
                    columns[entries[m]][entries[k]] += s * self.blocks[j][k][m];
                }
            }
        }
        columns
    }

    /// `I - s J` as one matrix by row (its first `size` rows and columns), for a
    /// Jacobian not [`Jacobian::worth_structure`].
    pub(super) fn implicit_matrix<const N: usize>(&self, s: f64) -> [[f64; N]; N] {
        let columns = self.scaled_columns::<N>(s);
        let mut matrix = [[0.0; N]; N];
        let size = self.size().min(N);
        for r in 0..size {
            for c in 0..size {
                matrix[r][c] = -columns[c][r];
            }
            matrix[r][r] += 1.0;
        }
        matrix
    }

    /// `I - s J` made ready to solve with; `None` if a block of `B` or `C` is singular.
    fn factor(&self, s: f64) -> Option<Factored<'_>> {
        by_state_count!(self.layout.states, N => self.factor_for::<N>(s))
    }

    /// [`Jacobian::factor`] for a model of `N` states: loops of a known length.
    fn factor_for<const N: usize>(&self, s: f64) -> Option<Factored<'_>> {
        let states = N;
        // C = I - s M B^-1 P: `M P` as if B were the identity (as it is outside every
        // slot), and for each slot's entries the difference of B^-1 P over its members.
        let mut capacitance = [[0.0; MAX_STATES]; MAX_STATES];
        for k in 0..states {
            for l in 0..states {
                capacitance[k][l] = -s * self.made_by_state[k][l];
            }
            capacitance[k][k] += 1.0;
        }
        let mut inverse_blocks = [[[0.0; MAX_MEMBERS]; MAX_MEMBERS]; MAX_TOGETHER];
        for (j, slot) in self.slots.iter().enumerate() {
            let (entries, count) = (slot.entries, slot.law.count);
            inverse_blocks[j] = shifted_inverse(&self.blocks[j], s, count)?;
            let inverse = &inverse_blocks[j];
            for k in 0..count {
                let (state, weight) = self.makes[entries[k]];
                // The slot's entry k: its row of P out, its row of B^-1 P in.
                let mut row = self.by_state[entries[k]];
                for m in 0..count {
                    let (factor, by_state) = (inverse[k][m], &self.by_state[entries[m]]);
                    for l in 0..states {
                        row[l] -= factor * by_state[l];
                    }
                }
                for l in 0..states {
                    capacitance[state][l] += s * weight * row[l];
                }
            }
        }
        let factors = lu::Factors::new(&mut capacitance, states)?;
        let mut inverse_capacitance = [[0.0; MAX_STATES]; MAX_STATES];
        for l in 0..states {
            let mut unit = [0.0; MAX_STATES];
            unit[l] = 1.0;
            let column = factors.solve(unit);
            for r in 0..states {
                inverse_capacitance[r][l] = column[r];
            }
        }
        Some(Factored {
            jacobian: self,
            s,
            inverse_blocks,
            inverse_capacitance,
        })
    }
}

impl Factored<'_> {
    /// The solution `y` of `(I - s J) y = r`: `y = B^-1 (r + s P c)`, where `c` solves
    /// `C c = M B^-1 r`.
    fn solve(&self, r: &Vector) -> Vector {
        let jacobian = self.jacobian;
        let (size, states) = (jacobian.size(), jacobian.layout.states);
        let mut w = *r;
        self.apply_inverse_blocks(&mut w);
        let made = jacobian.layout.model_states(&w);
        let mut correction = [0.0; MAX_STATES];
        for k in 0..states {
            for l in 0..states {
                correction[k] += self.inverse_capacitance[k][l] * made[l];
            }
            correction[k] *= self.s;
        }
        let mut y = *r;
        for c in 0..size {
            for l in 0..states {
                y[c] += jacobian.by_state[c][l] * correction[l];
            }
        }
        self.apply_inverse_blocks(&mut y);
        y
    }

    /// `v` replaced by `B^-1 v`: the entries outside every slot stay.
    fn apply_inverse_blocks(&self, v: &mut Vector) {
        let jacobian = self.jacobian;
        for (j, slot) in jacobian.slots.iter().enumerate() {
            let (entries, count) = (slot.entries, slot.law.count);
            let inverse = &self.inverse_blocks[j];
            if count == 1 {
                v[entries[0]] *= inverse[0][0];
            } else {
                let (v0, v1) = (v[entries[0]], v[entries[1]]);
                v[entries[0]] = inverse[0][0] * v0 + inverse[0][1] * v1;
                v[entries[1]] = inverse[1][0] * v0 + inverse[1][1] * v1;
            }
        }
    }
}

/// `(I - s D)^-1` of a group's block `D` of `count` members (one or two; the rows and
/// columns past them zero); `None` if it is singular.
pub(super) fn shifted_inverse(
    d: &[Members; MAX_MEMBERS],
    s: f64,
    count: usize,
) -> Option<[Members; MAX_MEMBERS]> {
    let mut inverse = [[0.0; MAX_MEMBERS]; MAX_MEMBERS];
    if count == 1 {
        inverse[0][0] = (1.0 - s * d[0][0]).recip();
    } else {
        let (b00, b01) = (1.0 - s * d[0][0], -s * d[0][1]);
        let (b10, b11) = (-s * d[1][0], 1.0 - s * d[1][1]);
        let inverse_determinant = (b00 * b11 - b01 * b10).recip();
        inverse = [
            [b11 * inverse_determinant, -b01 * inverse_determinant],
            [-b10 * inverse_determinant, b00 * inverse_determinant],
        ];
    }
    inverse
        .as_flattened()
        .iter()
        .all(|v| v.is_finite())
        .then_some(inverse)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::{Modes, SIZE, SlidingStep, tire_at};
    use crate::physics::friction::{FrictionLaw, Group, MAX_BRANCHES, SliderState};
    use crate::physics::lu;
    use crate::physics::state_space::{DrivingVector, StateVector};
    use crate::physics::{ModelKind, Parameter, Parameters};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The closed-form Jacobian is the right-hand side's, as central differences
        /// find it, for every model and law, each group sticking or sliding; and the
        /// structured solve with it is the elimination's.
        #[test]
        fn the_jacobian_is_the_slope_of_the_rates(
            model in prop::sample::select(ModelKind::ALL.to_vec()),
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            vx in -20.0..20.0f64,
            load_ratio in 0.01..2.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform4(0.05..1.5f64),
            offsets in prop::array::uniform6(0.05..0.5f64),
            signs in any::<u16>(),
            sliding in any::<u8>(),
        ) {
            let signed = |value: f64, bit: usize| if signs >> bit & 1 == 1 { -value } else { value };
            let mut p = Parameters::default().with_model(model).with_friction(law);
            p.set(Parameter::LongitudinalFriction, 0.4).unwrap();
            let load = load_ratio * p.get(Parameter::NominalLoad);
            // States and offsets of the order of the elastic travel.
            let (system, mut friction, limits, travel) = tire_at(&p, vx, load);
            let mut x = StateVector::zeros();
            for k in 0..system.states.min(4) {
                x[k] = signed(states[k], k) * travel;
            }
            let mut sliders = SliderState::AT_REST;
            for d in 0..3 {
                for i in 0..friction.branches.len().min(2) {
                    sliders.offsets[d][i] = signed(offsets[2 * d + i], 4 + 2 * d + i) * travel;
                }
            }
            let u = DrivingVector::new(inputs[0], inputs[1], inputs[2]);
            let step = SlidingStep::new(&system, &mut friction, limits, (u, DrivingVector::zeros()), travel);
            let z = step.layout.pack(&x, &sliders);
            let mut modes: Modes = [[false; MAX_BRANCHES]; Group::COUNT];
            for (bit, mode) in modes.as_flattened_mut().iter_mut().enumerate() {
                *mode = sliding >> bit & 1 == 1;
            }
            let x = step.layout.model_states(&z);
            let x_rates = step.system.state_rates(&x, &u);
            for slot in step.slots() {
                let input = step.slot_input(slot, &x, &x_rates, &z);
                let trial = input.utilisation(&input.sticking_force());
                // A spring-damper slides where the force that sticking needs is past its
                // ellipse: its sliding law puts the force on the ellipse only there.
                let mode = &mut modes[slot.group][slot.branch];
                if slot.law.damped() {
                    *mode = trial > 1.0;
                }
                // Away from a sliding group without force, where its law has a corner.
                if *mode {
                    prop_assume!(trial > 1e-6 && input.utilisation(&input.spring_force()) > 1e-6);
                }
            }
            let structured = step.jacobian(0.0, &z, &step.rates(0.0, &z, &modes).0, &modes);
            // `J` itself: `I - s J` at `s = -1`, less the identity.
            let mut jacobian = structured.implicit_matrix::<SIZE>(-1.0);
            for k in 0..SIZE {
                jacobian[k][k] -= 1.0;
            }
            let size = step.size();
            let largest = jacobian.as_flattened().iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for c in 0..size {
                let delta = 1e-6 * z[c].abs().max(travel);
                let at = |sign: f64| {
                    let mut moved = z;
                    moved[c] += sign * delta;
                    step.rates(0.0, &moved, &modes).0
                };
                let (plus, minus) = (at(1.0), at(-1.0));
                for r in 0..size {
                    let difference = (plus[r] - minus[r]) / (2.0 * delta);
                    // Each row against its largest entry, its scale (a row of zeros against
                    // the rounding of the differences).
                    let scale = jacobian[r][..size].iter().fold(1e-5 * largest, |m, v| m.max(v.abs()));
                    prop_assert!(
                        (jacobian[r][c] - difference).abs() <= 1e-5 * scale,
                        "{model:?} {law:?} entry ({r}, {c}) of {size}: {} vs {difference} (row scale {scale})",
                        jacobian[r][c]
                    );
                }
            }
            // The structured solve is the elimination's, from short steps to long ones.
            let r: [f64; SIZE] = std::array::from_fn(|k| (k as f64 + 1.0).sin() * travel);
            for s in [1e-6, 1e-3, 1.0] {
                let Some(factored) = structured.factor(s) else { continue };
                let y = factored.solve(&r);
                let matrix = structured.implicit_matrix::<SIZE>(s);
                let Some(dense) = lu::solve(matrix, r, size) else { continue };
                let scale = dense[..size].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for k in 0..size {
                    prop_assert!(
                        (y[k] - dense[k]).abs() <= 1e-9 * scale,
                        "{model:?} {law:?} s {s}: entry {k} {} vs {} (scale {scale})",
                        y[k],
                        dense[k]
                    );
                }
            }
        }
    }
}
