//! The tire-lag physics: plain Rust, no FFI, nothing about FMI.
//!
//! Conventions (docs/specification.md 2): wheel frame W with x forward along the wheel
//! heading, y to the left, z up. `rho = |vx|` is the rolling speed; every relaxation term
//! uses it, so reverse driving is symmetric and no equation divides by the speed. Forces
//! and moments are those the tire applies to the wheel hub, in N and N.m.
//!
//! Each model ([`models`]) is a linear time-invariant system for a given `vx`:
//! `dx/dt = A x + B u`, `y = C x + D u` with `u = [vy, steerRate, vsx]`. The [`stepper`]
//! steps it exactly, block by block, for inputs held or ramped over a step; the [`Tire`]
//! holds the states and inputs.

pub mod brush;
pub mod friction;
pub mod load;
mod lu;
pub mod math;
pub mod models;
pub mod parameters;
pub mod signals;
pub mod state_space;
pub mod stepper;
pub mod tire;

pub use parameters::{FrictionLaw, ModelKind, Parameter, ParameterError, Parameters};
pub use signals::{DrivingInput, Input, Output, OutputVector};
pub use state_space::{StateSpace, StateVector};
pub use stepper::StepMap;
pub use tire::Tire;
