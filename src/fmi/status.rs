//! FMI status codes and the one place where call results become them.

use super::sys;

/// fmi2Status as a Rust enum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Status {
    Ok = sys::fmi2Status_fmi2OK,
    Warning = sys::fmi2Status_fmi2Warning,
    Discard = sys::fmi2Status_fmi2Discard,
    Error = sys::fmi2Status_fmi2Error,
    Fatal = sys::fmi2Status_fmi2Fatal,
}

/// Why a call did not simply succeed: the status it returns and a message that says
/// what was expected and what came.
#[derive(Clone, Debug, PartialEq)]
pub struct Rejection {
    pub status: Status,
    pub message: String,
}

impl Rejection {
    pub fn error(message: impl Into<String>) -> Box<Self> {
        Box::new(Self {
            status: Status::Error,
            message: message.into(),
        })
    }

    pub fn discard(message: impl Into<String>) -> Box<Self> {
        Box::new(Self {
            status: Status::Discard,
            message: message.into(),
        })
    }
}

/// The result of an FMI call made on an instance. The rejection is boxed: a call that
/// succeeds returns one machine word.
pub type CallResult<T = ()> = Result<T, Box<Rejection>>;
