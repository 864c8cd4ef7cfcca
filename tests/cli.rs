//! Every one-shot command of the binary against `--link sim`: exit codes, text and JSON.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::cli::{fails, json, ok};

#[test]
fn status_in_text_and_json() {
    let (text, _) = ok(&["--link", "sim", "status"]);
    assert!(text.contains("Switch on disabled"), "{text}");
    assert!(text.contains("603Fh       0000h no error"), "{text}");
    let v = json(&["--link", "sim", "status"]);
    assert_eq!(v["state"], "Switch on disabled");
    assert_eq!(v["bits"].as_array().map(Vec::len), Some(11));
    assert_eq!(v["error_code"], 0);
}

#[test]
fn absolute_and_relative_moves_wait_for_the_target() {
    let (text, _) = ok(&[
        "--link", "sim", "move-abs", "2000", "--speed", "200", "--wait",
    ]);
    assert!(
        text.contains("[D0 07 00 00 C8 00 00 14]: done (ReturnValue 2000)"),
        "{text}"
    );
    let v = json(&[
        "--link", "sim", "move-rel", "-900", "--speed", "300", "--wait",
    ]);
    assert_eq!(v["outcome"], "done");
    assert_eq!(v["return_value"], -900);
    assert_eq!(v["image"][7], 21);
}

#[test]
fn velocity_torque_and_homing() {
    let v = json(&["--link", "sim", "velocity", "300", "--wait"]);
    assert_eq!(v["outcome"], "done");
    // Without --wait a command returns once the drive accepted it.
    let v = json(&["--link", "sim", "velocity", "-100"]);
    assert_eq!(v["outcome"], "accepted");

    let (_, stderr) = ok(&["--link", "sim", "torque", "500", "--max-speed", "100"]);
    assert!(stderr.contains("torque slope 6087h is 0"), "{stderr}");
    let v = json(&[
        "--link",
        "sim",
        "torque",
        "500",
        "--max-speed",
        "100",
        "--slope",
        "2000",
        "--wait",
    ]);
    assert_eq!(v["outcome"], "done");
    assert_eq!(v["return_value"], 500);

    let v = json(&["--link", "sim", "home", "--method", "34", "--wait"]);
    assert_eq!(v["outcome"], "done");
    let v = json(&["--link", "sim", "home-here", "1234"]);
    assert_eq!(v["outcome"], "done");
    assert_eq!(v["return_value"], 1234);
}

#[test]
fn auto_setup_waits() {
    let v = json(&["--link", "sim", "auto-setup", "--wait"]);
    assert_eq!(v["outcome"], "done");
}

#[test]
fn stops_and_clear_error() {
    for cmd in ["quickstop", "switch-off", "clear-error"] {
        let v = json(&["--link", "sim", cmd]);
        assert_eq!(v["outcome"], "done", "{cmd}");
    }
    // A fresh simulated drive has no travel command to halt: the reason is given.
    let stderr = fails(&["--link", "sim", "halt"], 1);
    assert!(stderr.contains("no travel command to halt"), "{stderr}");
    let stderr = fails(&["--link", "sim", "resume"], 1);
    assert!(stderr.contains("no travel command"), "{stderr}");
}

#[test]
fn objects_read_and_write() {
    let (text, _) = ok(&["--link", "sim", "read", "1018:01"]);
    assert_eq!(
        text.trim(),
        "1018h:01h Identity Object / Vendor-ID = 620 (0000026Ch)"
    );
    let v = json(&["--link", "sim", "read", "1018:01", "--via", "pdi"]);
    assert_eq!(v["hex"], "0000026Ch");
    let v = json(&["--link", "sim", "read", "1008"]);
    assert_eq!(v["text"], "\"drivedeck simulated drive\"");
    let v = json(&["--link", "sim", "write", "203B:01", "1000", "--via", "pdi"]);
    assert_eq!(v["written"], true);
    let stderr = fails(&["--link", "sim", "read", "2FFF:00", "--via", "pdi"], 1);
    assert!(
        stderr.contains("06020000h: Object does not exist"),
        "{stderr}"
    );
    let stderr = fails(&["--link", "sim", "write", "1018:01", "5"], 2);
    assert!(stderr.contains("read-only"), "{stderr}");
    let stderr = fails(&["--link", "sim", "write", "2290", "300"], 2);
    assert!(stderr.contains("300 is out of range for U8"), "{stderr}");
}

#[test]
fn bad_input_is_refused_before_connecting() {
    let stderr = fails(
        &["--link", "sim", "move-abs", "2000", "--speed", "40000"],
        2,
    );
    assert!(stderr.contains("does not fit PDI-SetValue2"), "{stderr}");
    let stderr = fails(&["--link", "modbus-tcp://127.0.0.1:1", "status"], 2);
    assert!(stderr.contains("refused the connection"), "{stderr}");
    let stderr = fails(&["--link", "canopen+socketcan://can0", "status"], 2);
    assert!(stderr.contains("ip link set can0 up"), "{stderr}");
    let stderr = fails(&["--link", "enip://127.0.0.1:1", "status"], 2);
    assert!(
        stderr.contains("refuses TCP connections") && stderr.contains("44818"),
        "{stderr}"
    );
    let stderr = fails(&["--link", "nonsense", "status"], 2);
    assert!(stderr.contains("Forms: sim"), "{stderr}");
    let stderr = fails(&["sim"], 2);
    assert!(stderr.contains("nothing to serve"), "{stderr}");
}

#[test]
fn a_timeout_out_of_range_is_refused_with_the_range_not_clamped() {
    for bad in ["0", "-1", "NaN", "inf", "86401"] {
        let stderr = fails(&["--link", "sim", "--timeout", bad, "status"], 2);
        assert!(
            stderr.contains("give 0.1 to 86400 seconds"),
            "--timeout {bad}: {stderr}"
        );
    }
    let stderr = fails(&["--link", "sim", "--timeout", "soon", "status"], 2);
    assert!(stderr.contains("is not a number of seconds"), "{stderr}");
    ok(&["--link", "sim", "--timeout", "0.1", "status"]);
}

#[test]
fn a_traced_scan_prints_its_frames() {
    let (code, stdout, stderr) =
        common::cli::run(&["--link", "canopen+sim://?node=3", "--trace", "scan"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert!(stdout.contains("node   3"), "{stdout}");
    // The identity read to every node id, and node 3's answer, each on a line.
    assert!(stderr.lines().any(|l| l.starts_with("tx 603#")), "{stderr}");
    assert!(stderr.lines().any(|l| l.starts_with("rx 583#")), "{stderr}");
}

#[test]
fn gains_lists_the_controller_and_the_limits_with_addresses_and_factory_values() {
    let report = json(&["--link", "sim", "gains"]);
    let gains = report["gains"].as_array().expect("gains");
    let row = |address: &str| {
        gains
            .iter()
            .find(|g| g["address"] == address)
            .unwrap_or_else(|| panic!("{address} not listed: {report:#}"))
    };
    let velocity_kp = row("3210h:03h");
    assert!(
        velocity_kp["name"]
            .as_str()
            .is_some_and(|n| n.contains("Velocity Loop, Proportional Gain")),
        "{velocity_kp:#}"
    );
    assert_eq!(velocity_kp["value"], "12000", "{velocity_kp:#}");
    assert_eq!(velocity_kp["factory"], "12000", "{velocity_kp:#}");
    assert_eq!(row("6073h:00h")["unit"], "‰");
    assert_eq!(row("2031h:00h")["unit"], "mA");
    for address in [
        "321Ah:01h",
        "321Bh:01h",
        "321Ch:01h",
        "6080h:00h",
        "607Fh:00h",
    ] {
        assert!(row(address)["value"].is_string(), "{address}: {report:#}");
    }
    let (text, _) = ok(&["--link", "sim", "gains"]);
    assert!(
        text.contains("controller (3210h):") && text.contains("limit:"),
        "{text}"
    );
}
