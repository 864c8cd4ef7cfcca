//! Merging an EDS with the built-in catalog ([`Eds::merged_with`]; the rules are in the
//! module documentation of [`super`]).

use std::fmt;

use serde::Serialize;

use super::{Eds, NANOTEC_VENDOR_ID, is_manufacturer};
use crate::od::{Address, Catalog, Entry};

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
                complete(&mut entry, k, &mut merged.notes);
            }
            merged.catalog.insert(entry);
        }
        merged
    }
}

/// An EDS entry with what the catalog's entry `k` for the same object adds; a note where
/// the two disagree.
fn complete(entry: &mut Entry, k: &Entry, notes: &mut Vec<MergeNote>) {
    if entry.description.trim().is_empty() {
        entry.description = k.description.clone();
    }
    if entry.unit.is_none() {
        entry.unit = k.unit.clone();
    }
    // What the catalog knows to act stays unwritten, whatever the EDS says.
    entry.role = entry.role.stricter(k.role);
    let mut note = |eds: &dyn fmt::Display, catalog: &dyn fmt::Display| {
        notes.push(MergeNote {
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

#[cfg(test)]
mod tests {
    use crate::od::eds::testing::parse;
    use crate::od::{Address, Catalog, Role};

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
