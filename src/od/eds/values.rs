//! Values as an EDS writes them: integers in CiA 306's forms, `$NODEID` formulas, and a
//! key's text read for its data type (see the module documentation of [`super`] for the
//! rules).

use std::fmt;

use serde::Serialize;

use super::ini::clip;
use crate::od::{DataType, Value};

/// A value given as `$NODEID + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NodeFormula {
    pub offset: i128,
}

impl NodeFormula {
    /// The value for a node id.
    pub fn resolve(self, node_id: u8) -> i128 {
        i128::from(node_id) + self.offset
    }
}

impl fmt::Display for NodeFormula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset {
            0 => f.write_str("$NODEID"),
            o if o > 0 => write!(f, "$NODEID+0x{o:X}"),
            o => write!(f, "$NODEID-0x{:X}", o.unsigned_abs()),
        }
    }
}

/// An integer as written in an EDS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct EdsInt {
    pub(super) value: i128,
    /// Written in hex (or octal): may be a two's complement bit pattern.
    pub(super) pattern: bool,
    pub(super) octal: bool,
}

impl EdsInt {
    /// A number as written in decimal.
    fn decimal(value: i128) -> EdsInt {
        EdsInt {
            value,
            pattern: false,
            octal: false,
        }
    }
}

/// Decimal, `0x` hex, octal with a leading 0, negative; spaces ignored.
pub(super) fn parse_int(text: &str) -> Option<EdsInt> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let (negative, body) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t.strip_prefix('+').unwrap_or(&t)),
    };
    if body.is_empty() || body.len() > 40 {
        return None;
    }
    let (magnitude, pattern, octal) =
        if let Some(hex) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
            if hex.is_empty() || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
                return None;
            }
            (i128::from_str_radix(hex, 16).ok()?, true, false)
        } else if !body.chars().all(|c| c.is_ascii_digit()) {
            return None;
        } else if body.len() > 1 && body.starts_with('0') && body.chars().all(|c| c < '8') {
            (i128::from_str_radix(body, 8).ok()?, true, true)
        } else {
            (body.parse::<i128>().ok()?, false, false)
        };
    Some(EdsInt {
        value: if negative { -magnitude } else { magnitude },
        pattern: pattern && !negative,
        octal,
    })
}

/// `$NODEID`, `$NODEID+N`, `$NODEID-N`, `N+$NODEID`: the offset. `None` when the text has
/// no `$NODEID`.
pub(super) fn parse_formula(text: &str) -> Option<Result<EdsInt, String>> {
    let t: String = text
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_uppercase();
    let at = t.find("$NODEID")?;
    let before = &t[..at];
    let after = &t[at + "$NODEID".len()..];
    let bad = || {
        Err(format!(
            "'{text}' is not a formula CiA 306 allows ($NODEID, $NODEID+N, N+$NODEID)"
        ))
    };
    let offset = match (before, after) {
        ("", "") => Some(EdsInt::decimal(0)),
        ("", rest) if rest.starts_with('+') => parse_int(&rest[1..]),
        ("", rest) if rest.starts_with('-') => parse_int(rest),
        (first, "") if first.ends_with('+') => parse_int(&first[..first.len() - 1]),
        _ => return Some(bad()),
    };
    Some(offset.ok_or(()).or_else(|()| bad()))
}

/// How a data type code is used in the catalog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum TypeUse {
    Native(DataType),
    /// An integer width drivedeck has no type for: kept as DOMAIN bytes.
    OddInteger {
        bits: u32,
        signed: bool,
    },
    /// Kept as DOMAIN, values not read.
    Opaque,
}

/// An integer type's width, signedness and range.
#[derive(Clone, Copy, Debug, PartialEq)]
struct IntType {
    bits: u32,
    signed: bool,
    min: i128,
    max: i128,
}

impl IntType {
    fn out_of_range(self, v: i128, type_name: &str) -> String {
        let IntType { min, max, .. } = self;
        format!(
            "{v} is out of range for {type_name}: {}",
            crate::number::range_text(min, max)
        )
    }

    fn contains(self, v: i128) -> bool {
        (self.min..=self.max).contains(&v)
    }
}

impl TypeUse {
    pub(super) fn of(code: u16) -> TypeUse {
        if let Some(t) = DataType::from_code(code) {
            TypeUse::Native(t)
        } else if let Some((bits, signed)) = odd_integer(code) {
            TypeUse::OddInteger { bits, signed }
        } else {
            TypeUse::Opaque
        }
    }

    pub(super) fn dtype(self) -> DataType {
        match self {
            TypeUse::Native(t) => t,
            _ => DataType::Domain,
        }
    }

    /// Bits, signedness and range of an integer type.
    fn integer(self) -> Option<IntType> {
        match self {
            TypeUse::Native(t) => {
                let (min, max) = t.integer_range()?;
                let bits = match t {
                    DataType::Boolean => 1,
                    _ => t.size().map_or(64, |s| s as u32 * 8),
                };
                let signed = t.is_signed();
                Some(IntType {
                    bits,
                    signed,
                    min,
                    max,
                })
            }
            TypeUse::OddInteger { bits, signed } => {
                let (min, max) = if signed {
                    (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
                } else {
                    (0, (1i128 << bits) - 1)
                };
                Some(IntType {
                    bits,
                    signed,
                    min,
                    max,
                })
            }
            TypeUse::Opaque => None,
        }
    }

    fn name(self, code: u16) -> String {
        match self {
            TypeUse::Native(t) => t.short_name().to_owned(),
            _ => type_name(code),
        }
    }
}

/// One value read from the file.
#[derive(Debug, Default, PartialEq)]
pub(super) struct Parsed {
    pub(super) value: Option<Value>,
    pub(super) formula: Option<NodeFormula>,
    pub(super) octal: bool,
}

/// Parse `text` for a type. Blank: nothing.
pub(super) fn parse_value(
    text: &str,
    ty: TypeUse,
    code: u16,
    node_id: Option<u8>,
) -> Result<Parsed, String> {
    let t = text.trim();
    if t.is_empty() {
        return Ok(Parsed::default());
    }
    let type_name = ty.name(code);
    match ty.integer() {
        Some(int) => parse_integer(t, ty, int, &type_name, node_id),
        None => parse_other(t, ty, &type_name),
    }
}

/// An integer type's value (`t` trimmed): a `$NODEID` formula or a number.
fn parse_integer(
    t: &str,
    ty: TypeUse,
    int: IntType,
    type_name: &str,
    node_id: Option<u8>,
) -> Result<Parsed, String> {
    let (wide, formula, octal) = match parse_formula(t) {
        Some(offset) => {
            let formula = NodeFormula {
                offset: offset?.value,
            };
            (
                resolve(t, formula, int, type_name, node_id)?,
                Some(formula),
                false,
            )
        }
        None => {
            let n = parse_number(t, int, type_name)?;
            (Some(n.value), None, n.octal)
        }
    };
    let value = match (wide, ty) {
        (None, _) => None,
        (Some(v), TypeUse::Native(t)) => Some(Value::from_i128(t, v).map_err(|e| e.to_string())?),
        (Some(v), _) => {
            let bytes = (int.bits / 8) as usize;
            Some(Value::Bytes(v.to_le_bytes()[..bytes].to_vec()))
        }
    };
    Ok(Parsed {
        value,
        formula,
        octal,
    })
}

/// A formula's value for the node, if one is known.
fn resolve(
    t: &str,
    formula: NodeFormula,
    int: IntType,
    type_name: &str,
    node_id: Option<u8>,
) -> Result<Option<i128>, String> {
    let Some(node) = node_id else {
        return Ok(None);
    };
    let v = formula.resolve(node);
    if !int.contains(v) {
        return Err(format!(
            "{t} for node {node}: {}",
            int.out_of_range(v, type_name)
        ));
    }
    Ok(Some(v))
}

/// A number (or `true`/`false` for a BOOLEAN) in the type's range; a hex or octal pattern
/// above a signed type's maximum is two's complement.
fn parse_number(t: &str, int: IntType, type_name: &str) -> Result<EdsInt, String> {
    let n = match t.to_ascii_lowercase().as_str() {
        "true" if int.bits == 1 => EdsInt::decimal(1),
        "false" if int.bits == 1 => EdsInt::decimal(0),
        _ => parse_int(t).ok_or_else(|| format!("'{t}' is not a {type_name} value"))?,
    };
    let mut v = n.value;
    let unsigned_max = if int.bits >= 128 {
        i128::MAX
    } else {
        (1i128 << int.bits) - 1
    };
    if int.signed && n.pattern && v > int.max && v <= unsigned_max {
        v -= 1i128 << int.bits;
    }
    if !int.contains(v) {
        return Err(int.out_of_range(n.value, type_name));
    }
    Ok(EdsInt { value: v, ..n })
}

/// A value of a type that is no integer (`t` trimmed): reals, strings, hex bytes.
fn parse_other(t: &str, ty: TypeUse, type_name: &str) -> Result<Parsed, String> {
    let value = match ty {
        TypeUse::Native(DataType::Real32 | DataType::Real64) => {
            t.parse::<f64>()
                .map(Value::Real)
                .map_err(|_| format!("'{t}' is not a {type_name} number"))?
        }
        TypeUse::Native(DataType::VisibleString | DataType::UnicodeString) => {
            Value::Text(t.to_owned())
        }
        TypeUse::Native(dtype @ (DataType::OctetString | DataType::Domain)) => {
            Value::parse(dtype, t).map_err(|_| {
                format!(
                    "'{}' is not hex bytes (a {type_name} value is written as hex, e.g. 0A1B2C)",
                    clip(t)
                )
            })?
        }
        _ => return Ok(Parsed::default()),
    };
    Ok(Parsed {
        value: Some(value),
        formula: None,
        octal: false,
    })
}

/// CiA 301 integer types drivedeck has no [`DataType`] for: (bits, signed).
pub(super) fn odd_integer(code: u16) -> Option<(u32, bool)> {
    Some(match code {
        0x0010 => (24, true),
        0x0012 => (40, true),
        0x0013 => (48, true),
        0x0014 => (56, true),
        0x0016 => (24, false),
        0x0018 => (40, false),
        0x0019 => (48, false),
        0x001A => (56, false),
        _ => return None,
    })
}

/// The CiA 301 name of a data type code, for messages.
pub(super) fn type_name(code: u16) -> String {
    let name = match code {
        0x000C => "TIME_OF_DAY",
        0x000D => "TIME_DIFFERENCE",
        0x0010 => "INTEGER24",
        0x0012 => "INTEGER40",
        0x0013 => "INTEGER48",
        0x0014 => "INTEGER56",
        0x0016 => "UNSIGNED24",
        0x0018 => "UNSIGNED40",
        0x0019 => "UNSIGNED48",
        0x001A => "UNSIGNED56",
        _ => return format!("data type {code:04X}h"),
    };
    format!("{name} ({code:04X}h)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_in_every_eds_form() {
        let v = |t: &str| parse_int(t).map(|n| n.value);
        assert_eq!(v("12"), Some(12));
        assert_eq!(v("-12"), Some(-12));
        assert_eq!(v("0x1F"), Some(31));
        assert_eq!(v("0X1f"), Some(31));
        assert_eq!(v("010"), Some(8));
        assert_eq!(v("0"), Some(0));
        assert_eq!(v("09"), Some(9));
        assert_eq!(v("1 000"), Some(1000));
        for bad in ["", "-", "0x", "12a", "h", "1.5", "--1", "0x-1"] {
            assert_eq!(v(bad), None, "{bad}");
        }
    }

    #[test]
    fn node_id_formulas() {
        let f = |t: &str| parse_formula(t).map(|r| r.map(|n| n.value));
        assert_eq!(f("$NODEID+0x180"), Some(Ok(0x180)));
        assert_eq!(f("$nodeid + 384"), Some(Ok(384)));
        assert_eq!(f("0x180+$NODEID"), Some(Ok(0x180)));
        assert_eq!(f("$NODEID"), Some(Ok(0)));
        assert_eq!(f("$NODEID-1"), Some(Ok(-1)));
        assert_eq!(f("0x180"), None);
        assert!(matches!(f("$NODEID*2"), Some(Err(_))));
        assert!(matches!(f("1+$NODEID+2"), Some(Err(_))));
        assert_eq!(NodeFormula { offset: 0x180 }.to_string(), "$NODEID+0x180");
        assert_eq!(NodeFormula { offset: 0 }.to_string(), "$NODEID");
        assert_eq!(NodeFormula { offset: -2 }.to_string(), "$NODEID-0x2");
    }

    #[test]
    fn values_per_type() {
        let p = |t: &str, dtype: DataType| {
            parse_value(t, TypeUse::Native(dtype), dtype.code(), Some(5)).map(|p| p.value)
        };
        assert_eq!(
            p("0xFFFFFFFF", DataType::Integer32),
            Ok(Some(Value::Int(-1)))
        );
        assert_eq!(p("0x80", DataType::Integer8), Ok(Some(Value::Int(-128))));
        assert!(p("4294967295", DataType::Integer32).is_err());
        assert!(p("256", DataType::Unsigned8).is_err());
        assert_eq!(
            p("$NODEID+0x180", DataType::Unsigned32),
            Ok(Some(Value::Uint(0x185)))
        );
        assert_eq!(p("", DataType::Unsigned32), Ok(None));
        assert_eq!(p("1", DataType::Boolean), Ok(Some(Value::Bool(true))));
        assert_eq!(p("5.2", DataType::Real32), Ok(Some(Value::Real(5.2))));
        assert_eq!(
            p("ABCD", DataType::OctetString),
            Ok(Some(Value::Bytes(vec![0xAB, 0xCD])))
        );
        assert!(p("@ABCD", DataType::Domain).is_err());
        assert_eq!(
            p("TEST", DataType::VisibleString),
            Ok(Some(Value::Text("TEST".into())))
        );
        let odd = TypeUse::OddInteger {
            bits: 24,
            signed: true,
        };
        assert_eq!(
            parse_value("-1", odd, 0x10, None).map(|p| p.value),
            Ok(Some(Value::Bytes(vec![0xFF, 0xFF, 0xFF])))
        );
        let unresolved = parse_value(
            "$NODEID+0x80",
            TypeUse::Native(DataType::Unsigned32),
            7,
            None,
        )
        .unwrap();
        assert_eq!(unresolved.value, None);
        assert_eq!(unresolved.formula, Some(NodeFormula { offset: 0x80 }));
    }
}
