//! Faults and warnings that can be injected into the simulated drive for demos and tests:
//! the vocabulary the window, the worker and the simulator share (each condition with the
//! CiA error code the drive reports for it).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::cia::ErrorCode;

/// An injectable condition. A fault stops the drive and stays until Clear Error is sent
/// *after* the condition is withdrawn; a warning only lights PdiStatusWarning.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Injection {
    /// The load is blocked: the motor cannot follow its demand (fault 8611h).
    FollowingError,
    /// The output current exceeded its limit (fault 2300h).
    OverCurrent,
    /// The supply voltage dropped to 9 V (fault 3100h).
    UnderVoltage,
    /// The controller is hot: 85 °C (warning 4200h, no fault).
    OverTemperature,
    /// The wire to input 1 (the negative limit switch, normally closed) is broken: the
    /// input reads low, so the switch reads as pressed. A condition of the machine, neither
    /// a fault nor a warning of the drive.
    WireBreak,
    /// The cable is pulled for 3 s: the link to the simulated drive stops answering (the
    /// drive itself carries on). Only the in-process link can simulate this.
    LinkLoss,
}

impl Injection {
    pub const ALL: [Injection; 6] = [
        Injection::FollowingError,
        Injection::OverCurrent,
        Injection::UnderVoltage,
        Injection::OverTemperature,
        Injection::WireBreak,
        Injection::LinkLoss,
    ];

    /// The conditions of the drive itself (not of the link to it).
    pub const DRIVE: [Injection; 5] = [
        Injection::FollowingError,
        Injection::OverCurrent,
        Injection::UnderVoltage,
        Injection::OverTemperature,
        Injection::WireBreak,
    ];

    /// The code the drive reports in 603Fh, 1003h and EMCY.
    pub fn error_code(self) -> ErrorCode {
        match self {
            Injection::FollowingError => ErrorCode::FOLLOWING_ERROR,
            Injection::OverCurrent => ErrorCode::OUTPUT_CURRENT,
            Injection::UnderVoltage => ErrorCode::VOLTAGE,
            Injection::OverTemperature => ErrorCode::TEMPERATURE,
            Injection::WireBreak | Injection::LinkLoss => ErrorCode::NONE,
        }
    }

    /// Nanotec error number (1003h bits 31-24).
    pub fn error_number(self) -> u8 {
        match self {
            Injection::FollowingError => 13,
            Injection::OverCurrent => 2,
            Injection::UnderVoltage => 3,
            Injection::OverTemperature => 12,
            Injection::WireBreak | Injection::LinkLoss => 0,
        }
    }

    /// The 1001h error register bits this condition sets.
    pub fn error_register(self) -> u8 {
        match self {
            Injection::FollowingError => 0x20 | 0x01,
            Injection::OverCurrent => 0x02 | 0x01,
            Injection::UnderVoltage => 0x04 | 0x01,
            Injection::OverTemperature => 0x08 | 0x01,
            Injection::WireBreak | Injection::LinkLoss => 0,
        }
    }

    pub fn is_fault(self) -> bool {
        !matches!(
            self,
            Injection::OverTemperature | Injection::WireBreak | Injection::LinkLoss
        )
    }

    /// Whether the drive reports it (a fault or a warning with its code); a condition of
    /// the machine or the link it does not.
    pub fn is_reported(self) -> bool {
        !matches!(self, Injection::WireBreak | Injection::LinkLoss)
    }

    /// Whether this is a condition of the link rather than of the drive.
    pub fn is_link(self) -> bool {
        self == Injection::LinkLoss
    }

    pub fn name(self) -> &'static str {
        match self {
            Injection::FollowingError => "following-error",
            Injection::OverCurrent => "over-current",
            Injection::UnderVoltage => "under-voltage",
            Injection::OverTemperature => "over-temperature",
            Injection::WireBreak => "wire-break",
            Injection::LinkLoss => "link-loss",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            Injection::FollowingError => "load blocked: following error fault (8611h)",
            Injection::OverCurrent => "output current too large: fault (2300h)",
            Injection::UnderVoltage => "supply voltage at 9 V: fault (3100h)",
            Injection::OverTemperature => "controller at 85 °C: warning (4200h)",
            Injection::WireBreak => {
                "wire to input 1 broken: the normally closed negative limit switch reads as pressed"
            }
            Injection::LinkLoss => {
                "cable pulled for 3 s: the link stops answering, the drive carries on"
            }
        }
    }
}

impl fmt::Display for Injection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Injection {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Injection::ALL
            .into_iter()
            .find(|i| i.name() == s.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = Injection::ALL.iter().map(|i| i.name()).collect();
                format!("unknown fault '{s}': use one of {}", names.join(", "))
            })
    }
}
