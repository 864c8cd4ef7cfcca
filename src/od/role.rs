//! What writing an object does: set a setting, or act. The one rule that decides which
//! objects a backup saves and a restore, a comparison or the window's restore may write.
//!
//! A setting (configuration) is an object the drive reads and writes and whose value only
//! takes effect as a parameter. Everything else is never restored, whatever a backup file
//! says:
//!
//! * read-only and constant objects (the drive takes no writes);
//! * write-only objects (triggers: nothing to read back and compare);
//! * DOMAIN objects (raw data such as a program, not a value);
//! * commands, whose write makes the drive act: the CiA 402 controlword and modes of
//!   operation, CiA 301 store (1010h) and restore-defaults (1011h) parameters and the
//!   error history's clear, the CiA 302 program download and control, Nanotec's PDI input
//!   (2291h: set values and command), NanoJ control and the reboot command;
//! * process data: set values and outputs the drive acts on cyclically (CiA 402 targets
//!   and offsets, digital outputs, the NanoJ and PDI images), and for dictionaries from an
//!   EDS every entry the file's AccessType marks as process data (`rww`, written on
//!   process output; `rwr`, read on process input, as CiA 306 defines AccessType).
//!
//! The catalog sets [`Entry::role`](super::Entry::role) with [`Role::of`] for the built-in
//! objects and for those of an EDS ([`Role::of_eds`]); the command and process-data
//! indices apply to both, so an EDS cannot turn the controlword into a setting. An EDS's
//! `PDOMapping=1` alone does not make an entry process data: device makers mark settings
//! such as the profile velocity 6081h mappable (a master may change them on the fly), and
//! drivedeck's own export marks every fixed-size entry of 2000h-9FFFh so.

use std::fmt;

use super::{Access, Address, DataType};

/// What an object is, for backup and restore.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A setting: saved in a backup, compared and restored.
    Configuration,
    /// Writing it makes the drive act; what it does.
    Command(&'static str),
    /// A set value or output the drive acts on, or a process input; which.
    ProcessData(&'static str),
    /// Read-only or constant: the drive takes no writes.
    ReadOnly,
    /// Write-only: a trigger with no value to read back.
    WriteOnly,
    /// Raw data (DOMAIN), such as a program.
    Domain,
}

/// Indices (all their sub-indices) that act when written, by their meaning in CiA 301,
/// CiA 302 and CiA 402, and in Nanotec's online manuals (2291h PDI, 2300h NanoJ, 2800h:01
/// reboots the firmware when 746F6F62h "boot" is written).
const COMMANDS: [(u16, &str); 11] = [
    (0x1003, "writing 0 clears the error history"),
    (
        0x1010,
        "store parameters: writes the drive's non-volatile memory",
    ),
    (
        0x1011,
        "restore default parameters: the factory values after the next restart",
    ),
    (0x1F25, "configuration request (CiA 302)"),
    (0x1F51, "program control: starts, stops or erases a program"),
    (0x1F82, "request NMT: changes a node's NMT state"),
    (
        0x2291,
        "PDI input: its set values and command byte run a PDI command",
    ),
    (0x2300, "NanoJ control: starts and stops the NanoJ program"),
    (0x2800, "bootloader and reboot: reboots the drive"),
    (
        0x6040,
        "the controlword: switches the power stage and starts motion",
    ),
    (
        0x6060,
        "modes of operation: selects what the controlword starts",
    ),
];

/// Indices that carry process data: set values, outputs and process inputs.
const PROCESS_DATA: [(u16, &str); 14] = [
    (0x1013, "high-resolution time stamp"),
    (0x2292, "PDI output"),
    (0x2400, "NanoJ inputs"),
    (0x2500, "NanoJ outputs"),
    (0x6042, "vl target velocity"),
    (0x6071, "target torque"),
    (0x607A, "target position"),
    (0x60B0, "position offset"),
    (0x60B1, "velocity offset"),
    (0x60B2, "torque offset"),
    (0x60B8, "touch probe function"),
    (0x60C1, "interpolation data record"),
    (0x60FE, "digital outputs"),
    (0x60FF, "target velocity"),
];

impl Role {
    /// The role of an object of the built-in catalog (or of any dictionary without more
    /// to say): by access, then by what its index means, then by type.
    pub fn of(address: Address, access: Access, dtype: DataType) -> Role {
        match access {
            Access::Ro | Access::Const => return Role::ReadOnly,
            Access::Wo => return Role::WriteOnly,
            Access::Rw => {}
        }
        let known = |table: &[(u16, &'static str)]| {
            table
                .iter()
                .find(|(index, _)| *index == address.index)
                .map(|(_, what)| *what)
        };
        if let Some(what) = known(&COMMANDS) {
            Role::Command(what)
        } else if let Some(what) = known(&PROCESS_DATA) {
            Role::ProcessData(what)
        } else if dtype == DataType::Domain {
            Role::Domain
        } else {
            Role::Configuration
        }
    }

    /// The role of an entry of an EDS: [`Role::of`], and process data where the file's
    /// AccessType is `rww` or `rwr` (`process_data`).
    pub fn of_eds(address: Address, access: Access, dtype: DataType, process_data: bool) -> Role {
        match Role::of(address, access, dtype) {
            Role::Configuration if process_data => {
                Role::ProcessData("the EDS's AccessType marks it process data (rww/rwr)")
            }
            role => role,
        }
    }

    /// Whether a backup saves it and a restore may write it.
    pub fn is_configuration(self) -> bool {
        self == Role::Configuration
    }

    /// Of two judgements of the same object, the one that restores less: what one source
    /// knows to act is never written because another calls it a setting.
    pub fn stricter(self, other: Role) -> Role {
        if self.is_configuration() { other } else { self }
    }
}

impl fmt::Display for Role {
    /// Why a restore leaves it alone (or "configuration").
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Role::Configuration => f.write_str("configuration"),
            Role::Command(what) => write!(f, "a command ({what}), not a setting"),
            Role::ProcessData(what) => write!(f, "process data ({what}), not a setting"),
            Role::ReadOnly => f.write_str("read-only: the drive takes no writes to it"),
            Role::WriteOnly => {
                f.write_str("write-only: a trigger with no value to read back, not a setting")
            }
            Role::Domain => f.write_str("raw data (DOMAIN, such as a program), not a setting"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn role(index: u16, sub: u8, access: Access, dtype: DataType) -> Role {
        Role::of(Address::new(index, sub), access, dtype)
    }

    #[test]
    fn settings_are_configuration_and_actions_are_not() {
        use DataType::*;
        assert_eq!(role(0x6081, 0, Access::Rw, Unsigned32), Role::Configuration);
        assert_eq!(role(0x1600, 1, Access::Rw, Unsigned32), Role::Configuration);
        assert_eq!(role(0x2009, 0, Access::Rw, Unsigned8), Role::Configuration);
        for (index, sub, dtype) in [
            (0x6040, 0, Unsigned16),
            (0x6060, 0, Integer8),
            (0x1010, 1, Unsigned32),
            (0x1011, 1, Unsigned32),
            (0x1003, 0, Unsigned8),
            (0x2291, 4, Integer8),
            (0x2300, 0, Unsigned32),
            (0x1F51, 1, Unsigned8),
        ] {
            assert!(
                matches!(role(index, sub, Access::Rw, dtype), Role::Command(_)),
                "{index:04X}h"
            );
        }
        for index in [0x607A, 0x60FF, 0x6071, 0x6042, 0x60FE, 0x2400, 0x60B1] {
            assert!(
                matches!(role(index, 0, Access::Rw, Integer32), Role::ProcessData(_)),
                "{index:04X}h"
            );
        }
        assert_eq!(role(0x6041, 0, Access::Ro, Unsigned16), Role::ReadOnly);
        assert_eq!(role(0x1018, 1, Access::Const, Unsigned32), Role::ReadOnly);
        assert_eq!(role(0x2FF0, 0, Access::Wo, Unsigned32), Role::WriteOnly);
        assert_eq!(role(0x1F50, 1, Access::Rw, Domain), Role::Domain);
    }

    #[test]
    fn an_eds_adds_process_data_but_never_relaxes_the_rule() {
        let at = Address::new(0x3000, 1);
        assert!(matches!(
            Role::of_eds(at, Access::Rw, DataType::Integer32, true),
            Role::ProcessData(_)
        ));
        assert_eq!(
            Role::of_eds(at, Access::Rw, DataType::Integer32, false),
            Role::Configuration
        );
        // The controlword stays a command whatever the file's AccessType.
        assert!(matches!(
            Role::of_eds(
                Address::new(0x6040, 0),
                Access::Rw,
                DataType::Unsigned16,
                false
            ),
            Role::Command(_)
        ));
        assert_eq!(Role::Configuration.stricter(Role::ReadOnly), Role::ReadOnly);
        assert_eq!(
            Role::WriteOnly.stricter(Role::Configuration),
            Role::WriteOnly
        );
    }

    #[test]
    fn the_reason_says_what_the_object_does() {
        let text = role(0x6040, 0, Access::Rw, DataType::Unsigned16).to_string();
        assert!(
            text.contains("command") && text.contains("controlword"),
            "{text}"
        );
        assert!(Role::ReadOnly.to_string().contains("read-only"));
    }
}
