//! DDT, the dynamic-deflection tire (Koo & Tan eqs 1-12).
//! States: yaw deflection uPsi, lateral deflection uY, longitudinal deflection uX.
//! `duPsi/dt = r - (rho/sigmaPsi) uPsi` (the yaw lag acts on the steer angle, eq 11),
//! `duY/dt = vy + vx uPsi - (rho/sigmaY) uY`, `Fy = -(C_y uY + D_lat duY/dt)`,
//! `Mz = -(C_yaw uPsi + D_yaw duPsi/dt) - trail Fy`; longitudinally as RLT plus D_long.
//! The tread dampers keep it damped at standstill.

use super::{Relaxation, TireLagModel, write_common_outputs, write_rolling_moment_from_fx};
use crate::physics::friction::{ContactElement, ContactElements};
use crate::physics::load::OperatingPoint;
use crate::physics::parameters::{Parameter, Parameters};
use crate::physics::signals::{DrivingInput, Output};
use crate::physics::state_space::{StateSpace, StateVector, SystemBuilder};

pub struct Ddt;

const YAW: usize = 0;
const LATERAL: usize = 1;
const LONGITUDINAL: usize = 2;

fn longitudinal(p: &Parameters) -> Relaxation {
    Relaxation::longitudinal(p, LONGITUDINAL, p.get(Parameter::LongitudinalDamping))
}

impl TireLagModel for Ddt {
    fn state_names(&self) -> &'static [&'static str] {
        &["uPsi", "uY", "uX"]
    }

    fn system(&self, p: &Parameters, at: &OperatingPoint) -> StateSpace {
        let mut b = SystemBuilder::new(3);
        let yaw_stiffness = p.get(Parameter::YawStiffness);
        let yaw_damping = p.get(Parameter::YawDamping);
        let lateral_damping = p.get(Parameter::LateralDamping);

        b.rate(
            YAW,
            &[(
                YAW,
                -at.lateral_relaxation_speed() / p.get(Parameter::YawRelaxationLength),
            )],
            &[(DrivingInput::SteerRate, 1.0)],
        );
        b.rate(
            LATERAL,
            &[
                (YAW, at.vx()),
                (
                    LATERAL,
                    -at.lateral_relaxation_speed() / p.lateral_relaxation_length(),
                ),
            ],
            &[(DrivingInput::Vy, 1.0)],
        );
        b.output(Output::Fy, &[(LATERAL, -p.lateral_stiffness())], &[]);
        b.output_rate(Output::Fy, LATERAL, -lateral_damping);
        b.output(Output::DeflY, &[(LATERAL, 1.0)], &[]);
        b.output(Output::Mz, &[(YAW, -yaw_stiffness)], &[]);
        b.output_rate(Output::Mz, YAW, -yaw_damping);
        b.output(Output::DeflPsi, &[(YAW, 1.0)], &[]);

        longitudinal(p).write(&mut b, at.longitudinal_relaxation_speed());
        write_rolling_moment_from_fx(&mut b, p);
        write_common_outputs(&mut b, p, at);
        b.finish()
    }

    /// The lateral and longitudinal spring-dampers and the yaw spring-damper, whose
    /// moment is `-Mz` (less the trail term).
    fn contact_elements(&self, p: &Parameters) -> ContactElements {
        let lateral = ContactElement {
            state: LATERAL,
            stiffness: p.lateral_stiffness(),
            damping: p.get(Parameter::LateralDamping),
            force_outputs: [(Output::Fy, -1.0), (Output::Mz, p.get(Parameter::PneumaticTrail))],
        };
        let yaw = ContactElement {
            state: YAW,
            stiffness: p.get(Parameter::YawStiffness),
            damping: p.get(Parameter::YawDamping),
            force_outputs: [(Output::Mz, -1.0), (Output::Mz, 0.0)],
        };
        [
            Some(longitudinal(p).longitudinal_element(p)),
            Some(lateral),
            Some(yaw),
        ]
    }

    /// The yaw deflection feeds the lateral one (`vx uPsi`): energy can flow in through
    /// that coupling.
    fn passive(&self) -> bool {
        false
    }

    fn stored_energy(&self, p: &Parameters, x: &StateVector) -> f64 {
        0.5 * p.get(Parameter::YawStiffness) * x[YAW].powi(2)
            + 0.5 * p.lateral_stiffness() * x[LATERAL].powi(2)
            + longitudinal(p).energy(x)
    }
}
