//! RLT, the relaxation-length tire (Koo & Tan eq 13; Kim eqs 8-10).
//! States: lateral and longitudinal deflections uY, uX.
//! `duY/dt = vy - (rho/sigmaY) uY`, `Fy = -C_y uY`; the same longitudinally.
//! At standstill it is an undamped spring of stiffness `C_y = Calpha/sigmaY`.

use super::{Relaxation, TireLagModel, write_common_outputs, write_rolling_moment_from_fx};
use crate::physics::friction::ContactElements;
use crate::physics::load::OperatingPoint;
use crate::physics::parameters::Parameters;
use crate::physics::signals::{DrivingInput, Output};
use crate::physics::state_space::{StateSpace, StateVector, SystemBuilder};

pub struct Rlt;

const LATERAL: usize = 0;
const LONGITUDINAL: usize = 1;

fn lateral(p: &Parameters) -> Relaxation {
    Relaxation {
        state: LATERAL,
        input: DrivingInput::Vy,
        relaxation_length: p.lateral_relaxation_length(),
        stiffness: p.lateral_stiffness(),
        damping: 0.0,
        force: Output::Fy,
        deflection: Output::DeflY,
    }
}

impl TireLagModel for Rlt {
    fn state_names(&self) -> &'static [&'static str] {
        &["uY", "uX"]
    }

    fn system(&self, p: &Parameters, at: &OperatingPoint) -> StateSpace {
        let mut b = SystemBuilder::new(2);
        lateral(p).write(&mut b, at.lateral_relaxation_speed());
        Relaxation::longitudinal(p, LONGITUDINAL, 0.0).write(&mut b, at.longitudinal_relaxation_speed());
        write_rolling_moment_from_fx(&mut b, p);
        write_common_outputs(&mut b, p, at);
        b.finish()
    }

    fn stored_energy(&self, p: &Parameters, x: &StateVector) -> f64 {
        lateral(p).energy(x) + Relaxation::longitudinal(p, LONGITUDINAL, 0.0).energy(x)
    }

    fn contact_elements(&self, p: &Parameters) -> ContactElements {
        [
            Some(Relaxation::longitudinal(p, LONGITUDINAL, 0.0).longitudinal_element(p)),
            Some(lateral(p).lateral_element(p)),
            None,
        ]
    }
}
