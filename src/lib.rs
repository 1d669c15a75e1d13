//! TireLag: the transient (lagged) forces of one tire, as an FMI 2.0 and an FMI 3.0 FMU
//! (Co-Simulation and Model Exchange, one library for both), for Windows, macOS and Linux.
//!
//! - [`physics`]: the tire-lag models as small linear state-space systems, stepped exactly.
//!   Plain Rust, no FFI, usable and testable on its own.
//! - [`fmi`]: the thin FMI 2.0 and FMI 3.0 layers over one C boundary: C ABI, call-sequence
//!   state machine, value references, logging and FMU state. It knows the physics only
//!   through [`physics::Tire`].
//! - [`tire_data`]: tire property files (`.tir`) read and mapped to the parameters.
//! - [`fitting`]: parameters fitted to measurements by the exact step.

pub mod fitting;
pub mod fmi;
pub mod physics;
pub mod tire_data;
