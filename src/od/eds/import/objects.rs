//! The `[XXXX]` object sections: VARs, and ARRAYs and RECORDs with their `[XXXXsubN]`
//! sections or `CompactSubObj`, into catalog entries and [`ObjectInfo`]s.

use std::collections::BTreeMap;

use super::{Gathered, Importer};
use crate::od::eds::ini::{Section, clip};
use crate::od::eds::values::parse_int;
use crate::od::eds::{EdsAccess, EntryInfo, ObjectInfo, ObjectKind};
use crate::od::{Access, Address, DataType, Entry, Group, Role, Value};

impl Importer<'_> {
    pub(super) fn import_object(&mut self, index: u16, section: &Section, g: &Gathered<'_>) {
        const OBJECT_KEYS: [&str; 6] = [
            "ParameterName",
            "ObjectType",
            "DataType",
            "AccessType",
            "SubNumber",
            "CompactSubObj",
        ];
        if OBJECT_KEYS.iter().all(|k| section.get(k).is_none()) {
            let message = format!(
                "[{}] has none of ParameterName, ObjectType, DataType, AccessType: \
                 not an object description; skipped",
                section.name
            );
            self.warn(section.line, message);
            return;
        }
        let Some(object_type) = self.object_type(index, section) else {
            return;
        };
        let name = match section.text("ParameterName") {
            Some(n) => n.to_owned(),
            None => {
                self.warn(section.line, format!("{index:04X}h has no ParameterName"));
                format!("Object {index:04X}h")
            }
        };
        match object_type {
            0x7 | 0x2 => self.import_var(index, section, &name, object_type == 0x2, g),
            0x8 => self.import_subs(index, section, &name, ObjectKind::Array, g),
            0x9 => self.import_subs(index, section, &name, ObjectKind::Record, g),
            // NULL, DEFTYPE, DEFSTRUCT: data type definitions, not objects.
            0x0 | 0x5 | 0x6 => {}
            other => {
                let message = format!(
                    "{index:04X}h {name}: ObjectType {other:#X} is not VAR (7), ARRAY (8) \
                     nor RECORD (9); skipped"
                );
                self.warn(section.line_of("ObjectType"), message);
            }
        }
    }

    /// ObjectType, 7 (VAR) where not given; `None` (with a warning) where not a number.
    fn object_type(&mut self, index: u16, section: &Section) -> Option<u8> {
        let Some(text) = section.text("ObjectType") else {
            return Some(0x7);
        };
        match parse_int(text).filter(|v| (0..=0xFF).contains(&v.value)) {
            Some(v) => Some(v.value as u8),
            None => {
                let message = format!(
                    "{index:04X}h: ObjectType='{}' is not a number; skipped",
                    clip(text)
                );
                self.warn(section.line_of("ObjectType"), message);
                None
            }
        }
    }

    fn import_var(
        &mut self,
        index: u16,
        section: &Section,
        name: &str,
        domain_object: bool,
        g: &Gathered<'_>,
    ) {
        if index < 0x1000 {
            let message = format!(
                "{index:04X}h is in the data type area (below 1000h), not an object; skipped"
            );
            self.warn(section.line, message);
            return;
        }
        if let Some(first) = g.subs.get(&index).and_then(|subs| subs.values().next()) {
            let message =
                format!("{index:04X}h is a VAR: its [{index:04X}subN] sections are ignored");
            self.warn(first.line, message);
        }
        let address = Address::new(index, 0);
        let pair = self.read_entry(section, address, name, name.to_owned(), domain_object);
        self.add(ObjectKind::Var, name, vec![pair]);
    }

    /// An ARRAY or RECORD: from its sub-index sections, else from CompactSubObj.
    fn import_subs(
        &mut self,
        index: u16,
        section: &Section,
        name: &str,
        kind: ObjectKind,
        g: &Gathered<'_>,
    ) {
        let compact = section.text("CompactSubObj").map(|text| {
            parse_int(text)
                .filter(|v| (0..=0xFE).contains(&v.value))
                .map(|v| v.value as u8)
                .ok_or_else(|| text.to_owned())
        });
        let entries = match (g.subs.get(&index), compact) {
            (Some(subs), compact) => {
                if compact.is_some() {
                    let message = format!(
                        "{index:04X}h has CompactSubObj and [{index:04X}subN] sections: \
                         the sections count"
                    );
                    self.warn(section.line_of("CompactSubObj"), message);
                }
                self.check_sub_number(index, section, name, subs.len());
                self.read_subs(index, name, subs, true)
            }
            (None, Some(Ok(count))) if count > 0 => {
                let names = g.names.get(&index).copied();
                self.compact_entries(index, section, name, count, names)
            }
            (None, Some(Err(text))) => {
                let message = format!(
                    "{index:04X}h {name}: CompactSubObj='{}' is not a count up to 254; skipped",
                    clip(&text)
                );
                self.warn(section.line_of("CompactSubObj"), message);
                return;
            }
            (None, _) => {
                let kind_name = match kind {
                    ObjectKind::Array => "an ARRAY",
                    _ => "a RECORD",
                };
                let message = format!(
                    "{index:04X}h {name} is {kind_name} without sub-indices \
                     (no [{index:04X}subN] sections, no CompactSubObj); skipped"
                );
                self.warn(section.line, message);
                return;
            }
        };
        self.add(kind, name, entries);
    }

    /// The entries of `[XXXXsubN]` sections. A sub-index without ParameterName is named by
    /// its number, with a warning where `warn_unnamed`.
    fn read_subs(
        &mut self,
        index: u16,
        object_name: &str,
        subs: &BTreeMap<u8, &Section>,
        warn_unnamed: bool,
    ) -> Vec<(Entry, EntryInfo)> {
        let mut entries = Vec::new();
        for (&sub, &s) in subs {
            let sub_name = match s.text("ParameterName") {
                Some(n) => n.to_owned(),
                None => {
                    if warn_unnamed {
                        let message = format!("{index:04X}h:{sub:02X}h has no ParameterName");
                        self.warn(s.line, message);
                    }
                    format!("Sub-index {sub:02X}h")
                }
            };
            let address = Address::new(index, sub);
            entries.push(self.read_entry(s, address, object_name, sub_name, false));
        }
        entries
    }

    /// SubNumber, where given, should count the sub-index sections.
    fn check_sub_number(&mut self, index: u16, section: &Section, name: &str, found: usize) {
        let Some(text) = section.text("SubNumber") else {
            return;
        };
        if parse_int(text).is_some_and(|n| n.value == found as i128) {
            return;
        }
        let message = format!(
            "{index:04X}h {name}: SubNumber={text}, but {found} [{index:04X}subN] sections \
             are there; those are imported"
        );
        self.warn(section.line_of("SubNumber"), message);
    }

    /// Sub-indices of an index that has no `[XXXX]` section: imported as a RECORD.
    pub(super) fn import_orphan_subs(&mut self, index: u16, subs: &BTreeMap<u8, &Section>) {
        let Some(first) = subs.values().next() else {
            return;
        };
        let name = format!("Object {index:04X}h");
        self.warn(
            first.line,
            format!(
                "[{}] has no [{index:04X}] section: imported as a RECORD named '{name}'",
                first.name
            ),
        );
        // No warning per unnamed sub-index: the one above says the object is made up.
        let entries = self.read_subs(index, &name, subs, false);
        if !entries.is_empty() {
            self.add(ObjectKind::Record, &name, entries);
        }
    }

    /// A CompactSubObj array: sub-index 0 and `count` entries from the object's keys.
    fn compact_entries(
        &mut self,
        index: u16,
        section: &Section,
        name: &str,
        count: u8,
        names: Option<&Section>,
    ) -> Vec<(Entry, EntryInfo)> {
        let count_entry = Entry {
            address: Address::new(index, 0),
            object_name: name.to_owned(),
            name: "Number of entries".to_owned(),
            dtype: DataType::Unsigned8,
            access: Access::Ro,
            unit: None,
            description: String::new(),
            default: Some(Value::Uint(u64::from(count))),
            min: None,
            max: None,
            group: Group::of_index(index),
            role: Role::ReadOnly,
            bits: Vec::new(),
        };
        let count_info = EntryInfo {
            type_code: DataType::Unsigned8.code(),
            access: EdsAccess::Ro,
            pdo_mapping: false,
            default_formula: None,
            low_formula: None,
            high_formula: None,
        };
        let mut entries = vec![(count_entry, count_info)];
        let (template, info) =
            self.read_entry(section, Address::new(index, 1), name, String::new(), false);
        for sub in 1..=count {
            let sub_name = names
                .and_then(|s| s.text(&sub.to_string()))
                .map_or_else(|| format!("{name}{sub}"), str::to_owned);
            let mut entry = template.clone();
            entry.address = Address::new(index, sub);
            entry.name = sub_name;
            entries.push((entry, info.clone()));
        }
        entries
    }

    fn add(&mut self, kind: ObjectKind, name: &str, entries: Vec<(Entry, EntryInfo)>) {
        let Some(index) = entries.first().map(|(e, _)| e.address.index) else {
            return;
        };
        self.eds.objects.insert(
            index,
            ObjectInfo {
                kind,
                name: name.to_owned(),
                links: vec![],
            },
        );
        for (entry, info) in entries {
            self.eds.entries.insert(entry.address, info);
            self.eds.catalog.insert(entry);
        }
    }
}
