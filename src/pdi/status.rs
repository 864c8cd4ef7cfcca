//! PDI-Status (2292h:01h): the drive's and the interface's state as a bit mask
//! (spec section 2.3).

use std::fmt;

enum_with_all! {
    /// The 11 named bits of PDI-Status.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum StatusBit {
        OperationEnabled = 0,
        Warning = 1,
        Fault = 2,
        TargetReached = 3,
        FollowingError = 4,
        LimitReached = 5,
        QsHaltBit = 7,
        HomingDone = 11,
        AutosetupDone = 12,
        ToggleCmd = 14,
        Error = 15,
    }
}

impl StatusBit {
    pub fn bit(self) -> u8 {
        self as u8
    }

    pub fn mask(self) -> u16 {
        1 << self.bit()
    }

    /// The spec's name, e.g. `PdiStatusTargetReached`.
    pub fn name(self) -> &'static str {
        match self {
            StatusBit::OperationEnabled => "PdiStatusOperationEnabled",
            StatusBit::Warning => "PdiStatusWarning",
            StatusBit::Fault => "PdiStatusFault",
            StatusBit::TargetReached => "PdiStatusTargetReached",
            StatusBit::FollowingError => "PdiStatusFollowingError",
            StatusBit::LimitReached => "PdiStatusLimitReached",
            StatusBit::QsHaltBit => "PdiStatusQsHaltBit",
            StatusBit::HomingDone => "PdiStatusHomingDone",
            StatusBit::AutosetupDone => "PdiStatusAutosetupDone",
            StatusBit::ToggleCmd => "PdiStatusToggleCmd",
            StatusBit::Error => "PdiStatusError",
        }
    }

    /// A short label for a lamp.
    pub fn label(self) -> &'static str {
        match self {
            StatusBit::OperationEnabled => "Operation enabled",
            StatusBit::Warning => "Warning",
            StatusBit::Fault => "Fault",
            StatusBit::TargetReached => "Target reached",
            StatusBit::FollowingError => "Following error",
            StatusBit::LimitReached => "Limit reached",
            StatusBit::QsHaltBit => "Quick stop / halt",
            StatusBit::HomingDone => "Homing done",
            StatusBit::AutosetupDone => "Auto setup done",
            StatusBit::ToggleCmd => "Toggle (cmd seen)",
            StatusBit::Error => "Command error",
        }
    }

    /// One line of meaning for the UI's tooltip.
    pub fn meaning(self) -> &'static str {
        match self {
            StatusBit::OperationEnabled => {
                "The drive is in the Operation enabled state: energised and following its set values."
            }
            StatusBit::Warning => "A warning is active; its code is in 603Fh.",
            StatusBit::Fault => {
                "A drive fault is active; its code is in 603Fh. Remove the cause, then Clear Error."
            }
            StatusBit::TargetReached => {
                "The target (position or speed) is reached within the mode's tolerance window; with halt set, the axis has stopped."
            }
            StatusBit::FollowingError => {
                "Following error (6065h/6066h) in position mode or slippage error in velocity mode."
            }
            StatusBit::LimitReached => {
                "A position or speed limit is exceeded (e.g. a limit switch)."
            }
            StatusBit::QsHaltBit => "The drive is in Quick stop active or the halt bit is set.",
            StatusBit::HomingDone => {
                "A homing operation was performed successfully (stays set until power-off)."
            }
            StatusBit::AutosetupDone => {
                "An auto setup was performed successfully (stays set until power-off). Restart the device before moving."
            }
            StatusBit::ToggleCmd => "Toggles whenever the drive detects a new command.",
            StatusBit::Error => "The last command failed; its error code is in PDI-ReturnValue.",
        }
    }
}

impl fmt::Display for StatusBit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The raw PDI-Status word. Undefined bits (6, 8, 9, 10, 13) are kept, never dropped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Status(pub u16);

impl Status {
    /// The mask of the 11 defined bits.
    pub const DEFINED: u16 = 0b1101_1000_1011_1111;

    pub fn from_i16(value: i16) -> Self {
        Self(value as u16)
    }

    pub fn to_i16(self) -> i16 {
        self.0 as i16
    }

    pub fn is_set(self, bit: StatusBit) -> bool {
        self.0 & bit.mask() != 0
    }

    pub fn with(self, bit: StatusBit, on: bool) -> Self {
        if on {
            Self(self.0 | bit.mask())
        } else {
            Self(self.0 & !bit.mask())
        }
    }

    /// Bits set that the spec does not define; shown raw in the UI.
    pub fn undefined_bits(self) -> u16 {
        self.0 & !Self::DEFINED
    }

    /// The named bits currently set.
    pub fn set_bits(self) -> impl Iterator<Item = StatusBit> {
        StatusBit::ALL
            .into_iter()
            .filter(move |bit| self.is_set(*bit))
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}h", self.0)?;
        let names: Vec<&str> = self.set_bits().map(StatusBit::label).collect();
        if !names.is_empty() {
            write!(f, " [{}]", names.join(", "))?;
        }
        let undefined = self.undefined_bits();
        if undefined != 0 {
            write!(f, " undefined bits {undefined:04X}h")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_positions_follow_the_spec() {
        let positions: Vec<u8> = StatusBit::ALL.iter().map(|b| b.bit()).collect();
        assert_eq!(positions, [0, 1, 2, 3, 4, 5, 7, 11, 12, 14, 15]);
        let mask: u16 = StatusBit::ALL.iter().map(|b| b.mask()).sum();
        assert_eq!(mask, Status::DEFINED);
    }

    #[test]
    fn undefined_bits_are_kept() {
        let status = Status(0x2741); // bits 0, 6, 8, 9, 10, 13
        assert!(status.is_set(StatusBit::OperationEnabled));
        assert_eq!(status.undefined_bits(), 0x2740);
        assert_eq!(
            status.to_string(),
            "2741h [Operation enabled] undefined bits 2740h"
        );
    }

    #[test]
    fn signed_word_round_trips() {
        let status = Status::from_i16(-32768);
        assert!(status.is_set(StatusBit::Error));
        assert_eq!(status.to_i16(), -32768);
    }
}
