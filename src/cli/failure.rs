//! Why a one-shot command did not succeed: the message and the exit code.

use super::interrupt::OsSignal;
use super::{EXIT_FAILED, EXIT_INTERRUPTED, EXIT_USAGE};

/// Why a one-shot command did not succeed: the message and the exit code.
pub(super) struct Failure {
    pub(super) code: u8,
    pub(super) message: String,
    /// The signal that ended it, if one did.
    pub(super) signal: Option<OsSignal>,
    /// The command it ended may still run on the drive (a signal, a --wait that timed
    /// out): stop the drive by the `--on-exit` policy before exiting.
    pub(super) stop: bool,
}

impl Failure {
    /// This failure with more said after its message.
    pub(super) fn and(mut self, more: impl std::fmt::Display) -> Failure {
        self.message = format!("{}; {more}", self.message);
        self
    }
}

pub(super) fn interrupted(signal: OsSignal) -> Failure {
    Failure {
        code: EXIT_INTERRUPTED,
        message: format!("interrupted by {signal}"),
        signal: Some(signal),
        stop: true,
    }
}

pub(super) fn usage(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_USAGE,
        message: message.into(),
        signal: None,
        stop: false,
    }
}

pub(super) fn failed(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_FAILED,
        message: message.into(),
        signal: None,
        stop: false,
    }
}
