//! SecondOrder, the contact-mass model (Kim eqs 1-5), made standstill-safe by a tread
//! state. States: contact-mass offset from the wheel eta, tread deflection uT,
//! contact-mass absolute lateral velocity w, longitudinal deflection uX.
//! Laterally a contact mass sits between the carcass spring-damper
//! (`k_y = Calpha/(sigmaY - sigmaTread)`, `carcassDampingY`) and the lagged tread spring
//! (`kT_y = Calpha/sigmaTread`); longitudinally it is RLT.

use super::{ContactMass, Relaxation, TireLagModel, write_common_outputs, write_rolling_moment_from_fx};
use crate::physics::friction::ContactElements;
use crate::physics::load::OperatingPoint;
use crate::physics::parameters::{Parameter, Parameters};
use crate::physics::signals::Output;
use crate::physics::state_space::{StateSpace, StateVector, SystemBuilder};

pub struct SecondOrder;

const LATERAL: usize = 0; // eta, uT, w
const LONGITUDINAL: usize = 3;

fn lateral(p: &Parameters) -> ContactMass {
    ContactMass::lateral(
        p,
        LATERAL,
        p.get(Parameter::ContactMass),
        p.get(Parameter::CarcassLateralDamping),
    )
}

impl TireLagModel for SecondOrder {
    fn state_names(&self) -> &'static [&'static str] {
        &["eta", "uT", "w", "uX"]
    }

    fn system(&self, p: &Parameters, at: &OperatingPoint) -> StateSpace {
        let mut b = SystemBuilder::new(4);
        let contact = lateral(p);
        contact.write(&mut b, at.lateral_relaxation_speed());
        contact.carcass_force(&mut b, Output::Fy, 1.0);
        contact.deflection(&mut b, Output::DeflY);
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
            Some(lateral(p).tread_element()),
            None,
        ]
    }
}
