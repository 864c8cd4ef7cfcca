//! CANopen over slcan on a pseudo-terminal pair, the way a technician's USB adapter is
//! seen: `drivedeck sim --slcan A --node 5` is the simulated drive behind an emulated
//! adapter on one end, our master (the worker, and the window) is the slcan host on the
//! other. Needs socat: skipped with a reason without it, and required in CI.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;
mod window;

use std::time::Duration;

use common::{PtyPair, Sim, slcan_spec};
use drivedeck::cia::AbortCode;
use drivedeck::link::Refusal;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::StatusBit;
use drivedeck::worker::{ObjectError, ObjectPath, Request};
use egui_kittest::kittest::Queryable;
use probe::Probe;
use window::{lamp, step_until, step_until_shown};

#[test]
fn the_worker_moves_the_motor_over_slcan_pdos_and_reads_a_string() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    let mut probe = Probe::connected(slcan_spec(&pair.b, 5));
    let info = probe.link_info();
    assert!(
        info.description.contains("CANopen node 5")
            && info.description.contains("RPDO1/TPDO1")
            && info.description.contains("slcan"),
        "{}",
        info.description
    );
    probe.move_absolute(2000, 200);
    let at = probe.sample_where("target reached", Duration::from_secs(5), |s| {
        s.tx.status.is_set(StatusBit::TargetReached) && s.tx.return_value == 2000
    });
    assert!(at.tx.status.is_set(StatusBit::OperationEnabled));
    // A segmented SDO upload through the adapter, and an expedited one.
    assert_eq!(
        probe.device_name(ObjectPath::Auto),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    assert_eq!(probe.vendor_id(ObjectPath::Native), Ok(Value::Uint(0x26C)));
    let missing = probe
        .read(
            Address::new(0x1018, 9),
            DataType::Unsigned32,
            ObjectPath::Native,
        )
        .expect_err("no such subindex");
    assert_eq!(
        missing,
        ObjectError::Refused(Refusal::Abort(AbortCode::NO_SUBINDEX))
    );
    // The motor's position follows over the bus, by whatever path the link has for it.
    probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(2000.0)
    });
}

#[test]
fn a_scan_over_slcan_finds_the_node_with_its_identity() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 9, &[]);
    let found = Probe::new()
        .scan(
            Request::Scan(slcan_spec(&pair.b, 1)),
            Duration::from_secs(30),
        )
        .expect("a scan without errors");
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].node, Some(9));
    assert_eq!(found[0].vendor, Some(0x26C));
    assert_eq!(found[0].name.as_deref(), Some("drivedeck simulated drive"));
}

#[test]
fn the_window_connects_over_slcan_and_moves_the_motor() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    let mut harness = window::disconnected_harness();
    window::choose_bus(&mut harness, "CANopen (slcan)");
    window::fill(
        &mut harness,
        &[
            ("Connection: Port", pair.b.to_str().expect("utf-8 path")),
            ("Connection: Bit rate", "1000000"),
            ("Connection: Node", "5"),
        ],
    );
    harness.get_by_label("Connect").click();
    harness.step();
    step_until(
        &mut harness,
        "the slcan connection",
        Duration::from_secs(10),
        |h| {
            h.state().shown().link_info().is_some_and(|i| {
                i.description.contains("CANopen node 5") && i.description.contains("RPDO1/TPDO1")
            }) && h.state().shown().latest().is_some()
        },
    );
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the target over slcan",
        Duration::from_secs(15),
        |h| {
            lamp(h, "Target reached")
                && h.state().shown().latest().map(|s| s.tx.return_value) == Some(2000)
        },
    );
    window::read_object(
        &mut harness,
        "1008",
        &Value::Text("drivedeck simulated drive".into()),
        Duration::from_secs(5),
    );
    // Disconnect releases the port and puts the node's mapping back. The motor is
    // energised after the move: the window asks what to leave behind; halt.
    harness.get_by_label("Disconnect").click();
    step_until_shown(&mut harness, "Halt, then disconnect");
    harness.get_by_label("Halt, then disconnect").click();
    harness.step();
    step_until(
        &mut harness,
        "the disconnection",
        Duration::from_secs(5),
        |h| h.state().shown().link_info().is_none(),
    );
}
