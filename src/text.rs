//! Foreign strings shown to a person: what a device says of itself (its name 1008h, its
//! versions 1009h/100Ah, an EtherNet/IP product name) and what a file says (a drive's
//! name, an EDS's names) reach the terminal only through [`shown`], which makes every
//! control character visible (an escape sequence can no longer clear the screen or set
//! the title) and shortens a long value. JSON output needs none of this: its encoder
//! escapes control characters, and a program reads it whole.

use std::borrow::Cow;
use std::fmt::Write;

/// Characters of a foreign string shown in a message before it is cut short.
pub const SHOWN_CHARS: usize = 200;

/// `text` safe for a terminal and short enough for a message: control characters
/// escaped (see [`escaped`]), and past [`SHOWN_CHARS`] characters cut off with the
/// whole length said, e.g. `AAAA… (10485760 chars)`.
pub fn shown(text: &str) -> Cow<'_, str> {
    shortened(text, SHOWN_CHARS)
}

/// [`shown`] with a limit of `max` characters of the original.
pub fn shortened(text: &str, max: usize) -> Cow<'_, str> {
    let long = text.chars().nth(max).is_some();
    if !long {
        return escaped(text);
    }
    let cut: String = text.chars().take(max).collect();
    let total = text.chars().count();
    Cow::Owned(format!("{}… ({total} chars)", escaped(&cut)))
}

/// Whether a character must not reach a terminal as it is: C0 controls (tab and newline
/// included: a name is one line), DEL, the C1 controls (U+0080–U+009F, among them CSI
/// U+009B), and the invisible direction overrides that reorder what follows.
fn is_control(c: char) -> bool {
    c.is_control() || matches!(c, '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}')
}

/// `text` with every control character visible: `\x1b` for ESC and the other C0
/// controls and DEL, `\u{9b}` for the C1 controls and the direction overrides, `\\` for
/// a backslash (so that what is shown can be told from what was sent). Borrowed when
/// nothing needed escaping.
pub fn escaped(text: &str) -> Cow<'_, str> {
    if !text.chars().any(|c| is_control(c) || c == '\\') {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            c if is_control(c) && (c as u32) < 0x80 => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c if is_control(c) => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_sequences_are_shown_not_obeyed() {
        let evil = "\x1b[2J\x1b[31mEVIL\x1b]0;pwned\x07";
        assert_eq!(shown(evil), "\\x1b[2J\\x1b[31mEVIL\\x1b]0;pwned\\x07");
        assert_eq!(escaped("a\u{9b}31mb\u{7f}"), "a\\u{9b}31mb\\x7f");
        assert_eq!(escaped("line\nnext\ttab\r"), "line\\x0anext\\x09tab\\x0d");
        assert_eq!(escaped("abc\u{202E}def"), "abc\\u{202e}def");
        assert_eq!(escaped("C:\\x1b"), "C:\\\\x1b");
    }

    #[test]
    fn plain_text_is_borrowed_and_kept_whole() {
        let name = "PD4-C5918L4204-E-08 Ä°µ";
        assert!(matches!(shown(name), Cow::Borrowed(_)));
        assert_eq!(shown(name), name);
        let exactly = "x".repeat(SHOWN_CHARS);
        assert_eq!(shown(&exactly), exactly);
    }

    #[test]
    fn a_long_value_is_cut_with_its_length_said() {
        let huge = "A".repeat(10 * 1024 * 1024);
        let short = shown(&huge);
        assert_eq!(short, format!("{}… (10485760 chars)", "A".repeat(200)));
        // The cut counts characters, never splitting one.
        let wide = "é".repeat(300);
        assert_eq!(shortened(&wide, 3), "ééé… (300 chars)");
        // Escaping the kept part: never the characters cut off.
        let mixed = format!("\x1b{}", "b".repeat(300));
        assert!(shortened(&mixed, 2).starts_with("\\x1bb… (301 chars)"));
    }
}
