//! A drive's configuration as a file: what a backup saves, how a file compares with the
//! device, and the order a restore writes in.
//!
//! Saved are the objects whose [`Role`] is configuration: readable and writable, and not
//! process data nor commands (the PDI images, the controlword, targets, outputs, NanoJ
//! I/O, store/restore commands), since writing those back would move the motor or act,
//! not configure. The identity (1018h, 1008h, 1009h, 100Ah) goes in the file's header.
//!
//! A file is only ever trusted as far as the dictionary in use agrees with it: comparing
//! and restoring skip every saved object that dictionary does not know, knows with another
//! type, or does not call configuration, whatever the file says, and list it with the
//! reason ([`Comparison::Skipped`]); such an object is not even read. A file that names an
//! object twice, or none, is refused when it is loaded.
//!
//! A restore writes only what differs, in a safe order: drive configuration, then the
//! drive profile, then mappings with their procedure (PDO invalidated, count 0, entries,
//! count, PDO valid again), then communication objects, and last the settings that may cut
//! the very link the restore runs on (node id, bit rate, IP and Modbus settings).

use std::collections::BTreeMap;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::{Address, Catalog, DataType, Entry, Role, Value};

/// The `format` field of every backup file.
pub const FORMAT: &str = "drivedeck backup";
/// The file format's version.
pub const VERSION: u32 = 1;

/// Settings that change how the drive is reached: written last, with a warning.
const LINK_SETTINGS: [u16; 10] = [
    0x2005, 0x2009, 0x2010, 0x2011, 0x2012, 0x2013, 0x2028, 0x202A, 0x202C, 0x202D,
];

/// The identity read into a backup's header.
pub const IDENTITY: [(Address, DataType); 7] = [
    (Address::new(0x1018, 1), DataType::Unsigned32),
    (Address::new(0x1018, 2), DataType::Unsigned32),
    (Address::new(0x1018, 3), DataType::Unsigned32),
    (Address::new(0x1018, 4), DataType::Unsigned32),
    (Address::new(0x1008, 0), DataType::VisibleString),
    (Address::new(0x1009, 0), DataType::VisibleString),
    (Address::new(0x100A, 0), DataType::VisibleString),
];

/// 1010h:01 "save all": the value that stores the parameters in the drive's memory.
pub const STORE_ALL: (Address, u32) = (Address::new(0x1010, 1), 0x6576_6173);

/// A backup file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum BackupError {
    #[error("not a drivedeck backup: {0}")]
    Json(#[from] serde_json::Error),
    #[error("the file's format is '{0}', not '{FORMAT}'")]
    Format(String),
    #[error("backup version {0} is newer than this drivedeck reads ({VERSION})")]
    Version(u32),
    #[error("object '{address}' in the file: {reason}")]
    Object { address: String, reason: String },
    #[error(
        "object {address} is listed twice (as '{first}' and as '{second}'): which value is meant is unclear; remove one and try again"
    )]
    Twice {
        address: Address,
        first: String,
        second: String,
    },
    #[error("the file lists no objects: nothing to restore or compare")]
    Empty,
    /// The file could not be read (it names itself): missing, a FIFO, too large, ….
    #[error(transparent)]
    File(#[from] crate::file::ReadError),
    #[error("not a drivedeck backup: the file is not UTF-8 text (byte {0} is not)")]
    NotText(usize),
}

/// A backup file is a few hundred kB; one near this size is none.
pub const MAX_FILE_BYTES: u64 = 32 * 1024 * 1024;

/// Whether a catalog entry belongs in a backup: configuration, by its [`Role`].
pub fn savable(entry: &Entry) -> bool {
    entry.role.is_configuration()
}

/// Why comparing and restoring leave a saved object alone, or None when a restore may
/// write it: `catalog` (the dictionary in use) must know the object, with the file's
/// type, as configuration. An object it does not know is not written blind.
pub fn skip_reason(catalog: &Catalog, address: Address, saved: &SavedObject) -> Option<String> {
    let Some(entry) = catalog.get(address) else {
        return Some(
            "not in the dictionary in use (the built-in catalog, or the EDS given): what writing it does is unknown"
                .to_owned(),
        );
    };
    if entry.role != Role::Configuration {
        return Some(entry.role.to_string());
    }
    if entry.dtype != saved.dtype {
        return Some(format!(
            "the file says {}, the dictionary {}: not written as a type the object does not have",
            saved.dtype, entry.dtype
        ));
    }
    None
}

/// What a backup reads: the identity, then every savable object.
pub fn objects_to_read(catalog: &Catalog) -> Vec<(Address, DataType)> {
    let mut out: Vec<(Address, DataType)> = IDENTITY.to_vec();
    out.extend(
        catalog
            .entries()
            .filter(|e| savable(e))
            .map(|e| (e.address, e.dtype)),
    );
    out
}

/// The device a backup came from.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DeviceIdentity {
    /// 1018h:01
    pub vendor: Option<u32>,
    /// 1018h:02
    pub product: Option<u32>,
    /// 1018h:03
    pub revision: Option<u32>,
    /// 1018h:04
    pub serial: Option<u32>,
    /// 1008h
    pub name: Option<String>,
    /// 1009h
    pub hardware: Option<String>,
    /// 100Ah
    pub software: Option<String>,
}

impl DeviceIdentity {
    /// From the values read at [`IDENTITY`].
    pub fn from_reads<E>(reads: &BTreeMap<Address, Result<Value, E>>) -> DeviceIdentity {
        let uint = |index, sub| match reads.get(&Address::new(index, sub)) {
            Some(Ok(Value::Uint(v))) => u32::try_from(*v).ok(),
            _ => None,
        };
        let text = |index| match reads.get(&Address::new(index, 0)) {
            Some(Ok(Value::Text(t))) => Some(t.clone()),
            _ => None,
        };
        DeviceIdentity {
            vendor: uint(0x1018, 1),
            product: uint(0x1018, 2),
            revision: uint(0x1018, 3),
            serial: uint(0x1018, 4),
            name: text(0x1008),
            hardware: text(0x1009),
            software: text(0x100A),
        }
    }

    /// One line: `drivedeck simulated drive, vendor 0000026Ch, product …, serial …`.
    pub fn summary(&self) -> String {
        let hex = |v: Option<u32>| v.map_or("?".to_owned(), |v| format!("{v:08X}h"));
        format!(
            "{}, vendor {}, product {}, revision {}, serial {}{}",
            self.name
                .as_deref()
                .map_or("unnamed device".into(), crate::text::shown),
            hex(self.vendor),
            hex(self.product),
            hex(self.revision),
            hex(self.serial),
            self.software
                .as_ref()
                .map(|s| format!(", software {}", crate::text::shown(s)))
                .unwrap_or_default()
        )
    }

    /// Whether `other` is the same kind of device (vendor and product); the serial may
    /// differ (a backup is how a replacement drive gets its predecessor's settings).
    pub fn same_product(&self, other: &DeviceIdentity) -> bool {
        self.vendor == other.vendor && self.product == other.product
    }

    /// How the device a backup was saved from (`self`) differs from `device`, the one
    /// it is to be compared with or restored onto: another kind of device (a restore
    /// needs forcing), or another unit of the same kind (a replacement: fine, but said).
    pub fn mismatch(&self, device: &DeviceIdentity) -> Option<Mismatch> {
        let serial = |s: Option<u32>| s.map_or("?".into(), |s| format!("{s:08X}h"));
        if !self.same_product(device) {
            Some(Mismatch::OtherProduct(format!(
                "the file was saved from another kind of device ({}); this is {}",
                self.summary(),
                device.summary()
            )))
        } else if self.serial != device.serial {
            Some(Mismatch::OtherUnit(format!(
                "the file was saved from another unit (serial {}); this one is serial {}",
                serial(self.serial),
                serial(device.serial)
            )))
        } else {
            None
        }
    }
}

/// How a backup's device differs from the one at hand ([`DeviceIdentity::mismatch`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Mismatch {
    /// Another vendor or product (or the file does not say): its settings may mean
    /// something else here; a restore must be forced.
    OtherProduct(String),
    /// The same kind of device, another serial number.
    OtherUnit(String),
}

impl Mismatch {
    pub fn text(&self) -> &str {
        match self {
            Mismatch::OtherProduct(t) | Mismatch::OtherUnit(t) => t,
        }
    }
}

/// One saved object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SavedObject {
    /// `6081:00`
    pub address: String,
    pub name: String,
    #[serde(rename = "type")]
    pub dtype: DataType,
    pub value: Value,
    /// The value as the browser shows it, for a person reading the file.
    pub shown: String,
}

impl SavedObject {
    pub fn address(&self) -> Result<Address, BackupError> {
        Address::from_str(&self.address).map_err(|e| BackupError::Object {
            address: self.address.clone(),
            reason: e.to_string(),
        })
    }
}

/// A whole backup file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Backup {
    pub format: String,
    pub version: u32,
    /// Seconds since the Unix epoch.
    pub saved_at: u64,
    /// The connection string it was read over.
    pub link: String,
    pub identity: DeviceIdentity,
    pub objects: Vec<SavedObject>,
    /// Objects that could not be read when the backup was made, with the reason.
    #[serde(default)]
    pub unreadable: Vec<(String, String)>,
}

fn address_text(address: Address) -> String {
    format!("{:04X}:{:02X}", address.index, address.sub)
}

impl Backup {
    /// A backup from the values read (identity and objects alike), named by `catalog`.
    pub fn new<E: std::fmt::Display>(
        link: &str,
        catalog: &Catalog,
        reads: &BTreeMap<Address, Result<Value, E>>,
        saved_at: u64,
    ) -> Backup {
        let mut objects = vec![];
        let mut unreadable = vec![];
        for entry in catalog.entries().filter(|e| savable(e)) {
            match reads.get(&entry.address) {
                Some(Ok(value)) => objects.push(SavedObject {
                    address: address_text(entry.address),
                    name: entry.full_name(),
                    dtype: entry.dtype,
                    value: value.clone(),
                    shown: shown(value, entry),
                }),
                Some(Err(reason)) => {
                    unreadable.push((address_text(entry.address), reason.to_string()));
                }
                None => {}
            }
        }
        Backup {
            format: FORMAT.to_owned(),
            version: VERSION,
            saved_at,
            link: link.to_owned(),
            identity: DeviceIdentity::from_reads(reads),
            objects,
            unreadable,
        }
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The backup file at `path`, read and checked: a regular file (a FIFO, a device or a
    /// directory is refused at once, never waited on) of at most [`MAX_FILE_BYTES`], then
    /// as [`Backup::from_json`]. Only a [`BackupError::File`] names the file.
    pub fn load(path: &std::path::Path) -> Result<Backup, BackupError> {
        let bytes = crate::file::read_given(path, MAX_FILE_BYTES, "a backup file (od dump)")?;
        let text = String::from_utf8(bytes)
            .map_err(|e| BackupError::NotText(e.utf8_error().valid_up_to()))?;
        Backup::from_json(&text)
    }

    /// A backup file's text, checked: format, version, and every address and value.
    pub fn from_json(text: &str) -> Result<Backup, BackupError> {
        let backup: Backup = serde_json::from_str(text)?;
        if backup.format != FORMAT {
            return Err(BackupError::Format(backup.format));
        }
        if backup.version > VERSION {
            return Err(BackupError::Version(backup.version));
        }
        if backup.objects.is_empty() {
            return Err(BackupError::Empty);
        }
        let mut seen: BTreeMap<Address, &str> = BTreeMap::new();
        for object in &backup.objects {
            let address = object.address()?;
            if let Some(first) = seen.insert(address, &object.address) {
                return Err(BackupError::Twice {
                    address,
                    first: first.to_owned(),
                    second: object.address.clone(),
                });
            }
            object
                .value
                .to_le_bytes(object.dtype)
                .map_err(|e| BackupError::Object {
                    address: object.address.clone(),
                    reason: e.to_string(),
                })?;
        }
        Ok(backup)
    }

    /// The saved objects with their addresses.
    pub fn entries(&self) -> impl Iterator<Item = (Address, &SavedObject)> {
        self.objects
            .iter()
            .filter_map(|o| o.address().ok().map(|a| (a, o)))
    }

    /// The saved objects a restore may write, judged by `catalog` (see [`skip_reason`]).
    pub fn restorable<'a>(
        &'a self,
        catalog: &'a Catalog,
    ) -> impl Iterator<Item = (Address, &'a SavedObject)> + 'a {
        self.entries()
            .filter(|(a, o)| skip_reason(catalog, *a, o).is_none())
    }

    /// What to read from a device to compare it with this file: the identity and the
    /// objects a restore may write, each once.
    pub fn objects_to_read(&self, catalog: &Catalog) -> Vec<(Address, DataType)> {
        let mut out: Vec<(Address, DataType)> = IDENTITY.to_vec();
        for (address, saved) in self.restorable(catalog) {
            if !out.iter().any(|(a, _)| *a == address) {
                out.push((address, saved.dtype));
            }
        }
        out
    }
}

/// The value with its unit: `500 rpm`, `"name"`.
pub fn shown(value: &Value, entry: &Entry) -> String {
    match &entry.unit {
        Some(unit) if !unit.is_empty() && !matches!(value, Value::Text(_) | Value::Bytes(_)) => {
            format!("{value} {unit}")
        }
        _ => value.to_string(),
    }
}

/// How one saved object compares with the device.
#[derive(Clone, Debug, PartialEq)]
pub enum Comparison {
    Same,
    Differs(Value),
    Unreadable(String),
    /// Not compared and never restored, with the reason (see [`skip_reason`]).
    Skipped(String),
}

/// One line of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    pub address: Address,
    pub name: String,
    pub dtype: DataType,
    pub file: Value,
    pub device: Comparison,
}

/// Every saved object against the device's current values; the objects `catalog` (the
/// dictionary in use) does not let a restore write are [`Comparison::Skipped`].
pub fn compare<E: std::fmt::Display>(
    backup: &Backup,
    catalog: &Catalog,
    device: &BTreeMap<Address, Result<Value, E>>,
) -> Vec<Difference> {
    backup
        .entries()
        .map(|(address, saved)| {
            let skipped = skip_reason(catalog, address, saved);
            let device = match (skipped, device.get(&address)) {
                (Some(reason), _) => Comparison::Skipped(reason),
                (None, Some(Ok(value))) if same(value, &saved.value) => Comparison::Same,
                (None, Some(Ok(value))) => Comparison::Differs(value.clone()),
                (None, Some(Err(reason))) => Comparison::Unreadable(reason.to_string()),
                (None, None) => Comparison::Unreadable("not read".into()),
            };
            Difference {
                address,
                name: saved.name.clone(),
                dtype: saved.dtype,
                file: saved.value.clone(),
                device,
            }
        })
        .collect()
}

/// Equal as values (an integer read back as the other signedness is still equal).
fn same(a: &Value, b: &Value) -> bool {
    match (a.as_i128(), b.as_i128()) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

/// Why a restore step is there.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Why {
    /// The file's value, where the device differs.
    Restore,
    /// A step of the mapping procedure (invalidate, count 0, count, validate).
    Procedure(&'static str),
}

/// One write of a restore.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub address: Address,
    pub name: String,
    pub dtype: DataType,
    pub value: Value,
    /// What the device holds now (None for procedure steps the device has no value for).
    pub before: Option<Value>,
    pub why: Why,
    /// Set for settings that may cut the link (node id, bit rate, IP, Modbus).
    pub warning: Option<String>,
}

/// Mapping objects (PDO mapping, Modbus and EtherNet/IP process images): sub 0 is the
/// count, set to 0 before the entries change.
fn is_mapping(index: u16) -> bool {
    matches!(index, 0x1600..=0x17FF | 0x1A00..=0x1BFF | 0x3501 | 0x3502 | 0x3601 | 0x3602)
}

/// The PDO communication object of a PDO mapping object.
fn pdo_comm(index: u16) -> Option<u16> {
    match index {
        0x1600..=0x17FF => Some(index - 0x200),
        0x1A00..=0x1BFF => Some(index - 0x200),
        _ => None,
    }
}

/// The restore phase of an object: lower goes first.
fn phase(index: u16) -> u8 {
    if LINK_SETTINGS.contains(&index) {
        4
    } else if is_mapping(index) {
        2
    } else if index < 0x2000 {
        3
    } else if index < 0x6000 {
        0
    } else {
        1
    }
}

/// The writes that make the device match the file, in a safe order. Objects the device
/// could not read, and those `catalog` does not let a restore write, are left out (and
/// reported by [`compare`]).
pub fn restore_plan<E: std::fmt::Display>(
    backup: &Backup,
    catalog: &Catalog,
    device: &BTreeMap<Address, Result<Value, E>>,
) -> Vec<Step> {
    let differences: Vec<Difference> = compare(backup, catalog, device)
        .into_iter()
        .filter(|d| matches!(d.device, Comparison::Differs(_)))
        .collect();
    let current = |address: Address| match device.get(&address) {
        Some(Ok(v)) => Some(v.clone()),
        _ => None,
    };
    let saved = |address: Address| {
        backup
            .restorable(catalog)
            .find(|(a, _)| *a == address)
            .map(|(_, o)| o.value.clone())
    };
    let mut steps = vec![];
    // Plain objects, phase by phase.
    let mut plain: Vec<&Difference> = differences
        .iter()
        .filter(|d| !is_mapping(d.address.index))
        .collect();
    plain.sort_by_key(|d| (phase(d.address.index), d.address));
    let mut mapping_done = false;
    for difference in plain {
        if phase(difference.address.index) > 2 && !mapping_done {
            mapping_done = true;
            steps.extend(mapping_steps(&differences, &current, &saved));
        }
        steps.push(Step {
            warning: LINK_SETTINGS
                .contains(&difference.address.index)
                .then(|| "changes how the drive is reached once stored and restarted: this link may need new settings".to_owned()),
            ..Step::restore(difference, current(difference.address))
        });
    }
    if !mapping_done {
        steps.extend(mapping_steps(&differences, &current, &saved));
    }
    steps
}

/// The mapping objects that differ, each with its procedure.
fn mapping_steps(
    differences: &[Difference],
    current: &dyn Fn(Address) -> Option<Value>,
    saved: &dyn Fn(Address) -> Option<Value>,
) -> Vec<Step> {
    let mut indices: Vec<u16> = differences
        .iter()
        .map(|d| d.address.index)
        .filter(|i| is_mapping(*i))
        .collect();
    indices.sort_unstable();
    indices.dedup();
    indices
        .into_iter()
        .flat_map(|index| remap(index, differences, current, saved))
        .collect()
}

/// One mapping object's procedure: the PDO invalid (if it is one), the count 0, the
/// entries, the count, and the PDO valid again with the file's COB-ID.
fn remap(
    index: u16,
    differences: &[Difference],
    current: &dyn Fn(Address) -> Option<Value>,
    saved: &dyn Fn(Address) -> Option<Value>,
) -> Vec<Step> {
    let mut steps = vec![];
    let count = Address::new(index, 0);
    let entries: Vec<&Difference> = differences
        .iter()
        .filter(|d| d.address.index == index && d.address.sub > 0)
        .collect();
    let cob = pdo_comm(index).map(|comm| Address::new(comm, 1));
    // PDO: invalid while its mapping changes.
    let cob_now = cob.and_then(current);
    if let (Some(cob), Some(Value::Uint(id))) = (cob, &cob_now)
        && id & 0x8000_0000 == 0
    {
        let invalid = Value::Uint(id | 0x8000_0000);
        let why = Why::Procedure("invalidate the PDO while its mapping changes");
        steps.push(cob_id_step(index, cob, invalid, cob_now.clone(), why));
    }
    let count_file = saved(count).or_else(|| current(count));
    if !entries.is_empty() {
        let why = Why::Procedure("count 0 before the entries change");
        steps.push(count_step(index, Value::Uint(0), current(count), why));
        steps.extend(entries.iter().map(|e| Step::restore(e, current(e.address))));
    }
    if let Some(count_value) = count_file {
        let why = if saved(count).is_some() {
            Why::Restore
        } else {
            Why::Procedure("the count back")
        };
        steps.push(count_step(index, count_value, current(count), why));
    }
    // The PDO valid again, with the file's COB-ID where it has one.
    if let Some(cob) = cob {
        let target = saved(cob).or_else(|| cob_now.clone());
        if let Some(target) = target
            && (Some(&target) != cob_now.as_ref()
                || matches!(&cob_now, Some(Value::Uint(id)) if id & 0x8000_0000 == 0))
        {
            let why = Why::Procedure("the PDO's COB-ID as in the file");
            steps.push(cob_id_step(index, cob, target, cob_now.clone(), why));
        }
    }
    steps
}

/// A write of the COB-ID (`cob`) of the PDO that mapping object `index` maps.
fn cob_id_step(index: u16, cob: Address, value: Value, before: Option<Value>, why: Why) -> Step {
    Step {
        address: cob,
        name: format!("COB-ID of the PDO mapped by {index:04X}h"),
        dtype: DataType::Unsigned32,
        value,
        before,
        why,
        warning: None,
    }
}

/// A write of the number of objects mapping object `index` maps (its sub 0).
fn count_step(index: u16, value: Value, before: Option<Value>, why: Why) -> Step {
    Step {
        address: Address::new(index, 0),
        name: format!("{index:04X}h number of mapped objects"),
        dtype: DataType::Unsigned8,
        value,
        before,
        why,
        warning: None,
    }
}

impl Step {
    /// The file's value of a difference, where the device holds `before`.
    fn restore(difference: &Difference, before: Option<Value>) -> Step {
        Step {
            address: difference.address,
            name: difference.name.clone(),
            dtype: difference.dtype,
            value: difference.file.clone(),
            before,
            why: Why::Restore,
            warning: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device_of(catalog: &Catalog) -> BTreeMap<Address, Result<Value, String>> {
        let drive = crate::sim::Drive::new();
        objects_to_read(catalog)
            .into_iter()
            .map(|(a, _)| (a, drive.read(a).map_err(|e| e.to_string())))
            .collect()
    }

    #[test]
    fn a_backup_holds_configuration_not_commands() {
        let catalog = crate::od::builtin();
        let reads = device_of(catalog);
        let backup = Backup::new("sim", catalog, &reads, 1_700_000_000);
        let saved: Vec<Address> = backup.entries().map(|(a, _)| a).collect();
        assert!(saved.contains(&Address::new(0x6081, 0)), "profile velocity");
        assert!(
            saved.contains(&Address::new(0x2031, 0)),
            "max motor current"
        );
        for index in [0x2291, 0x6040, 0x607A, 0x60FF, 0x1010, 0x6041, 0x1018] {
            assert!(!saved.iter().any(|a| a.index == index), "{index:04X}h");
        }
        assert_eq!(backup.identity.vendor, Some(0x26C));
        assert!(backup.identity.name.is_some());
        let text = backup.to_json();
        assert_eq!(Backup::from_json(&text).unwrap(), backup);
        assert!(text.contains("\"address\": \"6081:00\""), "{text}");
    }

    #[test]
    fn bad_files_are_refused_by_name() {
        assert!(
            Backup::from_json("{}")
                .unwrap_err()
                .to_string()
                .starts_with("not a drivedeck backup")
        );
        let catalog = crate::od::builtin();
        let mut backup = Backup::new("sim", catalog, &device_of(catalog), 0);
        backup.format = "something else".into();
        assert!(matches!(
            Backup::from_json(&backup.to_json()),
            Err(BackupError::Format(_))
        ));
        backup.format = FORMAT.into();
        backup.version = 99;
        assert!(matches!(
            Backup::from_json(&backup.to_json()),
            Err(BackupError::Version(99))
        ));
        backup.version = 1;
        backup.objects[0].address = "zz:00".into();
        assert!(
            Backup::from_json(&backup.to_json())
                .unwrap_err()
                .to_string()
                .contains("object 'zz:00'")
        );
    }

    #[test]
    fn a_restore_writes_only_what_differs_in_a_safe_order() {
        let catalog = crate::od::builtin();
        let reads = device_of(catalog);
        let backup = Backup::new("sim", catalog, &reads, 0);
        assert!(
            restore_plan(&backup, catalog, &reads).is_empty(),
            "nothing differs"
        );
        // The device now differs in a profile object, a drive object, a link setting and
        // a PDO mapping entry.
        let mut device = reads.clone();
        device.insert(Address::new(0x6081, 0), Ok(Value::Uint(1)));
        device.insert(Address::new(0x2031, 0), Ok(Value::Uint(7)));
        device.insert(Address::new(0x2009, 0), Ok(Value::Uint(9)));
        device.insert(Address::new(0x1600, 1), Ok(Value::Uint(0x6040_0010)));
        let plan = restore_plan(&backup, catalog, &device);
        let order: Vec<Address> = plan.iter().map(|s| s.address).collect();
        let at = |a: Address| order.iter().position(|x| *x == a).expect("in the plan");
        assert!(at(Address::new(0x2031, 0)) < at(Address::new(0x6081, 0)));
        assert!(at(Address::new(0x6081, 0)) < at(Address::new(0x1600, 1)));
        assert_eq!(*order.last().unwrap(), Address::new(0x2009, 0), "link last");
        assert!(plan.last().unwrap().warning.is_some());
        // The mapping procedure around 1600h:01.
        let mapping: Vec<(Address, Value)> = plan
            .iter()
            .filter(|s| matches!(s.address.index, 0x1400 | 0x1600))
            .map(|s| (s.address, s.value.clone()))
            .collect();
        let cob = match reads.get(&Address::new(0x1400, 1)) {
            Some(Ok(Value::Uint(v))) => *v,
            other => panic!("{other:?}"),
        };
        let count = reads
            .get(&Address::new(0x1600, 0))
            .cloned()
            .expect("read")
            .expect("count");
        let mut expected = vec![];
        if cob & 0x8000_0000 == 0 {
            expected.push((Address::new(0x1400, 1), Value::Uint(cob | 0x8000_0000)));
        }
        expected.push((Address::new(0x1600, 0), Value::Uint(0)));
        expected.push((
            Address::new(0x1600, 1),
            backup
                .entries()
                .find(|(a, _)| *a == Address::new(0x1600, 1))
                .unwrap()
                .1
                .value
                .clone(),
        ));
        expected.push((Address::new(0x1600, 0), count));
        if cob & 0x8000_0000 == 0 {
            expected.push((Address::new(0x1400, 1), Value::Uint(cob)));
        }
        assert_eq!(mapping, expected);
    }

    #[test]
    fn compare_says_same_differs_or_unreadable() {
        let catalog = crate::od::builtin();
        let reads = device_of(catalog);
        let backup = Backup::new("sim", catalog, &reads, 0);
        let mut device = reads.clone();
        device.insert(Address::new(0x6083, 0), Ok(Value::Uint(42)));
        device.insert(Address::new(0x6084, 0), Err("abort 06020000h".into()));
        let report = compare(&backup, catalog, &device);
        let of = |a: Address| {
            report
                .iter()
                .find(|d| d.address == a)
                .unwrap()
                .device
                .clone()
        };
        assert_eq!(
            of(Address::new(0x6083, 0)),
            Comparison::Differs(Value::Uint(42))
        );
        assert_eq!(
            of(Address::new(0x6084, 0)),
            Comparison::Unreadable("abort 06020000h".into())
        );
        assert_eq!(of(Address::new(0x6081, 0)), Comparison::Same);
    }

    fn object(address: &str, dtype: DataType, value: Value) -> SavedObject {
        SavedObject {
            address: address.into(),
            name: String::new(),
            dtype,
            value,
            shown: String::new(),
        }
    }

    #[test]
    fn commands_process_data_read_only_and_unknown_objects_are_never_restored() {
        let catalog = crate::od::builtin();
        let reads = device_of(catalog);
        let mut backup = Backup::new("sim", catalog, &reads, 0);
        // Saved objects are all configuration: a dump never holds a skipped one.
        assert!(
            backup
                .entries()
                .all(|(a, o)| skip_reason(catalog, a, o).is_none())
        );
        let u32 = DataType::Unsigned32;
        let crafted = [
            (
                object("6040:00", DataType::Unsigned16, Value::Uint(0xF)),
                "command",
            ),
            (
                object("2291:04", DataType::Integer8, Value::Int(21)),
                "command",
            ),
            (object("1011:01", u32, Value::Uint(0x6461_6F6C)), "command"),
            (object("1010:01", u32, Value::Uint(0x6576_6173)), "command"),
            (object("2300:00", u32, Value::Uint(1)), "command"),
            (
                object("60FF:00", DataType::Integer32, Value::Int(500)),
                "process data",
            ),
            (
                object("6041:00", DataType::Unsigned16, Value::Uint(0x237)),
                "read-only",
            ),
            (object("1018:01", u32, Value::Uint(1)), "read-only"),
            (
                object("2FF0:00", u32, Value::Uint(1)),
                "not in the dictionary",
            ),
        ];
        backup
            .objects
            .extend(crafted.iter().map(|(o, _)| o.clone()));
        // Make every crafted object "differ" from the device.
        let mut device = reads.clone();
        for (o, _) in &crafted {
            device.insert(o.address().unwrap(), Ok(Value::Uint(0xDEAD)));
        }
        let report = compare(&backup, catalog, &device);
        for (o, word) in &crafted {
            let address = o.address().unwrap();
            let row = report.iter().find(|d| d.address == address).unwrap();
            match &row.device {
                Comparison::Skipped(reason) => assert!(reason.contains(word), "{reason}"),
                other => panic!("{address}: {other:?}"),
            }
        }
        assert!(restore_plan(&backup, catalog, &device).is_empty());
        // Nor are they read (1018h:01 only once, for the identity).
        let read = backup.objects_to_read(catalog);
        for (o, _) in &crafted[..7] {
            assert!(
                !read.iter().any(|(a, _)| *a == o.address().unwrap()),
                "{}",
                o.address
            );
        }
        assert_eq!(
            read.iter()
                .filter(|(a, _)| *a == Address::new(0x1018, 1))
                .count(),
            1
        );
    }

    #[test]
    fn a_setting_saved_with_another_type_is_skipped() {
        let catalog = crate::od::builtin();
        let reads = device_of(catalog);
        let mut backup = Backup::new("sim", catalog, &reads, 0);
        let at = backup
            .objects
            .iter()
            .position(|o| o.address == "6083:00")
            .unwrap();
        backup.objects[at] = object("6083:00", DataType::Unsigned8, Value::Uint(9));
        let report = compare(&backup, catalog, &reads);
        let row = report
            .iter()
            .find(|d| d.address == Address::new(0x6083, 0))
            .unwrap();
        assert!(
            matches!(&row.device, Comparison::Skipped(r) if r.contains("U8") && r.contains("U32")),
            "{row:?}"
        );
    }

    #[test]
    fn a_file_naming_an_object_twice_or_none_is_refused() {
        let catalog = crate::od::builtin();
        let mut backup = Backup::new("sim", catalog, &device_of(catalog), 0);
        let mut again = object("6081h:0", DataType::Unsigned32, Value::Uint(1));
        again.name = "Profile Velocity".into();
        backup.objects.push(again);
        let err = Backup::from_json(&backup.to_json()).unwrap_err();
        assert!(matches!(err, BackupError::Twice { .. }), "{err}");
        let text = err.to_string();
        assert!(
            text.contains("6081h:00h") && text.contains("'6081:00'") && text.contains("'6081h:0'"),
            "{text}"
        );
        backup.objects.clear();
        let err = Backup::from_json(&backup.to_json()).unwrap_err();
        assert!(err.to_string().contains("nothing to restore"), "{err}");
    }

    #[test]
    fn files_saved_before_the_rule_still_load() {
        // Version 1 as drivedeck wrote it, without the later `unreadable` list.
        let text = r#"{"format":"drivedeck backup","version":1,"saved_at":1700000000,
            "link":"sim","identity":{"vendor":620,"product":1},
            "objects":[{"address":"6081:00","name":"Profile Velocity","type":"UNSIGNED32",
                        "value":{"kind":"uint","value":200},"shown":"200 rpm"}]}"#;
        let backup = Backup::from_json(text).unwrap();
        assert_eq!(backup.restorable(crate::od::builtin()).count(), 1);
    }
}
