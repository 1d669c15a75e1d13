//! The FMI 2.0 call sequences of Co-Simulation and Model Exchange as one explicit state
//! machine: both share instantiation, initialisation and termination; after
//! initialisation a Co-Simulation instance is in step mode, a Model Exchange instance
//! alternates between event mode and continuous-time mode.
//!
//! A call that is not allowed in the current phase is rejected with fmi2Error and a
//! message naming the phase; a rejected call changes nothing.

use super::status::{CallResult, Rejection};

/// Where an instance is in its life (FMI 2.0 sections 3.2.3 and 4.2.4). Steps always
/// complete before fmi2DoStep returns, so there is no pending phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Instantiated = 0,
    InitializationMode = 1,
    StepComplete = 2,
    Terminated = 3,
    /// A panic was caught inside the FMU: only fmi2FreeInstance and fmi2Reset are allowed.
    Fatal = 4,
    /// Model Exchange: modes may change (fmi2NewDiscreteStates).
    EventMode = 5,
    /// Model Exchange: the importer's solver integrates the continuous states.
    ContinuousTimeMode = 6,
}

impl Phase {
    pub const ALL: [Phase; 7] = [
        Phase::Instantiated,
        Phase::InitializationMode,
        Phase::StepComplete,
        Phase::Terminated,
        Phase::Fatal,
        Phase::EventMode,
        Phase::ContinuousTimeMode,
    ];

    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|p| *p as u8 == code)
    }

    /// Initialised and not terminated: step mode, event mode or continuous-time mode.
    pub const fn running(self) -> bool {
        self.bit() & RUNNING != 0
    }

    const fn bit(self) -> u8 {
        1 << self as u8
    }

    pub const fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "instantiated",
            Phase::InitializationMode => "initialization mode",
            Phase::StepComplete => "step mode",
            Phase::Terminated => "terminated",
            Phase::Fatal => "fatal error",
            Phase::EventMode => "event mode",
            Phase::ContinuousTimeMode => "continuous-time mode",
        }
    }
}

/// The kinds of call whose allowed phases differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Call {
    SetDebugLogging,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetValues,
    /// Setting parameters (fixed) or inputs; which of them is checked per variable.
    SetValues,
    GetFmuState,
    SetFmuState,
    GetDirectionalDerivative,
    SetInputDerivatives,
    GetOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    SetTime,
    SetContinuousStates,
    EnterEventMode,
    NewDiscreteStates,
    EnterContinuousTimeMode,
    CompletedIntegratorStep,
    /// fmi2GetDerivatives, fmi2GetEventIndicators, fmi2GetContinuousStates.
    GetContinuousValues,
    GetNominals,
}

const INSTANTIATED: u8 = Phase::Instantiated.bit();
const INIT: u8 = Phase::InitializationMode.bit();
const STEP: u8 = Phase::StepComplete.bit();
const TERMINATED: u8 = Phase::Terminated.bit();
const FATAL: u8 = Phase::Fatal.bit();
const EVENT: u8 = Phase::EventMode.bit();
const CONTINUOUS: u8 = Phase::ContinuousTimeMode.bit();
/// Initialised and running: step mode (CS), event or continuous-time mode (ME).
const RUNNING: u8 = STEP | EVENT | CONTINUOUS;
const NONE: u8 = 0;

impl Call {
    /// The phases in which this call is allowed.
    const fn allowed(self) -> u8 {
        match self {
            Call::SetDebugLogging => INSTANTIATED | INIT | RUNNING | TERMINATED,
            Call::SetupExperiment | Call::EnterInitializationMode => INSTANTIATED,
            Call::ExitInitializationMode => INIT,
            Call::Terminate => RUNNING,
            Call::DoStep => STEP,
            Call::GetStatus => STEP | TERMINATED,
            Call::Reset => INSTANTIATED | INIT | RUNNING | TERMINATED | FATAL,
            Call::GetValues | Call::GetDirectionalDerivative => INIT | RUNNING | TERMINATED,
            Call::SetValues => INSTANTIATED | INIT | RUNNING,
            Call::SetInputDerivatives => INSTANTIATED | INIT | STEP,
            Call::GetFmuState | Call::SetFmuState => INSTANTIATED | INIT | RUNNING | TERMINATED,
            Call::GetOutputDerivatives => STEP | TERMINATED,
            Call::SetTime => EVENT | CONTINUOUS,
            Call::SetContinuousStates | Call::CompletedIntegratorStep => CONTINUOUS,
            Call::EnterEventMode => EVENT | CONTINUOUS,
            Call::NewDiscreteStates | Call::EnterContinuousTimeMode => EVENT,
            Call::GetContinuousValues => INIT | EVENT | CONTINUOUS | TERMINATED,
            Call::GetNominals => INSTANTIATED | INIT | EVENT | CONTINUOUS | TERMINATED,
            // fmi2DoStep never returns fmi2Pending, so there is never a step to cancel.
            Call::CancelStep => NONE,
        }
    }

    /// Ok if `self` may be called in `phase`, else the error that says why not.
    /// Whether the call is allowed in `phase`.
    #[inline]
    pub fn allows(self, phase: Phase) -> bool {
        self.allowed() & phase.bit() != 0
    }

    #[inline]
    pub fn check(self, phase: Phase) -> CallResult {
        if self.allows(phase) {
            Ok(())
        } else {
            self.refuse(phase)
        }
    }

    #[cold]
    #[inline(never)]
    fn refuse(self, phase: Phase) -> CallResult {
        let allowed: Vec<&str> = Phase::ALL
            .iter()
            .filter(|p| self.allowed() & p.bit() != 0)
            .map(|p| p.name())
            .collect();
        if allowed.is_empty() {
            return Err(Rejection::error(
                "this call is never allowed: fmi2DoStep completes before it returns, so no step is pending",
            ));
        }
        Err(Rejection::error(format!(
            "this call is not allowed in {}; it is allowed in {}",
            phase.name(),
            allowed.join(", ")
        )))
    }
}
