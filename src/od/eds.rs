//! EDS files (CiA 306 electronic data sheets): import into a [`Catalog`] plus the file's
//! device information, merging with the built-in catalog, and export of a catalog as an
//! EDS.
//!
//! # Import: tolerant, with warnings
//!
//! Vendors ship files that bend CiA 306 in many small ways. The importer keeps whatever it
//! can use and reports the rest as [`Warning`]s with line numbers; it fails
//! ([`EdsError`]) only when the file is not text or no object at all can be imported.
//!
//! * Sections and keys match case-insensitively (`[1a00sub1]`, `[3010Sub0]`, `accesstype`);
//!   lines may end in CRLF; a line starting with `;` is a comment; a UTF-8 BOM is skipped
//!   and a file that is not UTF-8 is read as Latin-1 (one warning).
//! * A key given twice in a section: the last one counts (warning). A section given twice:
//!   its keys are merged, later ones win (warning). Unknown sections and keys are ignored,
//!   as are the DCF-only `ParameterValue`, `Denotation`, `[XXXXValue]`.
//! * Objects are the `[XXXX]` sections with ObjectType 7 (VAR), 2 (DOMAIN, read as a VAR),
//!   8 (ARRAY) or 9 (RECORD); no ObjectType means VAR (CiA 306). Every object section is
//!   imported whether or not `[MandatoryObjects]`, `[OptionalObjects]` or
//!   `[ManufacturerObjects]` lists it; where lists and sections disagree, that is a warning.
//!   DEFTYPE/DEFSTRUCT sections (data type definitions, below 1000h) are skipped.
//! * ARRAY/RECORD sub-indices come from `[XXXXsubN]`; a SubNumber that differs from the
//!   number of sections found is a warning. A `CompactSubObj=N` array gets sub-index 0
//!   (UNSIGNED8, ro, value N) and sub-indices 1..N from the object's own keys, named from
//!   `[XXXXName]`, else `ParameterName` followed by the number (as lely-core names them).
//! * DataType is a CiA 301 code. drivedeck's [`DataType`] has no 24/40/48/56-bit
//!   integers, TIME_OF_DAY or TIME_DIFFERENCE; those and unknown codes (manufacturer
//!   complex types 0040h+) are kept as DOMAIN (the raw little-endian bytes), with a
//!   warning; integer defaults of the odd widths become their bytes. The code as written
//!   stays in [`EntryInfo::type_code`], so an export writes it back.
//! * AccessType ro, wo, rw, rwr, rww, const; rwr and rww are `rw` in the catalog and
//!   kept as written in [`EntryInfo::access`]. Anything else: ro, with a warning.
//! * Values: decimal, `0x` hex, negative, and octal with a leading 0 as CiA 306 says (with
//!   a warning: people usually mean decimal). Hex values of signed types above the type's
//!   maximum are two's complement (`HighLimit=0xFFFFFFFF` of an INTEGER32 is -1, as
//!   python-canopen reads them). Strings as written; OCTET_STRING and DOMAIN as hex bytes.
//!   A blank value means none. A value that does not parse or fit its type is dropped with
//!   a warning; limits with low > high are both dropped; a default outside its limits is
//!   kept, with a warning.
//! * `$NODEID` formulas (`$NODEID+0x180`, `0x180+$NODEID`, `$NODEID`) are resolved with the
//!   node id given to the parser, else with the `NodeID` of a DCF's `[DeviceComissioning]`.
//!   With neither, the value stays empty in the catalog: it is never guessed, since a
//!   COB-ID made for node 0 is wrong on every real node. The formula is kept in
//!   [`EntryInfo`] either way, so a listing can show it and an export writes it back.
//! * PDOMapping, `[XXXXObjectLinks]`, `[Comments]` and `[DummyUsage]` are kept in the
//!   [`Eds`] (dummy objects are not catalog entries: a device answers no read of them).
//! * CiA 306 has no key for units or descriptions. `Unit=` and `Description=` in an
//!   object section (python-canopen's extension, and what drivedeck's export writes) are
//!   read when present.
//!
//! # Merging with the built-in catalog
//!
//! [`Eds::merged_with`] answers "what does this device have, and what do I know about
//! it": the EDS decides which objects exist and their names, types, access, defaults and
//! limits (it is the device maker's statement about that device and firmware). The
//! catalog adds its description and unit where the EDS has none, but only where it
//! describes the same object: always in the CiA ranges (1000h-1FFFh, 6000h-FFFFh, whose
//! meaning the standards fix), in the manufacturer range 2000h-5FFFh only for a Nanotec
//! EDS (vendor 26Ch) or when the names agree, since another maker's 2031h is not
//! Nanotec's Max Motor Current. Catalog objects the EDS lacks are not added: the device
//! would refuse every read of them. Where type or access differ, the EDS wins and a note
//! says so. An entry's [`Role`] (whether a restore may write it) is the stricter of the
//! EDS's (AccessType `rww`/`rwr` is process data) and the catalog's.
//!
//! # Export
//!
//! [`Eds::to_text`] writes CiA 306 sections in the usual order, CRLF line ends, UTF-8
//! text. Integers in decimal, except UNSIGNED32/64 values of the communication objects
//! (1000h-1FFFh: ids, COB-IDs, mappings) or above FFFFh (bit fields, signatures) in hex;
//! `$NODEID` formulas as formulas. Units and descriptions
//! go in `Unit=`/`Description=` keys, which other tools skip.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{Access, Address, Catalog, DataType, Entry, Group, Role, Value};

/// Larger than any real EDS: the biggest vendor files are a few megabytes.
pub const MAX_SIZE: usize = 32 * 1024 * 1024;

/// Nanotec's CiA vendor id, as in 1018h:01h of every Nanotec drive.
pub const NANOTEC_VENDOR_ID: u32 = 0x26C;

/// Messages that list objects name this many, then "and N more".
const LISTED: usize = 8;

/// Something in the file that was skipped or read with a guess; the import went on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Warning {
    /// 1-based line in the file.
    pub line: usize,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

/// Why an EDS could not be read or written at all.
#[derive(Debug, thiserror::Error)]
pub enum EdsError {
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("line {line}: a NUL byte: this is a binary file, not an EDS (CiA 306 files are text)")]
    Binary { line: usize },

    #[error("the file has {size} bytes, more than any EDS ({MAX_SIZE} at most): is it one?")]
    TooLarge { size: usize },

    #[error("{}", nothing_usable(*lines, first.as_ref()))]
    NothingUsable {
        /// Lines read.
        lines: usize,
        /// The first problem found, if any.
        first: Option<Warning>,
    },
}

fn nothing_usable(lines: usize, first: Option<&Warning>) -> String {
    let mut text = format!(
        "no object could be imported from the {lines} lines: an EDS has [1000]-style sections with ParameterName, DataType and AccessType"
    );
    if let Some(first) = first {
        text.push_str(&format!("; the first problem is at {first}"));
    }
    text
}

/// `[FileInfo]`: who made the file and when. Kept as written.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FileInfo {
    pub file_name: Option<String>,
    pub file_version: Option<String>,
    pub file_revision: Option<String>,
    pub eds_version: Option<String>,
    pub description: Option<String>,
    pub creation_time: Option<String>,
    pub creation_date: Option<String>,
    pub created_by: Option<String>,
    pub modification_time: Option<String>,
    pub modification_date: Option<String>,
    pub modified_by: Option<String>,
}

/// `[DeviceInfo]`: the device the file describes.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DeviceInfo {
    pub vendor_name: Option<String>,
    pub vendor_number: Option<u32>,
    pub product_name: Option<String>,
    pub product_number: Option<u32>,
    pub revision_number: Option<u32>,
    pub order_code: Option<String>,
    /// Supported CAN bit rates in kbit/s (`BaudRate_125=1` …).
    pub baud_rates: Vec<u16>,
    pub simple_boot_up_master: bool,
    pub simple_boot_up_slave: bool,
    /// PDO mapping granularity in bits (0: no mapping, 8: whole bytes).
    pub granularity: Option<u8>,
    pub dynamic_channels_supported: bool,
    pub group_messaging: bool,
    pub nr_of_rx_pdo: Option<u16>,
    pub nr_of_tx_pdo: Option<u16>,
    pub lss_supported: bool,
}

/// The bit rates of CiA 306 `BaudRate_N` keys, kbit/s.
const BAUD_RATES: [u16; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// What an index holds (CiA 301 object code).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ObjectKind {
    /// 7h: one value at sub-index 0.
    Var,
    /// 8h: sub-index 0 counts entries of one type.
    Array,
    /// 9h: sub-index 0 counts entries of several types.
    Record,
}

impl ObjectKind {
    pub fn code(self) -> u8 {
        match self {
            ObjectKind::Var => 0x7,
            ObjectKind::Array => 0x8,
            ObjectKind::Record => 0x9,
        }
    }
}

/// One index of the file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ObjectInfo {
    pub kind: ObjectKind,
    pub name: String,
    /// `[XXXXObjectLinks]`: objects that belong with this one.
    pub links: Vec<u16>,
}

/// AccessType as CiA 306 writes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EdsAccess {
    Ro,
    Wo,
    Rw,
    /// Read/write, mapped in TPDOs (read on process input).
    Rwr,
    /// Read/write, mapped in RPDOs (written on process output).
    Rww,
    Const,
}

impl EdsAccess {
    pub fn as_str(self) -> &'static str {
        match self {
            EdsAccess::Ro => "ro",
            EdsAccess::Wo => "wo",
            EdsAccess::Rw => "rw",
            EdsAccess::Rwr => "rwr",
            EdsAccess::Rww => "rww",
            EdsAccess::Const => "const",
        }
    }

    /// The catalog's access right.
    pub fn access(self) -> Access {
        match self {
            EdsAccess::Ro => Access::Ro,
            EdsAccess::Wo => Access::Wo,
            EdsAccess::Rw | EdsAccess::Rwr | EdsAccess::Rww => Access::Rw,
            EdsAccess::Const => Access::Const,
        }
    }

    pub fn from_access(access: Access) -> Self {
        match access {
            Access::Ro => EdsAccess::Ro,
            Access::Wo => EdsAccess::Wo,
            Access::Rw => EdsAccess::Rw,
            Access::Const => EdsAccess::Const,
        }
    }

    fn parse(text: &str) -> Option<Self> {
        Some(match text.trim().to_ascii_lowercase().as_str() {
            "ro" => EdsAccess::Ro,
            "wo" => EdsAccess::Wo,
            "rw" => EdsAccess::Rw,
            "rwr" => EdsAccess::Rwr,
            "rww" => EdsAccess::Rww,
            "const" => EdsAccess::Const,
            _ => return None,
        })
    }
}

/// A value given as `$NODEID + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NodeFormula {
    pub offset: i128,
}

impl NodeFormula {
    /// The value for a node id.
    pub fn resolve(self, node_id: u8) -> i128 {
        i128::from(node_id) + self.offset
    }
}

impl fmt::Display for NodeFormula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset {
            0 => f.write_str("$NODEID"),
            o if o > 0 => write!(f, "$NODEID+0x{o:X}"),
            o => write!(f, "$NODEID-0x{:X}", o.unsigned_abs()),
        }
    }
}

/// What the file says about one entry beyond the catalog's [`Entry`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct EntryInfo {
    /// DataType as written; differs from the entry's type where that is kept as DOMAIN.
    pub type_code: u16,
    pub access: EdsAccess,
    pub pdo_mapping: bool,
    pub default_formula: Option<NodeFormula>,
    pub low_formula: Option<NodeFormula>,
    pub high_formula: Option<NodeFormula>,
}

/// An imported (or to-be-exported) EDS.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Eds {
    pub file_info: FileInfo,
    pub device_info: DeviceInfo,
    /// Every entry, in the catalog's terms.
    pub catalog: Catalog,
    /// Per index: VAR/ARRAY/RECORD, name, links.
    pub objects: BTreeMap<u16, ObjectInfo>,
    /// Per entry: the file's own terms.
    pub entries: BTreeMap<Address, EntryInfo>,
    /// `[Comments]`, one string a line.
    pub comments: Vec<String>,
    /// `[DummyUsage]`: the data type indices (1..7) usable as dummy PDO entries.
    pub dummy_usage: BTreeSet<u16>,
    /// The node id `$NODEID` formulas were resolved with, if any.
    pub node_id: Option<u8>,
    /// What was skipped or guessed, in file order.
    pub warnings: Vec<Warning>,
}

/// The result of [`Eds::merged_with`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Merged {
    pub catalog: Catalog,
    /// Where the EDS and the catalog disagree (the EDS counted).
    pub notes: Vec<MergeNote>,
}

/// One disagreement between an EDS and the built-in catalog.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct MergeNote {
    pub address: Address,
    pub message: String,
}

impl Eds {
    /// Read an EDS or DCF file. `node_id` resolves `$NODEID` formulas.
    pub fn load(path: &Path, node_id: Option<u8>) -> Result<Eds, EdsError> {
        let bytes = std::fs::read(path).map_err(|source| EdsError::Read {
            path: path.to_owned(),
            source,
        })?;
        Eds::from_bytes(&bytes, node_id)
    }

    /// Parse a file's bytes: UTF-8, else Latin-1 (with a warning).
    pub fn from_bytes(bytes: &[u8], node_id: Option<u8>) -> Result<Eds, EdsError> {
        if bytes.len() > MAX_SIZE {
            return Err(EdsError::TooLarge { size: bytes.len() });
        }
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
                entries.insert(
                    entry.address,
                    EntryInfo {
                        type_code: entry.dtype.code(),
                        access: EdsAccess::from_access(entry.access),
                        pdo_mapping: infer_pdo_mapping(entry, kind),
                        default_formula: None,
                        low_formula: None,
                        high_formula: None,
                    },
                );
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

    /// The EDS's objects with the catalog's descriptions and units where the EDS has none
    /// and the catalog describes the same object (see the module documentation).
    pub fn merged_with(&self, known: &Catalog) -> Merged {
        let nanotec = self.device_info.vendor_number == Some(NANOTEC_VENDOR_ID);
        let mut merged = Merged::default();
        for entry in self.catalog.entries() {
            let mut entry = entry.clone();
            if let Some(k) = known.get(entry.address)
                && same_object(&entry, k, nanotec)
            {
                if entry.description.trim().is_empty() {
                    entry.description = k.description.clone();
                }
                if entry.unit.is_none() {
                    entry.unit = k.unit.clone();
                }
                // What the catalog knows to act stays unwritten, whatever the EDS says.
                entry.role = entry.role.stricter(k.role);
                let mut note = |eds: &dyn fmt::Display, catalog: &dyn fmt::Display| {
                    merged.notes.push(MergeNote {
                        address: entry.address,
                        message: format!(
                            "{} {}: the EDS says {eds}, drivedeck's catalog {catalog}; the EDS counts",
                            entry.address,
                            entry.full_name(),
                        ),
                    });
                };
                if k.dtype != entry.dtype {
                    note(&entry.dtype, &k.dtype);
                }
                // ro and const read the same; only a different right to read or write counts.
                if k.access.readable() != entry.access.readable()
                    || k.access.writable() != entry.access.writable()
                {
                    note(&entry.access, &k.access);
                }
            }
            merged.catalog.insert(entry);
        }
        merged
    }

    /// The EDS as CiA 306 text (CRLF line ends).
    pub fn to_text(&self) -> String {
        let mut out = Writer::default();
        self.write_file_info(&mut out);
        self.write_device_info(&mut out);
        out.section("DummyUsage");
        for n in 1..=7u16 {
            out.key(
                &format!("Dummy{n:04}"),
                u8::from(self.dummy_usage.contains(&n)),
            );
        }
        out.section("Comments");
        out.key("Lines", self.comments.len());
        for (i, line) in self.comments.iter().enumerate() {
            out.key(&format!("Line{}", i + 1), one_line(line));
        }
        let indices: Vec<u16> = self.indices().collect();
        let lists: [(&str, Vec<u16>); 3] = [
            (
                "MandatoryObjects",
                indices
                    .iter()
                    .copied()
                    .filter(|i| MANDATORY.contains(i))
                    .collect(),
            ),
            (
                "OptionalObjects",
                indices
                    .iter()
                    .copied()
                    .filter(|i| !MANDATORY.contains(i) && !is_manufacturer(*i))
                    .collect(),
            ),
            (
                "ManufacturerObjects",
                indices
                    .iter()
                    .copied()
                    .filter(|i| is_manufacturer(*i))
                    .collect(),
            ),
        ];
        for (list, members) in lists {
            out.section(list);
            out.key("SupportedObjects", members.len());
            for (n, index) in members.iter().enumerate() {
                out.key(&(n + 1).to_string(), format!("0x{index:04X}"));
            }
            for index in members {
                self.write_object(&mut out, index);
            }
        }
        out.text
    }

    /// Write the EDS to a file.
    pub fn save(&self, path: &Path) -> Result<(), EdsError> {
        std::fs::write(path, self.to_text()).map_err(|source| EdsError::Write {
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
            out.key("ObjectLinks", info.links.len());
            for (n, link) in info.links.iter().enumerate() {
                out.key(&(n + 1).to_string(), format!("0x{link:04X}"));
            }
        }
    }

    fn write_entry(&self, out: &mut Writer, entry: &Entry, kind: ObjectKind) {
        let info = self
            .entries
            .get(&entry.address)
            .cloned()
            .unwrap_or_else(|| EntryInfo {
                type_code: entry.dtype.code(),
                access: EdsAccess::from_access(entry.access),
                pdo_mapping: infer_pdo_mapping(entry, kind),
                default_formula: None,
                low_formula: None,
                high_formula: None,
            });
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

/// The CiA 301 mandatory objects.
const MANDATORY: [u16; 3] = [0x1000, 0x1001, 0x1018];

fn is_manufacturer(index: u16) -> bool {
    (0x2000..=0x5FFF).contains(&index)
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

/// Whether a catalog entry describes the same object as an EDS entry.
fn same_object(eds: &Entry, known: &Entry, nanotec: bool) -> bool {
    let normal = |s: &str| -> String {
        s.chars()
            .filter(char::is_ascii_alphanumeric)
            .map(|c| c.to_ascii_lowercase())
            .collect()
    };
    !is_manufacturer(eds.address.index)
        || nanotec
        || normal(&eds.full_name()) == normal(&known.full_name())
        || normal(&eds.name) == normal(&known.name)
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

/// CiA 301 integer types drivedeck has no [`DataType`] for: (bits, signed).
fn odd_integer(code: u16) -> Option<(u32, bool)> {
    Some(match code {
        0x0010 => (24, true),
        0x0012 => (40, true),
        0x0013 => (48, true),
        0x0014 => (56, true),
        0x0016 => (24, false),
        0x0018 => (40, false),
        0x0019 => (48, false),
        0x001A => (56, false),
        _ => return None,
    })
}

/// The CiA 301 name of a data type code, for messages.
fn type_name(code: u16) -> String {
    let name = match code {
        0x000C => "TIME_OF_DAY",
        0x000D => "TIME_DIFFERENCE",
        0x0010 => "INTEGER24",
        0x0012 => "INTEGER40",
        0x0013 => "INTEGER48",
        0x0014 => "INTEGER56",
        0x0016 => "UNSIGNED24",
        0x0018 => "UNSIGNED40",
        0x0019 => "UNSIGNED48",
        0x001A => "UNSIGNED56",
        _ => return format!("data type {code:04X}h"),
    };
    format!("{name} ({code:04X}h)")
}

// ---------------------------------------------------------------- writer

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
}

// ---------------------------------------------------------------- INI layer

/// One `KEY=value` line.
#[derive(Debug)]
struct KeyValue {
    value: String,
    line: usize,
}

#[derive(Debug)]
struct Section {
    /// As written, for messages.
    name: String,
    line: usize,
    /// By lower-case key.
    keys: BTreeMap<String, KeyValue>,
}

impl Section {
    fn get(&self, key: &str) -> Option<&KeyValue> {
        self.keys.get(&key.to_ascii_lowercase())
    }

    /// A non-blank value.
    fn text(&self, key: &str) -> Option<&str> {
        self.get(key)
            .map(|k| k.value.as_str())
            .filter(|v| !v.is_empty())
    }

    /// The line of a key, else of the section header.
    fn line_of(&self, key: &str) -> usize {
        self.get(key).map_or(self.line, |k| k.line)
    }
}

#[derive(Debug, Default)]
struct Ini {
    sections: Vec<Section>,
    /// Lower-case section name to its place in `sections`.
    by_name: BTreeMap<String, usize>,
    lines: usize,
}

impl Ini {
    fn read(text: &str, warnings: &mut Vec<Warning>) -> Ini {
        let mut ini = Ini::default();
        let mut current: Option<usize> = None;
        let mut orphans = 0usize;
        for (n, raw) in text.lines().enumerate() {
            let line = n + 1;
            ini.lines = line;
            let t = raw.trim();
            if t.is_empty() || t.starts_with(';') {
                continue;
            }
            if let Some(rest) = t.strip_prefix('[') {
                let name = match rest.find(']') {
                    Some(end) => rest[..end].trim(),
                    None => {
                        warnings.push(Warning {
                            line,
                            message: format!("'{t}' has no closing ']': read as [{}]", rest.trim()),
                        });
                        rest.trim()
                    }
                };
                let key = name.to_ascii_lowercase();
                current = Some(match ini.by_name.get(&key) {
                    Some(&at) => {
                        warnings.push(Warning {
                            line,
                            message: format!(
                                "[{name}] appears again (first at line {}): its keys are merged, later ones count",
                                ini.sections[at].line
                            ),
                        });
                        at
                    }
                    None => {
                        ini.sections.push(Section {
                            name: name.to_owned(),
                            line,
                            keys: BTreeMap::new(),
                        });
                        ini.by_name.insert(key, ini.sections.len() - 1);
                        ini.sections.len() - 1
                    }
                });
                continue;
            }
            let Some((key, value)) = t.split_once('=') else {
                warnings.push(Warning {
                    line,
                    message: format!("'{}' is not KEY=VALUE: ignored", clip(t)),
                });
                continue;
            };
            let key = key.trim();
            if key.is_empty() {
                warnings.push(Warning {
                    line,
                    message: format!("'{}' has no key before '=': ignored", clip(t)),
                });
                continue;
            }
            let Some(at) = current else {
                orphans += 1;
                if orphans == 1 {
                    warnings.push(Warning {
                        line,
                        message: "keys before the first [section]: ignored".into(),
                    });
                }
                continue;
            };
            let section = &mut ini.sections[at];
            let value = KeyValue {
                value: value.trim().to_owned(),
                line,
            };
            if let Some(old) = section.keys.insert(key.to_ascii_lowercase(), value) {
                warnings.push(Warning {
                    line,
                    message: format!(
                        "{key} is given again in [{}] (first at line {}): the last one counts",
                        section.name, old.line
                    ),
                });
            }
        }
        ini
    }

    fn section(&self, name: &str) -> Option<&Section> {
        self.by_name
            .get(&name.to_ascii_lowercase())
            .map(|&at| &self.sections[at])
    }
}

/// Long text shortened for a message.
fn clip(text: &str) -> String {
    const MAX: usize = 60;
    if text.chars().count() <= MAX {
        text.to_owned()
    } else {
        let cut: String = text.chars().take(MAX).collect();
        format!("{cut}…")
    }
}

// ---------------------------------------------------------------- numbers

/// An integer as written in an EDS.
#[derive(Clone, Copy, Debug, PartialEq)]
struct EdsInt {
    value: i128,
    /// Written in hex (or octal): may be a two's complement bit pattern.
    pattern: bool,
    octal: bool,
}

/// Decimal, `0x` hex, octal with a leading 0, negative; spaces ignored.
fn parse_int(text: &str) -> Option<EdsInt> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    let (negative, body) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t.strip_prefix('+').unwrap_or(&t)),
    };
    if body.is_empty() || body.len() > 40 {
        return None;
    }
    let (magnitude, pattern, octal) =
        if let Some(hex) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) {
            if hex.is_empty() || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
                return None;
            }
            (i128::from_str_radix(hex, 16).ok()?, true, false)
        } else if !body.chars().all(|c| c.is_ascii_digit()) {
            return None;
        } else if body.len() > 1 && body.starts_with('0') && body.chars().all(|c| c < '8') {
            (i128::from_str_radix(body, 8).ok()?, true, true)
        } else {
            (body.parse::<i128>().ok()?, false, false)
        };
    Some(EdsInt {
        value: if negative { -magnitude } else { magnitude },
        pattern: pattern && !negative,
        octal,
    })
}

/// `$NODEID`, `$NODEID+N`, `$NODEID-N`, `N+$NODEID`: the offset. `None` when the text has
/// no `$NODEID`.
fn parse_formula(text: &str) -> Option<Result<EdsInt, String>> {
    let t: String = text
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_uppercase();
    let at = t.find("$NODEID")?;
    let before = &t[..at];
    let after = &t[at + "$NODEID".len()..];
    let bad = || {
        Err(format!(
            "'{text}' is not a formula CiA 306 allows ($NODEID, $NODEID+N, N+$NODEID)"
        ))
    };
    let offset = match (before, after) {
        ("", "") => Some(EdsInt {
            value: 0,
            pattern: false,
            octal: false,
        }),
        ("", rest) if rest.starts_with('+') => parse_int(&rest[1..]),
        ("", rest) if rest.starts_with('-') => parse_int(rest),
        (first, "") if first.ends_with('+') => parse_int(&first[..first.len() - 1]),
        _ => return Some(bad()),
    };
    Some(offset.ok_or(()).or_else(|()| bad()))
}

/// How a data type code is used in the catalog.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TypeUse {
    Native(DataType),
    /// An integer width drivedeck has no type for: kept as DOMAIN bytes.
    OddInteger {
        bits: u32,
        signed: bool,
    },
    /// Kept as DOMAIN, values not read.
    Opaque,
}

impl TypeUse {
    fn of(code: u16) -> TypeUse {
        if let Some(t) = DataType::from_code(code) {
            TypeUse::Native(t)
        } else if let Some((bits, signed)) = odd_integer(code) {
            TypeUse::OddInteger { bits, signed }
        } else {
            TypeUse::Opaque
        }
    }

    fn dtype(self) -> DataType {
        match self {
            TypeUse::Native(t) => t,
            _ => DataType::Domain,
        }
    }

    /// Bits, signedness and range of an integer type.
    fn integer(self) -> Option<(u32, bool, i128, i128)> {
        match self {
            TypeUse::Native(t) => {
                let (min, max) = t.integer_range()?;
                let bits = match t {
                    DataType::Boolean => 1,
                    _ => t.size().map_or(64, |s| s as u32 * 8),
                };
                Some((bits, t.is_signed(), min, max))
            }
            TypeUse::OddInteger { bits, signed } => {
                let (min, max) = if signed {
                    (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1)
                } else {
                    (0, (1i128 << bits) - 1)
                };
                Some((bits, signed, min, max))
            }
            TypeUse::Opaque => None,
        }
    }

    fn name(self, code: u16) -> String {
        match self {
            TypeUse::Native(t) => t.short_name().to_owned(),
            _ => type_name(code),
        }
    }
}

/// One value read from the file.
#[derive(Debug, Default, PartialEq)]
struct Parsed {
    value: Option<Value>,
    formula: Option<NodeFormula>,
    octal: bool,
}

/// Parse `text` for a type. Blank: nothing.
fn parse_value(text: &str, ty: TypeUse, code: u16, node_id: Option<u8>) -> Result<Parsed, String> {
    let t = text.trim();
    if t.is_empty() {
        return Ok(Parsed::default());
    }
    let type_name = ty.name(code);
    if let Some((bits, signed, min, max)) = ty.integer() {
        let out_of_range = |v: i128| format!("{v} is out of range for {type_name}: {min}..={max}");
        let (wide, formula, octal) = match parse_formula(t) {
            Some(offset) => {
                let offset = offset?.value;
                let formula = NodeFormula { offset };
                match node_id {
                    Some(node) => {
                        let v = formula.resolve(node);
                        if v < min || v > max {
                            return Err(format!("{t} for node {node}: {}", out_of_range(v)));
                        }
                        (Some(v), Some(formula), false)
                    }
                    None => (None, Some(formula), false),
                }
            }
            None => {
                let bool_text = match t.to_ascii_lowercase().as_str() {
                    "true" if bits == 1 => Some(1),
                    "false" if bits == 1 => Some(0),
                    _ => None,
                };
                let n = match bool_text {
                    Some(v) => EdsInt {
                        value: v,
                        pattern: false,
                        octal: false,
                    },
                    None => {
                        parse_int(t).ok_or_else(|| format!("'{t}' is not a {type_name} value"))?
                    }
                };
                let mut v = n.value;
                let unsigned_max = if bits >= 128 {
                    i128::MAX
                } else {
                    (1i128 << bits) - 1
                };
                if signed && n.pattern && v > max && v <= unsigned_max {
                    v -= 1i128 << bits;
                }
                if v < min || v > max {
                    return Err(out_of_range(n.value));
                }
                (Some(v), None, n.octal)
            }
        };
        let value = match (wide, ty) {
            (None, _) => None,
            (Some(v), TypeUse::Native(t)) => {
                Some(Value::from_i128(t, v).map_err(|e| e.to_string())?)
            }
            (Some(v), _) => {
                let bytes = (bits / 8) as usize;
                Some(Value::Bytes(v.to_le_bytes()[..bytes].to_vec()))
            }
        };
        return Ok(Parsed {
            value,
            formula,
            octal,
        });
    }
    let value = match ty {
        TypeUse::Native(DataType::Real32 | DataType::Real64) => {
            t.parse::<f64>()
                .map(Value::Real)
                .map_err(|_| format!("'{t}' is not a {type_name} number"))?
        }
        TypeUse::Native(DataType::VisibleString | DataType::UnicodeString) => {
            Value::Text(t.to_owned())
        }
        TypeUse::Native(t @ (DataType::OctetString | DataType::Domain)) => Value::parse(t, text)
            .map_err(|_| {
                format!(
                    "'{}' is not hex bytes (a {type_name} value is written as hex, e.g. 0A1B2C)",
                    clip(text.trim())
                )
            })?,
        _ => return Ok(Parsed::default()),
    };
    Ok(Parsed {
        value: Some(value),
        formula: None,
        octal: false,
    })
}

// ---------------------------------------------------------------- import

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
        let objects = gathered.objects.clone();
        for (&index, &section) in &objects {
            self.import_object(index, section, &gathered);
        }
        for (&index, subs) in &gathered.subs {
            if !objects.contains_key(&index) {
                self.import_orphan_subs(index, subs);
            }
        }
        for (&index, &section) in &gathered.links {
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
        self.check_lists(&objects);
    }

    fn read_file_info(&mut self) {
        let ini = self.ini;
        let Some(s) = ini.section("FileInfo") else {
            return;
        };
        let get = |key: &str| s.text(key).map(str::to_owned);
        self.eds.file_info = FileInfo {
            file_name: get("FileName"),
            file_version: get("FileVersion"),
            file_revision: get("FileRevision"),
            eds_version: get("EDSVersion"),
            description: get("Description"),
            creation_time: get("CreationTime"),
            creation_date: get("CreationDate"),
            created_by: get("CreatedBy"),
            modification_time: get("ModificationTime"),
            modification_date: get("ModificationDate"),
            modified_by: get("ModifiedBy"),
        };
    }

    /// An unsigned number of a device-info key, with a warning when it is not one.
    fn number(&mut self, s: &Section, key: &str, max: u32) -> Option<u32> {
        let text = s.text(key)?;
        match parse_int(text).filter(|n| (0..=i128::from(max)).contains(&n.value)) {
            Some(n) => Some(n.value as u32),
            None => {
                self.warn(
                    s.line_of(key),
                    format!(
                        "[{}] {key}='{}' is not a number up to {max}; ignored",
                        s.name,
                        clip(text)
                    ),
                );
                None
            }
        }
    }

    fn flag(&mut self, s: &Section, key: &str) -> bool {
        self.number(s, key, u32::MAX).is_some_and(|v| v != 0)
    }

    fn read_device_info(&mut self) {
        let ini = self.ini;
        let Some(s) = ini.section("DeviceInfo") else {
            self.warn(
                1,
                "no [DeviceInfo] section (CiA 306 requires one): vendor and product unknown",
            );
            return;
        };
        let text = |key: &str| s.text(key).map(str::to_owned);
        let mut info = DeviceInfo {
            vendor_name: text("VendorName"),
            product_name: text("ProductName"),
            order_code: text("OrderCode"),
            ..DeviceInfo::default()
        };
        info.vendor_number = self.number(s, "VendorNumber", u32::MAX);
        info.product_number = self.number(s, "ProductNumber", u32::MAX);
        info.revision_number = self.number(s, "RevisionNumber", u32::MAX);
        for rate in BAUD_RATES {
            if self.flag(s, &format!("BaudRate_{rate}")) {
                info.baud_rates.push(rate);
            }
        }
        info.simple_boot_up_master = self.flag(s, "SimpleBootUpMaster");
        info.simple_boot_up_slave = self.flag(s, "SimpleBootUpSlave");
        info.granularity = self.number(s, "Granularity", 64).map(|v| v as u8);
        info.dynamic_channels_supported = self.flag(s, "DynamicChannelsSupported");
        info.group_messaging = self.flag(s, "GroupMessaging");
        info.nr_of_rx_pdo = self.number(s, "NrOfRXPDO", 512).map(|v| v as u16);
        info.nr_of_tx_pdo = self.number(s, "NrOfTXPDO", 512).map(|v| v as u16);
        info.lss_supported = self.flag(s, "LSS_Supported");
        self.eds.device_info = info;
    }

    /// The node id: the caller's, else a DCF's.
    fn read_commissioning(&mut self) {
        let ini = self.ini;
        let from_file = ini
            .section("DeviceComissioning")
            .or_else(|| ini.section("DeviceCommissioning"))
            .and_then(|s| {
                self.number(s, "NodeID", 127)
                    .filter(|n| *n >= 1)
                    .map(|n| n as u8)
            });
        self.node_id = self.node_id.or(from_file);
        self.eds.node_id = self.node_id;
    }

    fn read_comments(&mut self) {
        let ini = self.ini;
        let Some(s) = ini.section("Comments") else {
            return;
        };
        let count = self.number(s, "Lines", 10_000).unwrap_or(0);
        for n in 1..=count {
            match s.get(&format!("Line{n}")) {
                Some(k) => self.eds.comments.push(k.value.clone()),
                None => {
                    let message = format!(
                        "[Comments] Lines={count} but Line{n} is missing; the comment ends there"
                    );
                    self.warn(s.line_of("Lines"), message);
                    break;
                }
            }
        }
    }

    fn read_dummy_usage(&mut self) {
        let ini = self.ini;
        let Some(s) = ini.section("DummyUsage") else {
            return;
        };
        for n in 1..=7u16 {
            if self.flag(s, &format!("Dummy{n:04}")) {
                self.eds.dummy_usage.insert(n);
            }
        }
    }

    /// `N=0xXXXX` entries of a list section, with their lines; checks the count key.
    fn read_list(&mut self, s: &Section, count_key: &str) -> Vec<(u16, usize)> {
        let count = self.number(s, count_key, 0xFFFF);
        // Every `N=` key, in the order of N (a gap in the numbers loses nothing).
        let mut numbered: Vec<(u32, &KeyValue)> = s
            .keys
            .iter()
            .filter_map(|(key, value)| {
                let n = key.parse::<u32>().ok().filter(|n| *n >= 1)?;
                Some((n, value))
            })
            .collect();
        numbered.sort_by_key(|(n, _)| *n);
        let mut found = Vec::new();
        for &(n, k) in &numbered {
            match parse_int(&k.value).filter(|v| (0..=0xFFFF).contains(&v.value)) {
                Some(v) => found.push((v.value as u16, k.line)),
                None => self.warn(
                    k.line,
                    format!(
                        "[{}] {n}='{}' is not an object index; ignored",
                        s.name,
                        clip(&k.value)
                    ),
                ),
            }
        }
        if let Some(count) = count
            && count as usize != numbered.len()
        {
            self.warn(
                s.line_of(count_key),
                format!(
                    "[{}] {count_key}={count}, but {} entries follow; all of them are read",
                    s.name,
                    numbered.len()
                ),
            );
        }
        found
    }

    /// Lists vs sections: every section was imported; say where they disagree.
    fn check_lists(&mut self, objects: &BTreeMap<u16, &Section>) {
        let ini = self.ini;
        let mut listed = BTreeSet::new();
        let mut any_list = false;
        for list in ["MandatoryObjects", "OptionalObjects", "ManufacturerObjects"] {
            let Some(s) = ini.section(list) else {
                continue;
            };
            any_list = true;
            let members = self.read_list(s, "SupportedObjects");
            let missing: Vec<u16> = members
                .iter()
                .map(|(i, _)| *i)
                .filter(|i| !objects.contains_key(i))
                .collect();
            if !missing.is_empty() {
                self.warn(
                    s.line,
                    format!(
                        "[{list}] names {} with no [XXXX] section: not imported",
                        index_list(&missing)
                    ),
                );
            }
            listed.extend(members.into_iter().map(|(i, _)| i));
        }
        let unlisted: Vec<u16> = objects
            .keys()
            .copied()
            .filter(|i| !listed.contains(i) && self.eds.objects.contains_key(i))
            .collect();
        if let Some(first) = unlisted.first().and_then(|i| objects.get(i)) {
            let message = if any_list {
                format!(
                    "{} have sections but no [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects] entry: imported anyway",
                    index_list(&unlisted)
                )
            } else {
                "the file has no [MandatoryObjects], [OptionalObjects] nor [ManufacturerObjects]: every object section is imported".to_owned()
            };
            self.warn(first.line, message);
        }
    }

    fn import_object(&mut self, index: u16, section: &Section, g: &Gathered<'_>) {
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
        let object_type = match section.text("ObjectType") {
            None => 0x7,
            Some(text) => match parse_int(text).filter(|v| (0..=0xFF).contains(&v.value)) {
                Some(v) => v.value as u8,
                None => {
                    let message = format!(
                        "{index:04X}h: ObjectType='{}' is not a number; skipped",
                        clip(text)
                    );
                    self.warn(section.line_of("ObjectType"), message);
                    return;
                }
            },
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
                let mut entries = Vec::new();
                for (&sub, &s) in subs {
                    let sub_name = match s.text("ParameterName") {
                        Some(n) => n.to_owned(),
                        None => {
                            let message = format!("{index:04X}h:{sub:02X}h has no ParameterName");
                            self.warn(s.line, message);
                            format!("Sub-index {sub:02X}h")
                        }
                    };
                    let address = Address::new(index, sub);
                    entries.push(self.read_entry(s, address, name, sub_name, false));
                }
                entries
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
    fn import_orphan_subs(&mut self, index: u16, subs: &BTreeMap<u8, &Section>) {
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
        let mut entries = Vec::new();
        for (&sub, &s) in subs {
            let sub_name = s
                .text("ParameterName")
                .map_or_else(|| format!("Sub-index {sub:02X}h"), str::to_owned);
            entries.push(self.read_entry(s, Address::new(index, sub), &name, sub_name, false));
        }
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

    /// One entry from a VAR or sub-index section.
    fn read_entry(
        &mut self,
        s: &Section,
        address: Address,
        object_name: &str,
        name: String,
        domain_object: bool,
    ) -> (Entry, EntryInfo) {
        let at = format!("{address}");
        let code = match s.text("DataType") {
            Some(text) => match parse_int(text).filter(|v| (0..=0xFFFF).contains(&v.value)) {
                Some(v) => v.value as u16,
                None => {
                    let message = format!(
                        "{at}: DataType='{}' is not a type code; kept as DOMAIN (raw bytes)",
                        clip(text)
                    );
                    self.warn(s.line_of("DataType"), message);
                    DataType::Domain.code()
                }
            },
            None if domain_object => DataType::Domain.code(),
            None => {
                self.warn(
                    s.line,
                    format!("{at} has no DataType: kept as DOMAIN (raw bytes)"),
                );
                DataType::Domain.code()
            }
        };
        let ty = TypeUse::of(code);
        match ty {
            TypeUse::Native(_) => {}
            TypeUse::OddInteger { bits, .. } => {
                let message = format!(
                    "{at}: drivedeck has no {bits}-bit type for {}: \
                     kept as DOMAIN (its little-endian bytes)",
                    type_name(code)
                );
                self.warn(s.line_of("DataType"), message);
            }
            TypeUse::Opaque => {
                let message = format!(
                    "{at}: {} is not a CANopen basic type drivedeck knows: \
                     kept as DOMAIN (raw bytes), without default or limits",
                    type_name(code)
                );
                self.warn(s.line_of("DataType"), message);
            }
        }
        let access = match s.text("AccessType") {
            Some(text) => match EdsAccess::parse(text) {
                Some(a) => a,
                None => {
                    let guess = match text.trim().to_ascii_lowercase().as_str() {
                        "r" | "read" | "readonly" => EdsAccess::Ro,
                        "w" | "write" | "writeonly" => EdsAccess::Wo,
                        "readwrite" | "r/w" => EdsAccess::Rw,
                        _ => EdsAccess::Ro,
                    };
                    let message = format!(
                        "{at}: AccessType='{}' is not ro, wo, rw, rwr, rww or const: read as {}",
                        clip(text),
                        guess.as_str()
                    );
                    self.warn(s.line_of("AccessType"), message);
                    guess
                }
            },
            None => {
                self.warn(s.line, format!("{at} has no AccessType: read as ro"));
                EdsAccess::Ro
            }
        };
        let pdo_mapping = match s.text("PDOMapping") {
            None => false,
            Some(text) => match parse_int(text) {
                Some(v) if v.value == 0 || v.value == 1 => v.value == 1,
                _ => {
                    self.warn(
                        s.line_of("PDOMapping"),
                        format!("{at}: PDOMapping='{}' is not 0 or 1: read as 0", clip(text)),
                    );
                    false
                }
            },
        };
        let dtype = ty.dtype();
        let value = |this: &mut Self, key: &str| -> (Option<Value>, Option<NodeFormula>) {
            let Some(text) = s.text(key) else {
                return (None, None);
            };
            if ty == TypeUse::Opaque {
                return (None, None);
            }
            if matches!(
                ty,
                TypeUse::Native(
                    DataType::VisibleString
                        | DataType::UnicodeString
                        | DataType::OctetString
                        | DataType::Domain
                )
            ) && key != "DefaultValue"
            {
                this.warn(
                    s.line_of(key),
                    format!(
                        "{at}: {key} does not apply to a {}; ignored",
                        dtype.short_name()
                    ),
                );
                return (None, None);
            }
            match parse_value(text, ty, code, this.node_id) {
                Ok(parsed) => {
                    if parsed.octal {
                        this.warn(
                            s.line_of(key),
                            format!(
                                "{at}: {key}={text} has a leading 0: read as octal {} (CiA 306); write it without the 0 for decimal",
                                parsed.value.as_ref().map(Value::to_string).unwrap_or_default()
                            ),
                        );
                    }
                    (parsed.value, parsed.formula)
                }
                Err(e) => {
                    this.warn(s.line_of(key), format!("{at}: {key}: {e}; ignored"));
                    (None, None)
                }
            }
        };
        let (default, default_formula) = value(self, "DefaultValue");
        let (mut min, mut low_formula) = value(self, "LowLimit");
        let (mut max, mut high_formula) = value(self, "HighLimit");
        if let (Some(lo), Some(hi)) = (
            min.as_ref().and_then(Value::as_f64),
            max.as_ref().and_then(Value::as_f64),
        ) && lo > hi
        {
            self.warn(
                s.line_of("LowLimit"),
                format!("{at}: LowLimit {lo} is above HighLimit {hi}; both ignored"),
            );
            (min, max, low_formula, high_formula) = (None, None, None, None);
        }
        let unit = s.text("Unit").map(str::to_owned);
        let description = s.text("Description").unwrap_or_default().to_owned();
        let entry = Entry {
            address,
            object_name: object_name.to_owned(),
            name: if name.is_empty() {
                object_name.to_owned()
            } else {
                name
            },
            dtype,
            access: access.access(),
            unit,
            description,
            default,
            min,
            max,
            group: Group::of_index(address.index),
            role: Role::of_eds(
                address,
                access.access(),
                dtype,
                matches!(access, EdsAccess::Rww | EdsAccess::Rwr),
            ),
        };
        if let Some(default) = &entry.default
            && let Err(e) = entry.check(default)
        {
            self.warn(
                s.line_of("DefaultValue"),
                format!("{at}: DefaultValue {e} (kept)"),
            );
        }
        let info = EntryInfo {
            type_code: code,
            access,
            pdo_mapping,
            default_formula,
            low_formula,
            high_formula,
        };
        (entry, info)
    }
}

fn index_list(indices: &[u16]) -> String {
    let mut names: Vec<String> = indices
        .iter()
        .take(LISTED)
        .map(|i| format!("{i:04X}h"))
        .collect();
    if indices.len() > LISTED {
        names.push(format!("and {} more", indices.len() - LISTED));
    }
    names.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Eds {
        Eds::parse(text, None).unwrap()
    }

    const MINIMAL: &str = "[DeviceInfo]\nVendorNumber=0x26C\n\
        [1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\n\
        DefaultValue=0x00040192\n";

    #[test]
    fn integers_in_every_eds_form() {
        let v = |t: &str| parse_int(t).map(|n| n.value);
        assert_eq!(v("12"), Some(12));
        assert_eq!(v("-12"), Some(-12));
        assert_eq!(v("0x1F"), Some(31));
        assert_eq!(v("0X1f"), Some(31));
        assert_eq!(v("010"), Some(8));
        assert_eq!(v("0"), Some(0));
        assert_eq!(v("09"), Some(9));
        assert_eq!(v("1 000"), Some(1000));
        for bad in ["", "-", "0x", "12a", "h", "1.5", "--1", "0x-1"] {
            assert_eq!(v(bad), None, "{bad}");
        }
    }

    #[test]
    fn node_id_formulas() {
        let f = |t: &str| parse_formula(t).map(|r| r.map(|n| n.value));
        assert_eq!(f("$NODEID+0x180"), Some(Ok(0x180)));
        assert_eq!(f("$nodeid + 384"), Some(Ok(384)));
        assert_eq!(f("0x180+$NODEID"), Some(Ok(0x180)));
        assert_eq!(f("$NODEID"), Some(Ok(0)));
        assert_eq!(f("$NODEID-1"), Some(Ok(-1)));
        assert_eq!(f("0x180"), None);
        assert!(matches!(f("$NODEID*2"), Some(Err(_))));
        assert!(matches!(f("1+$NODEID+2"), Some(Err(_))));
        assert_eq!(NodeFormula { offset: 0x180 }.to_string(), "$NODEID+0x180");
        assert_eq!(NodeFormula { offset: 0 }.to_string(), "$NODEID");
        assert_eq!(NodeFormula { offset: -2 }.to_string(), "$NODEID-0x2");
    }

    #[test]
    fn values_per_type() {
        let p = |t: &str, dtype: DataType| {
            parse_value(t, TypeUse::Native(dtype), dtype.code(), Some(5)).map(|p| p.value)
        };
        assert_eq!(
            p("0xFFFFFFFF", DataType::Integer32),
            Ok(Some(Value::Int(-1)))
        );
        assert_eq!(p("0x80", DataType::Integer8), Ok(Some(Value::Int(-128))));
        assert!(p("4294967295", DataType::Integer32).is_err());
        assert!(p("256", DataType::Unsigned8).is_err());
        assert_eq!(
            p("$NODEID+0x180", DataType::Unsigned32),
            Ok(Some(Value::Uint(0x185)))
        );
        assert_eq!(p("", DataType::Unsigned32), Ok(None));
        assert_eq!(p("1", DataType::Boolean), Ok(Some(Value::Bool(true))));
        assert_eq!(p("5.2", DataType::Real32), Ok(Some(Value::Real(5.2))));
        assert_eq!(
            p("ABCD", DataType::OctetString),
            Ok(Some(Value::Bytes(vec![0xAB, 0xCD])))
        );
        assert!(p("@ABCD", DataType::Domain).is_err());
        assert_eq!(
            p("TEST", DataType::VisibleString),
            Ok(Some(Value::Text("TEST".into())))
        );
        let odd = TypeUse::OddInteger {
            bits: 24,
            signed: true,
        };
        assert_eq!(
            parse_value("-1", odd, 0x10, None).map(|p| p.value),
            Ok(Some(Value::Bytes(vec![0xFF, 0xFF, 0xFF])))
        );
        let unresolved = parse_value(
            "$NODEID+0x80",
            TypeUse::Native(DataType::Unsigned32),
            7,
            None,
        )
        .unwrap();
        assert_eq!(unresolved.value, None);
        assert_eq!(unresolved.formula, Some(NodeFormula { offset: 0x80 }));
    }

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

    #[test]
    fn odd_but_readable_files() {
        let text = "\u{FEFF}[DeviceInfo]\nVendorNumber=1\n\
[OptionalObjects]\nSupportedObjects=2\n1=0x2000\n3=0x2001\n\
[2000]\nParameterName=Flag\nDataType=1\nAccessType=RW\nDefaultValue=true\n\
[2001]\nParameterName=Octal\nDataType=0x0005\nAccessType=Read\nDefaultValue=010\nLowLimit=9\nHighLimit=2\n\
[2002]\nParameterName=Outside\nDataType=0x0005\nAccessType=ro\nDefaultValue=7\nHighLimit=6\n";
        let eds = parse(text);
        let get = |i: u16| eds.catalog.get(Address::new(i, 0)).unwrap();
        assert_eq!(get(0x2000).default, Some(Value::Bool(true)));
        assert_eq!(get(0x2001).default, Some(Value::Uint(8)));
        assert_eq!(get(0x2001).access, Access::Ro);
        assert_eq!((&get(0x2001).min, &get(0x2001).max), (&None, &None));
        assert_eq!(get(0x2002).default, Some(Value::Uint(7)));
        let messages: Vec<String> = eds.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(
            messages,
            [
                "line 15: 2001h:00h: AccessType='Read' is not ro, wo, rw, rwr, rww or const: read as ro",
                "line 16: 2001h:00h: DefaultValue=010 has a leading 0: read as octal 8 (CiA 306); write it without the 0 for decimal",
                "line 17: 2001h:00h: LowLimit 9 is above HighLimit 2; both ignored",
                "line 19: 2002h have sections but no [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects] entry: imported anyway",
                "line 23: 2002h:00h: DefaultValue 7 is above the object's maximum 6 (kept)",
            ]
        );
    }

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

    #[test]
    fn an_eds_entry_is_a_setting_only_where_the_rule_and_the_catalog_agree() {
        let text = "[DeviceInfo]\nVendorNumber=0x26C\n\
[3000]\nParameterName=Set value\nDataType=0x0004\nAccessType=rww\nPDOMapping=1\n\
[3001]\nParameterName=Input\nDataType=0x0004\nAccessType=rwr\nPDOMapping=1\n\
[3002]\nParameterName=Gain\nDataType=0x0004\nAccessType=rw\nPDOMapping=1\n\
[6040]\nParameterName=Controlword\nDataType=0x0006\nAccessType=rw\nPDOMapping=1\n\
[6041]\nParameterName=Statusword\nDataType=0x0006\nAccessType=rw\n";
        let eds = parse(text);
        let role = |i: u16| eds.catalog.get(Address::new(i, 0)).unwrap().role;
        assert!(matches!(role(0x3000), Role::ProcessData(_)));
        assert!(matches!(role(0x3001), Role::ProcessData(_)));
        // Mappable alone is no process data: settings are mappable too.
        assert_eq!(role(0x3002), Role::Configuration);
        assert!(matches!(role(0x6040), Role::Command(_)));
        assert_eq!(role(0x6041), Role::Configuration, "what this EDS says");
        // Merged with the catalog, which knows the statusword is read-only.
        let merged = eds.merged_with(&Catalog::builtin().unwrap()).catalog;
        let merged_role = |i: u16| merged.get(Address::new(i, 0)).unwrap().role;
        assert_eq!(merged_role(0x6041), Role::ReadOnly);
        assert_eq!(merged_role(0x3002), Role::Configuration);
        assert!(matches!(merged_role(0x6040), Role::Command(_)));
    }
}
