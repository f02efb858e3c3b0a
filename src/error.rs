//! One error type for the whole harness.
//!
//! Every error is a single line that names the file, the field and what was expected, so that a
//! researcher can fix a broken scene or experiment file without reading a backtrace. The binary
//! prints it as `error: <message>` and exits with status 2.

use std::fmt;

/// A one-line, user-facing error message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    message: String,
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn new(message: impl Into<String>) -> Self {
        let message: String = message.into();
        // Keep the promise of one line even when a library hands us a multi-line message.
        let message = message.split_whitespace().collect::<Vec<_>>().join(" ");
        Self { message }
    }

    pub fn message(&self) -> &str {
        &self.message
    }

    /// Prefixes the message with more context, e.g. the file it came from.
    pub fn context(self, prefix: impl fmt::Display) -> Self {
        Self::new(format!("{prefix}: {}", self.message))
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

/// Returns early with an [`Error`] built from a format string.
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::error::Error::new(format!($($arg)*)))
    };
}

/// Attaches a one-line context to any error convertible to a string.
pub trait Context<T> {
    fn context(self, what: impl fmt::Display) -> Result<T>;
}

impl<T, E: fmt::Display> Context<T> for std::result::Result<T, E> {
    fn context(self, what: impl fmt::Display) -> Result<T> {
        self.map_err(|e| Error::new(format!("{what}: {e}")))
    }
}
