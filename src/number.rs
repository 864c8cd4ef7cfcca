//! Numbers as people type and read them: one integer parser for every input box and
//! command-line value, and one way to show bytes in hex.

/// Parse an integer: decimal by default (`-123`, `1_000`), hex with `0x` or an `h` suffix
/// (`0x203B`, `203Bh`), or plain hex digits when `hex_by_default` (OD indices).
pub fn parse_integer(text: &str, hex_by_default: bool) -> Option<i128> {
    let t = text.trim().replace('_', "");
    let (negative, body) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t.as_str()),
    };
    if body.is_empty() || body.starts_with(['-', '+']) {
        return None;
    }
    let hex = |digits: &str| {
        if digits.is_empty() || digits.starts_with(['+', '-']) {
            None
        } else {
            i128::from_str_radix(digits, 16).ok()
        }
    };
    let magnitude =
        if let Some(digits) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
            hex(digits)?
        } else if let Some(digits) = body.strip_suffix('h').or_else(|| body.strip_suffix('H')) {
            hex(digits)?
        } else if hex_by_default {
            hex(body)?
        } else {
            body.parse::<i128>().ok()?
        };
    Some(if negative { -magnitude } else { magnitude })
}

/// Bytes as `12 AB …`, for messages and the frame log.
pub fn hex(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        out.push(char::from(HEX_DIGITS[usize::from(b >> 4)]));
        out.push(char::from(HEX_DIGITS[usize::from(b & 0x0F)]));
    }
    out
}

/// [`hex`] of the first `max` bytes, with ` …` when there were more (long frames in a
/// message).
pub fn hex_cut(bytes: &[u8], max: usize) -> String {
    let shown = hex(&bytes[..bytes.len().min(max)]);
    if bytes.len() > max {
        format!("{shown} …")
    } else {
        shown
    }
}

const HEX_DIGITS: &[u8; 16] = b"0123456789ABCDEF";

/// A decimal integer as people read it: its digits in groups of three from the right when
/// there are five or more ("4294967295" → "4 294 967 295", "-32768" → "-32 768"; "1000"
/// stays). Text that is not a plain integer comes back as it was.
pub fn grouped(text: &str) -> String {
    let (sign, digits) = match text.strip_prefix('-') {
        Some(rest) => ("-", rest),
        None => ("", text),
    };
    if digits.len() < 5 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return text.to_owned();
    }
    let mut out = String::with_capacity(text.len() + digits.len() / 3);
    out.push_str(sign);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// A range of values for messages: "0 … 4 294 967 295" (not Rust's "0..=4294967295").
pub fn range_text(min: impl std::fmt::Display, max: impl std::fmt::Display) -> String {
    format!(
        "{} … {}",
        grouped(&min.to_string()),
        grouped(&max.to_string())
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn numbers_are_grouped_and_ranges_written_for_people() {
        assert_eq!(super::grouped("4294967295"), "4 294 967 295");
        assert_eq!(super::grouped("-32768"), "-32 768");
        assert_eq!(super::grouped("1000"), "1000");
        assert_eq!(super::grouped("12.5"), "12.5");
        assert_eq!(super::range_text(0, 4_294_967_295u32), "0 … 4 294 967 295");
        assert_eq!(
            super::range_text(-2_147_483_648i64, 7),
            "-2 147 483 648 … 7"
        );
    }

    use super::{hex, hex_cut, parse_integer};

    #[test]
    fn bytes_show_as_spaced_hex() {
        assert_eq!(hex(&[]), "");
        assert_eq!(hex(&[0x01, 0xAB, 0xFF]), "01 AB FF");
        assert_eq!(hex_cut(&[1, 2, 3], 2), "01 02 …");
        assert_eq!(hex_cut(&[1, 2], 2), "01 02");
    }

    #[test]
    fn every_written_form() {
        assert_eq!(parse_integer("2000", false), Some(2000));
        assert_eq!(parse_integer(" -5 ", false), Some(-5));
        assert_eq!(parse_integer("0x1F", false), Some(31));
        assert_eq!(parse_integer("203Bh", false), Some(0x203B));
        assert_eq!(parse_integer("203B", true), Some(0x203B));
        assert_eq!(parse_integer("10", true), Some(16));
        assert_eq!(parse_integer("1_000", false), Some(1000));
        for bad in ["", "-", "12a", "h", "0x", "--1", "+5", "0x-1"] {
            assert_eq!(parse_integer(bad, false), None, "{bad}");
        }
    }
}
