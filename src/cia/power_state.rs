//! The CiA 402 power state machine as seen through the statusword 6041h (protocol notes §4.4).

use std::fmt;

/// The CiA 402 power states, decoded from 6041h with the masks of CiA 402.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PowerState {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
}

impl PowerState {
    /// Every state, in the order the state machine is usually drawn.
    pub const ALL: [PowerState; 8] = [
        PowerState::NotReadyToSwitchOn,
        PowerState::SwitchOnDisabled,
        PowerState::ReadyToSwitchOn,
        PowerState::SwitchedOn,
        PowerState::OperationEnabled,
        PowerState::QuickStopActive,
        PowerState::FaultReactionActive,
        PowerState::Fault,
    ];

    /// Decode the statusword. `None` when the low bits match no state (a corrupt word).
    pub fn from_statusword(word: u16) -> Option<Self> {
        let w = word;
        let state = if w & 0x4F == 0x00 {
            PowerState::NotReadyToSwitchOn
        } else if w & 0x4F == 0x40 {
            PowerState::SwitchOnDisabled
        } else if w & 0x6F == 0x21 {
            PowerState::ReadyToSwitchOn
        } else if w & 0x6F == 0x23 {
            PowerState::SwitchedOn
        } else if w & 0x6F == 0x27 {
            PowerState::OperationEnabled
        } else if w & 0x6F == 0x07 {
            PowerState::QuickStopActive
        } else if w & 0x4F == 0x0F {
            PowerState::FaultReactionActive
        } else if w & 0x4F == 0x08 {
            PowerState::Fault
        } else {
            return None;
        };
        Some(state)
    }

    /// The low statusword bits (0-6) that encode this state. Bit 5 (quick stop) is 1 in
    /// every state except Quick stop active, as CiA 402 prescribes.
    pub fn statusword_bits(self) -> u16 {
        match self {
            PowerState::NotReadyToSwitchOn => 0x0000,
            PowerState::SwitchOnDisabled => 0x0040,
            PowerState::ReadyToSwitchOn => 0x0021,
            PowerState::SwitchedOn => 0x0023,
            PowerState::OperationEnabled => 0x0027,
            PowerState::QuickStopActive => 0x0007,
            PowerState::FaultReactionActive => 0x000F,
            PowerState::Fault => 0x0008,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            PowerState::NotReadyToSwitchOn => "Not ready to switch on",
            PowerState::SwitchOnDisabled => "Switch on disabled",
            PowerState::ReadyToSwitchOn => "Ready to switch on",
            PowerState::SwitchedOn => "Switched on",
            PowerState::OperationEnabled => "Operation enabled",
            PowerState::QuickStopActive => "Quick stop active",
            PowerState::FaultReactionActive => "Fault reaction active",
            PowerState::Fault => "Fault",
        }
    }

    /// What the state means for a technician beside the machine.
    pub fn meaning(self) -> &'static str {
        match self {
            PowerState::NotReadyToSwitchOn => {
                "the drive is initialising; the motor is not energised"
            }
            PowerState::SwitchOnDisabled => {
                "power stage off, motor de-energised; any travel command switches it on"
            }
            PowerState::ReadyToSwitchOn => "power stage ready but off",
            PowerState::SwitchedOn => "power stage on, motor holds, no motion allowed yet",
            PowerState::OperationEnabled => "motor energised and following its set values",
            PowerState::QuickStopActive => {
                "stopped by Quickstop, still energised; a travel command resumes operation"
            }
            PowerState::FaultReactionActive => "reacting to a fault (braking)",
            PowerState::Fault => "a fault is active; remove its cause, then Clear Error",
        }
    }

    /// Whether the power stage drives the motor in this state.
    pub fn is_energised(self) -> bool {
        matches!(
            self,
            PowerState::SwitchedOn
                | PowerState::OperationEnabled
                | PowerState::QuickStopActive
                | PowerState::FaultReactionActive
        )
    }
}

impl fmt::Display for PowerState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Statusword bits above the state bits, named for display.
pub const STATUSWORD_BITS: [(u8, &str); 10] = [
    (4, "Voltage enabled"),
    (5, "Quick stop (0 = active)"),
    (7, "Warning"),
    (8, "Manufacturer (sync)"),
    (9, "Remote"),
    (10, "Target reached"),
    (11, "Internal limit active"),
    (12, "Mode specific 12"),
    (13, "Mode specific 13"),
    (14, "Manufacturer 14"),
];

/// Controlword 6040h commands (CiA 402).
pub mod controlword {
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    pub const QUICK_STOP: u16 = 0x0002;
    pub const SHUTDOWN: u16 = 0x0006;
    pub const SWITCH_ON: u16 = 0x0007;
    pub const ENABLE_OPERATION: u16 = 0x000F;
    pub const FAULT_RESET: u16 = 0x0080;
    pub const HALT: u16 = 0x0100;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_state_round_trips_through_its_bits() {
        for state in PowerState::ALL {
            assert_eq!(
                PowerState::from_statusword(state.statusword_bits()),
                Some(state)
            );
            // upper bits do not disturb the decode
            assert_eq!(
                PowerState::from_statusword(state.statusword_bits() | 0xFF90),
                Some(state)
            );
        }
    }

    #[test]
    fn typical_words_decode() {
        assert_eq!(
            PowerState::from_statusword(0x0637),
            Some(PowerState::OperationEnabled)
        );
        assert_eq!(
            PowerState::from_statusword(0x0250),
            Some(PowerState::SwitchOnDisabled)
        );
        assert_eq!(PowerState::from_statusword(0x0218), Some(PowerState::Fault));
        // 0x01 (ready bit alone, no quick stop bit) matches no state
        assert_eq!(PowerState::from_statusword(0x0001), None);
    }
}
