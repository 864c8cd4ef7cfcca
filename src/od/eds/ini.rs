//! The INI layer under an EDS: `[section]` headers and `KEY=value` lines, both matched
//! case-insensitively, with a line number on everything so that messages can name it.
//! What the layer cannot read (a line without `=`, keys before the first section, a key
//! or section given twice) becomes a [`Warning`]; the reading goes on.

use std::collections::BTreeMap;

use super::Warning;

/// One `KEY=value` line.
#[derive(Debug)]
pub(super) struct KeyValue {
    pub(super) value: String,
    pub(super) line: usize,
}

#[derive(Debug)]
pub(super) struct Section {
    /// As written, for messages.
    pub(super) name: String,
    pub(super) line: usize,
    /// By lower-case key.
    pub(super) keys: BTreeMap<String, KeyValue>,
}

impl Section {
    pub(super) fn get(&self, key: &str) -> Option<&KeyValue> {
        self.keys.get(&key.to_ascii_lowercase())
    }

    /// A non-blank value.
    pub(super) fn text(&self, key: &str) -> Option<&str> {
        self.get(key)
            .map(|k| k.value.as_str())
            .filter(|v| !v.is_empty())
    }

    /// The line of a key, else of the section header.
    pub(super) fn line_of(&self, key: &str) -> usize {
        self.get(key).map_or(self.line, |k| k.line)
    }
}

#[derive(Debug, Default)]
pub(super) struct Ini {
    pub(super) sections: Vec<Section>,
    /// Lower-case section name to its place in `sections`.
    by_name: BTreeMap<String, usize>,
    pub(super) lines: usize,
}

impl Ini {
    pub(super) fn read(text: &str, warnings: &mut Vec<Warning>) -> Ini {
        let mut reader = Reader {
            ini: Ini::default(),
            current: None,
            orphans: 0,
            warnings,
        };
        // Lines end in LF, CR LF, or CR alone (old Mac editors): one line each way.
        let text = text.replace("\r\n", "\n");
        let text = text.strip_suffix(['\n', '\r']).unwrap_or(text.as_str());
        for (n, raw) in text.split(['\n', '\r']).enumerate() {
            let line = n + 1;
            reader.ini.lines = line;
            let t = raw.trim();
            if t.is_empty() || t.starts_with(';') {
                continue;
            }
            match t.strip_prefix('[') {
                Some(rest) => reader.header(line, t, rest),
                None => reader.key_value(line, t),
            }
        }
        reader.ini
    }

    pub(super) fn section(&self, name: &str) -> Option<&Section> {
        self.by_name
            .get(&name.to_ascii_lowercase())
            .map(|&at| &self.sections[at])
    }
}

/// [`Ini::read`] under way.
struct Reader<'w> {
    ini: Ini,
    /// The section the keys go to: its place in `ini.sections`.
    current: Option<usize>,
    /// Keys read before the first section.
    orphans: usize,
    warnings: &'w mut Vec<Warning>,
}

impl Reader<'_> {
    fn warn(&mut self, line: usize, message: String) {
        self.warnings.push(Warning { line, message });
    }

    /// A `[name]` line (`t`, with `rest` after the `[`): the keys that follow go there.
    fn header(&mut self, line: usize, t: &str, rest: &str) {
        let name = match rest.find(']') {
            Some(end) => rest[..end].trim(),
            None => {
                let message = format!("'{t}' has no closing ']': read as [{}]", rest.trim());
                self.warn(line, message);
                rest.trim()
            }
        };
        self.current = Some(self.open(line, name));
    }

    /// The place of section `name`, made new unless it was there before.
    fn open(&mut self, line: usize, name: &str) -> usize {
        let key = name.to_ascii_lowercase();
        if let Some(&at) = self.ini.by_name.get(&key) {
            let message = format!(
                "[{name}] appears again (first at line {}): its keys are merged, later ones count",
                self.ini.sections[at].line
            );
            self.warn(line, message);
            return at;
        }
        self.ini.sections.push(Section {
            name: name.to_owned(),
            line,
            keys: BTreeMap::new(),
        });
        self.ini.by_name.insert(key, self.ini.sections.len() - 1);
        self.ini.sections.len() - 1
    }

    /// Any other line: `KEY=value` in the current section.
    fn key_value(&mut self, line: usize, t: &str) {
        let Some((key, value)) = t.split_once('=') else {
            self.warn(line, format!("'{}' is not KEY=VALUE: ignored", clip(t)));
            return;
        };
        let key = key.trim();
        if key.is_empty() {
            self.warn(
                line,
                format!("'{}' has no key before '=': ignored", clip(t)),
            );
            return;
        }
        let Some(at) = self.current else {
            self.orphans += 1;
            if self.orphans == 1 {
                self.warn(line, "keys before the first [section]: ignored".into());
            }
            return;
        };
        let section = &mut self.ini.sections[at];
        let value = KeyValue {
            value: value.trim().to_owned(),
            line,
        };
        if let Some(old) = section.keys.insert(key.to_ascii_lowercase(), value) {
            let message = format!(
                "{key} is given again in [{}] (first at line {}): the last one counts",
                section.name, old.line
            );
            self.warn(line, message);
        }
    }
}

/// Long text shortened for a message.
pub(super) fn clip(text: &str) -> String {
    const MAX: usize = 60;
    if text.chars().count() <= MAX {
        text.to_owned()
    } else {
        let cut: String = text.chars().take(MAX).collect();
        format!("{cut}…")
    }
}

#[cfg(test)]
mod tests {
    use crate::od::eds::testing::{MINIMAL, parse};
    use crate::od::{Access, Address, Value};

    #[test]
    fn keys_and_sections_are_case_insensitive_and_crlf_is_fine() {
        let text = "[deviceinfo]\r\nvendornumber=7\r\n\
            [1a00]\r\nparametername=Map\r\nobjecttype=9\r\nsubnumber=1\r\n\
            [1A00SUB0]\r\nPARAMETERNAME=Count\r\nDATATYPE=5\r\nACCESSTYPE=RW\r\n";
        let eds = parse(text);
        let entry = eds.catalog.get(Address::new(0x1A00, 0)).unwrap();
        assert_eq!(entry.name, "Count");
        assert_eq!(entry.object_name, "Map");
        assert_eq!(entry.access, Access::Rw);
        assert_eq!(eds.device_info.vendor_number, Some(7));
    }

    #[test]
    fn duplicates_warn_and_the_last_counts() {
        let text = format!("{MINIMAL}DefaultValue=1\n[1000]\nAccessType=rw\n");
        let eds = parse(&text);
        let entry = eds.catalog.get(Address::new(0x1000, 0)).unwrap();
        assert_eq!(entry.default, Some(Value::Uint(1)));
        assert_eq!(entry.access, Access::Rw);
        let lines: Vec<usize> = eds.warnings.iter().map(|w| w.line).collect();
        assert_eq!(lines, vec![3, 9, 10, 11], "{:?}", eds.warnings);
        assert!(
            eds.warnings[1]
                .message
                .contains("DefaultValue is given again"),
            "{:?}",
            eds.warnings
        );
        assert!(
            eds.warnings[2]
                .message
                .contains("appears again (first at line 3)")
        );
    }
}
