//! What a link (or the worker) tells the user as it goes, with what it is about, so the
//! window and the scripts act on the kind and show the words.

use std::fmt;

/// One thing to tell the user.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Notice {
    pub kind: NoticeKind,
    pub text: String,
}

/// What a notice is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoticeKind {
    /// For the log: something learned or chosen (a fallback, a PDO mapping, a refused
    /// setting, a command sent again).
    Info,
    /// An emergency message from the drive (CANopen EMCY); error code 0 is its reset.
    Emcy {
        node: u8,
        error_code: u16,
        error_register: u8,
    },
    /// The worker stopped the motor by itself: a jog whose keep-alives stopped, a move
    /// whose link failed.
    MotorStopped,
}

impl Notice {
    pub fn info(text: impl Into<String>) -> Notice {
        Notice {
            kind: NoticeKind::Info,
            text: text.into(),
        }
    }

    pub fn motor_stopped(text: impl Into<String>) -> Notice {
        Notice {
            kind: NoticeKind::MotorStopped,
            text: text.into(),
        }
    }
}

impl fmt::Display for Notice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}
