//! The sections about the file and the device (`[FileInfo]`, `[DeviceInfo]`, a DCF's
//! `[DeviceComissioning]`, `[Comments]`, `[DummyUsage]`) and the object lists
//! (`[MandatoryObjects]` …), checked against the object sections.

use std::collections::{BTreeMap, BTreeSet};

use super::Importer;
use crate::od::eds::ini::{KeyValue, Section, clip};
use crate::od::eds::values::parse_int;
use crate::od::eds::{BAUD_RATES, DeviceInfo, FileInfo};

/// Messages that list objects name this many, then "and N more".
const LISTED: usize = 8;

impl Importer<'_> {
    pub(super) fn read_file_info(&mut self) {
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

    pub(super) fn read_device_info(&mut self) {
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
    pub(super) fn read_commissioning(&mut self) {
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

    pub(super) fn read_comments(&mut self) {
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

    pub(super) fn read_dummy_usage(&mut self) {
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
    pub(super) fn read_list(&mut self, s: &Section, count_key: &str) -> Vec<(u16, usize)> {
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
    pub(super) fn check_lists(&mut self, objects: &BTreeMap<u16, &Section>) {
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
}

/// Indices for a message: the first few, then how many more.
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
