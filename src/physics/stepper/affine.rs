//! A model's system as an affine function of its operating point, so that a new speed
//! costs a few multiply-adds instead of writing the equations again.

use crate::physics::signals::Output;
use crate::physics::state_space::{MAX_STATES, StateSpace};

/// Where the tire operates: the quantities its system matrices depend on. Every model's
/// matrices are affine in `vx` and in `rho = |vx|` separately (no product of the two, no
/// division by either).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingPoint {
    /// Longitudinal speed, m/s.
    pub vx: f64,
    /// Rolling speed, m/s; `|vx|` for a real operating point.
    pub rho: f64,
}

impl OperatingPoint {
    pub const COORDINATES: usize = 2;

    pub fn rolling(vx: f64) -> Self {
        Self { vx, rho: vx.abs() }
    }

    pub const fn coordinates(&self) -> [f64; Self::COORDINATES] {
        [self.vx, self.rho]
    }

    fn unit(coordinate: usize) -> Self {
        let mut c = [0.0; Self::COORDINATES];
        c[coordinate] = 1.0;
        Self { vx: c[0], rho: c[1] }
    }

    /// Bit pattern, for caches keyed on the exact operating point.
    pub fn key(&self) -> [u64; Self::COORDINATES] {
        self.coordinates().map(f64::to_bits)
    }
}

/// Which matrix of a [`StateSpace`] an entry lives in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Matrix {
    A,
    B,
    C,
    D,
}

/// One matrix entry that changes with the operating point:
/// `value = at_rest + sum(slope[k] * coordinate[k])`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct VaryingEntry {
    matrix: Matrix,
    row: u8,
    column: u8,
    /// Column-major position in its matrix.
    index: u16,
    at_rest: f64,
    slope: [f64; OperatingPoint::COORDINATES],
}

/// Room for the varying entries of any model: the relaxation rates on A's diagonal, the
/// couplings, and the damper-force rows of C and D that copy them.
const MAX_VARYING: usize = 64;

/// `S(q) = S(0) + sum(q_k dS/dq_k)`, with only the entries that vary stored.
#[derive(Clone, Debug, PartialEq)]
pub struct AffineSystem {
    at_rest: StateSpace,
    /// Ordered by matrix (A, B, C, D); `matrix_ends[m]` is one past the last entry of m.
    varying: [VaryingEntry; MAX_VARYING],
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
    let rows = match matrix {
        Matrix::A => s.a.nrows(),
        Matrix::B => s.b.nrows(),
        Matrix::C => s.c.nrows(),
        Matrix::D => s.d.nrows(),
    };
    column * rows + row
}

/// Writes `value = at_rest + slope . q` for each entry into one matrix's storage.
fn write_entries(storage: &mut [f64], entries: &[VaryingEntry], q: [f64; OperatingPoint::COORDINATES]) {
    for entry in entries {
        let mut value = entry.at_rest;
        for (slope, coordinate) in entry.slope.iter().zip(q) {
            value += slope * coordinate;
        }
        storage[entry.index as usize] = value;
    }
}

impl AffineSystem {
    /// Samples `system` at rest and at a unit step of each coordinate. The models' systems
    /// are affine in the operating point, so these samples give it everywhere.
    pub fn from_samples(system: impl Fn(OperatingPoint) -> StateSpace) -> Self {
        let at_rest = system(OperatingPoint { vx: 0.0, rho: 0.0 });
        let units: [StateSpace; OperatingPoint::COORDINATES] =
            std::array::from_fn(|k| system(OperatingPoint::unit(k)));
        let placeholder = VaryingEntry {
            matrix: Matrix::A,
            row: 0,
            column: 0,
            index: 0,
            at_rest: 0.0,
            slope: [0.0; OperatingPoint::COORDINATES],
        };
        let mut affine = AffineSystem {
            at_rest: at_rest.clone(),
            varying: [placeholder; MAX_VARYING],
            varying_count: 0,
            matrix_ends: [0; 4],
        };
        let mut unit_entries = units.each_ref().map(entries);
        for (matrix, row, column, value) in entries(&at_rest) {
            let slope = unit_entries
                .each_mut()
                .map(|unit| unit.next().expect("same shape").3 - value);
            if slope.iter().any(|&s| s != 0.0) {
                assert!(
                    affine.varying_count < MAX_VARYING,
                    "more than {MAX_VARYING} varying entries"
                );
                affine.varying[affine.varying_count] = VaryingEntry {
                    matrix,
                    row: row as u8,
                    column: column as u8,
                    index: column_major_index(&at_rest, matrix, row, column) as u16,
                    at_rest: value,
                    slope,
                };
                affine.varying_count += 1;
            }
        }
        affine.index_by_matrix();
        affine
    }

    /// The same system with the wheel off the ground: no loads, no driving inputs, and
    /// every state relaxing to zero with time constant `relaxation_time`.
    pub fn lifted_off(&self, relaxation_time: f64) -> Self {
        let mut lifted = self.clone();
        let s = &mut lifted.at_rest;
        s.a.fill(0.0);
        for i in 0..s.states {
            s.a[(i, i)] = -1.0 / relaxation_time;
        }
        s.b.fill(0.0);
        s.d.fill(0.0);
        for load in Output::LOADS {
            s.c.row_mut(load as usize).fill(0.0);
        }
        let is_load_row = |row: u8| Output::LOADS.iter().any(|&l| l as u8 == row);
        let mut kept = 0;
        for k in 0..lifted.varying_count {
            let entry = lifted.varying[k];
            if entry.matrix == Matrix::C && !is_load_row(entry.row) {
                lifted.varying[kept] = entry;
                kept += 1;
            }
        }
        lifted.varying_count = kept;
        lifted.index_by_matrix();
        lifted
    }

    /// Orders the entries by matrix and records where each matrix's run ends.
    fn index_by_matrix(&mut self) {
        let count = self.varying_count;
        self.varying[..count].sort_by_key(|e| e.matrix);
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

    fn varying(&self) -> &[VaryingEntry] {
        &self.varying[..self.varying_count]
    }

    /// Writes the system at `point` into `system`, which must hold this system's entries
    /// at some operating point (a copy of [`AffineSystem::at_rest`] or an earlier result):
    /// only the varying entries are rewritten.
    pub fn evaluate(&self, point: OperatingPoint, system: &mut StateSpace) {
        let q = point.coordinates();
        let [a, b, c, d] = self.matrix_ends;
        write_entries(system.a.as_mut_slice(), &self.varying[..a], q);
        write_entries(system.b.as_mut_slice(), &self.varying[a..b], q);
        write_entries(system.c.as_mut_slice(), &self.varying[b..c], q);
        write_entries(system.d.as_mut_slice(), &self.varying[c..d], q);
    }

    /// Typical magnitude of each state-matrix entry (at rest plus 10 m/s of each
    /// coordinate), zero where the entry is zero everywhere: the coupling pattern.
    pub fn state_coupling(&self) -> [[f64; MAX_STATES]; MAX_STATES] {
        const TYPICAL_SPEED: f64 = 10.0;
        let mut magnitude = [[0.0; MAX_STATES]; MAX_STATES];
        for (i, row) in magnitude.iter_mut().enumerate().take(self.states()) {
            for (j, value) in row.iter_mut().enumerate().take(self.states()) {
                *value = self.at_rest.a[(i, j)].abs();
            }
        }
        for entry in self.varying().iter().filter(|e| e.matrix == Matrix::A) {
            let slopes: f64 = entry.slope.iter().map(|s| s.abs()).sum();
            magnitude[entry.row as usize][entry.column as usize] += TYPICAL_SPEED * slopes;
        }
        magnitude
    }

    /// `d(C x + D u)/d coordinate`: how the outputs change with one coordinate of the
    /// operating point at fixed states and inputs. Exact: the outputs are affine in it.
    pub fn output_slope(
        &self,
        coordinate: usize,
        x: &crate::physics::state_space::StateVector,
        u: &crate::physics::state_space::DrivingVector,
    ) -> crate::physics::signals::OutputVector {
        let mut slope = crate::physics::signals::OutputVector::zeros();
        for entry in self.varying() {
            let (row, column) = (entry.row as usize, entry.column as usize);
            match entry.matrix {
                Matrix::C => slope[row] += entry.slope[coordinate] * x[column],
                Matrix::D => slope[row] += entry.slope[coordinate] * u[column],
                Matrix::A | Matrix::B => {}
            }
        }
        slope
    }
}
