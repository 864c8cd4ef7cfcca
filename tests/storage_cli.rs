//! `drivedeck store`, `defaults` and `reboot` against the simulated drive served on Modbus
//! TCP, CANopen over slcan and EtherNet/IP: a stored value comes back after the restart, one
//! written after the store does not, the factory values come back after `defaults
//! --reboot`; the restart is waited out and timed; the in-process simulator is refused.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::time::Duration;

use common::cli::{fails, json, run};
use common::{PtyPair, Sim};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::StatusBit;
use drivedeck::worker::ObjectPath;
use probe::Probe;

fn read_6083(link: &str) -> i64 {
    read(link, "6083:00")
}

fn read(link: &str, object: &str) -> i64 {
    let value = json(&["--link", link, "read", object]);
    value["hex"]
        .as_str()
        .and_then(|h| i64::from_str_radix(h.trim_end_matches('h'), 16).ok())
        .unwrap_or_else(|| panic!("{object}: {value:#}"))
}

fn write(link: &str, object: &str, value: &str) {
    let (code, out, err) = run(&["--link", link, "write", object, value]);
    assert_eq!(code, 0, "{object} = {value}: {out}{err}");
}

/// Store, restart and restore on the drive at `link`: a changed gain (the velocity
/// loop's P) and a changed ramp come back after the restart, and the factory values
/// replace them.
fn store_reboot_and_defaults(link: &str) {
    write(link, "3210:03", "48000");
    write(link, "6083:00", "1234");
    let stored = json(&["--link", link, "store"]);
    assert!(
        stored["done"][0].as_str().unwrap().contains("stored"),
        "{stored:#}"
    );
    write(link, "6083:00", "999");
    let rebooted = json(&["--link", link, "reboot"]);
    let back = rebooted["back_after_s"].as_f64().expect("back after");
    // The simulated drive is gone for 1.5 s.
    assert!((1.0..15.0).contains(&back), "{rebooted:#}");
    assert!(rebooted.get("notes").is_none(), "{rebooted:#}");
    assert_eq!(read_6083(link), 1234, "stored, then back");
    assert_eq!(read(link, "3210:03"), 48000, "the gain stored, then back");

    let restored = json(&["--link", link, "defaults", "--reboot"]);
    assert!(restored["back_after_s"].as_f64().is_some(), "{restored:#}");
    assert_eq!(read_6083(link), 500, "the factory's");
    assert_eq!(read(link, "3210:03"), 12000, "the factory's gain");
}

#[test]
fn store_reboot_and_defaults_over_modbus_tcp() {
    let (_sim, addr) = Sim::tcp(&[]);
    store_reboot_and_defaults(&format!("modbus-tcp://{addr}"));
}

#[test]
fn store_reboot_and_defaults_over_ethernet_ip() {
    let (_sim, addr) = Sim::enip(&[]);
    store_reboot_and_defaults(&format!("enip://{addr}"));
}

#[test]
fn store_reboot_and_defaults_over_canopen_slcan() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    let link = format!(
        "canopen+slcan://{}?bitrate=1000000&node=5",
        pair.b.display()
    );
    store_reboot_and_defaults(&link);
}

#[test]
fn without_store_a_written_value_is_gone_after_the_restart() {
    let (_sim, addr) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    write(&link, "6083:00", "1234");
    let (code, out, err) = run(&["--link", &link, "reboot"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("answers again after"), "{out}");
    assert_eq!(read_6083(&link), 500);
}

#[test]
fn the_in_process_simulator_cannot_store_or_restart_and_says_what_to_do() {
    for command in ["store", "reboot", "defaults"] {
        let said = fails(&["--link", "sim", command], 2);
        assert!(
            said.contains("drivedeck sim --modbus-tcp"),
            "{command}: {said}"
        );
    }
}

#[test]
fn the_window_s_worker_finds_the_drive_again_after_its_restart() {
    let (_sim, addr) = Sim::tcp(&[]);
    let mut probe = Probe::connected(format!("modbus-tcp://{addr}").parse().expect("spec"));
    probe.move_absolute(1800, 300);
    probe
        .write(
            Address::new(0x2800, 1),
            DataType::Unsigned32,
            Value::Uint(0x746F_6F62),
            ObjectPath::Auto,
        )
        .expect("the restart is accepted");
    let reason = probe.lost(Duration::from_secs(10));
    assert!(!reason.is_empty());
    probe.reconnected(Duration::from_secs(20));
    // Back as at power-on: the power stage off, the counter at 0.
    let sample = probe.sample_where("a sample after the restart", Duration::from_secs(5), |s| {
        !s.tx.status.is_set(StatusBit::OperationEnabled)
    });
    assert_eq!(sample.tx.return_value, 0, "{sample:?}");
}
