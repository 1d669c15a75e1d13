//! The exact stepper: how a communication step is computed.
//!
//! A model writes its equations once ([`crate::physics::models`]); the stepper makes them
//! fast without touching them:
//!
//! 1. **Affine form** ([`affine`]). When the parameters are set, the model's system is
//!    sampled at rest and at a unit step of each operating-point coordinate (vx, rho).
//!    The matrices are affine in these, so a new speed rewrites only the few entries that
//!    vary (relaxation rates, couplings, damper rows) in place.
//! 2. **Blocks** ([`blocks`]). The states split into groups that do not feed each other:
//!    RLT two 1x1 lags, DDT a 2x2 triangular yaw-lateral pair and a 1x1 lag, SecondOrder a
//!    3x3 contact mass and a 1x1 lag, RingBody two 3x3 contact masses. Each block is
//!    balanced once with power-of-two scalings.
//! 3. **Phi-functions per block** ([`phi`]). For a step of length h with inputs
//!    `u0 + t du`, each block's `e^(hA)`, `h phi1(hA) B` and `h^2 phi2(hA) B` come from
//!    closed forms (lags, triangular pairs) or one Taylor series with scaling and
//!    squaring on fixed-size matrices; no division by the speed anywhere. The map's
//!    entries are made before the output matrix's (which do not feed it). The blocks
//!    together give the [`StepMap`]
//!    `x(h) = transition x(0) + hold u0 + ramp du`, exact to rounding for any h.
//! 4. **Reuse.** The step map is kept while the operating point, contact mode and step
//!    size are unchanged, with the system at its point, so a step at constant speed is
//!    the map applied to the states in use and the outputs of the system in hand.
//!
//! The state at any time within a step is the same map for a shorter h, which is how an
//! event inside a step is located. Nothing here allocates.

pub mod affine;
pub mod blocks;
pub mod phi;

use nalgebra::SMatrix;

use super::load::OperatingPoint;
use super::signals::DrivingInput;
use super::state_space::{DrivingVector, InputMatrix, MAX_STATES, StateMatrix, StateSpace, StateVector};
pub use affine::AffineSystem;
pub use blocks::{Block, Blocks};

/// What a step map is made for: the bits of vx, Fz (at mid-step) and the step size. For
/// one parameter set they decide the operating point and the contact mode.
///
/// Compared word by word in registers: an array comparison of a key just built goes
/// through memory, and a wide load of values just stored one by one stalls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepKey([u64; 3]);

impl StepKey {
    /// No step map: a step size of zero is never taken.
    pub const NONE: StepKey = StepKey([0; 3]);

    pub fn new(vx: f64, load: f64, h: f64) -> Self {
        StepKey([vx.to_bits(), load.to_bits(), h.to_bits()])
    }

    #[inline]
    pub fn same_as(&self, other: &StepKey) -> bool {
        let (a, b) = (&self.0, &other.0);
        (a[0] ^ b[0]) | (a[1] ^ b[1]) | (a[2] ^ b[2]) == 0
    }
}

impl Default for StepKey {
    fn default() -> Self {
        Self::NONE
    }
}

/// The exact one-step map for inputs `u(t) = u0 + t du`, t from 0 to h:
/// `x(h) = transition x(0) + hold u0 + ramp du`.
#[derive(Clone, Debug, PartialEq)]
pub struct StepMap {
    /// How many states the map moves; the rest stay zero.
    pub states: usize,
    pub transition: StateMatrix,
    pub hold: InputMatrix,
    pub ramp: InputMatrix,
}

impl Default for StepMap {
    fn default() -> Self {
        Self::zeros()
    }
}

impl StepMap {
    /// The states after the step from `x`, with the driving inputs `u0` at its start and
    /// their rates `du` (`None`: held).
    pub fn advance(&self, x: &StateVector, u0: &DrivingVector, du: Option<&DrivingVector>) -> StateVector {
        match self.states {
            1 => self.advance_sized::<1>(x, u0, du),
            2 => self.advance_sized::<2>(x, u0, du),
            3 => self.advance_sized::<3>(x, u0, du),
            4 => self.advance_sized::<4>(x, u0, du),
            _ => self.advance_sized::<MAX_STATES>(x, u0, du),
        }
    }

    /// [`StepMap::advance`] over the `N` states in use (the rest stay zero), row by row:
    /// hold, then transition, then ramp, each summed in column order.
    #[inline]
    fn advance_sized<const N: usize>(
        &self,
        x: &StateVector,
        u0: &DrivingVector,
        du: Option<&DrivingVector>,
    ) -> StateVector {
        let mut next = StateVector::zeros();
        for i in 0..N {
            let mut value = self.hold[(i, 0)] * u0[0] + self.hold[(i, 1)] * u0[1] + self.hold[(i, 2)] * u0[2];
            for j in 0..N {
                value += self.transition[(i, j)] * x[j];
            }
            if let Some(du) = du {
                value += self.ramp[(i, 0)] * du[0] + self.ramp[(i, 1)] * du[1] + self.ramp[(i, 2)] * du[2];
            }
            next[i] = value;
        }
        next
    }

    /// A map that leaves every state at zero.
    pub fn zeros() -> Self {
        StepMap {
            states: 0,
            transition: StateMatrix::zeros(),
            hold: InputMatrix::zeros(),
            ramp: InputMatrix::zeros(),
        }
    }

    /// The exact step map of `system` over `h` seconds, block by block. Not finite if the
    /// system or `h` is not.
    pub fn new(system: &StateSpace, blocks: &Blocks, h: f64) -> Self {
        let mut map = Self::zeros();
        map.make(system, blocks, h);
        map
    }

    /// Makes this the exact step map of `system` over `h` seconds, in place.
    pub fn make(&mut self, system: &StateSpace, blocks: &Blocks, h: f64) {
        self.states = system.states;
        self.transition.fill(0.0);
        self.hold.fill(0.0);
        self.ramp.fill(0.0);
        self.make_blocks(system, blocks, h);
    }

    /// Writes every block's entries; the entries between blocks must already be zero
    /// (a map made before for the same blocks).
    fn make_blocks(&mut self, system: &StateSpace, blocks: &Blocks, h: f64) {
        for block in blocks.iter() {
            match block.size {
                1 => self.add_scalar_block(system, block, h),
                2 => self.add_block::<2>(system, block, h),
                3 => self.add_block::<3>(system, block, h),
                4 => self.add_block::<4>(system, block, h),
                5 => self.add_block::<5>(system, block, h),
                _ => self.add_block::<MAX_STATES>(system, block, h),
            }
        }
    }

    /// A triangular pair (DDT's yaw lag driving its lateral lag) in closed form; false,
    /// and nothing written, if the pair is not triangular.
    fn add_triangular_pair(&mut self, system: &StateSpace, block: &Block, h: f64) -> bool {
        let (first, second) = (block.states[0], block.states[1]);
        let (z1, z2) = (h * system.a[(first, first)], h * system.a[(second, second)]);
        let (upper, lower) = (system.a[(first, second)], system.a[(second, first)]);
        let phi = if upper == 0.0 {
            phi::lower_triangular_phi_functions(z1, z2, h * lower)
        } else if lower == 0.0 {
            phi::lower_triangular_phi_functions(z1, z2, h * upper).transposed()
        } else {
            return false;
        };
        let states = [first, second];
        for (i, &row) in states.iter().enumerate() {
            for (j, &column) in states.iter().enumerate() {
                self.transition[(row, column)] = phi.exp[(i, j)];
            }
        }
        for k in block.inputs() {
            let input = nalgebra::Vector2::new(system.b[(first, k)], system.b[(second, k)]);
            let hold = phi.phi1 * input * h;
            let ramp = phi.phi2 * input * (h * h);
            for (i, &row) in states.iter().enumerate() {
                self.hold[(row, k)] = hold[i];
                self.ramp[(row, k)] = ramp[i];
            }
        }
        true
    }

    /// A single lag: closed forms, no matrices.
    #[inline]
    fn add_scalar_block(&mut self, system: &StateSpace, block: &Block, h: f64) {
        let state = block.states[0];
        let (exp, phi1, phi2) = phi::scalar_phi_functions(h * system.a[(state, state)]);
        self.transition[(state, state)] = exp;
        for k in block.inputs() {
            let b = system.b[(state, k)];
            self.hold[(state, k)] = h * phi1 * b;
            self.ramp[(state, k)] = h * h * phi2 * b;
        }
    }

    /// A block of `N` > 1 states (out of line: its matrices need a large frame, which a
    /// system of lags alone should not pay for).
    #[inline(never)]
    fn add_block<const N: usize>(&mut self, system: &StateSpace, block: &Block, h: f64) {
        let states = &block.states[..N];
        if N == 2 && self.add_triangular_pair(system, block, h) {
            return;
        }
        let x = SMatrix::<f64, N, N>::from_fn(|i, j| h * system.a[(states[i], states[j])]);
        let inputs = SMatrix::<f64, N, { DrivingInput::COUNT }>::from_fn(|i, k| system.b[(states[i], k)]);
        let phi = balanced_phi_functions(&x, block);
        for (i, &row) in states.iter().enumerate() {
            for (j, &column) in states.iter().enumerate() {
                self.transition[(row, column)] = phi.exp[(i, j)];
            }
        }
        // Only the inputs that drive the block; the other columns stay zero.
        for k in block.inputs() {
            let hold = phi.phi1 * inputs.column(k) * h;
            let ramp = phi.phi2 * inputs.column(k) * (h * h);
            for (i, &row) in states.iter().enumerate() {
                self.hold[(row, k)] = hold[i];
                self.ramp[(row, k)] = ramp[i];
            }
        }
    }
}

/// The phi-functions of a block's `x = hA`, computed on the balanced `S^-1 x S` (whose
/// norm reflects the dynamics, not the units) and brought back: `f(x) = S f(S^-1 x S) S^-1`.
fn balanced_phi_functions<const N: usize>(x: &SMatrix<f64, N, N>, block: &Block) -> phi::PhiFunctions<N> {
    let (scale, inverse) = (&block.scale[..N], &block.inverse_scale[..N]);
    let balanced = SMatrix::<f64, N, N>::from_fn(|i, j| x[(i, j)] * scale[j] * inverse[i]);
    let phi = phi::phi_functions(&balanced);
    let back =
        |m: SMatrix<f64, N, N>| SMatrix::<f64, N, N>::from_fn(|i, j| m[(i, j)] * scale[i] * inverse[j]);
    phi::PhiFunctions {
        exp: back(phi.exp),
        phi1: back(phi.phi1),
        phi2: back(phi.phi2),
    }
}

/// A model's system in one contact mode, with its blocks, the system at the operating
/// point last asked for, and the step map last made.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactSystem {
    affine: AffineSystem,
    blocks: Blocks,
    current: StateSpace,
    current_point: OperatingPoint,
    /// Made for these blocks only, so the entries between blocks stay zero.
    map: StepMap,
    /// The operating point the map was made at, and whether `current` is still there.
    map_point: OperatingPoint,
    current_at_map_point: bool,
    /// Whether `current`'s output entries (C, D) are at `current_point` too: a caller that
    /// needs only the dynamics leaves them ([`ContactSystem::dynamics_at`]).
    outputs_current: bool,
}

impl ContactSystem {
    pub fn new(affine: AffineSystem) -> Self {
        let blocks = Blocks::new(
            affine.states(),
            &affine.state_coupling(),
            &affine.input_coupling(),
        );
        let current = affine.at_rest().clone();
        let current_point = OperatingPoint::from_coordinates([0.0; OperatingPoint::COORDINATES]);
        let map = StepMap::new(&current, &blocks, 0.0);
        Self {
            affine,
            blocks,
            current,
            current_point,
            map,
            map_point: current_point,
            current_at_map_point: true,
            outputs_current: true,
        }
    }

    pub fn affine(&self) -> &AffineSystem {
        &self.affine
    }

    pub fn blocks(&self) -> &Blocks {
        &self.blocks
    }

    /// The system at `point`; only its varying entries are rewritten, and only when the
    /// point changed.
    #[inline]
    pub fn at(&mut self, point: OperatingPoint) -> &StateSpace {
        self.dynamics_at(point);
        if !self.outputs_current {
            self.affine.evaluate_outputs(&point, &mut self.current);
            self.outputs_current = true;
        }
        &self.current
    }

    /// The system at `point` for its state rates only (A, B): the output entries may be
    /// left at an earlier point, until [`ContactSystem::at`] asks for them.
    #[inline]
    pub fn dynamics_at(&mut self, point: OperatingPoint) -> &StateSpace {
        if !point.same_as(&self.current_point) {
            // Kept first and read from where it is kept: a copy of the caller's point
            // after the call would read it back wide, right after it was written narrow.
            self.current_point = point;
            self.affine
                .evaluate_dynamics(&self.current_point, &mut self.current);
            self.current_at_map_point = false;
            self.outputs_current = false;
        }
        &self.current
    }

    /// Makes the exact step map at `point` over `h` seconds.
    pub fn make_step_map(&mut self, point: OperatingPoint, h: f64) -> &StepMap {
        if point.same_as(&self.current_point) {
            self.map.make_blocks(&self.current, &self.blocks, h);
            if !self.outputs_current {
                self.affine.evaluate_outputs(&point, &mut self.current);
            }
        } else {
            // The output entries after the map: they do not feed it, so they are written
            // while its series (chains of dependent multiplications) are under way.
            self.affine.evaluate_dynamics(&point, &mut self.current);
            self.map.make_blocks(&self.current, &self.blocks, h);
            self.affine.evaluate_outputs(&point, &mut self.current);
            self.current_point = point;
        }
        self.map_point = point;
        self.current_at_map_point = true;
        self.outputs_current = true;
        &self.map
    }

    /// The system at the operating point of the step map last made, that map, and the
    /// blocks it was made for.
    #[inline]
    pub fn at_step_map_point(&mut self) -> (&StateSpace, &StepMap, &Blocks) {
        // At the map's point the outputs are current too: only a move away leaves them.
        if !self.current_at_map_point {
            self.affine.evaluate(&self.map_point, &mut self.current);
            self.current_point = self.map_point;
            self.current_at_map_point = true;
            self.outputs_current = true;
        }
        (&self.current, &self.map, &self.blocks)
    }
}
