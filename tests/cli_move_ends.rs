//! How a command that moves the motor ends when the move cannot end as asked (issue 26):
//!
//! - a `--wait` ends as soon as the target can no longer be reached (the drive at a limit
//!   switch, a fault mid-move) and names it, with the position where the drive stopped;
//! - a Modbus TCP connection reset once during a move, the server reachable again at
//!   once, is reconnected within the `--lost-after` budget and the move completes; a
//!   connection that stays dead gets its last halt over a new connection.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::{Duration, Instant};

use common::cli::{run, start};
use common::{Process, modbus_server};
use drivedeck::injection::Injection;
use drivedeck::sim::server::modbus::ServerOptions;

/// The exit code of a process that should end by itself within `timeout`.
fn exit_code(process: &mut Process, timeout: Duration) -> i32 {
    match process.wait(timeout) {
        Some(status) => status.code().unwrap_or(-1),
        None => panic!("still running after {timeout:?}: {}", process.report()),
    }
}

/// The number after "at position " in `text`.
fn position_in(text: &str) -> f64 {
    let at = text.find("at position ").expect("the position is named") + "at position ".len();
    let digits: String = text[at..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '-' || *c == '.')
        .collect();
    digits.parse().expect("a number")
}

#[test]
fn a_move_into_a_limit_switch_ends_at_once_naming_the_switch_and_the_position() {
    let started = Instant::now();
    let (code, stdout, stderr) = run(&[
        "--link", "sim", "move-rel", "60000", "--speed", "300", "--wait",
    ]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(
        stderr.starts_with("drivedeck: Move the axis off the limit switch"),
        "what to do leads: {stderr}"
    );
    assert!(stderr.contains("PdiStatusLimitReached"), "{stderr}");
    assert!(stderr.contains("target not reached"), "{stderr}");
    assert!(!stderr.contains("timed out"), "{stderr}");
    // The simulated axis's positive limit switch is at +36000.
    let at = position_in(&stderr);
    assert!((36_000.0..38_000.0).contains(&at), "{at}: {stderr}");
    // A functional bound only: the 30 s --timeout did not end it.
    assert!(started.elapsed() < Duration::from_secs(20), "{stderr}");
}

#[test]
fn a_fault_mid_move_ends_the_wait_naming_the_fault_read_again_and_the_position() {
    let server = modbus_server(ServerOptions::default());
    let link = format!("modbus-tcp://{}", server.addr);
    let mut mover = start(&[
        "--link", &link, "move-rel", "300000", "--speed", "60", "--wait",
    ]);
    common::wait_until("the move", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() > 10.0
    });
    server.drive().lock().inject(Injection::OverCurrent);
    let code = exit_code(&mut mover, Duration::from_secs(15));
    let report = mover.report();
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("Remove the fault's cause, then clear it"),
        "{report}"
    );
    assert!(report.contains("2300h"), "the fault is named: {report}");
    assert!(
        report.contains("the drive read again is in Fault (6041h = "),
        "judged after reading the statusword again: {report}"
    );
    assert!(report.contains("at position "), "{report}");
    assert!(!report.contains("timed out"), "{report}");
}
