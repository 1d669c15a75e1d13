//! A step in which no branch can carry a force: every limit is zero (a friction
//! coefficient of zero, or a load at which the load sensitivity takes it to zero). The
//! contact is frictionless, so the tire is linear again: the elements' states are held
//! at zero (their branches emptied where the modes were decided), and the rest of the
//! model (a carcass, a contact mass, a ring) moves by its own equations with them. Its
//! exact step map takes the step, at any stiffness and any length, where an integration
//! would have to resolve the model's fastest mode (a ring of a few grams on a stiff
//! damper: 1e7/s).

use super::{NotConverged, SlidingStep};
use crate::physics::signals::DrivingInput;
use crate::physics::state_space::{DrivingVector, StateVector};
use crate::physics::stepper::{Blocks, StepMap};

impl SlidingStep<'_> {
    /// Whether no branch can carry a force: no group has a member.
    pub(super) fn frictionless(&self) -> bool {
        self.slots().is_empty()
    }

    /// The step of `h` seconds of a frictionless contact ([`SlidingStep::frictionless`]):
    /// the model's step map with its elements' states held at zero. Not converged only
    /// where the states would not be finite.
    pub(super) fn frictionless_step(&self, x: &mut StateVector, h: f64) -> Result<(), NotConverged> {
        // The branches were emptied where the modes were decided, the elements' states
        // with them: the map holds those at zero, and the offsets stay as they are.
        let mut system = self.system.clone();
        for e in self.layout.elements() {
            for j in 0..system.states {
                system.a[(e.state, j)] = 0.0;
            }
            for k in 0..DrivingInput::COUNT {
                system.b[(e.state, k)] = 0.0;
            }
        }
        let map = StepMap::new(&system, &Blocks::of(&system), h);
        let ramp = (self.input_rates != DrivingVector::zeros()).then_some(&self.input_rates);
        let end = map.advance(x, &self.inputs, ramp);
        if !end.iter().all(|v| v.is_finite()) {
            return Err(NotConverged);
        }
        *x = end;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::with_prepared_step;
    use crate::physics::friction::FrictionLaw;
    use crate::physics::{ModelKind, Parameter, Parameters};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// With muX = muY = 0 every limit is zero, and the frictionless step's map ends
        /// where the whole-system integration of the same step does (each to a relative
        /// 1e-12, here within 1e-10 of the largest state), for every model and law, from
        /// random deflections (emptied at the start) and carcass states of up to 1 cm,
        /// over steps of 0.1 to 20 ms.
        #[test]
        fn a_frictionless_step_ends_where_the_integration_does(
            model in prop::sample::select(ModelKind::ALL.to_vec()),
            law in prop::sample::select(vec![FrictionLaw::Coulomb, FrictionLaw::Brush]),
            vx in -20.0..20.0f64,
            load_ratio in 0.2..2.0f64,
            inputs in prop::array::uniform3(-1.0..1.0f64),
            states in prop::array::uniform4(-1.0..1.0f64),
            h in prop::sample::select(vec![1e-4, 1e-3, 2e-2]),
        ) {
            let mut p = Parameters::default().with_model(model).with_friction(law);
            p.set(Parameter::LongitudinalFriction, 0.0).unwrap();
            p.set(Parameter::LateralFriction, 0.0).unwrap();
            let load = load_ratio * p.get(Parameter::NominalLoad);
            with_prepared_step(&p, (vx, load), (&states, inputs), |step, x, sliders, unit| {
                prop_assert!(step.frictionless());
                let (mut x_map, sliders_map) = (x, sliders);
                step.frictionless_step(&mut x_map, h).expect("a finite step");
                let (mut x_whole, mut sliders_whole) = (x, sliders);
                step.integrate_by_current_method(&mut x_whole, &mut sliders_whole, h).expect("a valid step");
                prop_assert_eq!(sliders_map, sliders_whole);
                let largest = x_map.iter().chain(x_whole.iter()).fold(unit, |m: f64, v| m.max(v.abs()));
                for k in 0..step.system.states {
                    prop_assert!(
                        (x_map[k] - x_whole[k]).abs() <= 1e-10 * largest,
                        "{model:?} {law:?}, state {k}: {} vs {} (largest {largest})", x_map[k], x_whole[k]
                    );
                }
                Ok(())
            })?;
        }
    }
}
