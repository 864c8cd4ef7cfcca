//! Integers as people type them. One parser for every input box and command-line value.

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

#[cfg(test)]
mod tests {
    use super::parse_integer;

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
