//! EDS import and export (CiA 306) against files drivedeck did not write (python-canopen's
//! test files and a real drive's EDS, tests/data/eds/), the shipped EDS of the simulated
//! drive, and the agreement of the built-in catalog with the simulated drive.
//!
//! `DRIVEDECK_WRITE_EDS=1 cargo test --test eds` rewrites assets/od/drivedeck-sim.eds from
//! the catalog.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use drivedeck::od::eds::{Eds, EdsAccess, NodeFormula, ObjectKind};
use drivedeck::od::{self, Access, Address, Catalog, DataType, Group, Value};
use drivedeck::sim;
use proptest::prelude::*;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/eds")
        .join(name)
}

fn local_node() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/canopen_local_node.eds")
}

fn load(path: &Path, node: Option<u8>) -> Eds {
    Eds::load(path, node).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn entry(eds: &Eds, index: u16, sub: u8) -> &od::Entry {
    eds.catalog
        .get(Address::new(index, sub))
        .unwrap_or_else(|| panic!("{index:04X}h:{sub:02X}h is missing"))
}

fn warnings_containing(eds: &Eds, text: &str) -> Vec<usize> {
    eds.warnings
        .iter()
        .filter(|w| w.message.contains(text))
        .map(|w| w.line)
        .collect()
}

#[test]
fn every_file_parses_with_stable_warnings() {
    // (file, entries, objects, warnings)
    let files = [
        (data("sample.eds"), 124, 39, 7),
        (data("e35.eds"), 995, 211, 3),
        (data("datatypes.eds"), 28, 24, 9),
        (local_node(), 14, 10, 0),
    ];
    for (path, entries, objects, warnings) in files {
        for node in [None, Some(5)] {
            let eds = load(&path, node);
            let name = path.display();
            assert_eq!(eds.catalog.len(), entries, "{name}");
            assert_eq!(eds.objects.len(), objects, "{name}");
            assert_eq!(eds.warnings.len(), warnings, "{name}: {:#?}", eds.warnings);
            assert!(eds.warnings.windows(2).all(|w| w[0].line <= w[1].line));
        }
    }
}

#[test]
fn sample_eds_arrays_records_formulas_and_limits() {
    let eds = load(&data("sample.eds"), Some(5));
    assert_eq!(eds.node_id, Some(5));
    assert_eq!(eds.device_info.vendor_name.as_deref(), Some("Vendor Name"));
    assert_eq!(eds.device_info.vendor_number, Some(1));
    assert_eq!(eds.device_info.baud_rates, vec![125, 250, 500, 1000]);
    assert_eq!(
        eds.file_info.created_by.as_deref(),
        Some("Christian Sandberg")
    );
    assert_eq!(eds.comments[1], "| Don't panic |");
    assert_eq!(eds.dummy_usage.iter().copied().collect::<Vec<_>>(), vec![3]);

    // A VAR.
    let heartbeat = entry(&eds, 0x1017, 0);
    assert_eq!(heartbeat.name, "Producer heartbeat time");
    assert_eq!(
        (heartbeat.dtype, heartbeat.access),
        (DataType::Unsigned16, Access::Rw)
    );
    assert_eq!(heartbeat.default, Some(Value::Uint(0)));
    assert_eq!(heartbeat.group, Group::Communication);
    assert!(eds.entries[&Address::new(0x1001, 0)].pdo_mapping);
    // A RECORD with a sub-index left out: what is there, and a warning.
    assert_eq!(eds.objects[&0x1018].kind, ObjectKind::Record);
    let vendor = entry(&eds, 0x1018, 1);
    assert_eq!(vendor.full_name(), "Identity object / Vendor-ID");
    assert_eq!(
        (vendor.dtype, vendor.access),
        (DataType::Unsigned32, Access::Ro)
    );
    assert!(eds.catalog.get(Address::new(0x1018, 3)).is_none());
    assert_eq!(warnings_containing(&eds, "SubNumber=5, but 4"), vec![77]);
    assert_eq!(entry(&eds, 0x1018, 0).access, Access::Const);
    assert_eq!(
        eds.entries[&Address::new(0x1018, 0)].access,
        EdsAccess::Const
    );
    // An ARRAY with gaps.
    assert_eq!(eds.objects[&0x1003].kind, ObjectKind::Array);
    assert_eq!(entry(&eds, 0x1003, 5).name, "Pre-defined error field_5");
    assert!(eds.catalog.get(Address::new(0x1003, 2)).is_none());
    // $NODEID formulas, both ways round, resolved for node 5; the formula is kept.
    assert_eq!(entry(&eds, 0x1400, 1).default, Some(Value::Uint(512 + 5)));
    assert_eq!(
        eds.entries[&Address::new(0x1400, 1)].default_formula,
        Some(NodeFormula { offset: 512 })
    );
    assert_eq!(entry(&eds, 0x1403, 1).default, Some(Value::Uint(1280 + 5)));
    assert_eq!(entry(&eds, 0x1803, 1).default, Some(Value::Uint(1152 + 5)));
    // Lower-case hex in the section name.
    assert_eq!(
        entry(&eds, 0x1A00, 1).default,
        Some(Value::Uint(1_614_872_592))
    );
    // A string.
    let name = entry(&eds, 0x1008, 0);
    assert_eq!(name.dtype, DataType::VisibleString);
    assert_eq!(name.default, Some(Value::Text("TEST DEVICE".into())));
    // CompactSubObj arrays: sub-index 0 plus N entries, named from [3004Name] or numbered.
    let status: Vec<&od::Entry> = eds.catalog.filter("3004:").collect();
    assert_eq!(status.len(), 4);
    assert_eq!(status[0].dtype, DataType::Unsigned8);
    assert_eq!(status[0].default, Some(Value::Uint(3)));
    assert_eq!(status[3].name, "Sensor Status 3");
    assert_eq!(status[3].dtype, DataType::Unsigned16);
    assert_eq!(status[3].default, Some(Value::Uint(3)));
    assert_eq!(eds.catalog.filter("3006:").count(), 25);
    let valve = entry(&eds, 0x3006, 24);
    assert_eq!(valve.name, "Valve 1 % Open24");
    assert_eq!(
        (valve.dtype, valve.access, &valve.default),
        (DataType::Real32, Access::Rw, &None)
    );
    // "Sub" with a capital S.
    assert_eq!(entry(&eds, 0x3010, 0).name, "Temperature");
    // Limits: decimal, hex, hex two's complement of signed types.
    let limits = |index: u16| {
        let e = entry(&eds, index, 0);
        (e.min.clone(), e.max.clone())
    };
    assert_eq!(limits(0x3020), (Some(Value::Int(0)), Some(Value::Int(127))));
    assert_eq!(
        limits(0x3021),
        (Some(Value::Uint(2)), Some(Value::Uint(10)))
    );
    assert_eq!(
        limits(0x3030),
        (Some(Value::Int(i64::from(i32::MIN))), Some(Value::Int(-1)))
    );
    assert_eq!(
        limits(0x3040),
        (Some(Value::Int(-10)), Some(Value::Int(10)))
    );
    let rate = entry(&eds, 0x3002, 0);
    assert_eq!(
        (rate.default.clone(), rate.min.clone()),
        (Some(Value::Real(5.2)), Some(Value::Real(4.5)))
    );
    // python-canopen's Unit= and Description= keys.
    let extension = entry(&eds, 0x3050, 1);
    assert_eq!(extension.unit.as_deref(), Some("mV"));
    assert_eq!(extension.description, "This is the a test description");
    assert_eq!(entry(&eds, 0x3050, 2).unit, None);
    // A complex type (0040h) is kept as raw bytes; an ARRAY without entries is not.
    let complex = entry(&eds, 0x2020, 0);
    assert_eq!((complex.dtype, &complex.default), (DataType::Domain, &None));
    assert_eq!(eds.entries[&Address::new(0x2020, 0)].type_code, 0x40);
    assert_eq!(warnings_containing(&eds, "data type 0040h"), vec![891]);
    assert!(!eds.catalog.has_index(0x3003));
    assert_eq!(
        warnings_containing(&eds, "3003h Valve % open is an ARRAY"),
        vec![907]
    );
    assert_eq!(
        warnings_containing(&eds, "SupportedObjects=0, but 1"),
        vec![835]
    );
}

#[test]
fn formulas_without_a_node_id() {
    // sample.eds is a DCF of node 10h: its [DeviceComissioning] NodeID resolves them.
    let eds = load(&data("sample.eds"), None);
    assert_eq!(eds.node_id, Some(0x10));
    assert_eq!(
        entry(&eds, 0x1400, 1).default,
        Some(Value::Uint(512 + 0x10))
    );
    // A plain EDS: the value stays empty, the formula is kept.
    let eds = load(&local_node(), None);
    assert_eq!(eds.node_id, None);
    assert_eq!(entry(&eds, 0x1014, 0).default, None);
    assert_eq!(
        eds.entries[&Address::new(0x1014, 0)]
            .default_formula
            .map(|f| f.to_string()),
        Some("$NODEID+0x80".into())
    );
    let eds = load(&local_node(), Some(5));
    assert_eq!(entry(&eds, 0x1014, 0).default, Some(Value::Uint(0x85)));
}

#[test]
fn e35_a_real_drives_eds() {
    let eds = load(&data("e35.eds"), Some(5));
    let device = &eds.device_info;
    assert_eq!(device.vendor_number, Some(101));
    assert_eq!(device.product_name.as_deref(), Some("example"));
    assert_eq!(
        (device.product_number, device.revision_number),
        (Some(25), Some(295))
    );
    assert!(device.lss_supported);
    assert_eq!(eds.file_info.eds_version.as_deref(), Some("402"));
    assert_eq!(entry(&eds, 0x1000, 0).default, Some(Value::Uint(0x20192)));
    // COB-IDs with flags around $NODEID.
    assert_eq!(entry(&eds, 0x1014, 0).default, Some(Value::Uint(0x85)));
    assert_eq!(
        entry(&eds, 0x1800, 1).default,
        Some(Value::Uint(0x4000_0185))
    );
    // rww is rw in the catalog, rww in the EDS.
    let mode = entry(&eds, 0x6060, 0);
    assert_eq!((mode.dtype, mode.access), (DataType::Integer8, Access::Rw));
    assert_eq!(eds.entries[&Address::new(0x6060, 0)].access, EdsAccess::Rww);
    assert_eq!(
        (mode.min.clone(), mode.max.clone()),
        (Some(Value::Int(-2)), Some(Value::Int(10)))
    );
    assert_eq!(mode.group, Group::Profile);
    let offset = entry(&eds, 0x60B2, 0);
    assert_eq!(offset.min, Some(Value::Int(-32767)));
    // Write-only entries of an ARRAY without DataType of its own.
    assert_eq!(eds.objects[&0x200F].kind, ObjectKind::Array);
    assert_eq!(entry(&eds, 0x200F, 1).access, Access::Wo);
    // UNSIGNED64, with and without a default; strings.
    let drive_name = entry(&eds, 0x2FFE, 0);
    assert_eq!(drive_name.dtype, DataType::Unsigned64);
    assert_eq!(drive_name.default, Some(Value::Uint(0x6576_6972_4420_794D)));
    assert_eq!(entry(&eds, 0x2C05, 3).default, None);
    assert_eq!(
        entry(&eds, 0x1009, 0).default,
        Some(Value::Text("See PCB".into()))
    );
    assert_eq!(entry(&eds, 0x2290, 0).group, Group::Manufacturer);
    assert_eq!(warnings_containing(&eds, "names 6505h with no"), vec![6670]);
    // The statusword's bits are the profile's: named as in the built-in catalog.
    let statusword = entry(&eds, 0x6041, 0);
    assert_eq!(
        statusword.bits.get(2),
        Some(&(2, "operation enabled".into()))
    );
}

#[test]
fn datatypes_eds_every_type() {
    let eds = load(&data("datatypes.eds"), None);
    let expect = [
        (0x2001, DataType::Boolean, Value::Bool(false)),
        (0x2002, DataType::Integer8, Value::Int(12)),
        (0x2003, DataType::Integer16, Value::Int(34)),
        (0x2004, DataType::Integer32, Value::Int(45)),
        (0x2005, DataType::Unsigned8, Value::Uint(56)),
        (0x2006, DataType::Unsigned16, Value::Uint(8198)),
        (0x2007, DataType::Unsigned32, Value::Uint(537_337_864)),
        (0x2008, DataType::Real32, Value::Real(1.2)),
        (0x2009, DataType::VisibleString, Value::Text("ABCD".into())),
        (
            0x200A,
            DataType::OctetString,
            Value::Bytes(vec![0xAB, 0xCD]),
        ),
        (0x200B, DataType::UnicodeString, Value::Text("abc✓".into())),
        (0x2011, DataType::Real64, Value::Real(1.6)),
        (0x2015, DataType::Integer64, Value::Int(-64)),
        (0x201B, DataType::Unsigned64, Value::Uint(64)),
        // The widths drivedeck has no type for: DOMAIN, the default as its bytes.
        (0x2010, DataType::Domain, Value::Bytes(vec![0xFF; 3])),
        (
            0x2012,
            DataType::Domain,
            Value::Bytes((-40i64).to_le_bytes()[..5].to_vec()),
        ),
        (
            0x2013,
            DataType::Domain,
            Value::Bytes((-48i64).to_le_bytes()[..6].to_vec()),
        ),
        (
            0x2014,
            DataType::Domain,
            Value::Bytes((-56i64).to_le_bytes()[..7].to_vec()),
        ),
        (0x2016, DataType::Domain, Value::Bytes(vec![24, 0, 0])),
        (0x2018, DataType::Domain, Value::Bytes(vec![40, 0, 0, 0, 0])),
        (
            0x2019,
            DataType::Domain,
            Value::Bytes(vec![48, 0, 0, 0, 0, 0]),
        ),
        (
            0x201A,
            DataType::Domain,
            Value::Bytes(vec![56, 0, 0, 0, 0, 0, 0]),
        ),
    ];
    for (index, dtype, default) in expect {
        let e = entry(&eds, index, 0);
        assert_eq!(
            (e.dtype, e.default.clone()),
            (dtype, Some(default)),
            "{index:04X}h"
        );
        assert_eq!(e.access, Access::Rw);
        assert!(eds.entries[&e.address].pdo_mapping);
    }
    assert_eq!(eds.entries[&Address::new(0x2016, 0)].type_code, 0x16);
    // A DOMAIN default that is not hex bytes is dropped, with a warning.
    let domain = entry(&eds, 0x200F, 0);
    assert_eq!((domain.dtype, &domain.default), (DataType::Domain, &None));
    assert_eq!(
        warnings_containing(&eds, "'@ABCD' is not hex bytes"),
        vec![221]
    );
    assert_eq!(warnings_containing(&eds, "kept as DOMAIN").len(), 8);
}

#[test]
fn the_peer_tests_local_node() {
    let eds = load(&local_node(), Some(5));
    assert!(eds.warnings.is_empty(), "{:?}", eds.warnings);
    assert_eq!(eds.device_info.vendor_number, Some(0x1234_5678));
    assert_eq!(entry(&eds, 0x2001, 0).default, Some(Value::Int(-1234)));
    assert_eq!(
        entry(&eds, 0x2002, 0).default,
        Some(Value::Uint(0xCAFE_F00D))
    );
    assert_eq!(
        entry(&eds, 0x2003, 0).default,
        Some(Value::Text("factory".into()))
    );
    assert_eq!(entry(&eds, 0x1008, 0).access, Access::Const);
}

/// Export and import again: the same catalog and EDS details, warnings only for what the
/// file itself lacks (types kept as DOMAIN).
#[test]
fn real_files_round_trip_through_the_export() {
    for path in [
        data("sample.eds"),
        data("e35.eds"),
        data("datatypes.eds"),
        local_node(),
    ] {
        for node in [None, Some(5)] {
            let eds = load(&path, node);
            let text = eds.to_text();
            let back = Eds::parse(&text, eds.node_id).unwrap();
            let name = path.display();
            assert_eq!(back.catalog, eds.catalog, "{name}");
            assert_eq!(back.entries, eds.entries, "{name}");
            assert_eq!(back.objects, eds.objects, "{name}");
            assert_eq!(back.device_info, eds.device_info, "{name}");
            assert_eq!(back.file_info, eds.file_info, "{name}");
            assert_eq!(back.comments, eds.comments, "{name}");
            assert_eq!(back.dummy_usage, eds.dummy_usage, "{name}");
            assert!(
                back.warnings
                    .iter()
                    .all(|w| w.message.contains("as DOMAIN")),
                "{name}: {:#?}",
                back.warnings
            );
            assert_eq!(back.to_text(), text, "{name}");
        }
    }
}

fn shipped_sim_eds() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(sim::eds::EDS_PATH)
}

#[test]
fn the_shipped_sim_eds_is_generated_from_the_catalog() {
    let path = shipped_sim_eds();
    let generated = sim::eds::eds_text();
    if std::env::var_os("DRIVEDECK_WRITE_EDS").is_some() {
        std::fs::write(&path, &generated).expect("assets/od is writable");
        return;
    }
    let shipped = std::fs::read_to_string(&path).unwrap_or_default();
    if shipped != generated {
        let first = shipped
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .map_or(
                shipped.lines().count().min(generated.lines().count()),
                |n| n,
            )
            + 1;
        panic!(
            "{} differs from the catalog's EDS from line {first}: regenerate it with\n    DRIVEDECK_WRITE_EDS=1 cargo test --test eds",
            path.display()
        );
    }
}

#[test]
fn the_shipped_sim_eds_gives_back_the_catalog() {
    let catalog = Catalog::builtin().unwrap();
    let eds = load(&shipped_sim_eds(), Some(sim::eds::CATALOG_NODE_ID));
    assert!(eds.warnings.is_empty(), "{:#?}", eds.warnings);
    // Addresses, types, access, defaults, limits, and names, units and descriptions too.
    assert_eq!(eds.catalog, catalog);
    assert_eq!(eds.device_info.vendor_number, Some(0x26C));
    assert_eq!(eds.objects[&0x1018].kind, ObjectKind::Record);
    assert_eq!(eds.objects[&0x2400].kind, ObjectKind::Array);
    // Merging with the catalog changes nothing.
    let merged = eds.merged_with(&catalog);
    assert_eq!(merged.catalog, catalog);
    assert!(merged.notes.is_empty(), "{:?}", merged.notes);
    // Without a node id the COB-IDs are formulas.
    let plain = load(&shipped_sim_eds(), None);
    assert_eq!(entry(&plain, 0x1014, 0).default, None);
    assert_eq!(entry(&plain, 0x1800, 1).default, None);
    assert_eq!(entry(&plain, 0x6081, 0).default, Some(Value::Uint(200)));
}

/// The EDS for node 5 says what a simulated CANopen node 5 holds.
#[test]
fn the_sim_eds_formulas_match_a_simulated_node() {
    let eds = load(&shipped_sim_eds(), Some(5));
    let mut drive = sim::Drive::new();
    let _node = sim::server::canopen::Node::new(5, &mut drive);
    for address in sim::eds::NODE_RELATIVE {
        assert!(eds.entries[&address].default_formula.is_some(), "{address}");
        assert_eq!(
            eds.catalog.get(address).and_then(|e| e.default.clone()),
            drive.read(address).ok(),
            "{address}"
        );
    }
    assert_eq!(entry(&eds, 0x1014, 0).default, Some(Value::Uint(0x85)));
    assert_eq!(
        entry(&eds, 0x1800, 1).default,
        Some(Value::Uint(0x8000_0185))
    );
}

#[test]
fn merging_fills_only_what_the_catalog_knows_of_the_same_object() {
    let e35 = load(&data("e35.eds"), Some(5));
    let merged = e35.merged_with(od::builtin());
    // The EDS decides what exists: nothing of the catalog is added.
    assert_eq!(merged.catalog.len(), e35.catalog.len());
    // A CiA 402 object: the catalog's description and unit, the EDS's type and access.
    let position = merged.catalog.get(Address::new(0x607A, 0)).unwrap();
    assert_eq!(position.unit.as_deref(), Some("0.1°"));
    assert!(!position.description.is_empty());
    assert_eq!(position.access, Access::Rw);
    // Another maker's 2290h is not Nanotec's PDI-Ctrl.
    let other = merged.catalog.get(Address::new(0x2290, 0)).unwrap();
    assert_eq!(other.name, "Drive setup status");
    assert_eq!(other.description, "");
    assert!(
        merged
            .notes
            .iter()
            .all(|n| n.address != Address::new(0x2290, 0))
    );
    // Disagreements in the CiA ranges are noted; the EDS counts.
    for note in &merged.notes {
        assert!(note.message.ends_with("the EDS counts"), "{}", note.message);
        assert!(
            !(0x2000..=0x5FFF).contains(&note.address.index),
            "{}",
            note.message
        );
    }
}

/// Every catalog entry is in a fresh simulated drive with the same type, access and
/// default, and the drive has nothing the catalog lacks.
#[test]
fn catalog_and_simulated_drive_agree() {
    let catalog = od::builtin();
    let drive = sim::Drive::new();
    // Objects the drive sets at power-on, where the catalog gives no default: identity
    // strings and live measurements. Objects with a default hold it.
    let mut differ = vec![];
    assert!(!catalog.is_empty());
    for entry in catalog.entries() {
        let address = entry.address;
        let held = drive
            .entry(address)
            .unwrap_or_else(|| panic!("{address} is not in the simulated drive"));
        assert_eq!(held.dtype, entry.dtype, "{address}");
        assert_eq!(held.access, entry.access, "{address}");
        assert_eq!(held.default, entry.default, "{address}");
        match drive.read(address) {
            Ok(value) => {
                assert!(entry.access.readable(), "{address}");
                assert!(
                    value.to_le_bytes(entry.dtype).is_ok(),
                    "{address}: {value:?}"
                );
                if let Some(default) = &entry.default
                    && &value != default
                {
                    differ.push(format!(
                        "{address} {} {value:?} {default:?}",
                        entry.full_name()
                    ));
                }
            }
            Err(abort) => assert!(!entry.access.readable(), "{address}: {abort}"),
        }
    }
    // Its own factory values where the catalog holds the manuals' presets: the
    // machine's switches (sim::FACTORY_SETTINGS), and nothing else.
    let own: Vec<String> = sim::FACTORY_SETTINGS
        .iter()
        .map(|&(index, sub, value)| {
            let address = od::Address::new(index, sub);
            let entry = catalog.get(address).expect("in the catalog");
            format!(
                "{address} {} {:?} {:?}",
                entry.full_name(),
                od::Value::Uint(u64::from(value)),
                entry.default.clone().expect("a default")
            )
        })
        .collect();
    assert_eq!(differ, own);
    for address in drive.addresses() {
        assert!(
            catalog.get(address).is_some(),
            "{address} is not in the catalog"
        );
    }
}

/// What python-canopen reads from an EDS: every entry as JSON.
const PYTHON_READ_EDS: &str = r#"
import json, sys, canopen
od = canopen.import_od(sys.argv[1], int(sys.argv[2]))
out = []
for index in sorted(od.indices):
    obj = od[index]
    if isinstance(obj, canopen.objectdictionary.ODVariable):
        members = [obj]
    else:
        members = [obj[s] for s in sorted(obj.subindices)]
    for v in members:
        d = v.default
        if isinstance(d, (bytes, bytearray)):
            d = d.hex().upper()
        out.append({"index": v.index, "sub": v.subindex, "type": v.data_type,
                    "access": v.access_type, "default": d, "min": v.min, "max": v.max,
                    "pdo": v.pdo_mappable, "unit": v.unit, "name": v.name})
print(json.dumps(out))
"#;

fn as_json(value: &Option<Value>) -> serde_json::Value {
    match value {
        None => serde_json::Value::Null,
        Some(Value::Bool(b)) => u8::from(*b).into(),
        Some(Value::Int(v)) => (*v).into(),
        Some(Value::Uint(v)) => (*v).into(),
        Some(Value::Real(v)) => (*v).into(),
        Some(Value::Text(t)) => t.clone().into(),
        Some(Value::Bytes(b)) => b
            .iter()
            .map(|x| format!("{x:02X}"))
            .collect::<String>()
            .into(),
    }
}

/// An independent reader, python-canopen, imports the shipped EDS to the same entries:
/// types, access, defaults (formulas for node 5), limits, PDO mapping, units, names.
#[test]
fn python_canopen_reads_the_shipped_sim_eds_alike() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let path = shipped_sim_eds();
    let out = Command::new(&python.path)
        .arg("-c")
        .arg(PYTHON_READ_EDS)
        .arg(&path)
        .arg("5")
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let theirs: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).expect("JSON");
    let ours = load(&path, Some(5));
    assert_eq!(theirs.len(), ours.catalog.len());
    for v in &theirs {
        let address = Address::new(
            v["index"].as_u64().unwrap_or(0) as u16,
            v["sub"].as_u64().unwrap_or(0) as u8,
        );
        let entry = entry(&ours, address.index, address.sub);
        let info = &ours.entries[&address];
        assert_eq!(v["type"], u64::from(info.type_code), "{address}");
        assert_eq!(v["access"], info.access.as_str(), "{address}");
        assert_eq!(v["default"], as_json(&entry.default), "{address}");
        assert_eq!(v["min"], as_json(&entry.min), "{address}");
        assert_eq!(v["max"], as_json(&entry.max), "{address}");
        assert_eq!(v["pdo"], info.pdo_mapping, "{address}");
        assert_eq!(
            v["unit"],
            entry.unit.clone().unwrap_or_default(),
            "{address}"
        );
        assert_eq!(v["name"], entry.name, "{address}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn the_parser_never_panics_on_any_text(text in "\\PC{0,400}") {
        let _ = Eds::parse(&text, None);
        let _ = Eds::from_bytes(text.as_bytes(), Some(5));
    }

    #[test]
    fn the_parser_never_panics_on_eds_like_text(
        lines in proptest::collection::vec(
            prop_oneof![
                "\\[[0-9A-Fa-f]{4}(sub[0-9A-Fa-f]{1,3}|Name|ObjectLinks)?\\]",
                "(ParameterName|ObjectType|DataType|AccessType|DefaultValue|LowLimit|HighLimit|SubNumber|CompactSubObj|PDOMapping|NrOfEntries|[0-9]{1,2})=[ -~]{0,20}",
                "(DataType|ObjectType|SubNumber|CompactSubObj)=0x[0-9A-F]{1,4}",
                "(DefaultValue|LowLimit|HighLimit)=(\\$NODEID)?[+-]?(0x)?[0-9A-Fa-f]{0,20}(\\+\\$NODEID)?",
                "\\[(FileInfo|DeviceInfo|Comments|DummyUsage|MandatoryObjects|OptionalObjects|ManufacturerObjects|DeviceComissioning)\\]",
                "[ -~]{0,30}",
            ],
            0..60,
        ),
        node in proptest::option::of(1u8..=127),
    ) {
        let text = lines.join("\r\n");
        if let Ok(eds) = Eds::parse(&text, node) {
            // Whatever was imported exports and imports again.
            let again = Eds::parse(&eds.to_text(), eds.node_id);
            prop_assert!(again.is_ok());
        }
    }

    #[test]
    fn mutated_lines_of_a_real_file_never_panic(
        edits in proptest::collection::vec((0usize..1019, 0u8..4, "[ -~]{0,24}"), 1..12),
    ) {
        let original = include_str!("data/eds/sample.eds");
        let mut lines: Vec<String> = original.lines().map(str::to_owned).collect();
        for (at, how, text) in edits {
            let at = at % lines.len().max(1);
            match how {
                0 => lines[at] = text,
                1 => { lines.remove(at); }
                2 => { let copy = lines[at].clone(); lines.insert(at, copy); }
                _ => lines[at].push_str(&text),
            }
            if lines.is_empty() {
                lines.push(String::new());
            }
        }
        let text = lines.join("\n");
        let _ = Eds::parse(&text, Some(5));
        let _ = Eds::parse(&text, None);
    }
}
