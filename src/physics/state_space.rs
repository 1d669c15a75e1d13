//! Linear state-space systems of at most [`MAX_STATES`] states, in fixed-size storage.

use nalgebra::{SMatrix, SVector};

use super::signals::{DrivingInput, Output, OutputVector};

/// The most states any model has (RingBody: two contact masses of three states).
pub const MAX_STATES: usize = 6;

/// `$call` with the const `$n` set to the model's state count `$states` (2, 3 or 4, else
/// [`MAX_STATES`]): work on fixed-size arrays of the model's own size, unrolled.
macro_rules! by_state_count {
    ($states:expr, $n:ident => $call:expr) => {
        match $states {
            2 => {
                const $n: usize = 2;
                $call
            }
            3 => {
                const $n: usize = 3;
                $call
            }
            4 => {
                const $n: usize = 4;
                $call
            }
            _ => {
                const $n: usize = $crate::physics::state_space::MAX_STATES;
                $call
            }
        }
    };
}
pub(crate) use by_state_count;

/// The states of a model; entries past the model's state count stay zero.
pub type StateVector = SVector<f64, MAX_STATES>;
/// `u = [vy, steerRate, vsx]`, the inputs that drive the states.
pub type DrivingVector = SVector<f64, { DrivingInput::COUNT }>;
pub type StateMatrix = SMatrix<f64, MAX_STATES, MAX_STATES>;
pub type InputMatrix = SMatrix<f64, MAX_STATES, { DrivingInput::COUNT }>;
pub type OutputMatrix = SMatrix<f64, { Output::COUNT }, MAX_STATES>;
pub type FeedthroughMatrix = SMatrix<f64, { Output::COUNT }, { DrivingInput::COUNT }>;

/// `dx/dt = A x + B u`, `y = C x + D u` with `u = [vy, steerRate, vsx]` and `y` the
/// outputs in [`Output`] order. Rows and columns past `states` are zero.
#[derive(Clone, Debug, PartialEq)]
pub struct StateSpace {
    pub states: usize,
    pub a: StateMatrix,
    pub b: InputMatrix,
    pub c: OutputMatrix,
    pub d: FeedthroughMatrix,
    /// Whether column k of `d` may be nonzero (at some operating point): the outputs skip
    /// the others. All true unless the pattern is known (the affine form marks it).
    pub feedthrough: [bool; DrivingInput::COUNT],
}

impl StateSpace {
    /// A system with `states` states and every matrix zero.
    pub fn zeros(states: usize) -> Self {
        assert!(states <= MAX_STATES, "{states} states: at most {MAX_STATES}");
        Self {
            states,
            a: StateMatrix::zeros(),
            b: InputMatrix::zeros(),
            c: OutputMatrix::zeros(),
            d: FeedthroughMatrix::zeros(),
            feedthrough: [true; DrivingInput::COUNT],
        }
    }

    /// `y = C x + D u`.
    pub fn outputs(&self, x: &StateVector, u: &DrivingVector) -> OutputVector {
        // Column by column over the inputs that feed through and the states in use (a
        // small model leaves most columns zero).
        let mut y = OutputVector::zeros();
        for (k, &uk) in u.iter().enumerate() {
            if self.feedthrough[k] {
                y.axpy(uk, &self.d.column(k), 1.0);
            }
        }
        for (j, &xj) in x.iter().enumerate().take(self.states) {
            y.axpy(xj, &self.c.column(j), 1.0);
        }
        y
    }

    /// The inputs' part of state `k`'s rate, `(B u)_k`.
    pub fn input_rate(&self, k: usize, u: &DrivingVector) -> f64 {
        (0..u.len()).map(|j| self.b[(k, j)] * u[j]).sum()
    }

    /// `dx/dt = A x + B u`, over the model's own states (the unused rows and columns of
    /// the fixed-size storage are zero: skipped; the step with sliding evaluates this many
    /// times per step).
    #[inline]
    pub fn state_rates(&self, x: &StateVector, u: &DrivingVector) -> StateVector {
        let mut rates = [0.0; MAX_STATES];
        self.write_state_rates(x, u, &mut rates);
        StateVector::from(rates)
    }

    /// [`StateSpace::state_rates`] written into `rates`, where they are to be kept (a
    /// copy read right after they are written one by one would wait for the writes to
    /// land); entries past the model's states are left alone where the model's state
    /// count has its own size (every model's does), and are zero (as A's and B's rows
    /// there are) where it takes [`MAX_STATES`].
    #[inline]
    pub fn write_state_rates(&self, x: &StateVector, u: &DrivingVector, rates: &mut [f64; MAX_STATES]) {
        by_state_count!(self.states, N => self.write_sized_state_rates::<N>(x, u, rates))
    }

    /// [`StateSpace::write_state_rates`] for the first `N` states, column by column over
    /// all rows at once: the rows go in pairs, and the rates are stored as wide as they
    /// are read (a wide read of narrow stores waits). Each rate sums in the same order as
    /// a row by row product would.
    #[inline]
    fn write_sized_state_rates<const N: usize>(
        &self,
        x: &StateVector,
        u: &DrivingVector,
        rates: &mut [f64; MAX_STATES],
    ) {
        // Column-major storage: entry (i, j) at i + MAX_STATES j.
        let (a, b) = (self.a.as_slice(), self.b.as_slice());
        let mut states: [f64; N] = std::array::from_fn(|i| a[i] * x[0]);
        for j in 1..N {
            for (i, s) in states.iter_mut().enumerate() {
                *s += a[i + MAX_STATES * j] * x[j];
            }
        }
        let inputs: [f64; N] =
            std::array::from_fn(|i| b[i] * u[0] + b[i + MAX_STATES] * u[1] + b[i + 2 * MAX_STATES] * u[2]);
        for ((r, s), i) in rates.iter_mut().zip(states).zip(inputs) {
            *r = s + i;
        }
    }

    /// `dy/dt = C dx/dt + D du/dt`.
    pub fn output_rates(&self, x: &StateVector, u: &DrivingVector, du: &DrivingVector) -> OutputVector {
        self.c * self.state_rates(x, u) + self.d * du
    }
}

/// Writes a [`StateSpace`] equation by equation, in the words of the model papers.
pub struct SystemBuilder {
    system: StateSpace,
}

impl SystemBuilder {
    pub fn new(states: usize) -> Self {
        Self {
            system: StateSpace::zeros(states),
        }
    }

    /// `d x[state]/dt = sum(coefficient * x[j]) + sum(coefficient * u[k])`.
    pub fn rate(&mut self, state: usize, states: &[(usize, f64)], inputs: &[(DrivingInput, f64)]) {
        for &(j, coefficient) in states {
            self.system.a[(state, j)] += coefficient;
        }
        for &(k, coefficient) in inputs {
            self.system.b[(state, k as usize)] += coefficient;
        }
    }

    /// Adds `sum(coefficient * x[j]) + sum(coefficient * u[k])` to an output.
    pub fn output(&mut self, output: Output, states: &[(usize, f64)], inputs: &[(DrivingInput, f64)]) {
        for &(j, coefficient) in states {
            self.system.c[(output as usize, j)] += coefficient;
        }
        for &(k, coefficient) in inputs {
            self.system.d[(output as usize, k as usize)] += coefficient;
        }
    }

    /// Adds `coefficient * d x[state]/dt` to an output (a damper force); the state's
    /// rate equation must already be written.
    pub fn output_rate(&mut self, output: Output, state: usize, coefficient: f64) {
        let o = output as usize;
        let a_row = self.system.a.row(state) * coefficient;
        let b_row = self.system.b.row(state) * coefficient;
        self.system.c.row_mut(o).zip_apply(&a_row, |c, a| *c += a);
        self.system.d.row_mut(o).zip_apply(&b_row, |d, b| *d += b);
    }

    /// Adds `coefficient * source` to an output; `source` must already be written.
    pub fn output_from(&mut self, output: Output, source: Output, coefficient: f64) {
        let (o, s) = (output as usize, source as usize);
        let c_row = self.system.c.row(s) * coefficient;
        let d_row = self.system.d.row(s) * coefficient;
        self.system.c.row_mut(o).zip_apply(&c_row, |c, a| *c += a);
        self.system.d.row_mut(o).zip_apply(&d_row, |d, b| *d += b);
    }

    pub fn finish(self) -> StateSpace {
        self.system
    }
}
