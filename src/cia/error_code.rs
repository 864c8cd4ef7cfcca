//! Drive error codes: 603Fh / EMCY error codes, the 1001h error register and the
//! Nanotec layout of a 1003h error-history entry (protocol notes §4.5).

use std::fmt;

/// A 16-bit error code as in 603Fh, the low half of a 1003h entry and the first two bytes
/// of an EMCY frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct ErrorCode(pub u16);

impl ErrorCode {
    pub const NONE: Self = Self(0x0000);
    pub const GENERIC: Self = Self(0x1000);
    pub const OUTPUT_CURRENT: Self = Self(0x2300);
    pub const VOLTAGE: Self = Self(0x3100);
    pub const TEMPERATURE: Self = Self(0x4200);
    /// The fieldbus master went silent (e.g. an EtherNet/IP I/O connection timed out).
    pub const FIELDBUS_MONITORING: Self = Self(0x8000);
    pub const FOLLOWING_ERROR: Self = Self(0x8611);
    pub const LIMIT_SWITCH: Self = Self(0x8612);

    /// The meaning of the code: Nanotec's own text where the public tables list it,
    /// otherwise the CiA 301 error class it falls into.
    pub fn meaning(self) -> &'static str {
        if let Some((_, text)) = NANOTEC.iter().find(|(code, _)| *code == self.0) {
            return text;
        }
        class_text(self.0)
    }

    /// Whether Nanotec's public tables name this exact code (otherwise only its class is known).
    pub fn is_listed(self) -> bool {
        NANOTEC.iter().any(|(code, _)| *code == self.0)
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}h ({})", self.0, self.meaning())
    }
}

/// Nanotec error codes (GBEM `n5.c`, protocol notes §4.5; lists differ per product and firmware).
const NANOTEC: &[(u16, &str)] = &[
    (0x0000, "no error"),
    (0x1000, "general error"),
    (0x2300, "output current too large"),
    (0x3100, "over- or under-voltage of the supply"),
    (0x4200, "controller temperature out of range"),
    (0x6010, "software reset (watchdog)"),
    (0x6100, "internal software error"),
    (0x6320, "rated current must be set (203Bh:01)"),
    (0x7121, "motor blocked"),
    (0x7305, "incremental encoder or Hall sensor faulty"),
    (0x7600, "non-volatile memory full or corrupt"),
    (0x8000, "fieldbus monitoring"),
    (0x8130, "life guard or heartbeat error"),
    (0x8200, "PDO not processed (too slow)"),
    (0x8210, "PDO length error"),
    (0x8220, "PDO length exceeded"),
    (0x8611, "following error too large (6065h/6066h)"),
    (0x8612, "limit switch and tolerance zone exceeded"),
    (0x9000, "EtherCAT: motor running during OP to SafeOP/PreOP"),
];

fn class_text(code: u16) -> &'static str {
    match code >> 12 {
        0x1 => "generic error",
        0x2 => "current error",
        0x3 => "voltage error",
        0x4 => "temperature error",
        0x5 => "device hardware error",
        0x6 => "device software error",
        0x7 => "additional modules error",
        0x8 => match code >> 8 {
            0x81 => "communication error",
            0x82 => "protocol error",
            0x86 => "position control error",
            _ => "monitoring error",
        },
        0x9 => "external error",
        0xF => match code >> 8 {
            0xFF => "device-specific error",
            _ => "additional functions error",
        },
        _ => "unknown error class",
    }
}

/// The bits of the error register 1001h (CiA 301; bit 7 per Nanotec).
pub const ERROR_REGISTER_BITS: [&str; 8] = [
    "generic error",
    "current",
    "voltage",
    "temperature",
    "communication error",
    "device profile specific",
    "reserved",
    "manufacturer: motor turns in wrong direction",
];

/// Names of the bits set in an error register value.
pub fn error_register_text(register: u8) -> Vec<&'static str> {
    (0..8)
        .filter(|bit| register & (1 << bit) != 0)
        .map(|bit| ERROR_REGISTER_BITS[bit])
        .collect()
}

/// One 1003h error-history entry in Nanotec's layout: error number in bits 31-24, error
/// class (1001h-style bits) in bits 23-16, error code in bits 15-0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HistoryEntry {
    pub number: u8,
    pub class: u8,
    pub code: ErrorCode,
}

impl HistoryEntry {
    pub fn from_raw(raw: u32) -> Self {
        Self {
            number: (raw >> 24) as u8,
            class: (raw >> 16) as u8,
            code: ErrorCode(raw as u16),
        }
    }

    pub fn to_raw(self) -> u32 {
        (u32::from(self.number) << 24) | (u32::from(self.class) << 16) | u32::from(self.code.0)
    }

    /// Nanotec's text for the error number (N5 list, protocol notes §4.5).
    pub fn number_text(self) -> &'static str {
        ERROR_NUMBERS
            .get(usize::from(self.number))
            .copied()
            .unwrap_or("unknown error number")
    }
}

impl fmt::Display for HistoryEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "#{} {} — {} [{}]",
            self.number,
            self.number_text(),
            self.code,
            error_register_text(self.class).join(", ")
        )
    }
}

/// Nanotec error numbers (1003h bits 31-24), N5 list.
const ERROR_NUMBERS: [&str; 29] = [
    "watchdog reset",
    "input voltage too high",
    "output current too high",
    "input voltage too low",
    "fieldbus error",
    "motor turns against active block",
    "NMT node guarding too slow",
    "encoder electrical or hardware fault",
    "encoder index not found during auto setup",
    "AB track error",
    "positive limit switch and tolerance zone exceeded",
    "negative limit switch and tolerance zone exceeded",
    "device temperature above 80 °C",
    "following error (6065h/6066h exceeded)",
    "non-volatile memory full (restart)",
    "motor blocked",
    "non-volatile memory damaged",
    "PDO too slow",
    "Hall sensor faulty",
    "PDO length error",
    "PDO length exceeded",
    "non-volatile memory full",
    "rated current must be set (203Bh:01)",
    "encoder resolution, pole pairs or similar incorrect",
    "motor current too high (adjust PI)",
    "internal software error",
    "current too high at digital output",
    "unexpected SYNC length",
    "EtherCAT OP to SafeOP/PreOP while moving",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn listed_codes_have_nanotec_text_others_their_class() {
        assert_eq!(
            ErrorCode(0x8611).meaning(),
            "following error too large (6065h/6066h)"
        );
        assert!(ErrorCode(0x8611).is_listed());
        assert_eq!(ErrorCode(0x2310).meaning(), "current error");
        assert!(!ErrorCode(0x2310).is_listed());
        assert_eq!(ErrorCode(0x8140).meaning(), "communication error");
        assert_eq!(ErrorCode(0xFF01).meaning(), "device-specific error");
        assert_eq!(ErrorCode(0x0000).to_string(), "0000h (no error)");
    }

    #[test]
    fn history_entry_round_trips_and_decodes() {
        let entry = HistoryEntry::from_raw(0x0D20_8611);
        assert_eq!(entry.number, 13);
        assert_eq!(entry.class, 0x20);
        assert_eq!(entry.code, ErrorCode::FOLLOWING_ERROR);
        assert_eq!(entry.to_raw(), 0x0D20_8611);
        assert_eq!(
            entry.number_text(),
            "following error (6065h/6066h exceeded)"
        );
        assert_eq!(
            HistoryEntry::from_raw(0xFF00_0000).number_text(),
            "unknown error number"
        );
    }

    #[test]
    fn error_register_bits_are_named() {
        assert_eq!(error_register_text(0x05), vec!["generic error", "voltage"]);
        assert!(error_register_text(0).is_empty());
    }
}
