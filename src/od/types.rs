//! Object addresses, CANopen data types, access rights.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::Error;

/// An object dictionary address, `index:sub`, written `1018h:01h` in the manuals and
/// `1018:01` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Address {
    pub index: u16,
    pub sub: u8,
}

impl Address {
    pub const fn new(index: u16, sub: u8) -> Self {
        Self { index, sub }
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}h:{:02X}h", self.index, self.sub)
    }
}

impl FromStr for Address {
    type Err = Error;

    /// Accepts `1018:01`, `1018h:01h`, `0x1018:0x01`, `1018.1` and `6041` (sub 0). Both
    /// parts are hex, as in every Nanotec manual.
    fn from_str(text: &str) -> Result<Self, Error> {
        let bad = || Error::BadAddress(text.trim().to_owned());
        let t = text.trim();
        let (index, sub) = match t.split_once([':', '.', '/']) {
            Some((i, s)) => (i, s),
            None => (t, "0"),
        };
        let hex = |part: &str| crate::number::parse_integer(part, true);
        let index = hex(index)
            .filter(|v| (0..=0xFFFF).contains(v))
            .ok_or_else(bad)?;
        let sub = hex(sub)
            .filter(|v| (0..=0xFF).contains(v))
            .ok_or_else(bad)?;
        Ok(Address::new(index as u16, sub as u8))
    }
}

/// CANopen basic data types (CiA 301 table 44), with their data-type codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum DataType {
    Boolean,
    Integer8,
    Integer16,
    Integer32,
    Integer64,
    Unsigned8,
    Unsigned16,
    Unsigned32,
    Unsigned64,
    Real32,
    Real64,
    VisibleString,
    OctetString,
    UnicodeString,
    Domain,
}

impl DataType {
    pub const ALL: [DataType; 15] = [
        DataType::Boolean,
        DataType::Integer8,
        DataType::Integer16,
        DataType::Integer32,
        DataType::Integer64,
        DataType::Unsigned8,
        DataType::Unsigned16,
        DataType::Unsigned32,
        DataType::Unsigned64,
        DataType::Real32,
        DataType::Real64,
        DataType::VisibleString,
        DataType::OctetString,
        DataType::UnicodeString,
        DataType::Domain,
    ];

    /// The CiA 301 data-type code (as in EDS `DataType=` and the EtherNet/IP 34h reply).
    pub fn code(self) -> u16 {
        match self {
            DataType::Boolean => 0x0001,
            DataType::Integer8 => 0x0002,
            DataType::Integer16 => 0x0003,
            DataType::Integer32 => 0x0004,
            DataType::Unsigned8 => 0x0005,
            DataType::Unsigned16 => 0x0006,
            DataType::Unsigned32 => 0x0007,
            DataType::Real32 => 0x0008,
            DataType::VisibleString => 0x0009,
            DataType::OctetString => 0x000A,
            DataType::UnicodeString => 0x000B,
            DataType::Domain => 0x000F,
            DataType::Real64 => 0x0011,
            DataType::Integer64 => 0x0015,
            DataType::Unsigned64 => 0x001B,
        }
    }

    pub fn from_code(code: u16) -> Option<Self> {
        DataType::ALL.into_iter().find(|t| t.code() == code)
    }

    /// The size in bytes of a fixed-size type; `None` for strings and domains.
    pub fn size(self) -> Option<usize> {
        match self {
            DataType::Boolean | DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer32 | DataType::Unsigned32 | DataType::Real32 => Some(4),
            DataType::Integer64 | DataType::Unsigned64 | DataType::Real64 => Some(8),
            DataType::VisibleString
            | DataType::OctetString
            | DataType::UnicodeString
            | DataType::Domain => None,
        }
    }

    /// The integer type of `bits` bits (8, 16, 32, 64), signed or not.
    pub fn integer(bits: u8, signed: bool) -> Option<DataType> {
        Some(match (bits, signed) {
            (8, true) => DataType::Integer8,
            (16, true) => DataType::Integer16,
            (32, true) => DataType::Integer32,
            (64, true) => DataType::Integer64,
            (8, false) => DataType::Unsigned8,
            (16, false) => DataType::Unsigned16,
            (32, false) => DataType::Unsigned32,
            (64, false) => DataType::Unsigned64,
            _ => return None,
        })
    }

    pub fn is_signed(self) -> bool {
        matches!(
            self,
            DataType::Integer8 | DataType::Integer16 | DataType::Integer32 | DataType::Integer64
        )
    }

    pub fn is_integer(self) -> bool {
        matches!(
            self,
            DataType::Boolean
                | DataType::Integer8
                | DataType::Integer16
                | DataType::Integer32
                | DataType::Integer64
                | DataType::Unsigned8
                | DataType::Unsigned16
                | DataType::Unsigned32
                | DataType::Unsigned64
        )
    }

    /// The range of an integer type as i128 (wide enough for every CANopen integer).
    pub fn integer_range(self) -> Option<(i128, i128)> {
        Some(match self {
            DataType::Boolean => (0, 1),
            DataType::Integer8 => (i8::MIN.into(), i8::MAX.into()),
            DataType::Integer16 => (i16::MIN.into(), i16::MAX.into()),
            DataType::Integer32 => (i32::MIN.into(), i32::MAX.into()),
            DataType::Integer64 => (i64::MIN.into(), i64::MAX.into()),
            DataType::Unsigned8 => (0, u8::MAX.into()),
            DataType::Unsigned16 => (0, u16::MAX.into()),
            DataType::Unsigned32 => (0, u32::MAX.into()),
            DataType::Unsigned64 => (0, u64::MAX.into()),
            _ => return None,
        })
    }

    /// Whether a value of this type fits the 32-bit PDI-ReturnValue / SetValue1.
    pub fn fits_pdi(self) -> bool {
        self.is_integer() && self.size().is_some_and(|s| s <= 4) || self == DataType::Real32
    }

    /// The short name used in tables: `U32`, `I16`, `STRING`…
    pub fn short_name(self) -> &'static str {
        match self {
            DataType::Boolean => "BOOL",
            DataType::Integer8 => "I8",
            DataType::Integer16 => "I16",
            DataType::Integer32 => "I32",
            DataType::Integer64 => "I64",
            DataType::Unsigned8 => "U8",
            DataType::Unsigned16 => "U16",
            DataType::Unsigned32 => "U32",
            DataType::Unsigned64 => "U64",
            DataType::Real32 => "REAL32",
            DataType::Real64 => "REAL64",
            DataType::VisibleString => "STRING",
            DataType::OctetString => "OCTETS",
            DataType::UnicodeString => "USTRING",
            DataType::Domain => "DOMAIN",
        }
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.short_name())
    }
}

/// Access rights of an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Access {
    /// Read only.
    Ro,
    /// Write only.
    Wo,
    /// Read and write.
    Rw,
    /// Constant (read only, never changes).
    Const,
}

impl Access {
    pub fn readable(self) -> bool {
        !matches!(self, Access::Wo)
    }

    pub fn writable(self) -> bool {
        matches!(self, Access::Wo | Access::Rw)
    }

    pub fn short_name(self) -> &'static str {
        match self {
            Access::Ro => "ro",
            Access::Wo => "wo",
            Access::Rw => "rw",
            Access::Const => "const",
        }
    }
}

impl fmt::Display for Access {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.short_name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_in_every_written_form() {
        let want = Address::new(0x1018, 1);
        for text in ["1018:01", "1018h:01h", "0x1018:0x01", "1018.1", " 1018:1 "] {
            assert_eq!(text.parse::<Address>(), Ok(want), "{text}");
        }
        assert_eq!("6041".parse::<Address>(), Ok(Address::new(0x6041, 0)));
        assert_eq!(want.to_string(), "1018h:01h");
        for bad in ["", "xyz", "10000:0", "1018:100", ":", "1018:"] {
            assert!(bad.parse::<Address>().is_err(), "{bad}");
        }
    }

    #[test]
    fn type_codes_round_trip() {
        for t in DataType::ALL {
            assert_eq!(DataType::from_code(t.code()), Some(t));
        }
        assert_eq!(DataType::Unsigned32.code(), 7);
    }
}
