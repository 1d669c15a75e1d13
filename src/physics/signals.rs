//! Names and layout of the tire's inputs and outputs.

use nalgebra::SVector;

/// Inputs of the tire, in SI units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Input {
    /// Wheel-centre velocity along x_W, m/s (may be zero or negative).
    Vx,
    /// Wheel-centre velocity along y_W, m/s.
    Vy,
    /// Steer-angle rate of the wheel relative to the body, rad/s.
    SteerRate,
    /// Longitudinal slip velocity `vx - omega*Re`, m/s.
    Vsx,
    /// Normal load, N; `<= 0` means the wheel has lifted off.
    Fz,
}

impl Input {
    pub const COUNT: usize = 5;
    pub const ALL: [Input; Input::COUNT] = [Input::Vx, Input::Vy, Input::SteerRate, Input::Vsx, Input::Fz];

    /// The position of this input in the driving-input vector `u`, if it is one.
    /// `vx` and `Fz` are not: they select the system rather than drive it.
    pub const fn driving(self) -> Option<DrivingInput> {
        match self {
            Input::Vy => Some(DrivingInput::Vy),
            Input::SteerRate => Some(DrivingInput::SteerRate),
            Input::Vsx => Some(DrivingInput::Vsx),
            Input::Vx | Input::Fz => None,
        }
    }
}

/// The inputs that enter the state equations linearly: `u = [vy, steerRate, vsx]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DrivingInput {
    Vy = 0,
    SteerRate = 1,
    Vsx = 2,
}

impl DrivingInput {
    pub const COUNT: usize = 3;
}

/// Outputs of the tire; `Output as usize` is the row in `C` and `D`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Output {
    /// Longitudinal force on the hub, N.
    Fx = 0,
    /// Lateral force on the hub, N.
    Fy,
    /// Moment about z on the hub, N.m.
    Mz,
    /// Moment about the spin axis on the wheel, positive in the forward-rolling sense, N.m.
    My,
    /// Transient slip angle `-deflY/sigmaY`, rad.
    AlphaT,
    /// Transient longitudinal slip `-deflX/sigmaX`, 1.
    KappaT,
    /// Longitudinal deflection of the wheel relative to the ground contact point, m.
    DeflX,
    /// Lateral deflection of the wheel relative to the ground contact point, m.
    DeflY,
    /// Yaw deflection of the wheel relative to the contact patch, rad.
    DeflPsi,
}

impl Output {
    pub const COUNT: usize = 9;
    pub const ALL: [Output; Output::COUNT] = [
        Output::Fx,
        Output::Fy,
        Output::Mz,
        Output::My,
        Output::AlphaT,
        Output::KappaT,
        Output::DeflX,
        Output::DeflY,
        Output::DeflPsi,
    ];
    /// The outputs that are forces or moments on the hub (zero while lifted off).
    pub const LOADS: [Output; 4] = [Output::Fx, Output::Fy, Output::Mz, Output::My];
}

/// All outputs, indexed by `Output as usize`.
pub type OutputVector = SVector<f64, { Output::COUNT }>;
