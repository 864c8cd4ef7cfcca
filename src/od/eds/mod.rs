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
//! * DataType is a CiA 301 code. drivedeck's [`DataType`](super::DataType) has no
//!   24/40/48/56-bit integers, TIME_OF_DAY or TIME_DIFFERENCE; those and unknown codes
//!   (manufacturer complex types 0040h+) are kept as DOMAIN (the raw little-endian
//!   bytes), with a warning; integer defaults of the odd widths become their bytes. The
//!   code as written stays in [`EntryInfo::type_code`], so an export writes it back.
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
//! says so. An entry's [`Role`](super::Role) (whether a restore may write it) is the
//! stricter of the EDS's (AccessType `rww`/`rwr` is process data) and the catalog's.
//!
//! # Export
//!
//! [`Eds::to_text`] writes CiA 306 sections in the usual order, CRLF line ends, UTF-8
//! text. Integers in decimal, except UNSIGNED32/64 values of the communication objects
//! (1000h-1FFFh: ids, COB-IDs, mappings) or above FFFFh (bit fields, signatures) in hex;
//! `$NODEID` formulas as formulas. Units and descriptions
//! go in `Unit=`/`Description=` keys, which other tools skip.
//!
//! # Where it is
//!
//! * `error`: [`Warning`] and [`EdsError`].
//! * `ini`: the INI layer (sections, keys, line numbers).
//! * `values`: integers, `$NODEID` formulas and values as CiA 306 writes them.
//! * `import`: an EDS or DCF into an [`Eds`].
//! * `merge`: an [`Eds`] with the built-in catalog.
//! * `export`: a catalog as an [`Eds`], an [`Eds`] as text.

mod error;
mod export;
mod import;
mod ini;
mod merge;
mod values;

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::{Access, Address, Catalog};

pub use error::{EdsError, Warning};
pub use export::{infer_kind, infer_pdo_mapping};
pub use merge::{MergeNote, Merged};
pub use values::NodeFormula;

/// Larger than any real EDS: the biggest vendor files are a few megabytes.
pub const MAX_SIZE: usize = 32 * 1024 * 1024;

/// Nanotec's CiA vendor id, as in 1018h:01h of every Nanotec drive.
pub const NANOTEC_VENDOR_ID: u32 = 0x26C;

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

/// What the file says about one entry beyond the catalog's [`Entry`](super::Entry).
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

/// The manufacturer range of CiA 301, 2000h-5FFFh.
fn is_manufacturer(index: u16) -> bool {
    (0x2000..=0x5FFF).contains(&index)
}

/// What the tests of several files read.
#[cfg(test)]
mod testing {
    use super::Eds;

    pub(super) fn parse(text: &str) -> Eds {
        Eds::parse(text, None).unwrap()
    }

    pub(super) const MINIMAL: &str = "[DeviceInfo]\nVendorNumber=0x26C\n\
        [1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\n\
        DefaultValue=0x00040192\n";
}
