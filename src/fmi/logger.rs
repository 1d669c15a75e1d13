//! Log messages to the importer's logger callback, by FMI log category. The callback is
//! FMI 2.0's (a format string with the instance name) or FMI 3.0's (the plain text).

use std::ffi::CString;

use super::status::Status;
use super::sys::{fmi2CallbackLogger, fmi2ComponentEnvironment, fmi2Status};
use super::sys3::{fmi3InstanceEnvironment, fmi3LogMessageCallback, fmi3Status};

/// The importer's logger callback, as the FMI version it instantiated with gives it.
#[derive(Clone, Copy, Debug)]
pub enum Callback {
    Fmi2 {
        logger: fmi2CallbackLogger,
        environment: fmi2ComponentEnvironment,
    },
    Fmi3 {
        log_message: fmi3LogMessageCallback,
        environment: fmi3InstanceEnvironment,
    },
}

/// The log categories declared in the model description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Category {
    /// Calls that returned fmi2Error.
    StatusError,
    /// Calls that returned fmi2Warning.
    StatusWarning,
    /// Every call and its arguments.
    All,
}

impl Category {
    pub const ALL: [Category; 3] = [Category::StatusError, Category::StatusWarning, Category::All];

    pub const fn name(self) -> &'static str {
        match self {
            Category::StatusError => "logStatusError",
            Category::StatusWarning => "logStatusWarning",
            Category::All => "logAll",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    pub fn for_status(status: Status) -> Self {
        match status {
            Status::Error | Status::Fatal => Category::StatusError,
            Status::Warning | Status::Discard => Category::StatusWarning,
            Status::Ok => Category::All,
        }
    }
}

/// The importer's logger with the categories switched on.
#[derive(Clone, Debug)]
pub struct Logger {
    callback: Callback,
    instance_name: CString,
    enabled: [bool; 3],
}

// SAFETY: the logger callback and its environment belong to the importer, which the FMI
// standard makes responsible for calling an instance from one thread at a time.
unsafe impl Send for Logger {}

impl Logger {
    /// Errors are always logged; warnings and call traces when `logging_on`.
    pub fn new(callback: Callback, instance_name: CString, logging_on: bool) -> Self {
        Self {
            callback,
            instance_name,
            enabled: [true, logging_on, logging_on],
        }
    }

    pub fn instance_name(&self) -> &str {
        self.instance_name
            .to_str()
            .unwrap_or("(instance name is not UTF-8)")
    }

    pub fn enabled(&self, category: Category) -> bool {
        self.enabled[category as usize]
    }

    /// SetDebugLogging: no categories means all of them.
    pub fn set_categories(&mut self, on: bool, categories: &[Category]) {
        if categories.is_empty() {
            self.enabled = [on; 3];
        } else {
            for &c in categories {
                self.enabled[c as usize] = on;
            }
        }
    }

    pub fn log(&self, status: Status, category: Category, message: &str) {
        if self.enabled(category) {
            send(self.callback, &self.instance_name, status, category, message);
        }
    }
}

/// The message as an FMI 2.0 logger format (section 2.1.5): the text itself with every
/// '%' written as '%%' and every '#' as '##', so that it reads the same in importers that
/// format it (fmpy, FMI Library, fmusim) and in those that print it as it comes. NUL bytes
/// would cut the C string short; they become spaces.
pub fn escape_message(message: &str) -> CString {
    let mut escaped = String::with_capacity(message.len() + 8);
    for c in message.chars() {
        match c {
            '%' => escaped.push_str("%%"),
            '#' => escaped.push_str("##"),
            '\0' => escaped.push(' '),
            c => escaped.push(c),
        }
    }
    CString::new(escaped).expect("NUL bytes were replaced")
}

/// Calls the importer's logger: FMI 2.0's with the escaped message as the format and no
/// variable arguments, FMI 3.0's with the message as it is (FMI 3.0 does not format it).
pub(super) fn send(
    callback: Callback,
    instance_name: &CString,
    status: Status,
    category: Category,
    message: &str,
) {
    // The strings are made only for a callback that is there (FMI 3.0 allows none).
    match callback {
        Callback::Fmi2 {
            logger: Some(logger),
            environment,
        } => {
            let (category, message) = (c_text(category.name()), escape_message(message));
            // SAFETY: the importer gave this callback for exactly this call; every string
            // is a valid NUL-terminated C string that outlives the call.
            unsafe {
                logger(
                    environment,
                    instance_name.as_ptr(),
                    status as fmi2Status,
                    category.as_ptr(),
                    message.as_ptr(),
                )
            }
        }
        Callback::Fmi3 {
            log_message: Some(log_message),
            environment,
        } => {
            let (category, message) = (c_text(category.name()), c_text(message));
            // SAFETY: as above.
            unsafe {
                log_message(
                    environment,
                    status as fmi3Status,
                    category.as_ptr(),
                    message.as_ptr(),
                )
            }
        }
        _ => {}
    }
}

/// `text` as a C string, a NUL byte in it (which would end the string) made a space.
fn c_text(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).expect("NUL bytes were replaced")
}

#[cfg(test)]
mod tests {
    use super::escape_message;

    #[test]
    fn percent_and_hash_are_doubled_and_nul_becomes_space() {
        let escaped = escape_message("100% of #1\0end");
        assert_eq!(escaped.to_str().unwrap(), "100%% of ##1 end");
    }
}
