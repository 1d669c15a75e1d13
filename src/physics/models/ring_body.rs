//! RingBody (Park & Nikravesh): a rigid ring on the wheel with lateral and
//! circumferential flexibility and inertia, joined to the ground by lagged tread springs.
//! States: lateral (eta, uT, w) as SecondOrder with ringMass and ringDampingY;
//! circumferential ring displacement xr, tread deflection uTx and ring slip velocity wx,
//! with equivalent mass `ringInertia/Re^2`. Fx passes through the joint (`-kT_x uTx`);
//! My passes through the ring spring-damper, `-Re (k_x xr + ringDampingX (wx - vsx))`.

use super::{ContactMass, TireLagModel, write_common_outputs};
use crate::physics::friction::ContactElements;
use crate::physics::load::OperatingPoint;
use crate::physics::parameters::{Parameter, Parameters};
use crate::physics::signals::{DrivingInput, Output};
use crate::physics::state_space::{StateSpace, StateVector, SystemBuilder};

pub struct RingBody;

const LATERAL: usize = 0; // eta, uT, w
const CIRCUMFERENTIAL: usize = 3; // xr, uTx, wx

fn lateral(p: &Parameters) -> ContactMass {
    ContactMass::lateral(
        p,
        LATERAL,
        p.get(Parameter::RingMass),
        p.get(Parameter::RingLateralDamping),
    )
}

fn circumferential(p: &Parameters) -> ContactMass {
    let rolling_radius = p.get(Parameter::RollingRadius);
    ContactMass {
        offset: CIRCUMFERENTIAL,
        tread: CIRCUMFERENTIAL + 1,
        velocity: CIRCUMFERENTIAL + 2,
        input: DrivingInput::Vsx,
        mass: p.get(Parameter::RingInertia) / (rolling_radius * rolling_radius),
        carcass_stiffness: p.carcass_longitudinal_stiffness(),
        carcass_damping: p.get(Parameter::RingCircumferentialDamping),
        tread_stiffness: p.tread_longitudinal_stiffness(),
        tread_relaxation_length: p.tread_relaxation_length(),
    }
}

impl TireLagModel for RingBody {
    fn state_names(&self) -> &'static [&'static str] {
        &["eta", "uT", "w", "xr", "uTx", "wx"]
    }

    fn system(&self, p: &Parameters, at: &OperatingPoint) -> StateSpace {
        let mut b = SystemBuilder::new(6);
        let contact = lateral(p);
        contact.write(&mut b, at.lateral_relaxation_speed());
        contact.carcass_force(&mut b, Output::Fy, 1.0);
        contact.deflection(&mut b, Output::DeflY);

        let ring = circumferential(p);
        ring.write(&mut b, at.longitudinal_relaxation_speed());
        b.output(Output::Fx, &[(ring.tread, -ring.tread_stiffness)], &[]);
        ring.carcass_force(&mut b, Output::My, -p.get(Parameter::RollingRadius));
        ring.deflection(&mut b, Output::DeflX);

        write_common_outputs(&mut b, p, at);
        b.finish()
    }

    fn stored_energy(&self, p: &Parameters, x: &StateVector) -> f64 {
        lateral(p).energy(x) + circumferential(p).energy(x)
    }

    /// The treads; Fx is the circumferential tread force itself (`Fx = -kT_x uTx`).
    fn contact_elements(&self, p: &Parameters) -> ContactElements {
        let mut circumferential = circumferential(p).tread_element();
        circumferential.force_outputs[0] = (Output::Fx, -1.0);
        [Some(circumferential), Some(lateral(p).tread_element()), None]
    }
}
