//! The NanoJ program's status and error code in words (protocol notes §4.6): 2301h and
//! 2302h as Nanotec's manuals describe them.

/// 2301h NanoJ Status in words.
pub fn status_text(status: u32) -> &'static str {
    match status {
        0 => "stopped",
        1 => "running",
        _ => "stopped by an error",
    }
}

/// 2302h NanoJ Error Code in words.
pub fn error_text(code: u32) -> String {
    match code {
        0 => "no error".into(),
        1 => "the program uses a function the firmware does not support".into(),
        2 => "a bad pointer".into(),
        3 | 6 => "impermissible access to a system resource".into(),
        4 => "a hard fault".into(),
        5 => "it ran too long without yield() or sleep()".into(),
        7 => "stack overflow".into(),
        0x100 => "the program file is not valid".into(),
        0x1000 => "an object it uses does not exist".into(),
        0x1001 => "it wrote to a write-protected object".into(),
        0x1002 | 0x10002 => "a file-system error".into(),
        0x10003 => "the storage is not ready".into(),
        0x10004 => "the program file was not found".into(),
        c if c >> 24 == 0x10 => format!(
            "invalid mapping of object {:04X}h:{:02X}h",
            (c >> 8) & 0xFFFF,
            c & 0xFF
        ),
        _ => "not in the manuals".into(),
    }
}

/// A mapping entry of 2310h/2320h/2330h: (index, subindex, bits).
pub fn mapping(entry: u32) -> (u16, u8, u8) {
    ((entry >> 16) as u16, (entry >> 8) as u8, entry as u8)
}

/// The program names of 2304h: u32 words of ASCII (little-endian), eight characters a
/// name ("test" ".usr"); NUL padding dropped, anything not printable shown as '?'.
pub fn program_names(words: &[u32]) -> Vec<String> {
    words
        .chunks(2)
        .map(|pair| {
            pair.iter()
                .flat_map(|w| w.to_le_bytes())
                .filter(|b| *b != 0)
                .map(|b| {
                    if b.is_ascii_graphic() {
                        char::from(b)
                    } else {
                        '?'
                    }
                })
                .collect::<String>()
        })
        .filter(|name| !name.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documented_codes_read_in_words() {
        assert_eq!(error_text(5), "it ran too long without yield() or sleep()");
        assert_eq!(
            error_text(0x1060_4020),
            "invalid mapping of object 6040h:20h"
        );
        assert_eq!(error_text(0x1001), "it wrote to a write-protected object");
        assert_eq!(status_text(2), "stopped by an error");
    }

    #[test]
    fn names_and_mappings_are_read_as_the_drive_gives_them() {
        let words = [
            u32::from_le_bytes(*b"test"),
            u32::from_le_bytes(*b".usr"),
            u32::from_le_bytes(*b"a\0\0\0"),
            0,
        ];
        assert_eq!(program_names(&words), ["test.usr", "a"]);
        assert_eq!(mapping(0x2400_0120), (0x2400, 1, 32));
    }
}
