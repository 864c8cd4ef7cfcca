//! Modbus RTU end to end over a socat pseudo-terminal pair: `drivedeck sim --modbus-rtu A`
//! on one end, with the factory settings (slave 5, 19200 8E1), and on the other our worker
//! or pymodbus as an independent RTU master.
//!
//! Without socat or the Python peer (./.venv, which `cargo test` makes with the versions of
//! tests/peers/requirements.txt) a test passes without running and says `SKIPPED …` in the
//! output; with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) it fails.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::json;

use common::{PtyPair, Sim};
use drivedeck::link::{ErrorKind, LinkSpec};
use drivedeck::od::Value;
use drivedeck::pdi::StatusBit;
use drivedeck::worker::{Event, ObjectPath};
use probe::Probe;

fn rtu_spec(path: &Path, slave: u8) -> LinkSpec {
    format!(
        "modbus-rtu://{}?baud=19200&parity=even&slave={slave}",
        path.display()
    )
    .parse()
    .expect("spec")
}

#[test]
fn a_move_and_objects_over_modbus_rtu_with_the_factory_settings() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let sim = Sim::rtu(&pair.a, &[]);
    assert!(
        sim.banner
            .contains("slave 5, 19200 baud, parity even, 1 stop bit"),
        "{}",
        sim.banner
    );
    let mut probe = Probe::new();
    let connected = probe.connect(rtu_spec(&pair.b, 5));
    let Event::Connected(info) = connected else {
        panic!("{connected:?}");
    };
    // The link talks RTU to slave 5 with FC 23 and FC 43, no fallbacks.
    assert!(
        info.description.starts_with("Modbus RTU")
            && info.description.contains("slave 5")
            && info.description.contains("FC 23")
            && info.description.contains("FC 43"),
        "{}",
        info.description
    );
    probe.wait(
        "a sample",
        Duration::from_secs(5),
        |e| matches!(e, Event::Samples(s) if !s.is_empty()),
    );
    probe.move_absolute(2000, 200);
    let sample = probe.sample_where("a sample at the target", Duration::from_secs(2), |s| {
        s.tx.status.is_set(StatusBit::TargetReached)
    });
    // Position, statusword and mode from the process image at 5000, over RTU.
    assert_eq!(sample.position(), Some(2000.0));
    assert_eq!(sample.statusword().map(|w| w & 0x6F), Some(0x27));
    assert_eq!(sample.mode(), Some(1));
    // FC 43 (CANopen objects, data little-endian inside a big-endian frame).
    assert_eq!(probe.vendor_id(ObjectPath::Native), Ok(Value::Uint(0x26C)));
    // A string only FC 43 can carry.
    assert_eq!(
        probe.device_name(ObjectPath::Auto),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    // The same object through the PDI agrees.
    assert_eq!(probe.vendor_id(ObjectPath::Pdi), Ok(Value::Uint(0x26C)));
}

#[test]
fn a_wrong_slave_address_times_out_and_says_to_check_it() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _sim = Sim::rtu(&pair.a, &[]);
    let mut probe = Probe::new();
    let asked = Instant::now();
    let failed = probe.connect(rtu_spec(&pair.b, 6));
    let took = asked.elapsed();
    let Event::ConnectFailed {
        error, retry_in, ..
    } = failed
    else {
        panic!("slave 6 answered: {failed:?}");
    };
    assert_eq!(error.kind, ErrorKind::Timeout, "{error}");
    assert!(
        error.text.contains("no answer") && error.text.contains("check the slave address"),
        "{error}"
    );
    assert!(error.text.contains("slave 6"), "{error}");
    // A drive that may yet be switched on is tried again.
    assert!(retry_in.is_some(), "{retry_in:?}");
    // One request timeout (500 ms), not a hang.
    assert!(took < Duration::from_secs(3), "{took:?}");
}

#[test]
fn pymodbus_as_rtu_master_reads_the_pdi_and_runs_an_od_read() {
    let Some(python) = common::python(&["serial"]) else {
        return;
    };
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let mut sim = Sim::rtu(&pair.a, &[]);
    let b = pair.b.to_str().expect("utf-8 path");
    let mut got = common::try_run_peer(
        &python,
        "pymodbus_client.py",
        &["rtu", b],
        Duration::from_secs(30),
    )
    .unwrap_or_else(|e| panic!("{e}\n{}", sim.process.report()));
    // Whether pyserial needed the pty parity shim depends on the C library; not asserted.
    let shim = got
        .as_object_mut()
        .and_then(|o| o.remove("pty_parity_shim"));
    assert!(shim.is_some_and(|s| s.is_boolean()), "{got}");
    assert_eq!(
        got,
        json!({
            // 4996..4999 of a fresh drive: nothing run yet.
            "tx_registers": [0, 0, 0, 0],
            // OD-Read 1018h:01 through the PDI (FC 16 to 5996, FC 4 polls of 4996).
            "read_1018_01": {
                "toggled": true,
                "error": false,
                "return_value": 0x26C,
                "return_value_u32": 0x26C,
            },
        }),
        "{got}"
    );
}

#[test]
fn a_drive_that_goes_silent_on_rtu_and_comes_back_is_reconnected() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let first = Sim::rtu(&pair.a, &[]);
    let mut probe = Probe::connected(rtu_spec(&pair.b, 5));
    // The drive is switched off: no answer, the worker says so and keeps trying.
    drop(first);
    let lost = probe.lost(Duration::from_secs(3));
    assert!(lost.contains("no answer"), "{lost}");
    probe.retrying(Duration::from_secs(3));
    // Switched on again on the same port: the worker is back within its backoff.
    let _second = Sim::rtu(&pair.a, &[]);
    probe.reconnected(Duration::from_secs(10));
    assert_eq!(probe.vendor_id(ObjectPath::Native), Ok(Value::Uint(0x26C)));
}
