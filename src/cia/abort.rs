//! CiA 301 SDO abort codes (protocol notes §2.5).
//!
//! Nanotec reports failed object accesses with these codes on every channel: SDO aborts on
//! CANopen, the extended exception of Modbus FC 43/101/102 and, as far as the public record
//! tells (protocol notes §4.6), PDI-ReturnValue when PdiStatusError is set.

use std::fmt;

/// A 32-bit CiA 301 abort code, known or not. Unknown codes are kept and shown raw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AbortCode(pub u32);

impl AbortCode {
    pub const TOGGLE_BIT_NOT_ALTERNATED: Self = Self(0x0503_0000);
    pub const SDO_TIMEOUT: Self = Self(0x0504_0000);
    pub const INVALID_COMMAND_SPECIFIER: Self = Self(0x0504_0001);
    pub const OUT_OF_MEMORY: Self = Self(0x0504_0005);
    pub const UNSUPPORTED_ACCESS: Self = Self(0x0601_0000);
    pub const WRITE_ONLY: Self = Self(0x0601_0001);
    pub const READ_ONLY: Self = Self(0x0601_0002);
    pub const NO_OBJECT: Self = Self(0x0602_0000);
    pub const NOT_MAPPABLE: Self = Self(0x0604_0041);
    pub const PDO_LENGTH_EXCEEDED: Self = Self(0x0604_0042);
    pub const PARAMETER_INCOMPATIBLE: Self = Self(0x0604_0043);
    pub const INTERNAL_INCOMPATIBLE: Self = Self(0x0604_0047);
    pub const HARDWARE_ERROR: Self = Self(0x0606_0000);
    pub const TYPE_LENGTH_MISMATCH: Self = Self(0x0607_0010);
    pub const TYPE_LENGTH_TOO_HIGH: Self = Self(0x0607_0012);
    pub const TYPE_LENGTH_TOO_LOW: Self = Self(0x0607_0013);
    pub const NO_SUBINDEX: Self = Self(0x0609_0011);
    pub const VALUE_RANGE: Self = Self(0x0609_0030);
    pub const VALUE_TOO_HIGH: Self = Self(0x0609_0031);
    pub const VALUE_TOO_LOW: Self = Self(0x0609_0032);
    pub const MAX_LESS_THAN_MIN: Self = Self(0x0609_0036);
    pub const NO_SDO_CONNECTION: Self = Self(0x060A_0023);
    pub const GENERAL_ERROR: Self = Self(0x0800_0000);
    pub const CANNOT_STORE: Self = Self(0x0800_0020);
    pub const LOCAL_CONTROL: Self = Self(0x0800_0021);
    pub const DEVICE_STATE: Self = Self(0x0800_0022);
    pub const NO_DICTIONARY: Self = Self(0x0800_0023);
    pub const NO_DATA: Self = Self(0x0800_0024);

    /// The code as PDI-ReturnValue carries it (a SIGNED32, so codes ≥ 8000_0000h are negative).
    pub fn from_return_value(value: i32) -> Self {
        Self(value as u32)
    }

    /// The CiA 301 text of a known code.
    pub fn text(self) -> Option<&'static str> {
        TABLE
            .iter()
            .find(|(code, _)| *code == self.0)
            .map(|(_, text)| *text)
    }

    /// Every code of the CiA 301 table with its text, in ascending order.
    pub fn known() -> impl Iterator<Item = (AbortCode, &'static str)> {
        TABLE.iter().map(|(code, text)| (AbortCode(*code), *text))
    }
}

impl fmt::Display for AbortCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.text() {
            Some(text) => write!(f, "{:08X}h ({text})", self.0),
            None => write!(f, "{:08X}h (not a CiA 301 abort code)", self.0),
        }
    }
}

const TABLE: &[(u32, &str)] = &[
    (0x0503_0000, "Toggle bit not alternated"),
    (0x0504_0000, "SDO protocol timed out"),
    (
        0x0504_0001,
        "Client/server command specifier not valid or unknown",
    ),
    (0x0504_0002, "Invalid block size (block mode)"),
    (0x0504_0003, "Invalid sequence number (block mode)"),
    (0x0504_0004, "CRC error (block mode)"),
    (0x0504_0005, "Out of memory"),
    (0x0601_0000, "Unsupported access to an object"),
    (0x0601_0001, "Attempt to read a write-only object"),
    (0x0601_0002, "Attempt to write a read-only object"),
    (
        0x0602_0000,
        "Object does not exist in the object dictionary",
    ),
    (0x0604_0041, "Object cannot be mapped to the PDO"),
    (
        0x0604_0042,
        "Number and length of mapped objects would exceed PDO length",
    ),
    (0x0604_0043, "General parameter incompatibility"),
    (
        0x0604_0047,
        "General internal incompatibility in the device",
    ),
    (0x0606_0000, "Access failed due to a hardware error"),
    (
        0x0607_0010,
        "Data type does not match, length of service parameter does not match",
    ),
    (
        0x0607_0012,
        "Data type does not match, length of service parameter too high",
    ),
    (
        0x0607_0013,
        "Data type does not match, length of service parameter too low",
    ),
    (0x0609_0011, "Sub-index does not exist"),
    (
        0x0609_0030,
        "Invalid value for parameter / value range exceeded",
    ),
    (0x0609_0031, "Value of parameter written too high"),
    (0x0609_0032, "Value of parameter written too low"),
    (0x0609_0036, "Maximum value is less than minimum value"),
    (0x060A_0023, "Resource not available: SDO connection"),
    (0x0800_0000, "General error"),
    (
        0x0800_0020,
        "Data cannot be transferred or stored to the application",
    ),
    (
        0x0800_0021,
        "Data cannot be transferred or stored to the application because of local control",
    ),
    (
        0x0800_0022,
        "Data cannot be transferred or stored to the application because of the present device state",
    ),
    (
        0x0800_0023,
        "Object dictionary dynamic generation fails or no object dictionary is present",
    ),
    (0x0800_0024, "No data available"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cia_301_abort_code_has_its_text() {
        assert_eq!(AbortCode::known().count(), 31);
        assert_eq!(
            AbortCode::NO_OBJECT.text(),
            Some("Object does not exist in the object dictionary")
        );
        assert_eq!(
            AbortCode(0x0609_0011).text(),
            Some("Sub-index does not exist")
        );
        assert_eq!(
            AbortCode(0x0601_0002).text(),
            Some("Attempt to write a read-only object")
        );
        assert_eq!(
            AbortCode(0x0609_0030).text(),
            Some("Invalid value for parameter / value range exceeded")
        );
        assert_eq!(AbortCode(0x0800_0024).text(), Some("No data available"));
    }

    #[test]
    fn table_is_sorted_and_unique() {
        let codes: Vec<u32> = TABLE.iter().map(|(c, _)| *c).collect();
        let mut sorted = codes.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(codes, sorted);
    }

    #[test]
    fn negative_return_value_is_the_same_code() {
        // 0x8000_0000 and above arrive as negative SIGNED32 in PDI-ReturnValue.
        assert_eq!(
            AbortCode::from_return_value(0x0602_0000),
            AbortCode::NO_OBJECT
        );
        assert_eq!(AbortCode::from_return_value(-1), AbortCode(0xFFFF_FFFF));
    }

    #[test]
    fn unknown_codes_are_shown_raw() {
        assert_eq!(
            AbortCode(0x1234_5678).to_string(),
            "12345678h (not a CiA 301 abort code)"
        );
        assert_eq!(
            AbortCode::NO_OBJECT.to_string(),
            "06020000h (Object does not exist in the object dictionary)"
        );
    }
}
