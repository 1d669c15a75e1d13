//! A model's system as an affine function of its operating point, so that a new speed
//! costs a few multiply-adds instead of writing the equations again.

use crate::physics::load::OperatingPoint;
use crate::physics::signals::{DrivingInput, Output};
use crate::physics::state_space::{MAX_STATES, StateSpace};

/// Which matrix of a [`StateSpace`] an entry lives in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Matrix {
    A,
    B,
    C,
    D,
}

/// The terms of a pair of neighbouring entries of one matrix's storage (column-major
/// entries `index` and `index + 1`, `index` even) along one coordinate. The first term of
/// a pair sets both entries, `at_rest + slope * coordinate` (a slope of zero for an entry
/// that does not vary along it); any further terms of the same pair follow it and add
/// `slope * coordinate`. The last entry of a matrix of odd size has no partner and is
/// written alone.
///
/// Two at a time because the products read the matrices two entries at a time, right
/// after a new operating point wrote them: a wide read of two narrow writes waits until
/// they reach the cache, a wide read of one wide write is served from it at once (the
/// wait was a tenth of a Model Exchange evaluation).
#[derive(Clone, Copy, Debug, PartialEq)]
struct VaryingPair {
    matrix: Matrix,
    /// Column-major position in its matrix of the pair's first entry.
    index: u16,
    coordinate: u8,
    first: bool,
    at_rest: [f64; 2],
    slope: [f64; 2],
}

/// One entry's term along one coordinate: the slope of entry `index` (column-major) of
/// `matrix` along `coordinate`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct EntryTerm {
    matrix: Matrix,
    index: usize,
    coordinate: usize,
    slope: f64,
}

/// Room for the varying pairs of any model: the relaxation rates on A's diagonal, the
/// damper rows of C that copy them, and the transient slips' rows (at most 13 terms).
const MAX_VARYING: usize = 32;

/// `S(q) = S(0) + sum(q_k dS/dq_k)`, with only the terms that vary stored.
#[derive(Clone, Debug, PartialEq)]
pub struct AffineSystem {
    at_rest: StateSpace,
    /// Ordered by matrix (A, B, C, D), then pair, then coordinate; `matrix_ends[m]` is
    /// one past the last pair of matrix m.
    varying: [VaryingPair; MAX_VARYING],
    varying_count: usize,
    matrix_ends: [usize; 4],
}

fn entries(s: &StateSpace) -> impl Iterator<Item = (Matrix, usize, usize, f64)> + '_ {
    let n = s.states;
    let a = (0..n).flat_map(move |i| (0..n).map(move |j| (Matrix::A, i, j, s.a[(i, j)])));
    let b = (0..n).flat_map(move |i| (0..s.b.ncols()).map(move |k| (Matrix::B, i, k, s.b[(i, k)])));
    let c = (0..s.c.nrows()).flat_map(move |o| (0..n).map(move |j| (Matrix::C, o, j, s.c[(o, j)])));
    let d = (0..s.d.nrows()).flat_map(move |o| (0..s.d.ncols()).map(move |k| (Matrix::D, o, k, s.d[(o, k)])));
    a.chain(b).chain(c).chain(d)
}

fn column_major_index(s: &StateSpace, matrix: Matrix, row: usize, column: usize) -> usize {
    column * storage(s, matrix).1 + row
}

/// A matrix's column-major entries and its row count.
fn storage(s: &StateSpace, matrix: Matrix) -> (&[f64], usize) {
    match matrix {
        Matrix::A => (s.a.as_slice(), s.a.nrows()),
        Matrix::B => (s.b.as_slice(), s.b.nrows()),
        Matrix::C => (s.c.as_slice(), s.c.nrows()),
        Matrix::D => (s.d.as_slice(), s.d.nrows()),
    }
}

/// Writes each pair into one matrix's storage.
#[inline]
fn write_terms(storage: &mut [f64], terms: &[VaryingPair], point: &OperatingPoint) {
    for term in terms {
        let index = term.index as usize;
        let c = point.coordinate(term.coordinate);
        match storage.get_mut(index..index + 2) {
            Some(pair) => {
                let pair: &mut [f64; 2] = pair.try_into().expect("two entries");
                let base = if term.first { term.at_rest } else { *pair };
                *pair = [base[0] + term.slope[0] * c, base[1] + term.slope[1] * c];
            }
            None => {
                let base = if term.first {
                    term.at_rest[0]
                } else {
                    storage[index]
                };
                storage[index] = base + term.slope[0] * c;
            }
        }
    }
}

impl AffineSystem {
    /// Samples `system` at rest and at a unit step of each coordinate. The models' systems
    /// are affine in the operating point, so these samples give it everywhere.
    pub fn from_samples(system: impl Fn(OperatingPoint) -> StateSpace) -> Self {
        let at_rest = system(OperatingPoint::from_coordinates(
            [0.0; OperatingPoint::COORDINATES],
        ));
        let units: [StateSpace; OperatingPoint::COORDINATES] =
            std::array::from_fn(|k| system(OperatingPoint::unit(k)));
        let mut unit_entries = units.each_ref().map(entries);
        let terms = entries(&at_rest).flat_map(|(matrix, row, column, value)| {
            let slopes = unit_entries
                .each_mut()
                .map(|unit| unit.next().expect("same shape").3 - value);
            let index = column_major_index(&at_rest, matrix, row, column);
            (0..OperatingPoint::COORDINATES).filter_map(move |coordinate| {
                let slope = slopes[coordinate];
                (slope != 0.0).then_some(EntryTerm {
                    matrix,
                    index,
                    coordinate,
                    slope,
                })
            })
        });
        Self::with_terms(at_rest.clone(), terms)
    }

    /// The system `at_rest` with the entry terms `terms`, paired.
    fn with_terms(at_rest: StateSpace, terms: impl IntoIterator<Item = EntryTerm>) -> Self {
        let placeholder = VaryingPair {
            matrix: Matrix::A,
            index: 0,
            coordinate: 0,
            first: true,
            at_rest: [0.0; 2],
            slope: [0.0; 2],
        };
        let mut affine = AffineSystem {
            at_rest,
            varying: [placeholder; MAX_VARYING],
            varying_count: 0,
            matrix_ends: [0; 4],
        };
        for term in terms {
            let index = (term.index & !1) as u16;
            let coordinate = term.coordinate as u8;
            let count = affine.varying_count;
            let found = affine.varying[..count]
                .iter()
                .position(|p| (p.matrix, p.index, p.coordinate) == (term.matrix, index, coordinate));
            let k = found.unwrap_or_else(|| {
                assert!(count < MAX_VARYING, "more than {MAX_VARYING} varying pairs");
                affine.varying[count] = VaryingPair {
                    matrix: term.matrix,
                    index,
                    coordinate,
                    ..placeholder
                };
                affine.varying_count += 1;
                count
            });
            affine.varying[k].slope[term.index & 1] = term.slope;
        }
        let count = affine.varying_count;
        affine.varying[..count].sort_by_key(|t| (t.matrix, t.index, t.coordinate));
        let mut previous = None;
        for pair in &mut affine.varying[..count] {
            let (values, _) = storage(&affine.at_rest, pair.matrix);
            let index = pair.index as usize;
            pair.at_rest = [values[index], values.get(index + 1).copied().unwrap_or_default()];
            pair.first = previous != Some((pair.matrix, pair.index));
            previous = Some((pair.matrix, pair.index));
        }
        affine.index_by_matrix();
        affine.mark_feedthrough();
        affine
    }

    /// The same system with the wheel off the ground: no loads, no driving inputs, and
    /// every state relaxing to zero with time constant `relaxation_time`.
    pub fn lifted_off(&self, relaxation_time: f64) -> Self {
        let mut s = self.at_rest.clone();
        s.a.fill(0.0);
        for i in 0..s.states {
            s.a[(i, i)] = -1.0 / relaxation_time;
        }
        s.b.fill(0.0);
        s.d.fill(0.0);
        for load in Output::LOADS {
            s.c.row_mut(load as usize).fill(0.0);
        }
        let rows = self.at_rest.c.nrows();
        let is_load_row = |index: usize| Output::LOADS.iter().any(|&l| l as usize == index % rows);
        let kept = self
            .entry_terms()
            .filter(|t| t.matrix == Matrix::C && !is_load_row(t.index));
        Self::with_terms(s, kept)
    }

    /// Records where each matrix's run of pairs ends.
    fn index_by_matrix(&mut self) {
        let count = self.varying_count;
        for (m, matrix) in [Matrix::A, Matrix::B, Matrix::C, Matrix::D]
            .into_iter()
            .enumerate()
        {
            self.matrix_ends[m] = self.varying[..count]
                .iter()
                .filter(|e| e.matrix <= matrix)
                .count();
        }
    }

    pub fn states(&self) -> usize {
        self.at_rest.states
    }

    /// The system at rest; evaluate into a copy of it.
    pub fn at_rest(&self) -> &StateSpace {
        &self.at_rest
    }

    /// Marks in `at_rest` the feedthrough columns that are zero at every operating point
    /// (zero at rest and without a varying term), so that the outputs skip them.
    fn mark_feedthrough(&mut self) {
        let rows = self.at_rest.d.nrows();
        let mut nonzero = [false; DrivingInput::COUNT];
        for (k, column) in nonzero.iter_mut().enumerate() {
            *column = self.at_rest.d.column(k).iter().any(|&v| v != 0.0);
        }
        for term in self.entry_terms().filter(|t| t.matrix == Matrix::D) {
            nonzero[term.index / rows] = true;
        }
        self.at_rest.feedthrough = nonzero;
    }

    fn varying(&self) -> &[VaryingPair] {
        &self.varying[..self.varying_count]
    }

    /// The varying pairs' terms entry by entry (those of slope zero left out).
    fn entry_terms(&self) -> impl Iterator<Item = EntryTerm> + '_ {
        self.varying().iter().flat_map(|pair| {
            (0..2).filter(|&e| pair.slope[e] != 0.0).map(move |e| EntryTerm {
                matrix: pair.matrix,
                index: pair.index as usize + e,
                coordinate: pair.coordinate as usize,
                slope: pair.slope[e],
            })
        })
    }

    /// Writes the system at `point` into `system`, which must hold this system's entries
    /// at some operating point (a copy of [`AffineSystem::at_rest`] or an earlier result):
    /// only the varying entries are rewritten.
    pub fn evaluate(&self, point: &OperatingPoint, system: &mut StateSpace) {
        self.evaluate_dynamics(point, system);
        self.evaluate_outputs(point, system);
    }

    /// The state and input matrices of [`AffineSystem::evaluate`]: all a step map needs.
    pub fn evaluate_dynamics(&self, point: &OperatingPoint, system: &mut StateSpace) {
        let [a, b, ..] = self.matrix_ends;
        write_terms(system.a.as_mut_slice(), &self.varying[..a], point);
        write_terms(system.b.as_mut_slice(), &self.varying[a..b], point);
    }

    /// The output and feedthrough matrices of [`AffineSystem::evaluate`].
    pub fn evaluate_outputs(&self, point: &OperatingPoint, system: &mut StateSpace) {
        let [_, b, c, d] = self.matrix_ends;
        write_terms(system.c.as_mut_slice(), &self.varying[b..c], point);
        write_terms(system.d.as_mut_slice(), &self.varying[c..d], point);
    }

    /// Typical magnitude of each state-matrix entry (at rest plus 10 of each coordinate),
    /// zero where the entry is zero everywhere: the coupling pattern.
    pub fn state_coupling(&self) -> [[f64; MAX_STATES]; MAX_STATES] {
        const TYPICAL: f64 = 10.0;
        let n = self.states();
        let mut magnitude = [[0.0; MAX_STATES]; MAX_STATES];
        for (i, row) in magnitude.iter_mut().enumerate().take(n) {
            for (j, value) in row.iter_mut().enumerate().take(n) {
                *value = self.at_rest.a[(i, j)].abs();
            }
        }
        let rows = self.at_rest.a.nrows();
        for term in self.entry_terms().filter(|t| t.matrix == Matrix::A) {
            let (row, column) = (term.index % rows, term.index / rows);
            magnitude[row][column] += TYPICAL * term.slope.abs();
        }
        magnitude
    }

    /// Where the input matrix is nonzero at some operating point.
    pub fn input_coupling(&self) -> [[bool; crate::physics::signals::DrivingInput::COUNT]; MAX_STATES] {
        let mut driven = [[false; crate::physics::signals::DrivingInput::COUNT]; MAX_STATES];
        for (i, row) in driven.iter_mut().enumerate().take(self.states()) {
            for (k, value) in row.iter_mut().enumerate() {
                *value = self.at_rest.b[(i, k)] != 0.0;
            }
        }
        let rows = self.at_rest.b.nrows();
        for term in self.entry_terms().filter(|t| t.matrix == Matrix::B) {
            driven[term.index % rows][term.index / rows] = true;
        }
        driven
    }

    /// `d(A x + B u)/d q`: how the state rates change with the coordinates of the
    /// operating point at fixed states and inputs, for a change `dq` of them. Exact: the
    /// rates are affine in the coordinates.
    pub fn rate_slope(
        &self,
        dq: [f64; OperatingPoint::COORDINATES],
        x: &crate::physics::state_space::StateVector,
        u: &crate::physics::state_space::DrivingVector,
    ) -> crate::physics::state_space::StateVector {
        let mut slope = crate::physics::state_space::StateVector::zeros();
        self.add_slope(dq, (x, u), (Matrix::A, Matrix::B), slope.as_mut_slice());
        slope
    }

    /// `d(C x + D u)/d q`: how the outputs change with the coordinates of the operating
    /// point at fixed states and inputs, for a change `dq` of them. Exact: the outputs are
    /// affine in the coordinates.
    pub fn output_slope(
        &self,
        dq: [f64; OperatingPoint::COORDINATES],
        x: &crate::physics::state_space::StateVector,
        u: &crate::physics::state_space::DrivingVector,
    ) -> crate::physics::signals::OutputVector {
        let mut slope = crate::physics::signals::OutputVector::zeros();
        self.add_slope(dq, (x, u), (Matrix::C, Matrix::D), slope.as_mut_slice());
        slope
    }

    /// Adds `d(M x + N u)/d q dq` to `slope`, for the pair of matrices `(M, N)`: (A, B) or
    /// (C, D), whose rows are `slope`'s entries.
    fn add_slope(
        &self,
        dq: [f64; OperatingPoint::COORDINATES],
        (x, u): (
            &crate::physics::state_space::StateVector,
            &crate::physics::state_space::DrivingVector,
        ),
        (states, inputs): (Matrix, Matrix),
        slope: &mut [f64],
    ) {
        let rows = slope.len();
        for term in self.entry_terms() {
            let (index, change) = (term.index, term.slope * dq[term.coordinate]);
            if term.matrix == states {
                slope[index % rows] += change * x[index / rows];
            } else if term.matrix == inputs {
                slope[index % rows] += change * u[index / rows];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::load::{InverseLengthFactors, LoadLaw};
    use crate::physics::{ModelKind, Parameters};

    /// Each model with its default parameters, and its system sampled.
    fn sampled_models() -> impl Iterator<Item = (ModelKind, Parameters, AffineSystem)> {
        ModelKind::ALL.into_iter().map(|model| {
            let p = Parameters::default().with_model(model);
            let equations = p.model.equations();
            let affine = AffineSystem::from_samples(|at| equations.system(&p, &at));
            (model, p, affine)
        })
    }

    /// Operating points at several speeds (both signs) and loads.
    fn points(p: &Parameters) -> impl Iterator<Item = OperatingPoint> {
        let law = LoadLaw::new(p);
        [-7.0, 0.0, 0.3, 25.0].into_iter().flat_map(move |vx| {
            [800.0, 4000.0, 9000.0].map(|load| OperatingPoint::new(vx, law.inverse_factors(load)))
        })
    }

    fn assert_close(evaluated: &StateSpace, direct: &StateSpace, what: &str) {
        for (matrix, (e, d)) in [
            (evaluated.a.as_slice(), direct.a.as_slice()),
            (evaluated.b.as_slice(), direct.b.as_slice()),
            (evaluated.c.as_slice(), direct.c.as_slice()),
            (evaluated.d.as_slice(), direct.d.as_slice()),
        ]
        .into_iter()
        .enumerate()
        {
            for (k, (e, d)) in e.iter().zip(d).enumerate() {
                assert!(
                    (e - d).abs() <= 1e-12 * d.abs().max(1.0),
                    "{what}: matrix {matrix} entry {k}: {e} evaluated, {d} directly"
                );
            }
        }
    }

    /// Every model's system, evaluated from its samples into a system left at another
    /// point, is the model's own system at that point: the pairs set and add every
    /// varying entry and leave the others.
    #[test]
    fn evaluated_systems_are_the_models_systems() {
        for (model, p, affine) in sampled_models() {
            let mut evaluated = affine.at_rest().clone();
            for point in points(&p) {
                affine.evaluate(&point, &mut evaluated);
                let direct = p.model.equations().system(&p, &point);
                assert_close(&evaluated, &direct, &format!("{model:?}"));
            }
        }
    }

    /// Off the ground only the rows of C that are not loads keep their terms; the loads,
    /// inputs and the relaxation of the states stay as made.
    #[test]
    fn lifted_off_systems_keep_the_rows_that_are_not_loads() {
        for (model, p, rolling) in sampled_models() {
            let lifted = rolling.lifted_off(0.01);
            let mut evaluated = lifted.at_rest().clone();
            for point in points(&p) {
                lifted.evaluate(&point, &mut evaluated);
                let mut expected = lifted.at_rest().clone();
                let direct = p.model.equations().system(&p, &point);
                for output in Output::ALL.into_iter().filter(|o| !Output::LOADS.contains(o)) {
                    expected
                        .c
                        .row_mut(output as usize)
                        .copy_from(&direct.c.row(output as usize));
                }
                assert_close(&evaluated, &expected, &format!("{model:?} lifted off"));
            }
        }
    }

    /// The last entry of a matrix of odd size is written alone, and its neighbour by its
    /// own pair.
    #[test]
    fn the_last_entry_of_an_odd_matrix_is_written_alone() {
        let (rows, columns) = (Output::COUNT, DrivingInput::COUNT);
        assert_eq!(rows * columns % 2, 1, "the feedthrough matrix has an odd size");
        let system = |at: OperatingPoint| {
            let mut s = StateSpace::zeros(2);
            s.a[(0, 0)] = -1.0;
            s.d[(rows - 1, columns - 1)] = 3.0 + 2.0 * at.vx();
            s.d[(rows - 2, columns - 1)] = 5.0 - at.inverse_lateral_factor();
            s
        };
        let affine = AffineSystem::from_samples(system);
        let mut evaluated = affine.at_rest().clone();
        for vx in [-2.0, 0.5, 9.0] {
            let point = OperatingPoint::new(
                vx,
                InverseLengthFactors {
                    lateral: 0.7,
                    longitudinal: 1.2,
                },
            );
            affine.evaluate(&point, &mut evaluated);
            assert_close(&evaluated, &system(point), "odd feedthrough");
        }
    }
}
