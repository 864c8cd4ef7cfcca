//! "Restore what I changed": the worker reports every object the tool writes with its
//! value before the first write (read natively, or through the PDI before a PDI write);
//! writing those back, newest first, returns the simulated drive's whole configuration to
//! where it started.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod probe;

use std::collections::BTreeMap;
use std::time::Duration;

use drivedeck::link::LinkSpec;
use drivedeck::od::{self, Address, DataType, Value, backup};
use drivedeck::ui::changes::{ChangeEntry, note_change, restore_requests};
use drivedeck::worker::{Event, ObjectPath, Request};
use probe::Probe;

/// Every savable object of the catalog, as the drive holds it now.
fn snapshot(probe: &mut Probe) -> BTreeMap<Address, Result<Value, drivedeck::worker::ObjectError>> {
    let objects = backup::objects_to_read(od::builtin());
    let total = objects.len();
    let id = probe.send(Request::ReadMany {
        objects,
        path: ObjectPath::Native,
    });
    let mut reads = BTreeMap::new();
    while reads.len() < total {
        if let Event::ObjectRead {
            address, result, ..
        } = probe.wait(
            "the snapshot",
            Duration::from_secs(10),
            |e| matches!(e, Event::ObjectRead { id: i, .. } if *i == id),
        ) {
            reads.insert(address, result);
        }
    }
    reads
}

fn write(probe: &mut Probe, address: Address, value: u64, path: ObjectPath) {
    let written = probe.write(address, DataType::Unsigned32, Value::Uint(value), path);
    assert_eq!(written, Ok(()), "{address}");
}

/// The changes reported so far, as the window keeps them.
fn changes(probe: &Probe) -> Vec<ChangeEntry> {
    let mut changes = Vec::new();
    for event in &probe.seen {
        if let Event::Changed {
            address,
            dtype,
            before,
            after,
        } = event
        {
            note_change(
                &mut changes,
                ChangeEntry {
                    address: *address,
                    dtype: *dtype,
                    before: before.clone(),
                    after: after.clone(),
                },
            );
        }
    }
    changes
}

#[test]
fn restoring_what_was_changed_returns_the_dictionary_to_its_start() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let start = snapshot(&mut probe);
    let velocity = Address::new(0x6081, 0);
    let acceleration = Address::new(0x6083, 0);
    let slope = Address::new(0x6087, 0);
    write(&mut probe, velocity, 1234, ObjectPath::Native);
    // Through the PDI: the old value is read through the PDI first.
    write(&mut probe, acceleration, 4321, ObjectPath::Pdi);
    write(&mut probe, velocity, 999, ObjectPath::Auto);
    write(&mut probe, slope, 1000, ObjectPath::Auto);
    probe.settle(Duration::from_millis(100));

    let changes = changes(&probe);
    let addresses: Vec<Address> = changes.iter().map(|c| c.address).collect();
    assert_eq!(addresses, [velocity, acceleration, slope]);
    for change in &changes {
        assert_eq!(
            change.before.as_ref(),
            start[&change.address].as_ref().ok(),
            "{} before",
            change.address
        );
    }
    assert_eq!(changes[0].after, Value::Uint(999), "the newest value");
    assert_ne!(snapshot(&mut probe), start);

    for request in restore_requests(&changes) {
        let id = probe.send(request);
        assert_eq!(probe.written(id), Ok(()), "the restoring write");
    }
    assert_eq!(snapshot(&mut probe), start, "every object as it was");
    probe.settle(Duration::from_millis(100));
    assert!(
        self::changes(&probe).is_empty(),
        "written back: nothing changed any more"
    );
}
