//! An object the catalog does not know (a vendor object on a newer firmware, typed into the
//! Commands panel or `drivedeck read`) is read at the size the drive has, on every bus:
//!
//! - Modbus TCP: FC 43 must ask for the object's exact size (the N5 manual's example: 2
//!   bytes asked of a 1-byte object answer abort 06070012h), so 32 bits are asked first,
//!   then 16 and 8 on "length too high", 64 on "too low";
//! - CANopen: the SDO upload says how many bytes there are;
//! - EtherNet/IP: GetOD Rockwell brings the entry's type.
//!
//! An object the catalog knows is read in its catalog type even when the caller gave none.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::time::Duration;

use drivedeck::link::canopen::MemoryBus;
use drivedeck::link::canopen::client::CanopenLink;
use drivedeck::link::{CanopenOptions, Link, LinkSpec};
use drivedeck::od::{Access, Address, Catalog, DataType, Entry, Group, Role, Value};
use drivedeck::sim::Drive;
use drivedeck::sim::World;
use drivedeck::sim::server::canopen::{Node, run_node};
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::sim::server::{ServerThread, SharedDrive};
use drivedeck::worker::{Event, ObjectError, ObjectPath, Request};
use probe::Probe;

const BYTE: Address = Address::new(0x2FF0, 0);
const WORD: Address = Address::new(0x2FF1, 0);
const LONG: Address = Address::new(0x2FF2, 0);
const WIDE: Address = Address::new(0x2FF3, 0);

/// A catalog entry for the simulated drive only (the built-in catalog has none of these).
fn entry(address: Address, dtype: DataType, value: Value) -> Entry {
    Entry {
        address,
        object_name: format!("Unlisted {:04X}h", address.index),
        name: format!("Unlisted {:04X}h", address.index),
        dtype,
        access: Access::Ro,
        unit: None,
        description: String::new(),
        default: Some(value),
        min: None,
        max: None,
        group: Group::Manufacturer,
        role: Role::ReadOnly,
        bits: vec![],
    }
}

/// A simulated drive with four objects the built-in catalog does not know.
fn drive_with_unlisted_objects() -> SharedDrive {
    let mut catalog: Catalog = drivedeck::od::builtin().clone();
    catalog.insert(entry(BYTE, DataType::Unsigned8, Value::Uint(0xA7)));
    catalog.insert(entry(WORD, DataType::Integer16, Value::Int(-1234)));
    catalog.insert(entry(LONG, DataType::Unsigned32, Value::Uint(0x1234_5678)));
    catalog.insert(entry(WIDE, DataType::Unsigned64, Value::Uint(1 << 40)));
    for address in [BYTE, WORD, LONG, WIDE] {
        assert!(drivedeck::od::builtin().get(address).is_none());
    }
    SharedDrive::new(Drive::with_catalog(&catalog, World::default()))
}

/// The worker's read with no type given, as the Commands panel sends it.
fn read_untyped(probe: &mut Probe, address: Address) -> Result<Value, ObjectError> {
    let id = probe.send(Request::ReadObject {
        address,
        dtype: None,
        path: ObjectPath::Auto,
    });
    match probe.wait(
        "the read",
        Duration::from_secs(5),
        |e| matches!(e, Event::ObjectRead { id: i, .. } if *i == id),
    ) {
        Event::ObjectRead { result, .. } => result,
        _ => unreachable!(),
    }
}

/// What each bus reads for the four objects: integers of the object's own size. Modbus and
/// CANopen do not know the sign (signed, as the one type they guess); EtherNet/IP is told.
fn expect_sized(values: [Result<Value, ObjectError>; 4], typed: bool) {
    let [byte, word, long, wide] = values;
    if typed {
        assert_eq!(byte, Ok(Value::Uint(0xA7)));
        assert_eq!(word, Ok(Value::Int(-1234)));
        assert_eq!(long, Ok(Value::Uint(0x1234_5678)));
        assert_eq!(wide, Ok(Value::Uint(1 << 40)));
    } else {
        // A7h as a signed byte.
        assert_eq!(byte, Ok(Value::Int(-89)));
        assert_eq!(word, Ok(Value::Int(-1234)));
        assert_eq!(long, Ok(Value::Int(0x1234_5678)));
        assert_eq!(wide, Ok(Value::Int(1 << 40)));
    }
}

#[test]
fn modbus_tcp_reads_an_unlisted_object_at_the_size_the_drive_accepts() {
    let server = ServerThread::modbus_tcp_with(
        common::loopback(),
        ServerOptions::default(),
        drive_with_unlisted_objects(),
    )
    .expect("server");
    let spec: LinkSpec = format!("modbus-tcp://{}", server.addr)
        .parse()
        .expect("spec");
    let mut probe = Probe::connected(spec);
    let values = [BYTE, WORD, LONG, WIDE].map(|a| read_untyped(&mut probe, a));
    expect_sized(values, false);
    // A catalogued UNSIGNED8 asked without a type: its catalog type, not a 32-bit guess.
    assert_eq!(
        read_untyped(&mut probe, Address::new(0x1001, 0)),
        Ok(Value::Uint(0))
    );
    // A missing object is still named as missing, not as a size problem.
    assert!(matches!(
        read_untyped(&mut probe, Address::new(0x2FFF, 0)),
        Err(ObjectError::Refused(drivedeck::link::Refusal::Abort(
            drivedeck::cia::AbortCode::NO_OBJECT
        )))
    ));
}

#[test]
fn ethernet_ip_reads_an_unlisted_object_in_the_type_getod_rockwell_names() {
    let server = ServerThread::enip_with(
        common::loopback(),
        common::enip_options(),
        drive_with_unlisted_objects(),
    )
    .expect("adapter");
    let spec: LinkSpec = format!("enip://{}", server.addr).parse().expect("spec");
    let mut probe = Probe::connected(spec);
    let values = [BYTE, WORD, LONG, WIDE].map(|a| read_untyped(&mut probe, a));
    expect_sized(values, true);
}

#[test]
fn canopen_reads_an_unlisted_object_at_the_size_its_upload_has() {
    common::runtime().block_on(async {
        let bus = MemoryBus::new();
        let drive = drive_with_unlisted_objects();
        let served = drive.clone();
        let built = {
            let mut d = drive.lock();
            Node::new(4, &mut d)
        };
        let port = bus.port();
        tokio::spawn(async move {
            let _ = run_node(port, built, served).await;
        });
        let spec: LinkSpec = "canopen+sim://?node=4".parse().expect("spec");
        let options = CanopenOptions {
            node: 4,
            ..CanopenOptions::default()
        };
        let mut link = CanopenLink::connect(spec, bus.port(), options)
            .await
            .expect("connect");
        let mut values = vec![];
        for address in [BYTE, WORD, LONG, WIDE] {
            let read = link
                .read_object_of_unknown_type(address)
                .await
                .expect("the link")
                .map_err(ObjectError::Refused);
            values.push(read);
        }
        let values: [_; 4] = values.try_into().expect("four");
        expect_sized(values, false);
    });
}
