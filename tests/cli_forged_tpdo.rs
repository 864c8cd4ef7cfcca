//! A forged TPDO on an slcan line (issue 26): one TPDO1 from the simulated node whose
//! PDI status says "not Operation enabled" while the drive runs on. The command line
//! must read the drive again (the statusword 6041h by SDO) before judging, and, the
//! drive found still in Operation enabled, stop it by `--on-exit` and say whether the
//! stop was confirmed. Needs socat (pty pairs): skipped with a reason without it, and
//! required in CI.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{Read, Write};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread;
use std::time::Duration;

use common::cli::{ok, start};
use common::{PtyPair, Sim};

/// Pass slcan lines between the host's pty and the device's, forging the next `forge`
/// TPDO1 lines of node 1 (`t181…`): PdiStatusOperationEnabled (bit 0 of the first data
/// byte) cleared.
fn forwarder(host: &Path, device: &Path, forge: Arc<AtomicUsize>) {
    let open = |p: &Path| {
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(p)
            .unwrap_or_else(|e| panic!("open {}: {e}", p.display()))
    };
    let host_side = open(host);
    let device_side = open(device);
    let mut host_in = host_side.try_clone().expect("clone");
    let mut device_out = device_side.try_clone().expect("clone");
    thread::spawn(move || {
        let mut buf = [0u8; 1024];
        while let Ok(n) = host_in.read(&mut buf) {
            if n == 0 || device_out.write_all(&buf[..n]).is_err() {
                break;
            }
        }
    });
    let (mut from, mut to) = (device_side, host_side);
    thread::spawn(move || {
        let mut buf = [0u8; 1024];
        let mut line: Vec<u8> = Vec::new();
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 {
                break;
            }
            for &b in &buf[..n] {
                line.push(b);
                if b != b'\r' && b != 7 {
                    continue;
                }
                let mut out = std::mem::take(&mut line);
                // t181 8 SSSS…: the status's low byte first, its low nibble at [6].
                if out.starts_with(b"t181")
                    && out.len() > 7
                    && forge
                        .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                        .is_ok()
                {
                    let nibble = (out[6] as char).to_digit(16).unwrap_or(0) & !1;
                    out[6] = std::char::from_digit(nibble, 16)
                        .unwrap_or('0')
                        .to_ascii_uppercase() as u8;
                }
                if to.write_all(&out).is_err() {
                    return;
                }
            }
        }
    });
}

/// TPDOs forged in a row (the node sends one about every 10 ms while it moves).
const FORGED: usize = 5;

#[test]
fn a_forged_tpdo_saying_the_drive_left_operation_enabled_is_checked_by_sdo_and_the_drive_halted() {
    let (Some(host), Some(device)) = (PtyPair::new(), PtyPair::new()) else {
        eprintln!("SKIPPED: no socat, so no pty pairs: the forged TPDO test did not run");
        return;
    };
    let _sim = Sim::slcan(&device.a, 1, &[]);
    let forge = Arc::new(AtomicUsize::new(0));
    forwarder(&host.b, &device.b, forge.clone());
    let link = common::slcan_spec(&host.a, 1).to_string();
    let mut mover = start(&[
        "--link", &link, "move-rel", "300000", "--speed", "60", "--wait",
    ]);
    thread::sleep(Duration::from_millis(2500));
    assert!(mover.running(), "the move runs: {}", mover.report());
    // A few in a row: the link keeps the newest TPDO of those that came between two
    // exchanges, so that one alone may never be judged.
    forge.store(FORGED, Ordering::SeqCst);
    let code = match mover.wait(Duration::from_secs(30)) {
        Some(status) => status.code().unwrap_or(-1),
        None => panic!("still running: {}", mover.report()),
    };
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(forge.load(Ordering::SeqCst), 0, "the TPDO was forged");
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("drivedeck: Check the bus for a wrong status frame"),
        "what to do leads: {report}"
    );
    assert!(
        report.contains("the drive read again says Operation enabled (6041h = "),
        "judged after reading 6041h again: {report}"
    );
    assert!(
        report.contains("halt sent; the drive confirmed it"),
        "the --on-exit halt, confirmed: {report}"
    );
    // Found halted afterwards.
    let (stdout, _) = ok(&["--link", &link, "--json", "status"]);
    let status: serde_json::Value = serde_json::from_str(&stdout).expect("JSON status");
    assert_eq!(status["velocity"].as_f64(), Some(0.0), "{status}");
    let halted = status["bits"].as_array().is_some_and(|bits| {
        bits.iter()
            .any(|b| b["name"] == "PdiStatusQsHaltBit" && b["set"] == true)
    });
    assert!(halted, "{status}");
}
