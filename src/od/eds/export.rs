//! Export: an [`Eds`] for a catalog ([`Eds::from_catalog`]), written as CiA 306 text
//! ([`Eds::to_text`]) in the usual section order with CRLF line ends.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use super::values::odd_integer;
use super::{
    BAUD_RATES, DeviceInfo, Eds, EdsAccess, EdsError, EntryInfo, FileInfo, NodeFormula, ObjectInfo,
    ObjectKind, is_manufacturer,
};
use crate::od::{Access, Address, Catalog, DataType, Entry, Value};

/// The CiA 301 mandatory objects.
const MANDATORY: [u16; 3] = [0x1000, 0x1001, 0x1018];

impl Eds {
    /// An EDS for a catalog: object kinds, access and PDO mapping are inferred (see
    /// [`infer_kind`] and [`infer_pdo_mapping`]), no formulas.
    pub fn from_catalog(catalog: &Catalog, device_info: DeviceInfo, file_info: FileInfo) -> Eds {
        let mut objects = BTreeMap::new();
        let mut entries = BTreeMap::new();
        for (index, subs) in by_index(catalog) {
            let kind = infer_kind(index, &subs);
            let name = subs
                .first()
                .map(|e| e.object_name.clone())
                .unwrap_or_default();
            objects.insert(
                index,
                ObjectInfo {
                    kind,
                    name,
                    links: vec![],
                },
            );
            for entry in subs {
                entries.insert(entry.address, EntryInfo::inferred(entry, kind));
            }
        }
        Eds {
            file_info,
            device_info,
            catalog: catalog.clone(),
            objects,
            entries,
            ..Eds::default()
        }
    }

    /// Declare an entry's default as `$NODEID + offset`, where the catalog holds its value
    /// for `node_id`. False when the entry has no integer default.
    pub fn set_node_relative(&mut self, address: Address, node_id: u8) -> bool {
        let Some(value) = self
            .catalog
            .get(address)
            .and_then(|e| e.default.as_ref())
            .and_then(Value::as_i128)
        else {
            return false;
        };
        let Some(info) = self.entries.get_mut(&address) else {
            return false;
        };
        info.default_formula = Some(NodeFormula {
            offset: value - i128::from(node_id),
        });
        true
    }

    /// The EDS as CiA 306 text (CRLF line ends).
    pub fn to_text(&self) -> String {
        let mut out = Writer::default();
        self.write_file_info(&mut out);
        self.write_device_info(&mut out);
        self.write_dummy_usage(&mut out);
        self.write_comments(&mut out);
        for (list, members) in self.object_lists() {
            out.section(list);
            out.list("SupportedObjects", &members);
            for index in members {
                self.write_object(&mut out, index);
            }
        }
        out.text
    }

    /// Write the EDS to a file.
    pub fn save(&self, path: &Path) -> Result<(), EdsError> {
        crate::file::write_whole(path, self.to_text()).map_err(|source| EdsError::Write {
            path: path.to_owned(),
            source,
        })
    }

    /// Every index with at least one entry.
    fn indices(&self) -> impl Iterator<Item = u16> + '_ {
        let mut last = None;
        self.catalog.entries().filter_map(move |e| {
            let index = e.address.index;
            (last.replace(index) != Some(index)).then_some(index)
        })
    }

    /// The indices of `[MandatoryObjects]`, `[OptionalObjects]` and `[ManufacturerObjects]`.
    fn object_lists(&self) -> [(&'static str, Vec<u16>); 3] {
        let indices: Vec<u16> = self.indices().collect();
        let members = |keep: fn(u16) -> bool| -> Vec<u16> {
            indices.iter().copied().filter(|i| keep(*i)).collect()
        };
        [
            ("MandatoryObjects", members(|i| MANDATORY.contains(&i))),
            (
                "OptionalObjects",
                members(|i| !MANDATORY.contains(&i) && !is_manufacturer(i)),
            ),
            ("ManufacturerObjects", members(is_manufacturer)),
        ]
    }

    fn write_file_info(&self, out: &mut Writer) {
        let f = &self.file_info;
        out.section("FileInfo");
        let keys: [(&str, &Option<String>); 11] = [
            ("FileName", &f.file_name),
            ("FileVersion", &f.file_version),
            ("FileRevision", &f.file_revision),
            ("EDSVersion", &f.eds_version),
            ("Description", &f.description),
            ("CreationTime", &f.creation_time),
            ("CreationDate", &f.creation_date),
            ("CreatedBy", &f.created_by),
            ("ModificationTime", &f.modification_time),
            ("ModificationDate", &f.modification_date),
            ("ModifiedBy", &f.modified_by),
        ];
        for (key, value) in keys {
            match (key, value) {
                (_, Some(v)) => out.key(key, one_line(v)),
                ("EDSVersion", None) => out.key(key, "4.0"),
                _ => {}
            }
        }
    }

    fn write_device_info(&self, out: &mut Writer) {
        let d = &self.device_info;
        out.section("DeviceInfo");
        // What the file did not say stays out, so an import gives back what it read.
        if let Some(v) = &d.vendor_name {
            out.key("VendorName", one_line(v));
        }
        if let Some(v) = d.vendor_number {
            out.key("VendorNumber", format!("0x{v:08X}"));
        }
        if let Some(v) = &d.product_name {
            out.key("ProductName", one_line(v));
        }
        if let Some(v) = d.product_number {
            out.key("ProductNumber", format!("0x{v:08X}"));
        }
        if let Some(v) = d.revision_number {
            out.key("RevisionNumber", format!("0x{v:08X}"));
        }
        if let Some(v) = &d.order_code {
            out.key("OrderCode", one_line(v));
        }
        for rate in BAUD_RATES {
            out.key(
                &format!("BaudRate_{rate}"),
                u8::from(d.baud_rates.contains(&rate)),
            );
        }
        out.key("SimpleBootUpMaster", u8::from(d.simple_boot_up_master));
        out.key("SimpleBootUpSlave", u8::from(d.simple_boot_up_slave));
        if let Some(v) = d.granularity {
            out.key("Granularity", v);
        }
        out.key(
            "DynamicChannelsSupported",
            u8::from(d.dynamic_channels_supported),
        );
        out.key("GroupMessaging", u8::from(d.group_messaging));
        if let Some(v) = d.nr_of_rx_pdo {
            out.key("NrOfRXPDO", v);
        }
        if let Some(v) = d.nr_of_tx_pdo {
            out.key("NrOfTXPDO", v);
        }
        out.key("LSS_Supported", u8::from(d.lss_supported));
    }

    fn write_dummy_usage(&self, out: &mut Writer) {
        out.section("DummyUsage");
        for n in 1..=7u16 {
            out.key(
                &format!("Dummy{n:04}"),
                u8::from(self.dummy_usage.contains(&n)),
            );
        }
    }

    fn write_comments(&self, out: &mut Writer) {
        out.section("Comments");
        out.key("Lines", self.comments.len());
        for (i, line) in self.comments.iter().enumerate() {
            out.key(&format!("Line{}", i + 1), one_line(line));
        }
    }

    fn write_object(&self, out: &mut Writer, index: u16) {
        let subs: Vec<&Entry> = self
            .catalog
            .entries()
            .filter(|e| e.address.index == index)
            .collect();
        let Some(first) = subs.first() else {
            return;
        };
        let info = self.objects.get(&index);
        let kind = info.map_or_else(|| infer_kind(index, &subs), |o| o.kind);
        let name = info.map_or(first.object_name.as_str(), |o| o.name.as_str());
        let section = format!("{index:04X}");
        if kind == ObjectKind::Var && subs.len() == 1 && first.address.sub == 0 {
            out.section(&section);
            self.write_entry(out, first, kind);
        } else {
            out.section(&section);
            out.key("ParameterName", one_line(name));
            out.key("ObjectType", format!("0x{:X}", kind.code()));
            out.key("SubNumber", subs.len());
            for entry in &subs {
                out.section(&format!("{section}sub{:X}", entry.address.sub));
                self.write_entry(out, entry, ObjectKind::Var);
            }
        }
        if let Some(info) = info.filter(|o| !o.links.is_empty()) {
            out.section(&format!("{section}ObjectLinks"));
            out.list("ObjectLinks", &info.links);
        }
    }

    fn write_entry(&self, out: &mut Writer, entry: &Entry, kind: ObjectKind) {
        let info = self
            .entries
            .get(&entry.address)
            .cloned()
            .unwrap_or_else(|| EntryInfo::inferred(entry, kind));
        out.key("ParameterName", one_line(&entry.name));
        out.key("ObjectType", "0x7");
        out.key("DataType", format!("0x{:04X}", info.type_code));
        out.key("AccessType", info.access.as_str());
        let value = |formula: Option<NodeFormula>, value: &Option<Value>| match formula {
            Some(f) => Some(f.to_string()),
            None => value
                .as_ref()
                .map(|v| format_value(v, entry.address, entry.dtype, info.type_code)),
        };
        if let Some(text) = value(info.default_formula, &entry.default) {
            out.key("DefaultValue", text);
        }
        if let Some(text) = value(info.low_formula, &entry.min) {
            out.key("LowLimit", text);
        }
        if let Some(text) = value(info.high_formula, &entry.max) {
            out.key("HighLimit", text);
        }
        out.key("PDOMapping", u8::from(info.pdo_mapping));
        if let Some(unit) = entry.unit.as_deref().filter(|u| !u.trim().is_empty()) {
            out.key("Unit", one_line(unit));
        }
        if !entry.description.trim().is_empty() {
            out.key("Description", one_line(&entry.description));
        }
    }
}

impl EntryInfo {
    /// What an export says of an entry that no file described: its type's code, its
    /// access, PDO mapping by [`infer_pdo_mapping`], no formulas.
    fn inferred(entry: &Entry, kind: ObjectKind) -> EntryInfo {
        EntryInfo {
            type_code: entry.dtype.code(),
            access: EdsAccess::from_access(entry.access),
            pdo_mapping: infer_pdo_mapping(entry, kind),
            default_formula: None,
            low_formula: None,
            high_formula: None,
        }
    }
}

/// CiA 301 objects that are RECORDs although all their entries may share one type:
/// identity, SDO and PDO parameters.
fn is_cia_record(index: u16) -> bool {
    index == 0x1018 || (0x1200..=0x12FF).contains(&index) || (0x1400..=0x1BFF).contains(&index)
}

/// The object kind of an index from its entries: a VAR when it is a lone sub-index 0 with
/// the object's own name; a RECORD for the CiA 301 records or entries of several types;
/// an ARRAY otherwise.
pub fn infer_kind(index: u16, subs: &[&Entry]) -> ObjectKind {
    match subs {
        [only] if only.address.sub == 0 && only.name == only.object_name => ObjectKind::Var,
        _ => {
            let mut types = subs.iter().filter(|e| e.address.sub != 0).map(|e| e.dtype);
            let first = types.next();
            if is_cia_record(index) || types.any(|t| Some(t) != first) {
                ObjectKind::Record
            } else {
                ObjectKind::Array
            }
        }
    }
}

/// Whether an export marks an entry PDO-mappable when nothing says: fixed-size entries of
/// the manufacturer and profile ranges that are not constants nor an array's count.
pub fn infer_pdo_mapping(entry: &Entry, kind: ObjectKind) -> bool {
    entry.dtype.size().is_some()
        && (0x2000..=0x9FFF).contains(&entry.address.index)
        && entry.access != Access::Const
        && !(kind != ObjectKind::Var && entry.address.sub == 0)
}

fn by_index(catalog: &Catalog) -> BTreeMap<u16, Vec<&Entry>> {
    let mut map: BTreeMap<u16, Vec<&Entry>> = BTreeMap::new();
    for entry in catalog.entries() {
        map.entry(entry.address.index).or_default().push(entry);
    }
    map
}

fn one_line(text: &str) -> String {
    text.replace(['\r', '\n'], " ")
}

/// A value as an EDS writes it.
fn format_value(value: &Value, address: Address, dtype: DataType, type_code: u16) -> String {
    if let (Value::Bytes(bytes), Some((bits, signed))) = (value, odd_integer(type_code))
        && bytes.len() * 8 == bits as usize
    {
        let mut buf = [0u8; 16];
        buf[..bytes.len()].copy_from_slice(bytes);
        let raw = u128::from_le_bytes(buf);
        let wide = if signed && bits < 128 && raw >> (bits - 1) & 1 == 1 {
            raw as i128 - (1i128 << bits)
        } else {
            raw as i128
        };
        return wide.to_string();
    }
    match value {
        Value::Bool(b) => u8::from(*b).to_string(),
        Value::Int(v) => v.to_string(),
        Value::Uint(v) => {
            let ids = (0x1000..=0x1FFF).contains(&address.index);
            if (ids || *v > 0xFFFF) && matches!(dtype, DataType::Unsigned32 | DataType::Unsigned64)
            {
                let width = dtype.size().unwrap_or(4) * 2;
                format!("0x{v:0width$X}")
            } else {
                v.to_string()
            }
        }
        Value::Real(v) => v.to_string(),
        Value::Text(s) => one_line(s),
        Value::Bytes(b) => b.iter().map(|x| format!("{x:02X}")).collect(),
    }
}

/// CiA 306 text under way.
#[derive(Default)]
struct Writer {
    text: String,
}

impl Writer {
    fn section(&mut self, name: &str) {
        if !self.text.is_empty() {
            self.text.push_str("\r\n");
        }
        self.text.push('[');
        self.text.push_str(name);
        self.text.push_str("]\r\n");
    }

    fn key(&mut self, key: &str, value: impl fmt::Display) {
        self.text.push_str(key);
        self.text.push('=');
        self.text.push_str(&value.to_string());
        self.text.push_str("\r\n");
    }

    /// A CiA 306 list of indices: `count_key=N`, then `1=0xXXXX` … `N=0xXXXX`.
    fn list(&mut self, count_key: &str, indices: &[u16]) {
        self.key(count_key, indices.len());
        for (n, index) in indices.iter().enumerate() {
            self.key(&(n + 1).to_string(), format!("0x{index:04X}"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn export_round_trips() {
        let catalog = Catalog::builtin().unwrap();
        let eds = Eds::from_catalog(&catalog, DeviceInfo::default(), FileInfo::default());
        let text = eds.to_text();
        let back = Eds::parse(&text, None).unwrap();
        assert_eq!(back.warnings, vec![]);
        assert_eq!(back.catalog, catalog);
        assert_eq!(back.entries, eds.entries);
        assert_eq!(back.objects, eds.objects);
    }

    #[test]
    fn kinds_are_inferred() {
        let catalog = Catalog::builtin().unwrap();
        let eds = Eds::from_catalog(&catalog, DeviceInfo::default(), FileInfo::default());
        assert_eq!(eds.objects[&0x1018].kind, ObjectKind::Record);
        assert_eq!(eds.objects[&0x1003].kind, ObjectKind::Array);
        assert_eq!(eds.objects[&0x203B].kind, ObjectKind::Record);
        assert_eq!(eds.objects[&0x6040].kind, ObjectKind::Var);
        assert!(eds.entries[&Address::new(0x6040, 0)].pdo_mapping);
        assert!(!eds.entries[&Address::new(0x1018, 1)].pdo_mapping);
        assert!(!eds.entries[&Address::new(0x2400, 0)].pdo_mapping);
    }
}
