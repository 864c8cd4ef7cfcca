use std::fmt;
use std::time::Duration;

use crate::cia::AbortCode;

/// A link that cannot do its job: the connection, not the drive's answer.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: std::io::Error,
    },

    #[error("{what}: no answer within {} ms", after.as_millis())]
    Timeout { what: String, after: Duration },

    #[error("the connection was lost: {0}")]
    Disconnected(String),

    #[error("{0}")]
    Refused(String),

    #[error("{0}")]
    Unsupported(String),

    #[error("malformed reply: {0}")]
    Protocol(String),

    /// The drive answered the process-image exchange, but with a refusal (a Modbus
    /// exception, a CIP error status, an SDO abort): its answer, not a broken frame.
    #[error("{0}")]
    Answer(String),

    /// Every try of one request went wrong: lost, late, corrupted or mismatched replies,
    /// each named.
    #[error("{what}: no valid reply in {tries} tries ({})", troubles.join("; "))]
    NoValidReply {
        what: String,
        tries: u32,
        troubles: Vec<String>,
    },
}

/// Which kind of link failure it was, for those who act on it (retry, check the cable,
/// fix the configuration) without reading its words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    Io,
    Timeout,
    Disconnected,
    Refused,
    Unsupported,
    Protocol,
    Answer,
    NoValidReply,
}

/// A link error as it travels in the worker's events: its kind and its words (the
/// `io::Error` inside an [`Error`] cannot be cloned).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{text}")]
pub struct LinkFailure {
    pub kind: ErrorKind,
    pub text: String,
}

impl LinkFailure {
    /// `error`'s kind, told in other words (e.g. with what was done to the drive).
    pub fn new(error: &Error, text: impl Into<String>) -> LinkFailure {
        LinkFailure {
            kind: error.kind(),
            text: text.into(),
        }
    }
}

impl From<&Error> for LinkFailure {
    fn from(error: &Error) -> LinkFailure {
        LinkFailure::new(error, error.to_string())
    }
}

impl From<Error> for LinkFailure {
    fn from(error: Error) -> LinkFailure {
        LinkFailure::from(&error)
    }
}

impl Error {
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::Io { .. } => ErrorKind::Io,
            Error::Timeout { .. } => ErrorKind::Timeout,
            Error::Disconnected(_) => ErrorKind::Disconnected,
            Error::Refused(_) => ErrorKind::Refused,
            Error::Unsupported(_) => ErrorKind::Unsupported,
            Error::Protocol(_) => ErrorKind::Protocol,
            Error::Answer(_) => ErrorKind::Answer,
            Error::NoValidReply { .. } => ErrorKind::NoValidReply,
        }
    }

    /// Whether reconnecting may help (as opposed to a configuration mistake).
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            Error::Io { .. }
                | Error::Timeout { .. }
                | Error::Disconnected(_)
                | Error::Refused(_)
                | Error::Protocol(_)
                | Error::Answer(_)
                | Error::NoValidReply { .. }
        )
    }

    /// Whether the failure may pass by itself within a few cycles (a lost, late, corrupted
    /// or refused reply), so that the worker retries the next cycle before it calls the
    /// link lost; a closed connection or a failed socket is gone for good.
    pub fn is_momentary(&self) -> bool {
        matches!(
            self,
            Error::Timeout { .. }
                | Error::Protocol(_)
                | Error::Answer(_)
                | Error::NoValidReply { .. }
        )
    }
}

/// The drive's refusal of an object access. Each variant keeps its bus's own code.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// A CiA 301 abort code (SDO abort, the simulator, PDI-ReturnValue, FC 43 extended
    /// exception).
    Abort(AbortCode),
    /// A Modbus exception (01 to 04 and others) to an object access.
    Modbus { function: u8, code: u8 },
    /// A CIP error status to an EtherNet/IP object service, with the service and the
    /// object it named.
    Cip {
        what: String,
        status: u8,
        additional: Vec<u16>,
    },
    /// The answer did not fit the object's type.
    Malformed(String),
    /// The link has no object access of its own; use the PDI.
    NotSupported,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Abort(code) => write!(f, "abort {code}"),
            Refusal::Modbus { function, code } => write!(
                f,
                "Modbus exception {code:02X}h ({}) to FC {function}",
                modbus_exception_text(*code)
            ),
            Refusal::Cip {
                what,
                status,
                additional,
            } => {
                let general = crate::proto::enip::cip::GeneralStatus(*status);
                write!(f, "{what}: {general}")?;
                if !additional.is_empty() {
                    let words: Vec<String> =
                        additional.iter().map(|w| format!("{w:04X}h")).collect();
                    write!(f, ", additional status {}", words.join(" "))?;
                }
                // Two words after a vendor-specific error: the adapter's SDO abort code.
                if let (0x1F, [low, high]) = (*status, additional.as_slice()) {
                    let code = AbortCode(u32::from(*high) << 16 | u32::from(*low));
                    write!(f, " = SDO abort {code}")?;
                }
                Ok(())
            }
            Refusal::Malformed(text) => write!(f, "malformed answer: {text}"),
            Refusal::NotSupported => f.write_str("this link has no direct object access"),
        }
    }
}

/// The standard text of a Modbus exception code.
pub fn modbus_exception_text(code: u8) -> &'static str {
    crate::proto::modbus::pdu::Exception::Standard { function: 0, code }.text()
}
