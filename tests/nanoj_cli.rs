//! `drivedeck nanoj`: the simulated drive's program started, its injected error decoded,
//! started again and stopped, over Modbus TCP, EtherNet/IP and CANopen slcan.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::cli::{json, run};
use common::{PtyPair, Sim};

fn start_error_restart_and_stop(link: &str) {
    let status = json(&["--link", link, "nanoj", "status"]);
    assert_eq!(status["state"], "stopped", "{status:#}");
    assert_eq!(status["programs"][0], "demo.usr", "{status:#}");
    assert_eq!(status["inputs"][0]["object"], "2400h:01h", "{status:#}");
    assert_eq!(status["outputs"][1]["object"], "2500h:02h", "{status:#}");

    let started = json(&["--link", link, "nanoj", "start"]);
    assert_eq!(started["state"], "running", "{started:#}");
    assert!(
        started["done"]
            .as_str()
            .unwrap()
            .contains("the program runs"),
        "{started:#}"
    );

    // The injected error: NanoJ input 3 makes the program run too long.
    let (code, out, err) = run(&["--link", link, "write", "2400:03", "5"]);
    assert_eq!(code, 0, "{out}{err}");
    let failed = json(&["--link", link, "nanoj", "status"]);
    assert_eq!(failed["state"], "stopped by an error", "{failed:#}");
    assert_eq!(failed["error_code"], 5);
    assert_eq!(
        failed["error"],
        "it ran too long without yield() or sleep()"
    );

    // With the error still there, a start ends in it and says so (exit 1).
    let (code, out, _) = run(&["--link", link, "nanoj", "start"]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("stopped with an error") && out.contains("too long"),
        "{out}"
    );

    let (code, out, err) = run(&["--link", link, "write", "2400:03", "0"]);
    assert_eq!(code, 0, "{out}{err}");
    let started = json(&["--link", link, "nanoj", "start"]);
    assert_eq!(started["state"], "running", "{started:#}");
    assert_eq!(started["error_code"], 0);
    let stopped = json(&["--link", link, "nanoj", "stop"]);
    assert_eq!(stopped["state"], "stopped", "{stopped:#}");
}

#[test]
fn the_program_over_modbus_tcp() {
    let (_sim, addr) = Sim::tcp(&[]);
    start_error_restart_and_stop(&format!("modbus-tcp://{addr}"));
}

#[test]
fn the_program_over_ethernet_ip() {
    let (_sim, addr) = Sim::enip(&[]);
    start_error_restart_and_stop(&format!("enip://{addr}"));
}

#[test]
fn the_program_over_canopen_slcan() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    start_error_restart_and_stop(&format!(
        "canopen+slcan://{}?bitrate=1000000&node=5",
        pair.b.display()
    ));
}

/// python-canopen reads 2301h and 2302h from the node on `pty` (it has the line then).
fn python_reads(python: &common::Python, pty: &std::path::Path) -> (u64, u64) {
    let got = common::try_run_peer(
        python,
        "canopen_nanoj.py",
        &[pty.to_str().expect("utf-8 path"), "5"],
        std::time::Duration::from_secs(30),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    (
        got["status_2301"].as_u64().expect("2301h"),
        got["error_2302"].as_u64().expect("2302h"),
    )
}

#[test]
fn python_canopen_reads_the_program_running_after_nanoj_start_and_the_injected_error() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = Sim::slcan(&pair.a, 5, &[]);
    let link = format!(
        "canopen+slcan://{}?bitrate=1000000&node=5",
        pair.b.display()
    );
    let started = json(&["--link", &link, "nanoj", "start"]);
    assert_eq!(started["state"], "running", "{started:#}");
    assert_eq!(python_reads(&python, &pair.b), (1, 0), "running, no error");
    let (code, out, err) = run(&["--link", &link, "write", "2400:03", "5"]);
    assert_eq!(code, 0, "{out}{err}");
    assert_eq!(
        python_reads(&python, &pair.b),
        (2, 5),
        "stopped: ran too long"
    );
    let status = json(&["--link", &link, "nanoj", "status"]);
    assert_eq!(
        status["error"],
        "it ran too long without yield() or sleep()"
    );
}
