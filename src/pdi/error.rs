use super::{Field, Opcode, Radix};

/// Everything the PDI layer can reject. Each message names what was wrong and what fits.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    #[error(
        "unknown PDI command opcode {0} (the PDI knows 0, 1, 2, 3, 14, 15, 16, 17, 18, 20, 21, 23 and 25)"
    )]
    UnknownOpcode(u8),

    #[error(
        "{label} = {value} does not fit {field}: allowed {}{}",
        crate::number::range_text(min, max),
        hint_suffix(hint)
    )]
    OutOfRange {
        field: Field,
        label: &'static str,
        value: i64,
        min: i64,
        max: i64,
        hint: &'static str,
    },

    #[error("{label}: '{text}' is not a {} number", radix_name(*radix))]
    NotANumber {
        label: &'static str,
        text: String,
        radix: Radix,
    },

    #[error("{opcode} takes {expected} set value(s), got {got}")]
    WrongInputCount {
        opcode: Opcode,
        expected: usize,
        got: usize,
    },

    #[error("a PDI {image} image is 8 bytes, got {got}")]
    ImageLength { image: &'static str, got: usize },

    #[error("no travel command to halt or resume: start a move, velocity or torque command first")]
    NoTravel,

    #[error("the drive is not halted, so there is nothing to resume")]
    NotHalted,

    #[error(
        "no PDI-Status has been read from the drive yet, so an acknowledgement could not be recognised"
    )]
    NoStatusYet,
}

fn hint_suffix(hint: &str) -> String {
    if hint.is_empty() {
        String::new()
    } else {
        format!(" ({hint})")
    }
}

fn radix_name(radix: Radix) -> &'static str {
    match radix {
        Radix::Decimal => "decimal",
        Radix::Hex => "hexadecimal",
    }
}
