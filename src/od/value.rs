//! Typed object values: parsing what a person types, the little-endian wire form of
//! CANopen (SDO, FC 43, CIP 32h/33h) and the 32-bit form of PDI-SetValue1/ReturnValue.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::{DataType, Error};

/// One object value. Integers keep their sign in the variant so that a U32 of
/// 4 000 000 000 and an I32 of -1 never mix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", content = "value", rename_all = "lowercase")]
pub enum Value {
    Bool(bool),
    Int(i64),
    Uint(u64),
    Real(f64),
    Text(String),
    Bytes(Vec<u8>),
}

impl Value {
    /// The value as a person types it, checked against the type's range.
    pub fn parse(dtype: DataType, text: &str) -> Result<Value, Error> {
        let t = text.trim();
        let not_a_number = || Error::NotANumber {
            text: t.to_owned(),
            dtype,
        };
        match dtype {
            DataType::Boolean => match t.to_ascii_lowercase().as_str() {
                "1" | "true" | "on" | "yes" => Ok(Value::Bool(true)),
                "0" | "false" | "off" | "no" => Ok(Value::Bool(false)),
                _ => Err(not_a_number()),
            },
            DataType::Real32 | DataType::Real64 => t
                .parse::<f64>()
                .map(Value::Real)
                .map_err(|_| not_a_number()),
            DataType::VisibleString | DataType::UnicodeString => Ok(Value::Text(t.to_owned())),
            DataType::OctetString | DataType::Domain => parse_hex_bytes(t)
                .map(Value::Bytes)
                .ok_or_else(not_a_number),
            _ => {
                let wide = crate::number::parse_integer(t, false).ok_or_else(not_a_number)?;
                Value::from_i128(dtype, wide)
            }
        }
    }

    /// An integer of the given type, or a range error.
    pub fn from_i128(dtype: DataType, wide: i128) -> Result<Value, Error> {
        let (min, max) = dtype.integer_range().ok_or(Error::NotAnInteger(dtype))?;
        if wide < min || wide > max {
            return Err(Error::OutOfRange {
                value: wide.to_string(),
                dtype,
                min: min.to_string(),
                max: max.to_string(),
            });
        }
        Ok(match dtype {
            DataType::Boolean => Value::Bool(wide != 0),
            t if t.is_signed() => Value::Int(wide as i64),
            _ => Value::Uint(wide as u64),
        })
    }

    /// The value as an i128 if it is an integer or boolean.
    pub fn as_i128(&self) -> Option<i128> {
        match self {
            Value::Bool(b) => Some(i128::from(*b)),
            Value::Int(v) => Some(i128::from(*v)),
            Value::Uint(v) => Some(i128::from(*v)),
            _ => None,
        }
    }

    /// The value as a float for plots.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Real(v) => Some(*v),
            other => other.as_i128().map(|v| v as f64),
        }
    }

    /// Decode CANopen's little-endian wire form. The length must match fixed-size types.
    pub fn from_le_bytes(dtype: DataType, bytes: &[u8]) -> Result<Value, Error> {
        if let Some(size) = dtype.size()
            && bytes.len() != size
        {
            return Err(Error::Length {
                dtype,
                expected: size,
                got: bytes.len(),
            });
        }
        let mut buf = [0u8; 8];
        let n = bytes.len().min(8);
        buf[..n].copy_from_slice(&bytes[..n]);
        let raw = u64::from_le_bytes(buf);
        Ok(match dtype {
            DataType::Boolean => Value::Bool(raw != 0),
            DataType::Integer8 => Value::Int(i64::from(raw as u8 as i8)),
            DataType::Integer16 => Value::Int(i64::from(raw as u16 as i16)),
            DataType::Integer32 => Value::Int(i64::from(raw as u32 as i32)),
            DataType::Integer64 => Value::Int(raw as i64),
            DataType::Unsigned8
            | DataType::Unsigned16
            | DataType::Unsigned32
            | DataType::Unsigned64 => Value::Uint(raw),
            DataType::Real32 => Value::Real(f64::from(f32::from_bits(raw as u32))),
            DataType::Real64 => Value::Real(f64::from_bits(raw)),
            DataType::VisibleString => {
                // Devices pad strings with NULs; show what is before the first one.
                let end = bytes.iter().position(|b| *b == 0).unwrap_or(bytes.len());
                Value::Text(String::from_utf8_lossy(&bytes[..end]).into_owned())
            }
            DataType::UnicodeString => {
                let units: Vec<u16> = bytes
                    .chunks_exact(2)
                    .map(|c| u16::from_le_bytes([c[0], c[1]]))
                    .take_while(|u| *u != 0)
                    .collect();
                Value::Text(String::from_utf16_lossy(&units))
            }
            DataType::OctetString | DataType::Domain => Value::Bytes(bytes.to_vec()),
        })
    }

    /// Encode to CANopen's little-endian wire form for `dtype`.
    pub fn to_le_bytes(&self, dtype: DataType) -> Result<Vec<u8>, Error> {
        match (dtype, self) {
            (DataType::Real32, Value::Real(v)) => Ok((*v as f32).to_le_bytes().to_vec()),
            (DataType::Real64, Value::Real(v)) => Ok(v.to_le_bytes().to_vec()),
            (DataType::VisibleString, Value::Text(s)) => Ok(s.as_bytes().to_vec()),
            (DataType::UnicodeString, Value::Text(s)) => {
                Ok(s.encode_utf16().flat_map(|u| u.to_le_bytes()).collect())
            }
            (DataType::OctetString | DataType::Domain, Value::Bytes(b)) => Ok(b.clone()),
            (t, v) if t.is_integer() => {
                let wide = v.as_i128().ok_or_else(|| Error::TypeMismatch {
                    dtype: t,
                    value: v.to_string(),
                })?;
                // Range-check through the constructor, then take the low bytes.
                Value::from_i128(t, wide)?;
                let size = t.size().unwrap_or(8);
                Ok((wide as i64).to_le_bytes()[..size].to_vec())
            }
            (t, v) => Err(Error::TypeMismatch {
                dtype: t,
                value: v.to_string(),
            }),
        }
    }

    /// Decode PDI-ReturnValue of an OD-Read for an object of `dtype`: the low bits of the
    /// SIGNED32 carry the value, sign- or zero-extended per the type.
    pub fn from_pdi(dtype: DataType, raw: i32) -> Result<Value, Error> {
        if !dtype.fits_pdi() {
            return Err(Error::NotPdiSized(dtype));
        }
        let size = dtype.size().unwrap_or(4);
        Value::from_le_bytes(dtype, &raw.to_le_bytes()[..size])
    }

    /// Encode for PDI-SetValue1 of an OD-Write: unsigned values above 7FFF_FFFFh travel as
    /// two's complement.
    pub fn to_pdi(&self, dtype: DataType) -> Result<i32, Error> {
        if !dtype.fits_pdi() {
            return Err(Error::NotPdiSized(dtype));
        }
        let bytes = self.to_le_bytes(dtype)?;
        let mut buf = [0u8; 4];
        buf[..bytes.len()].copy_from_slice(&bytes);
        let raw = i32::from_le_bytes(buf);
        // Sign-extend signed types so that SetValue1 holds the value itself.
        Ok(match dtype {
            DataType::Integer8 => i32::from(raw as i8),
            DataType::Integer16 => i32::from(raw as i16),
            _ => raw,
        })
    }

    /// Hex form for the OD browser: the two's complement of the type's width.
    pub fn to_hex(&self, dtype: DataType) -> String {
        match (self, dtype.size()) {
            (Value::Bool(_) | Value::Int(_) | Value::Uint(_), Some(size)) => {
                let wide = self.as_i128().unwrap_or(0);
                let mask: u128 = if size >= 16 {
                    u128::MAX
                } else {
                    (1u128 << (size * 8)) - 1
                };
                format!("{:0width$X}h", (wide as u128) & mask, width = size * 2)
            }
            (Value::Real(_), _) => self
                .to_le_bytes(dtype)
                .map(|b| crate::number::hex(&b))
                .unwrap_or_default(),
            (Value::Text(s), _) => crate::number::hex(s.as_bytes()),
            (Value::Bytes(b), _) => crate::number::hex(b),
            _ => String::new(),
        }
    }

    /// The zero value of a type (used where a catalog gives no default).
    pub fn zero(dtype: DataType) -> Value {
        match dtype {
            DataType::Boolean => Value::Bool(false),
            DataType::Real32 | DataType::Real64 => Value::Real(0.0),
            DataType::VisibleString | DataType::UnicodeString => Value::Text(String::new()),
            DataType::OctetString | DataType::Domain => Value::Bytes(Vec::new()),
            t if t.is_signed() => Value::Int(0),
            _ => Value::Uint(0),
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{}", u8::from(*b)),
            Value::Int(v) => write!(f, "{v}"),
            Value::Uint(v) => write!(f, "{v}"),
            Value::Real(v) => write!(f, "{v}"),
            Value::Text(s) => write!(f, "{s:?}"),
            Value::Bytes(b) => f.write_str(&crate::number::hex(b)),
        }
    }
}

fn parse_hex_bytes(text: &str) -> Option<Vec<u8>> {
    let digits: String = text
        .chars()
        .filter(|c| !c.is_whitespace() && *c != ':' && *c != '-')
        .collect();
    let digits = digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
        .unwrap_or(&digits);
    if !digits.len().is_multiple_of(2) {
        return None;
    }
    (0..digits.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(digits.get(i..i + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn typed_input_is_range_checked() {
        assert_eq!(
            Value::parse(DataType::Unsigned8, "255"),
            Ok(Value::Uint(255))
        );
        let err = Value::parse(DataType::Unsigned8, "256").unwrap_err();
        assert_eq!(err.to_string(), "256 is out of range for U8: 0 … 255");
        assert!(Value::parse(DataType::Unsigned16, "-1").is_err());
        assert_eq!(
            Value::parse(DataType::Integer16, "-32768"),
            Ok(Value::Int(-32768))
        );
        assert_eq!(
            Value::parse(DataType::Unsigned32, "0x65766173"),
            Ok(Value::Uint(0x6576_6173))
        );
        assert_eq!(
            Value::parse(DataType::Unsigned32, "26Ch"),
            Ok(Value::Uint(0x26C))
        );
        assert_eq!(Value::parse(DataType::Boolean, "on"), Ok(Value::Bool(true)));
        assert!(Value::parse(DataType::Integer32, "12x").is_err());
        assert_eq!(
            Value::parse(DataType::OctetString, "01 02 ab"),
            Ok(Value::Bytes(vec![1, 2, 0xAB]))
        );
        assert!(Value::parse(DataType::OctetString, "123").is_err());
    }

    #[test]
    fn wire_form_is_little_endian_and_sized() {
        assert_eq!(
            Value::Uint(0xC0A8_00F4).to_le_bytes(DataType::Unsigned32),
            Ok(vec![0xF4, 0x00, 0xA8, 0xC0])
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Unsigned32, &[0xF4, 0x00, 0xA8, 0xC0]),
            Ok(Value::Uint(0xC0A8_00F4))
        );
        assert_eq!(
            Value::from_le_bytes(DataType::Integer16, &[0xFF, 0xFF]),
            Ok(Value::Int(-1))
        );
        assert!(matches!(
            Value::from_le_bytes(DataType::Unsigned16, &[1, 2, 3]),
            Err(Error::Length {
                expected: 2,
                got: 3,
                ..
            })
        ));
        assert_eq!(
            Value::from_le_bytes(DataType::VisibleString, b"N5-2-2\0\0"),
            Ok(Value::Text("N5-2-2".into()))
        );
    }

    #[test]
    fn pdi_form_extends_per_type() {
        assert_eq!(
            Value::from_pdi(DataType::Unsigned32, -1),
            Ok(Value::Uint(0xFFFF_FFFF))
        );
        assert_eq!(Value::from_pdi(DataType::Integer8, -5), Ok(Value::Int(-5)));
        assert_eq!(
            Value::from_pdi(DataType::Unsigned8, 0x1FF),
            Ok(Value::Uint(0xFF))
        );
        assert_eq!(
            Value::Uint(0xFFFF_FFFF).to_pdi(DataType::Unsigned32),
            Ok(-1)
        );
        assert_eq!(Value::Int(-2).to_pdi(DataType::Integer16), Ok(-2));
        assert_eq!(
            Value::from_pdi(DataType::VisibleString, 0),
            Err(Error::NotPdiSized(DataType::VisibleString))
        );
    }

    #[test]
    fn hex_shows_the_types_width() {
        assert_eq!(Value::Int(-1).to_hex(DataType::Integer16), "FFFFh");
        assert_eq!(Value::Uint(0x26C).to_hex(DataType::Unsigned32), "0000026Ch");
        assert_eq!(
            Value::Text("AB".into()).to_hex(DataType::VisibleString),
            "41 42"
        );
    }

    proptest! {
        #[test]
        fn fixed_types_round_trip_through_the_wire(raw in any::<u64>(), ti in 0usize..15) {
            let dtype = DataType::ALL[ti];
            if let Some(size) = dtype.size() {
                let bytes = raw.to_le_bytes()[..size].to_vec();
                let value = Value::from_le_bytes(dtype, &bytes).unwrap();
                if !matches!(dtype, DataType::Boolean | DataType::Real32 | DataType::Real64) {
                    prop_assert_eq!(value.to_le_bytes(dtype).unwrap(), bytes);
                }
            }
        }

        #[test]
        fn wire_decoder_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..16), ti in 0usize..15) {
            let _ = Value::from_le_bytes(DataType::ALL[ti], &bytes);
        }
    }
}
