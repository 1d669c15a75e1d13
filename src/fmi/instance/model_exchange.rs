//! The Model Exchange calls of an instance: time, continuous states, derivatives, event
//! indicators and the event update, over the hybrid tire
//! ([`crate::physics::tire::hybrid`]). The call sequence is checked as for Co-Simulation,
//! and a Model Exchange call on a Co-Simulation instance is refused.

use super::{CONTINUOUS_STATES, ContinuousStates, EventUpdate, GUARDS, Instance, Interface};
use crate::fmi::state_machine::Call;
use crate::fmi::status::{CallResult, Rejection};

impl Instance {
    /// Ok if `call` may be made now on a Model Exchange instance.
    #[inline]
    fn require_model_exchange(&self, call: Call) -> CallResult {
        if self.interface != Interface::ModelExchange {
            return Err(not_model_exchange());
        }
        self.require(call)
    }

    #[inline]
    pub fn set_time(&mut self, time: f64) -> CallResult {
        self.require_model_exchange(Call::SetTime)?;
        if !time.is_finite() {
            return Err(Rejection::error(format!("time {time} s is not finite")));
        }
        self.time = time;
        Ok(())
    }

    #[inline]
    pub fn set_continuous_states(&mut self, values: &[f64]) -> CallResult {
        self.require_model_exchange(Call::SetContinuousStates)?;
        let states = state_vector("x", values)?;
        self.tire.set_continuous_states(states).map_err(Rejection::error)
    }

    pub fn get_continuous_states(&mut self, values: &mut [f64]) -> CallResult {
        self.require_model_exchange(Call::GetContinuousValues)?;
        let values = fixed_length("x", values)?;
        self.sync_tire()?;
        *values = self.tire.continuous_states();
        Ok(())
    }

    #[inline]
    pub fn get_derivatives(&mut self, values: &mut [f64]) -> CallResult {
        self.require_model_exchange(Call::GetContinuousValues)?;
        let values: &mut ContinuousStates = fixed_length("derivatives", values)?;
        self.sync_tire()?;
        copy_inline(values, self.tire.continuous_rates());
        Ok(())
    }

    #[inline]
    pub fn get_event_indicators(&mut self, values: &mut [f64]) -> CallResult {
        self.require_model_exchange(Call::GetContinuousValues)?;
        let values: &mut [f64; GUARDS] = fixed_length("eventIndicators", values)?;
        self.sync_tire()?;
        *values = *self.tire.guards();
        Ok(())
    }

    pub fn get_nominals(&mut self, values: &mut [f64]) -> CallResult {
        self.require_model_exchange(Call::GetNominals)?;
        let values: &mut ContinuousStates = fixed_length("x_nominal", values)?;
        // Before initialisation the tire may not yet have the importer's parameters.
        let nominals = match self.sync_tire() {
            Ok(()) => self.tire.continuous_state_nominals(),
            Err(_) => [1.0; CONTINUOUS_STATES],
        };
        *values = nominals;
        Ok(())
    }

    pub fn enter_event_mode(&mut self) -> CallResult {
        self.require_model_exchange(Call::EnterEventMode)?;
        self.phase = crate::fmi::state_machine::Phase::EventMode;
        Ok(())
    }

    /// The modes decided anew from the states and inputs. One update settles them (the
    /// decision is made from the states it leaves), so no second one is needed.
    pub fn new_discrete_states(&mut self) -> CallResult<EventUpdate> {
        self.require_model_exchange(Call::NewDiscreteStates)?;
        Ok(EventUpdate {
            continuous_states_changed: self.tire.update_modes(),
        })
    }

    pub fn enter_continuous_time_mode(&mut self) -> CallResult {
        self.require_model_exchange(Call::EnterContinuousTimeMode)?;
        self.phase = crate::fmi::state_machine::Phase::ContinuousTimeMode;
        Ok(())
    }

    /// Nothing to do after an integrator step: modes change only at state events.
    pub fn completed_integrator_step(&mut self) -> CallResult {
        self.require_model_exchange(Call::CompletedIntegratorStep)
    }
}

#[cold]
#[inline(never)]
fn not_model_exchange() -> Box<Rejection> {
    Rejection::error("this is a Model Exchange function; the instance was made for Co-Simulation")
}

/// `*to = *from`, in two parts that each stay a few moves; one copy of the whole is a call
/// to memcpy, about 30 instructions more per evaluation (callgrind, `me_evaluation`'s
/// loop) and 3-6 ns. The parts split at an even entry, so that every write is of a pair
/// of entries: an importer that reads them two at a time right away (a vectorised update
/// of its states) is served from the writes, not kept waiting for them to land.
#[inline(always)]
fn copy_inline(to: &mut ContinuousStates, from: &ContinuousStates) {
    const SPLIT: usize = CONTINUOUS_STATES / 4 * 2;
    to[..SPLIT].copy_from_slice(&from[..SPLIT]);
    to[SPLIT..].copy_from_slice(&from[SPLIT..]);
}

/// An output array of a call, checked for its length.
#[inline]
fn fixed_length<'a, const N: usize>(name: &str, values: &'a mut [f64]) -> CallResult<&'a mut [f64; N]> {
    let given = values.len();
    <&mut [f64; N]>::try_from(values).map_err(|_| wrong_length(name, given, N, "were asked for"))
}

/// The continuous state vector of a call, checked for its length.
#[inline]
fn state_vector<'a>(name: &str, values: &'a [f64]) -> CallResult<&'a ContinuousStates> {
    <&ContinuousStates>::try_from(values)
        .map_err(|_| wrong_length(name, values.len(), CONTINUOUS_STATES, "were given"))
}

#[cold]
#[inline(never)]
fn wrong_length(name: &str, given: usize, expected: usize, what: &str) -> Box<Rejection> {
    Rejection::error(format!(
        "{name}: {given} values {what}, but the FMU has {expected}"
    ))
}
