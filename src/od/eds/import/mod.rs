//! Import of an EDS or DCF ([`Eds::load`], [`Eds::from_bytes`], [`Eds::parse`]): the INI
//! sections sorted into objects, sub-indices, names and links, then read into an [`Eds`]
//! with a [`Warning`] for whatever was skipped or guessed (the rules are in the module
//! documentation of [`super`]).
//!
//! * `info`: the sections about the file and the device, and the object lists.
//! * `objects`: the `[XXXX]` sections and their sub-indices.
//! * `entry`: one VAR or sub-index section into a catalog entry.

mod entry;
mod info;
mod objects;

use std::collections::BTreeMap;
use std::path::Path;

use super::ini::{Ini, Section};
use super::{Eds, EdsError, MAX_SIZE, Warning};

impl Eds {
    /// Read an EDS or DCF file. `node_id` resolves `$NODEID` formulas.
    pub fn load(path: &Path, node_id: Option<u8>) -> Result<Eds, EdsError> {
        let bytes =
            crate::file::read_given(path, MAX_SIZE as u64, "an EDS file").map_err(|e| match e {
                crate::file::ReadError::Io { source, .. } => EdsError::Read {
                    path: path.to_owned(),
                    source,
                },
                crate::file::ReadError::TooLarge { size, .. } => EdsError::TooLarge {
                    size: usize::try_from(size).unwrap_or(usize::MAX),
                },
                e @ crate::file::ReadError::NotAFile { .. } => EdsError::NotAFile(e.to_string()),
            })?;
        Eds::from_bytes(&bytes, node_id)
    }

    /// Parse a file's bytes: UTF-8, else Latin-1 (with a warning).
    pub fn from_bytes(bytes: &[u8], node_id: Option<u8>) -> Result<Eds, EdsError> {
        if bytes.len() > MAX_SIZE {
            return Err(EdsError::TooLarge { size: bytes.len() });
        }
        if let Some((text, encoding)) = utf16(bytes) {
            let mut eds = Eds::parse(&text, node_id)?;
            eds.warnings.insert(
                0,
                Warning {
                    line: 1,
                    message: format!(
                        "the file is {encoding}: read as such (CiA 306 files are usually ASCII)"
                    ),
                },
            );
            return Ok(eds);
        }
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        match std::str::from_utf8(bytes) {
            Ok(text) => Eds::parse(text, node_id),
            Err(e) => {
                let line = 1 + bytes[..e.valid_up_to()]
                    .iter()
                    .filter(|b| **b == b'\n')
                    .count();
                let text: String = bytes.iter().map(|b| char::from(*b)).collect();
                let mut eds = Eds::parse(&text, node_id)?;
                eds.warnings.insert(
                    0,
                    Warning {
                        line,
                        message: "the file is not UTF-8: read as Latin-1 (ISO 8859-1)".into(),
                    },
                );
                Ok(eds)
            }
        }
    }

    /// Parse an EDS or DCF text. `node_id` resolves `$NODEID` formulas; without it a
    /// DCF's `[DeviceComissioning] NodeID` does, else formulas stay unresolved.
    pub fn parse(text: &str, node_id: Option<u8>) -> Result<Eds, EdsError> {
        if text.len() > MAX_SIZE {
            return Err(EdsError::TooLarge { size: text.len() });
        }
        if let Some(at) = text.find('\0') {
            let line = 1 + text[..at].matches('\n').count();
            return Err(EdsError::Binary { line });
        }
        let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
        let mut warnings = Vec::new();
        let ini = Ini::read(text, &mut warnings);
        let mut importer = Importer {
            ini: &ini,
            node_id,
            eds: Eds::default(),
            warnings,
        };
        importer.run();
        let Importer {
            mut eds,
            mut warnings,
            ..
        } = importer;
        warnings.sort_by_key(|w| w.line);
        if eds.catalog.is_empty() {
            return Err(EdsError::NothingUsable {
                lines: ini.lines,
                first: warnings.into_iter().next(),
            });
        }
        eds.warnings = warnings;
        Ok(eds)
    }
}

struct Importer<'a> {
    ini: &'a Ini,
    node_id: Option<u8>,
    eds: Eds,
    warnings: Vec<Warning>,
}

/// Which section is which.
enum Kind {
    Object(u16),
    Sub(u16, u8),
    Names(u16),
    Links(u16),
    BadSub(u16),
    Other,
}

fn classify(name: &str) -> Kind {
    let lower = name.to_ascii_lowercase();
    let Some(head) = lower.get(..4) else {
        return Kind::Other;
    };
    if !head.chars().all(|c| c.is_ascii_hexdigit()) {
        return Kind::Other;
    }
    let Ok(index) = u16::from_str_radix(head, 16) else {
        return Kind::Other;
    };
    let rest = &lower[4..];
    match rest {
        "" => Kind::Object(index),
        "name" => Kind::Names(index),
        "objectlinks" => Kind::Links(index),
        _ => match rest.strip_prefix("sub") {
            Some(sub) => match u8::from_str_radix(sub, 16) {
                Ok(s) if !sub.starts_with(['+', '-']) => Kind::Sub(index, s),
                _ => Kind::BadSub(index),
            },
            None => Kind::Other,
        },
    }
}

/// An object section's pieces, gathered before import.
#[derive(Default)]
struct Gathered<'a> {
    objects: BTreeMap<u16, &'a Section>,
    subs: BTreeMap<u16, BTreeMap<u8, &'a Section>>,
    names: BTreeMap<u16, &'a Section>,
    links: BTreeMap<u16, &'a Section>,
}

impl<'a> Importer<'a> {
    fn warn(&mut self, line: usize, message: impl Into<String>) {
        self.warnings.push(Warning {
            line,
            message: message.into(),
        });
    }

    fn run(&mut self) {
        self.read_file_info();
        self.read_device_info();
        self.read_commissioning();
        self.read_comments();
        self.read_dummy_usage();
        let gathered = self.gather();
        for (&index, &section) in &gathered.objects {
            self.import_object(index, section, &gathered);
        }
        for (&index, subs) in &gathered.subs {
            if !gathered.objects.contains_key(&index) {
                self.import_orphan_subs(index, subs);
            }
        }
        self.read_links(&gathered.links);
        self.check_lists(&gathered.objects);
    }

    /// The object sections sorted by what they hold.
    fn gather(&mut self) -> Gathered<'a> {
        let ini = self.ini;
        let mut gathered = Gathered::default();
        for section in &ini.sections {
            match classify(&section.name) {
                Kind::Object(i) => {
                    gathered.objects.insert(i, section);
                }
                Kind::Sub(i, s) => {
                    gathered.subs.entry(i).or_default().insert(s, section);
                }
                Kind::Names(i) => {
                    gathered.names.insert(i, section);
                }
                Kind::Links(i) => {
                    gathered.links.insert(i, section);
                }
                Kind::BadSub(i) => self.warn(
                    section.line,
                    format!(
                        "[{}]: not a sub-index of {i:04X}h (write [{i:04X}subN], N in hex up to FF); ignored",
                        section.name
                    ),
                ),
                Kind::Other => {}
            }
        }
        gathered
    }

    /// `[XXXXObjectLinks]`, of the objects imported.
    fn read_links(&mut self, links: &BTreeMap<u16, &Section>) {
        for (&index, &section) in links {
            let links = self.read_list(section, "ObjectLinks");
            match self.eds.objects.get_mut(&index) {
                Some(object) => object.links = links.into_iter().map(|(i, _)| i).collect(),
                None => self.warn(
                    section.line,
                    format!(
                        "[{}] links an object {index:04X}h that is not imported; ignored",
                        section.name
                    ),
                ),
            }
        }
    }
}

/// The text of a UTF-16 file (with its byte-order mark, or without one when every other
/// byte of its start is zero, as in `[\0D\0`), and its encoding's name; `None` for any
/// other file. Units that are not UTF-16 become U+FFFD.
fn utf16(bytes: &[u8]) -> Option<(String, &'static str)> {
    let (body, little) = match bytes {
        [0xFF, 0xFE, rest @ ..] => (rest, true),
        [0xFE, 0xFF, rest @ ..] => (rest, false),
        _ => {
            let head = &bytes[..bytes.len().min(64)];
            if head.len() < 4 || !head.len().is_multiple_of(2) {
                return None;
            }
            let odd_zero = head.iter().skip(1).step_by(2).all(|b| *b == 0);
            let even_zero = head.iter().step_by(2).all(|b| *b == 0);
            match (odd_zero, even_zero) {
                (true, false) => (bytes, true),
                (false, true) => (bytes, false),
                _ => return None,
            }
        }
    };
    let units = body.chunks_exact(2).map(|pair| {
        let pair = [pair[0], pair[1]];
        if little {
            u16::from_le_bytes(pair)
        } else {
            u16::from_be_bytes(pair)
        }
    });
    let text = char::decode_utf16(units)
        .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
        .collect();
    Some((
        text,
        if little {
            "UTF-16 (little-endian)"
        } else {
            "UTF-16 (big-endian)"
        },
    ))
}

#[cfg(test)]
mod tests {
    use crate::od::eds::testing::{MINIMAL, parse};
    use crate::od::eds::{Eds, EdsError};
    use crate::od::{Address, Group, Value};

    #[test]
    fn a_minimal_file_imports_without_warnings() {
        let eds = parse(MINIMAL);
        assert_eq!(eds.warnings.len(), 1);
        assert_eq!(eds.warnings[0].line, 3);
        assert!(
            eds.warnings[0]
                .message
                .starts_with("the file has no [MandatoryObjects]")
        );
        let entry = eds.catalog.get(Address::new(0x1000, 0)).unwrap();
        assert_eq!(entry.default, Some(Value::Uint(0x40192)));
        assert_eq!(entry.group, Group::Communication);
        assert_eq!(eds.device_info.vendor_number, Some(0x26C));
    }

    #[test]
    fn a_utf16_file_with_or_without_its_mark_and_a_cr_only_file_are_read() {
        let expect = |eds: &Eds| {
            let entry = eds.catalog.get(Address::new(0x1000, 0)).unwrap();
            assert_eq!(entry.default, Some(Value::Uint(0x40192)));
            assert_eq!(eds.device_info.vendor_number, Some(0x26C));
        };
        let le: Vec<u8> = MINIMAL.encode_utf16().flat_map(u16::to_le_bytes).collect();
        let be: Vec<u8> = MINIMAL.encode_utf16().flat_map(u16::to_be_bytes).collect();
        for (bytes, encoding) in [
            ([&[0xFF, 0xFE][..], &le].concat(), "UTF-16 (little-endian)"),
            ([&[0xFE, 0xFF][..], &be].concat(), "UTF-16 (big-endian)"),
            (le.clone(), "UTF-16 (little-endian)"),
        ] {
            let eds = Eds::from_bytes(&bytes, None).unwrap();
            expect(&eds);
            assert!(
                eds.warnings[0].message.contains(encoding),
                "{:?}",
                eds.warnings
            );
        }
        // Old Mac line ends (CR alone), and a UTF-8 byte-order mark.
        let cr = MINIMAL.replace('\n', "\r");
        let eds = Eds::from_bytes(cr.as_bytes(), None).unwrap();
        expect(&eds);
        // The same line numbers as with LF.
        assert_eq!(eds.warnings[0].line, 3);
        let marked = [&b"\xEF\xBB\xBF"[..], MINIMAL.as_bytes()].concat();
        expect(&Eds::from_bytes(&marked, None).unwrap());
    }

    #[test]
    fn nothing_usable_fails_with_the_first_problem() {
        let err = Eds::parse("hello\n[1000]\nfoo=7\n", None).unwrap_err();
        let text = err.to_string();
        assert!(
            text.starts_with("no object could be imported from the 3 lines"),
            "{text}"
        );
        assert!(text.contains("line 1: 'hello' is not KEY=VALUE"), "{text}");
        assert!(matches!(
            Eds::parse("", None),
            Err(EdsError::NothingUsable { .. })
        ));
        let err = Eds::parse("[1000]\nx=\0\n", None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "line 2: a NUL byte: this is a binary file, not an EDS (CiA 306 files are text)"
        );
    }

    #[test]
    fn latin1_files_are_read() {
        let mut bytes = MINIMAL.as_bytes().to_vec();
        bytes.extend_from_slice(b"Unit=0.1\xB0\n");
        let eds = Eds::from_bytes(&bytes, None).unwrap();
        let entry = eds.catalog.get(Address::new(0x1000, 0)).unwrap();
        assert_eq!(entry.unit.as_deref(), Some("0.1°"));
        assert_eq!(eds.warnings[0].line, 9);
        assert!(eds.warnings[0].message.contains("Latin-1"));
    }
}
