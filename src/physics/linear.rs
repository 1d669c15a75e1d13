//! Linear state-space systems and their exact discretisation.

use nalgebra::{DMatrix, DVector, Vector3};

use super::signals::{DrivingInput, Output, OutputVector};

/// `dx/dt = A x + B u`, `y = C x + D u` with `u = [vy, steerRate, vsx]` and `y` the
/// outputs in [`Output`] order.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearSystem {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
}

/// The exact one-step map of a [`LinearSystem`] over a step of length `h` for an input
/// `u(t) = u0 + t du` (t from 0 to h): `x(h) = phi x(0) + hold u0 + ramp du`.
#[derive(Clone, Debug, PartialEq)]
pub struct StepMatrices {
    pub phi: DMatrix<f64>,
    pub hold: DMatrix<f64>,
    pub ramp: DMatrix<f64>,
}

impl LinearSystem {
    /// A system with `states` states and every matrix zero.
    pub fn zeros(states: usize) -> Self {
        Self {
            a: DMatrix::zeros(states, states),
            b: DMatrix::zeros(states, DrivingInput::COUNT),
            c: DMatrix::zeros(Output::COUNT, states),
            d: DMatrix::zeros(Output::COUNT, DrivingInput::COUNT),
        }
    }

    pub fn state_count(&self) -> usize {
        self.a.nrows()
    }

    /// `y = C x + D u`.
    pub fn outputs(&self, x: &DVector<f64>, u: &Vector3<f64>) -> OutputVector {
        let mut y = OutputVector::zeros();
        for (row, out) in y.iter_mut().enumerate() {
            *out = self.c.row(row).dot(&x.transpose()) + self.d.row(row).dot(&u.transpose());
        }
        y
    }

    /// `dx/dt = A x + B u`.
    pub fn state_rates(&self, x: &DVector<f64>, u: &Vector3<f64>) -> DVector<f64> {
        &self.a * x + &self.b * u
    }

    /// `dy/dt = C dx/dt + D du/dt`.
    pub fn output_rates(&self, x: &DVector<f64>, u: &Vector3<f64>, du: &Vector3<f64>) -> OutputVector {
        let dx = self.state_rates(x, u);
        let rates = &self.c * dx + &self.d * du;
        OutputVector::from_iterator(rates.iter().copied())
    }

    /// The exact step map for a step of `h` seconds, from one matrix exponential of the
    /// augmented system `d/dt [x; u; du] = [A x + B u; du; 0]` (Van Loan).
    pub fn discretise(&self, h: f64) -> StepMatrices {
        let n = self.state_count();
        let m = DrivingInput::COUNT;
        let mut augmented = DMatrix::zeros(n + 2 * m, n + 2 * m);
        augmented.view_mut((0, 0), (n, n)).copy_from(&(&self.a * h));
        augmented.view_mut((0, n), (n, m)).copy_from(&(&self.b * h));
        augmented.view_mut((n, n + m), (m, m)).fill_with_identity();
        augmented.view_mut((n, n + m), (m, m)).scale_mut(h);
        // A non-finite matrix (absurd speeds or steps) has no exponential: return NaN, which
        // the caller refuses, rather than hand it to the Pade solver.
        if !augmented.iter().all(|v| v.is_finite()) {
            let nan = |cols| DMatrix::from_element(n, cols, f64::NAN);
            return StepMatrices {
                phi: nan(n),
                hold: nan(m),
                ramp: nan(m),
            };
        }
        let e = augmented.exp();
        StepMatrices {
            phi: e.view((0, 0), (n, n)).into_owned(),
            hold: e.view((0, n), (n, m)).into_owned(),
            ramp: e.view((0, n + m), (n, m)).into_owned(),
        }
    }
}

impl StepMatrices {
    /// Advances `x` by one step with input `u0 + t du`.
    pub fn advance(&self, x: &DVector<f64>, u0: &Vector3<f64>, du: &Vector3<f64>) -> DVector<f64> {
        &self.phi * x + &self.hold * u0 + &self.ramp * du
    }
}

/// Writes a [`LinearSystem`] equation by equation, in the words of the model papers.
pub struct SystemBuilder {
    system: LinearSystem,
}

impl SystemBuilder {
    pub fn new(states: usize) -> Self {
        Self {
            system: LinearSystem::zeros(states),
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

    pub fn finish(self) -> LinearSystem {
        self.system
    }
}
