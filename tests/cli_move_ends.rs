//! How a command that moves the motor or records ends when it cannot end as asked
//! (issue 26):
//!
//! - a `--wait` ends as soon as the target can no longer be reached (the drive at a limit
//!   switch, a fault mid-move, a quick stop from another master) and names it, with the
//!   position where the drive stopped; a fault or a power loss is judged after reading
//!   the statusword 6041h again;
//! - a PDI status forged in one Modbus reply ("not Operation enabled") is checked by
//!   reading 6041h again, and the drive, found running, is halted by `--on-exit`;
//! - a Modbus TCP connection reset once during a move or a recording, the server
//!   reachable again at once, is opened again within the `--lost-after` budget and the
//!   command goes on; a connection that stays dead gets its last halt over a new one;
//! - an EtherNet/IP adapter stall shorter than `--lost-after` does not end a recording or
//!   a move: the I/O connection is opened again, and the fault the drive latched
//!   meanwhile (8000h) is named.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use common::cli::{run, start};
use common::{Process, Sim, modbus_server};
use drivedeck::injection::Injection;
use drivedeck::pdi::StatusBit;
use drivedeck::sim::Load;
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
    eprintln!("{stderr}");
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
    eprintln!("{report}");
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

#[test]
fn an_axis_that_does_not_follow_ends_the_wait_and_is_halted() {
    // A load the motor cannot move at its rated torque, in closed loop (after an auto
    // setup): the axis stalls. The drive's factory reaction to a following error is none
    // (3700h), so only PdiStatusFollowingError says it; the wait must not push on to
    // --timeout.
    let server = modbus_server(ServerOptions::default());
    let link = format!("modbus-tcp://{}", server.addr);
    let (code, out, err) = run(&["--link", &link, "auto-setup", "--wait"]);
    assert_eq!(code, 0, "{out}{err}");
    server.drive().lock().set_load(Load {
        inertia: 50.0,
        torque: 1000.0,
    });
    let blocked = Instant::now();
    let mut mover = start(&[
        "--link", &link, "move-abs", "20000", "--speed", "3000", "--wait",
    ]);
    let code = exit_code(&mut mover, Duration::from_secs(15));
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("Check what blocks or loads the axis"),
        "what to do leads: {report}"
    );
    assert!(report.contains("PdiStatusFollowingError"), "{report}");
    assert!(report.contains("behind (60F4h)"), "{report}");
    assert!(report.contains("target not reached"), "{report}");
    assert!(!report.contains("timed out"), "{report}");
    // Functional bound only: ended on the following error, not the 30 s --timeout.
    assert!(blocked.elapsed() < Duration::from_secs(15), "{report}");
    // Not a fault: the drive is still enabled, and was halted on the way out.
    let tx = server.drive().lock().tx_image();
    // 603Fh holds 8611h as a warning (PdiStatusWarning), not a fault.
    assert!(!tx.status.is_set(StatusBit::Fault), "no fault: {tx:?}");
    assert!(
        tx.status.is_set(StatusBit::OperationEnabled) && tx.status.is_set(StatusBit::QsHaltBit),
        "--on-exit halt: {tx:?} {report}"
    );
}

/// A Modbus TCP proxy in front of a served drive that can reset the connections it
/// carries (the client's connection aborted with an RST, the server's closed; the server
/// stays reachable through the proxy at once) and forge the PDI status of a reply.
struct ResetProxy {
    addr: std::net::SocketAddr,
    /// The client-side and server-side streams of the connections open now.
    open: Arc<Mutex<Vec<(TcpStream, TcpStream)>>>,
    /// Connections accepted so far.
    accepted: Arc<AtomicUsize>,
    /// FC 23 replies still to forge: PdiStatusOperationEnabled cleared in the PDI status
    /// register 4996 (the frame's word against the drive's).
    forge: Arc<AtomicUsize>,
}

impl ResetProxy {
    fn start(upstream: std::net::SocketAddr) -> ResetProxy {
        let listener = TcpListener::bind("127.0.0.1:0").expect("proxy port");
        let addr = listener.local_addr().expect("proxy address");
        let open: Arc<Mutex<Vec<(TcpStream, TcpStream)>>> = Arc::default();
        let accepted = Arc::new(AtomicUsize::new(0));
        let forge = Arc::new(AtomicUsize::new(0));
        let (kept, count, forging) = (open.clone(), accepted.clone(), forge.clone());
        thread::spawn(move || {
            for client in listener.incoming() {
                let Ok(client) = client else { return };
                let Ok(server) = TcpStream::connect(upstream) else {
                    return;
                };
                let _ = client.set_nodelay(true);
                let _ = server.set_nodelay(true);
                count.fetch_add(1, Ordering::SeqCst);
                kept.lock().unwrap().push((
                    client.try_clone().expect("clone"),
                    server.try_clone().expect("clone"),
                ));
                pipe(
                    client.try_clone().expect("clone"),
                    server.try_clone().expect("clone"),
                );
                replies(server, client, forging.clone());
            }
        });
        ResetProxy {
            addr,
            open,
            accepted,
            forge,
        }
    }

    /// Forge the next `count` FC 23 replies: the drive "left Operation enabled".
    fn forge_power_lost(&self, count: usize) {
        self.forge.store(count, Ordering::SeqCst);
    }

    /// Reset every connection open now: the client's side is closed with SO_LINGER 0
    /// once every copy of it is dropped (an RST, not a FIN), the server's side closed.
    fn reset(&self) {
        for (client, server) in self.open.lock().unwrap().drain(..) {
            abort(&client);
            // Ends the copying both ways, so that the last copy of the socket closes.
            let _ = client.shutdown(Shutdown::Read);
            let _ = server.shutdown(Shutdown::Both);
        }
    }

    fn accepted(&self) -> usize {
        self.accepted.load(Ordering::SeqCst)
    }
}

/// SO_LINGER 0: closing the socket resets the connection (RST) instead of closing it.
fn abort(stream: &TcpStream) {
    use std::os::fd::AsRawFd;
    let linger = libc::linger {
        l_onoff: 1,
        l_linger: 0,
    };
    // SAFETY: a valid socket descriptor and a linger struct of the size given.
    let _ = unsafe {
        libc::setsockopt(
            stream.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            (&linger as *const libc::linger).cast(),
            std::mem::size_of::<libc::linger>() as libc::socklen_t,
        )
    };
}

/// Copy `from` (the client) to `to` (the server) until either ends.
fn pipe(mut from: TcpStream, mut to: TcpStream) {
    thread::spawn(move || {
        let mut buffer = [0u8; 4096];
        loop {
            match from.read(&mut buffer) {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    if to.write_all(&buffer[..n]).is_err() {
                        break;
                    }
                }
            }
        }
        let _ = to.shutdown(Shutdown::Both);
    });
}

/// Copy the server's Modbus TCP replies to the client frame by frame, forging the FC 23
/// ones `forge` asks for.
fn replies(mut from: TcpStream, mut to: TcpStream, forge: Arc<AtomicUsize>) {
    thread::spawn(move || {
        loop {
            let mut header = [0u8; 7];
            if from.read_exact(&mut header).is_err() {
                break;
            }
            let len = usize::from(u16::from_be_bytes([header[4], header[5]]));
            let mut body = vec![0u8; len.saturating_sub(1)];
            if from.read_exact(&mut body).is_err() {
                break;
            }
            // body: FC, byte count, registers (big-endian) from 4996, the PDI status.
            if body.first() == Some(&0x17)
                && body.len() >= 4
                && forge
                    .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                    .is_ok()
            {
                body[3] &= !1;
            }
            if to.write_all(&header).is_err() || to.write_all(&body).is_err() {
                break;
            }
        }
        // Dropped, not shut down: a reset closes the client's side with an RST.
    });
}

#[test]
fn a_forged_power_loss_is_checked_by_reading_6041h_again_and_the_running_drive_is_halted() {
    let server = modbus_server(ServerOptions::default());
    let proxy = ResetProxy::start(server.addr);
    let link = format!("modbus-tcp://{}", proxy.addr);
    let mut mover = start(&[
        "--link", &link, "move-rel", "300000", "--speed", "60", "--wait",
    ]);
    common::wait_until("the move", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() > 10.0
    });
    proxy.forge_power_lost(1);
    let code = exit_code(&mut mover, Duration::from_secs(20));
    let report = mover.report();
    eprintln!("{report}");
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
    let drive = server.drive().lock();
    assert!(drive.velocity_rpm().abs() < 0.5, "{report}");
    assert!(
        drive
            .pdi_status()
            .is_set(drivedeck::pdi::StatusBit::QsHaltBit),
        "halted: {report}"
    );
}

#[test]
fn a_connection_reset_once_during_a_move_is_reopened_and_the_move_completes() {
    let server = modbus_server(ServerOptions::default());
    let proxy = ResetProxy::start(server.addr);
    let link = format!("modbus-tcp://{}", proxy.addr);
    let start_at = server.drive().lock().position();
    let mut mover = start(&[
        "--link",
        &link,
        "--json",
        "--lost-after",
        "3",
        "move-rel",
        "30000",
        "--speed",
        "120",
        "--wait",
    ]);
    common::wait_until("the move", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() > 10.0
    });
    proxy.reset();
    let code = exit_code(&mut mover, Duration::from_secs(30));
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(code, 0, "the move completed: {report}");
    assert!(
        report.contains("the connection to the drive was opened again"),
        "{report}"
    );
    assert!(proxy.accepted() >= 2, "a new connection: {report}");
    let end = server.drive().lock().position();
    assert!(
        (end - start_at - 30_000.0).abs() < 2.0,
        "at the target: {start_at} -> {end}: {report}"
    );
}

#[test]
fn the_last_halt_after_a_reset_goes_over_a_new_connection_and_halts_the_drive() {
    let server = modbus_server(ServerOptions::default());
    let proxy = ResetProxy::start(server.addr);
    let link = format!("modbus-tcp://{}", proxy.addr);
    // --lost-after 1: the reset ends the move, and the halt must reach the drive.
    let mut mover = start(&[
        "--link",
        &link,
        "--lost-after",
        "1",
        "move-rel",
        "300000",
        "--speed",
        "60",
        "--wait",
    ]);
    common::wait_until("the move", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() > 10.0
    });
    proxy.reset();
    let code = exit_code(&mut mover, Duration::from_secs(15));
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("halt was sent over a new connection and the drive confirmed it"),
        "{report}"
    );
    common::wait_until("standstill", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() < 0.5
    });
    let drive = server.drive().lock();
    assert!(
        drive
            .pdi_status()
            .is_set(drivedeck::pdi::StatusBit::QsHaltBit),
        "halted: {report}"
    );
}

#[test]
fn an_enip_adapter_stall_shorter_than_lost_after_does_not_end_a_recording_and_the_latched_fault_is_named()
 {
    let dir = common::temp_dir("record-enip-stall");
    let out = dir.path().join("stall.csv");
    let out = out.to_str().expect("utf-8 path");
    let (sim, addr) = Sim::enip(&[]);
    let link = format!("enip://{addr}?io=pdi");
    let mut recorder = start(&[
        "--link",
        &link,
        "--lost-after",
        "20",
        "--json",
        "record",
        "--duration",
        "7s",
        "--out",
        out,
    ]);
    thread::sleep(Duration::from_millis(2000));
    // The adapter stalls for 3 s: its I/O connection times out on both sides.
    sim.process.signal("STOP");
    thread::sleep(Duration::from_millis(3000));
    sim.process.signal("CONT");
    let code = exit_code(&mut recorder, Duration::from_secs(30));
    let report = recorder.report();
    eprintln!("{report}");
    assert_eq!(code, 0, "the recording went on: {report}");
    let json: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    assert!(json["ended_early"].is_null(), "{report}");
    let notes = json["notes"].to_string();
    assert!(
        notes.contains("the connection to the drive was opened again"),
        "the I/O connection was opened again: {notes}"
    );
    // Whether the adapter's side of the I/O connection timed out (and the drive latched
    // 8000h) depends on when the stopped adapter reads the datagrams queued meanwhile; a
    // fault the drive holds now must be named, and none claimed that it does not hold.
    let status = common::cli::json(&["--link", &link, "status"]);
    let latched = status["error_code"].as_u64() == Some(0x8000);
    assert_eq!(
        notes.contains("the drive latched a fault meanwhile: 603Fh = 8000h"),
        latched,
        "the fault latched across the outage is named, and only then: {notes}; status {status:#}"
    );
}

#[test]
fn a_connection_reset_once_during_a_recording_is_reopened_and_the_recording_goes_on() {
    let dir = common::temp_dir("record-reset");
    let out = dir.path().join("reset.csv");
    let out = out.to_str().expect("utf-8 path");
    let server = modbus_server(ServerOptions::default());
    let proxy = ResetProxy::start(server.addr);
    let link = format!("modbus-tcp://{}", proxy.addr);
    let mut recorder = start(&[
        "--link",
        &link,
        "--json",
        "record",
        "--duration",
        "3s",
        "--out",
        out,
    ]);
    common::wait_until("the connection", Duration::from_secs(10), || {
        proxy.accepted() >= 1
    });
    thread::sleep(Duration::from_millis(1000));
    proxy.reset();
    let code = exit_code(&mut recorder, Duration::from_secs(30));
    let report = recorder.report();
    eprintln!("{report}");
    assert_eq!(code, 0, "the recording went on: {report}");
    let json: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    assert!(json["ended_early"].is_null(), "{report}");
    assert!(
        json["notes"]
            .to_string()
            .contains("the connection to the drive was opened again"),
        "{report}"
    );
    assert!(proxy.accepted() >= 2, "a new connection: {report}");
}

#[test]
fn a_quick_stop_from_elsewhere_ends_the_wait_naming_the_power_state_read_again() {
    let server = modbus_server(ServerOptions::default());
    let link = format!("modbus-tcp://{}", server.addr);
    let mut mover = start(&[
        "--link", &link, "move-rel", "300000", "--speed", "60", "--wait",
    ]);
    common::wait_until("the move", Duration::from_secs(10), || {
        server.drive().lock().velocity_rpm().abs() > 10.0
    });
    // Another master writes the controlword: Quick stop (0bxxxx x01x).
    server
        .drive()
        .lock()
        .write(
            drivedeck::od::Address::new(0x6040, 0),
            drivedeck::od::Value::Uint(0x0002),
        )
        .expect("controlword written");
    let code = exit_code(&mut mover, Duration::from_secs(20));
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("drivedeck: Find what took the drive out of Operation enabled"),
        "what to do leads: {report}"
    );
    assert!(report.contains("the drive read again is in "), "{report}");
    assert!(report.contains("at position "), "{report}");
    assert!(!report.contains("timed out"), "{report}");
}

#[test]
fn an_enip_adapter_stall_during_a_move_names_the_fault_the_drive_latched() {
    let (sim, addr) = Sim::enip(&[]);
    let link = format!("enip://{addr}?io=pdi");
    let mut mover = start(&[
        "--link",
        &link,
        "--lost-after",
        "20",
        "move-rel",
        "300000",
        "--speed",
        "60",
        "--wait",
    ]);
    thread::sleep(Duration::from_millis(2000));
    assert!(mover.running(), "the move runs: {}", mover.report());
    sim.process.signal("STOP");
    thread::sleep(Duration::from_millis(3000));
    sim.process.signal("CONT");
    let code = exit_code(&mut mover, Duration::from_secs(30));
    let report = mover.report();
    eprintln!("{report}");
    assert_eq!(code, 1, "{report}");
    assert!(
        report.contains("drivedeck: Clear the fault (`drivedeck clear-error`) once the link is sound: the drive's fieldbus monitoring tripped while its link was down"),
        "{report}"
    );
    assert!(
        report.contains("603Fh = 8000h"),
        "the fault latched across the outage is named: {report}"
    );
    assert!(!report.contains("the link was lost"), "{report}");
}
