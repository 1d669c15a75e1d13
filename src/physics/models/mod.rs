//! The four tire-lag models. Each is a small file that writes its equations
//! (docs/specification.md 4) into a [`StateSpace`] for a given speed; the
//! [`Tire`](super::Tire) does the rest. Shared pieces (relaxation-length lag, contact
//! mass) live here.

mod ddt;
mod ring_body;
mod rlt;
mod second_order;

use super::friction::{ContactElement, ContactElements};
use super::load::OperatingPoint;
use super::parameters::{ModelKind, Parameter, Parameters};
use super::signals::{DrivingInput, Output};
use super::state_space::{StateSpace, StateVector, SystemBuilder};

impl ModelKind {
    /// The model's equations.
    pub fn equations(self) -> &'static dyn TireLagModel {
        match self {
            ModelKind::Rlt => &rlt::Rlt,
            ModelKind::Ddt => &ddt::Ddt,
            ModelKind::SecondOrder => &second_order::SecondOrder,
            ModelKind::RingBody => &ring_body::RingBody,
        }
    }
}

/// A tire-lag model: linear in its states and in `u = [vy, steerRate, vsx]`, with
/// matrices that depend on the speed and the load (the [`OperatingPoint`]).
pub trait TireLagModel: Sync {
    /// Names of the states, in state-vector order.
    fn state_names(&self) -> &'static [&'static str];

    /// The state-space system at an operating point. Relaxation rates are written as
    /// `at.lateral_relaxation_speed() / sigma` (or longitudinal), so that the loaded lengths
    /// follow; the system must stay affine in the operating point's coordinates.
    fn system(&self, p: &Parameters, at: &OperatingPoint) -> StateSpace;

    /// Mechanical energy stored in the tire (springs and moving masses), J: a sum of
    /// squares of the states, `sum q_j x_j^2 / 2`.
    fn stored_energy(&self, p: &Parameters, x: &StateVector) -> f64;

    /// Whether the model is passive: built of springs, masses, dampers and relaxing
    /// deflections only, so that under held inputs the stored energy of its distance from
    /// the equilibrium never grows, at any operating point. DDT is not: its yaw
    /// deflection drives the lateral one through `vx`.
    fn passive(&self) -> bool {
        true
    }

    /// The weights `q` of [`TireLagModel::stored_energy`], `E = sum q_j x_j^2 / 2`.
    fn energy_weights(&self, p: &Parameters) -> StateVector {
        StateVector::from_fn(|j, _| {
            let mut unit = StateVector::zeros();
            unit[j] = 1.0;
            2.0 * self.stored_energy(p, &unit)
        })
    }

    /// The elements through which the model touches the road (docs/specification.md
    /// 4c), by direction; each gets a friction slider in series.
    fn contact_elements(&self, p: &Parameters) -> ContactElements;
}

/// First-order relaxation of a deflection `u` driven by a slip velocity:
/// `du/dt = v - (rho/sigma) u`, force `-(stiffness u + damping du/dt)` into `force`.
/// `rho/sigma` is written as `relaxation_speed / relaxation_length`, the speed being the
/// operating point's lateral or longitudinal one (docs/specification.md 4b: loaded
/// lengths).
struct Relaxation {
    state: usize,
    input: DrivingInput,
    relaxation_length: f64,
    stiffness: f64,
    damping: f64,
    force: Output,
    deflection: Output,
}

impl Relaxation {
    fn write(&self, b: &mut SystemBuilder, relaxation_speed: f64) {
        let u = self.state;
        b.rate(
            u,
            &[(u, -relaxation_speed / self.relaxation_length)],
            &[(self.input, 1.0)],
        );
        b.output(self.force, &[(u, -self.stiffness)], &[]);
        b.output_rate(self.force, u, -self.damping);
        b.output(self.deflection, &[(u, 1.0)], &[]);
    }

    /// The longitudinal relaxation of RLT, DDT and SecondOrder, with tread damping.
    fn longitudinal(p: &Parameters, state: usize, damping: f64) -> Self {
        Relaxation {
            state,
            input: DrivingInput::Vsx,
            relaxation_length: p.longitudinal_relaxation_length(),
            stiffness: p.longitudinal_stiffness(),
            damping,
            force: Output::Fx,
            deflection: Output::DeflX,
        }
    }

    fn energy(&self, x: &StateVector) -> f64 {
        0.5 * self.stiffness * x[self.state].powi(2)
    }

    /// The relaxing spring (and damper) as a contact element. Its force
    /// `stiffness u + damping du/dt` is `-force`; `feeds` is the output that `force` feeds
    /// and the factor (`Mz = -trail Fy`, `My = -Re Fx`).
    fn contact_element(&self, feeds: (Output, f64)) -> ContactElement {
        ContactElement {
            state: self.state,
            stiffness: self.stiffness,
            damping: self.damping,
            force_outputs: [(self.force, -1.0), (feeds.0, -feeds.1)],
        }
    }

    /// A lateral relaxation: Fy feeds Mz through the trail.
    fn lateral_element(&self, p: &Parameters) -> ContactElement {
        self.contact_element((Output::Mz, -p.get(Parameter::PneumaticTrail)))
    }

    /// A longitudinal relaxation: Fx feeds My through the rolling radius.
    fn longitudinal_element(&self, p: &Parameters) -> ContactElement {
        self.contact_element((Output::My, -p.get(Parameter::RollingRadius)))
    }
}

/// A mass between a carcass spring-damper (to the wheel) and a lagged tread spring (to
/// the ground), moving with the slip velocity `v` of the wheel (Kim eqs 1-5, made
/// standstill-safe by the tread state):
/// `d offset/dt = w - v`, `d tread/dt = w - (rho/sigmaTread) tread`,
/// `m dw/dt = -kT tread - k offset - d (w - v)`; hub force `k offset + d (w - v)`.
struct ContactMass {
    /// State indices of the offset from the wheel, the tread deflection, the velocity.
    offset: usize,
    tread: usize,
    velocity: usize,
    input: DrivingInput,
    mass: f64,
    carcass_stiffness: f64,
    carcass_damping: f64,
    tread_stiffness: f64,
    tread_relaxation_length: f64,
}

impl ContactMass {
    fn write(&self, b: &mut SystemBuilder, relaxation_speed: f64) {
        let (offset, tread, w, v) = (self.offset, self.tread, self.velocity, self.input);
        let m = self.mass;
        b.rate(offset, &[(w, 1.0)], &[(v, -1.0)]);
        b.rate(
            tread,
            &[
                (w, 1.0),
                (tread, -relaxation_speed / self.tread_relaxation_length),
            ],
            &[],
        );
        b.rate(
            w,
            &[
                (tread, -self.tread_stiffness / m),
                (offset, -self.carcass_stiffness / m),
                (w, -self.carcass_damping / m),
            ],
            &[(v, self.carcass_damping / m)],
        );
    }

    /// The carcass force on the hub, `k offset + d (w - v)`, added to `output` times `sign`.
    fn carcass_force(&self, b: &mut SystemBuilder, output: Output, sign: f64) {
        b.output(
            output,
            &[
                (self.offset, sign * self.carcass_stiffness),
                (self.velocity, sign * self.carcass_damping),
            ],
            &[(self.input, -sign * self.carcass_damping)],
        );
    }

    /// Deflection of the wheel relative to the ground contact point: `tread - offset`.
    fn deflection(&self, b: &mut SystemBuilder, output: Output) {
        b.output(output, &[(self.tread, 1.0), (self.offset, -1.0)], &[]);
    }

    /// The tread spring as a contact element: its force acts on the contact mass.
    fn tread_element(&self) -> ContactElement {
        ContactElement {
            state: self.tread,
            stiffness: self.tread_stiffness,
            damping: 0.0,
            force_outputs: ContactElement::NO_OUTPUTS,
        }
    }

    fn energy(&self, x: &StateVector) -> f64 {
        0.5 * (self.carcass_stiffness * x[self.offset].powi(2)
            + self.tread_stiffness * x[self.tread].powi(2)
            + self.mass * x[self.velocity].powi(2))
    }

    /// The lateral contact mass of SecondOrder and RingBody.
    fn lateral(p: &Parameters, first_state: usize, mass: f64, damping: f64) -> Self {
        ContactMass {
            offset: first_state,
            tread: first_state + 1,
            velocity: first_state + 2,
            input: DrivingInput::Vy,
            mass,
            carcass_stiffness: p.carcass_lateral_stiffness(),
            carcass_damping: damping,
            tread_stiffness: p.tread_lateral_stiffness(),
            tread_relaxation_length: p.tread_relaxation_length(),
        }
    }
}

/// Rows every model shares: the pneumatic trail in Mz and the transient slips, which use
/// the loaded relaxation lengths.
fn write_common_outputs(b: &mut SystemBuilder, p: &Parameters, at: &OperatingPoint) {
    b.output_from(Output::Mz, Output::Fy, -p.get(Parameter::PneumaticTrail));
    b.output_from(
        Output::AlphaT,
        Output::DeflY,
        -at.inverse_lateral_factor() / p.lateral_relaxation_length(),
    );
    b.output_from(
        Output::KappaT,
        Output::DeflX,
        -at.inverse_longitudinal_factor() / p.longitudinal_relaxation_length(),
    );
}

/// `My = -Re Fx`: the rolling moment of the models whose Fx acts at the contact point.
fn write_rolling_moment_from_fx(b: &mut SystemBuilder, p: &Parameters) {
    b.output_from(Output::My, Output::Fx, -p.get(Parameter::RollingRadius));
}

#[cfg(test)]
mod tests;
