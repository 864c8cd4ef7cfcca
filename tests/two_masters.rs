//! Two masters on one drive: each is told that the other writes the PDI image, neither is
//! told "done" for a move the other one steered.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::Duration;

use common::Sim;
use common::cli::{json, start};

/// Two moves to different targets at once over one Modbus TCP server that lets two
/// clients in (the drill: both waited 40 s and timed out, naming nobody). The first is
/// told within seconds that another master writes the PDI image; the second is either
/// told the same or, once the first has gone, really ends at its own target.
#[test]
fn two_modbus_masters_moving_one_drive_are_told_of_each_other() {
    let (_sim, addr) = Sim::tcp(&["--max-clients", "2"]);
    let link = format!("modbus-tcp://{addr}");
    let mut first = start(&[
        "--link", &link, "move-rel", "30000", "--speed", "100", "--wait",
    ]);
    std::thread::sleep(Duration::from_millis(1000));
    let mut second = start(&[
        "--link", &link, "move-abs", "-5000", "--speed", "300", "--wait",
    ]);
    let status = first
        .wait(Duration::from_secs(35))
        .unwrap_or_else(|| panic!("the first master still waits: {}", first.report()));
    let said = first.report();
    assert!(!status.success(), "the first master was told done: {said}");
    assert!(
        said.contains("another master writes the PDI image"),
        "the first master: {said}"
    );
    let status = second
        .wait(Duration::from_secs(35))
        .unwrap_or_else(|| panic!("the second master still waits: {}", second.report()));
    let said = second.report();
    if status.success() {
        // Told done: then the drive is where it was sent.
        let position = json(&["--link", &link, "status"])["position"]
            .as_f64()
            .expect("a position");
        assert!(
            (position + 5000.0).abs() <= 10.0,
            "the second master was told done at {position}: {said}"
        );
    } else {
        assert!(
            said.contains("another master writes the PDI image"),
            "the second master: {said}"
        );
    }
}

/// Two command lines on one EtherNet/IP adapter (the drill: the second was refused the I/O
/// connection, fell back to SetOD 2291h, the first's class 1 image overwrote it, both
/// were told "done" and the drive ended at neither target). The second is refused at
/// once, naming the other master; the first's move is untouched and really done.
#[test]
fn a_second_enip_master_is_refused_and_the_first_move_ends_at_its_target() {
    let (_sim, addr) = Sim::enip(&[]);
    let link = format!("enip://{addr}?udp=0&rpi=10");
    let mut first = start(&[
        "--link", &link, "move-rel", "30000", "--speed", "300", "--wait",
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    let (code, stdout, stderr) = common::cli::run(&[
        "--link", &link, "move-abs", "-5000", "--speed", "300", "--wait",
    ]);
    let said = format!("{stdout}{stderr}");
    assert_ne!(code, 0, "the second master: {said}");
    assert!(
        said.contains("another master owns the drive's I/O connection"),
        "the second master: {said}"
    );
    let status = first
        .wait(Duration::from_secs(40))
        .unwrap_or_else(|| panic!("the first master still waits: {}", first.report()));
    let report = first.report();
    assert!(status.success(), "the first master: {report}");
    assert!(report.contains("done (ReturnValue 30000)"), "{report}");
}
