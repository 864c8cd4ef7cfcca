//! The command line at its edges, against a served simulator as a user would meet them:
//! Ctrl-C, SIGTERM and SIGHUP during a move (the drive is found stopped afterwards, as
//! `--on-exit` says), a `--wait` that times out, moves that cannot move refused before
//! anything is sent, recordings cut short by a signal, a lost link or a failed write (the
//! file is there, whole, and says why), and `--trace` showing the frames of a failure.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::Write;
use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use common::cli::{self, ok, run, start};
use common::{Process, Sim, eventually, temp_dir};
use drivedeck::telemetry::Recording;

fn link(addr: SocketAddr) -> String {
    format!("modbus-tcp://{addr}")
}

/// The drive's status as the command line reports it (JSON).
fn status(addr: SocketAddr) -> serde_json::Value {
    let (stdout, _) = ok(&["--link", &link(addr), "--json", "status"]);
    serde_json::from_str(&stdout).expect("JSON status")
}

fn bits(status: &serde_json::Value) -> Vec<String> {
    status["bits"]
        .as_array()
        .map(|bits| {
            bits.iter()
                .filter(|b| b["set"].as_bool() == Some(true))
                .filter_map(|b| b["name"].as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

fn velocity(status: &serde_json::Value) -> f64 {
    status["velocity"].as_f64().unwrap_or(f64::NAN)
}

fn position(status: &serde_json::Value) -> f64 {
    status["position"].as_f64().unwrap_or(f64::NAN)
}

/// The exit code of a process that should end by itself within `timeout`.
fn exit_code(process: &mut Process, timeout: Duration) -> i32 {
    match process.wait(timeout) {
        Some(status) => status.code().unwrap_or(-1),
        None => panic!("still running after {timeout:?}: {}", process.report()),
    }
}

/// A long relative move, well inside the simulated axis's limit switches: eight turns at
/// one turn a second.
const LONG_MOVE: [&str; 5] = ["move-rel", "30000", "--speed", "60", "--wait"];

/// `ARGS` started against the drive at `addr`, `signal` sent after `after`: the exit code
/// (130 expected) and what the command said.
fn interrupt(addr: SocketAddr, args: &[&str], signal_name: &str, after: Duration) -> String {
    let link = link(addr);
    let mut all = vec!["--link", link.as_str()];
    all.extend_from_slice(args);
    let mut process = start(&all);
    thread::sleep(after);
    assert!(
        process.running(),
        "ended before the signal: {}",
        process.report()
    );
    process.signal(signal_name);
    let code = exit_code(&mut process, Duration::from_secs(15));
    let report = process.report();
    assert_eq!(code, 130, "{args:?}: {report}");
    report
}

/// The long move with `options` before it, interrupted by `signal_name` once it has run
/// for a while (the served drive allows one client at a time, so the test cannot watch
/// it meanwhile): what the command said.
fn interrupt_the_long_move(addr: SocketAddr, options: &[&str], signal_name: &str) -> String {
    let mut args = options.to_vec();
    args.extend_from_slice(&LONG_MOVE);
    interrupt(addr, &args, signal_name, Duration::from_millis(1200))
}

#[test]
fn ctrl_c_during_a_move_halts_the_drive_says_so_and_exits_130() {
    let (_sim, addr) = Sim::tcp(&[]);
    let report = interrupt_the_long_move(addr, &[], "INT");
    assert!(report.contains("interrupted by SIGINT"), "{report}");
    assert!(
        report.contains("halt sent; the drive confirmed it: it stands still"),
        "{report}"
    );
    // Found stopped afterwards: the halt bit set, no speed, the position no longer moving.
    let first = status(addr);
    assert!(
        bits(&first).iter().any(|b| b == "PdiStatusQsHaltBit"),
        "{first}"
    );
    assert_eq!(velocity(&first), 0.0, "{first}");
    thread::sleep(Duration::from_millis(300));
    let later = status(addr);
    assert_eq!(position(&first), position(&later), "{first} / {later}");
    assert!(position(&later) > 100.0, "it had moved: {later}");
}

#[test]
fn sigterm_with_on_exit_switch_off_leaves_the_power_stage_off() {
    let (_sim, addr) = Sim::tcp(&[]);
    let report = interrupt_the_long_move(addr, &["--on-exit", "switch-off"], "TERM");
    assert!(report.contains("interrupted by SIGTERM"), "{report}");
    assert!(report.contains("switch-off sent"), "{report}");
    let after = status(addr);
    assert!(
        !bits(&after)
            .iter()
            .any(|b| b == "PdiStatusOperationEnabled"),
        "{after}"
    );
}

#[test]
fn sighup_with_on_exit_leave_leaves_the_drive_moving_and_says_so() {
    let (_sim, addr) = Sim::tcp(&[]);
    let report = interrupt_the_long_move(addr, &["--on-exit", "leave"], "HUP");
    assert!(report.contains("interrupted by SIGHUP"), "{report}");
    assert!(
        report.contains("left as it is (--on-exit leave): it still turns at 60 rpm"),
        "{report}"
    );
    let after = status(addr);
    assert!(velocity(&after) > 30.0, "it was left moving: {after}");
    ok(&["--link", &link(addr), "halt"]);
}

#[test]
fn ctrl_c_during_a_velocity_ramp_halts_it() {
    let (_sim, addr) = Sim::tcp(&[]);
    // A slow ramp (10 rpm/s): the velocity command takes half a minute to arrive.
    ok(&["--link", &link(addr), "write", "6083", "10"]);
    let report = interrupt(
        addr,
        &["velocity", "300", "--wait"],
        "INT",
        Duration::from_millis(1500),
    );
    assert!(
        report.contains("halt sent; the drive confirmed it"),
        "{report}"
    );
    let after = status(addr);
    assert_eq!(velocity(&after), 0.0, "{after}");
}

#[test]
fn sigterm_while_the_torque_builds_up_halts_the_drive() {
    let (_sim, addr) = Sim::tcp(&[]);
    // 10 ‰/s: 100 ‰ takes ten seconds to build up.
    let args = [
        "torque",
        "100",
        "--max-speed",
        "300",
        "--slope",
        "10",
        "--wait",
    ];
    let report = interrupt(addr, &args, "TERM", Duration::from_millis(1500));
    assert!(report.contains("interrupted by SIGTERM"), "{report}");
    assert!(
        report.contains("halt sent; the drive confirmed it"),
        "{report}"
    );
    let after = status(addr);
    assert_eq!(velocity(&after), 0.0, "{after}");
}

#[test]
fn ctrl_c_during_homing_quick_stops_it_because_a_halt_cannot() {
    let (_sim, addr) = Sim::tcp(&[]);
    let report = interrupt(
        addr,
        &["home", "--method", "17", "--wait"],
        "INT",
        Duration::from_millis(1500),
    );
    assert!(
        report.contains("no halt ("),
        "the halt bit acts on travel commands only: {report}"
    );
    assert!(
        report.contains("so quick stop sent; the drive confirmed it"),
        "{report}"
    );
    thread::sleep(Duration::from_millis(300));
    let after = status(addr);
    assert_eq!(velocity(&after), 0.0, "{after}");
    assert!(
        !bits(&after).iter().any(|b| b == "PdiStatusHomingDone"),
        "homing was cut short: {after}"
    );
}

#[test]
fn sighup_during_auto_setup_with_on_exit_switch_off_switches_the_drive_off() {
    let (_sim, addr) = Sim::tcp(&[]);
    let args = ["--on-exit", "switch-off", "auto-setup", "--wait"];
    let report = interrupt(addr, &args, "HUP", Duration::from_millis(1000));
    assert!(report.contains("interrupted by SIGHUP"), "{report}");
    assert!(
        report.contains("switch-off sent; the drive confirmed it"),
        "{report}"
    );
    let after = status(addr);
    let set = bits(&after);
    assert!(
        !set.iter().any(|b| b == "PdiStatusOperationEnabled"),
        "{after}"
    );
    assert!(
        !set.iter().any(|b| b == "PdiStatusAutosetupDone"),
        "{after}"
    );
}

#[test]
fn a_wait_that_times_out_stops_the_move_and_says_so() {
    let (_sim, addr) = Sim::tcp(&[]);
    let link = link(addr);
    let mut args = vec!["--link", link.as_str(), "--timeout", "1"];
    args.extend_from_slice(&LONG_MOVE);
    let (code, stdout, stderr) = run(&args);
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(stderr.contains("timed out after 1.0 s"), "{stderr}");
    assert!(
        stderr.contains("halt sent; the drive confirmed it"),
        "{stderr}"
    );
    let after = status(addr);
    assert_eq!(velocity(&after), 0.0, "{after}");
    // Halted, not carried on by a later command: the position stays.
    thread::sleep(Duration::from_millis(300));
    assert_eq!(position(&after), position(&status(addr)));
}

#[test]
fn a_move_that_cannot_move_is_refused_before_anything_is_sent() {
    // Max speed 0: refused before connecting (nothing listens at port 1).
    let (code, _, stderr) = run(&[
        "--link",
        "modbus-tcp://127.0.0.1:1",
        "move-abs",
        "1000",
        "--speed",
        "0",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("max speed of 0 rpm"), "{stderr}");
    assert!(!stderr.contains("cannot connect"), "{stderr}");
    for command in [
        vec!["move-rel", "1000", "--speed", "0"],
        vec!["torque", "100", "--max-speed", "0", "--slope", "1000"],
    ] {
        let mut args = vec!["--link", "modbus-tcp://127.0.0.1:1"];
        args.extend_from_slice(&command);
        let (code, _, stderr) = run(&args);
        assert_eq!(code, 2, "{command:?}: {stderr}");
        assert!(
            stderr.contains(&format!("{}: a max speed of 0 rpm", command[0])),
            "{stderr}"
        );
        assert!(!stderr.contains("cannot connect"), "{stderr}");
    }
    // A ramp at 0 on the drive: refused after reading it, nothing sent.
    let (_sim, addr) = Sim::tcp(&[]);
    let link = link(addr);
    for (object, name) in [("6083", "acceleration"), ("6084", "deceleration")] {
        ok(&["--link", &link, "write", object, "0"]);
        for command in [
            vec!["move-rel", "900", "--speed", "100"],
            vec!["move-abs", "900", "--speed", "100"],
            vec!["velocity", "100"],
        ] {
            let mut args = vec!["--link", link.as_str()];
            args.extend_from_slice(&command);
            let (code, _, stderr) = run(&args);
            assert_eq!(code, 1, "{command:?}: {stderr}");
            assert!(
                stderr.contains(&format!("profile {name} {object}h is 0")),
                "{stderr}"
            );
            assert!(stderr.contains("nothing was sent"), "{stderr}");
        }
        let after = status(addr);
        assert_eq!(after["state"], "Switch on disabled", "nothing ran: {after}");
        ok(&["--link", &link, "write", object, "1000"]);
    }
}

/// `drivedeck record` into `dir`, JSON report.
fn record_args<'a>(link: &'a str, out: &'a str, duration: &'a str) -> Vec<&'a str> {
    vec![
        "--link",
        link,
        "--json",
        "record",
        "--signals",
        "position,velocity,pdi_status",
        "--rate",
        "200",
        "--duration",
        duration,
        "--out",
        out,
    ]
}

fn read_back(path: &str) -> Recording {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    if path.ends_with(".json") {
        Recording::from_json(&text).expect("JSON recording")
    } else {
        Recording::from_csv(&text).expect("CSV recording")
    }
}

#[test]
fn a_recording_cut_short_by_ctrl_c_keeps_every_sample_and_says_why() {
    let dir = temp_dir("record-int");
    let out = dir.path().join("run.csv");
    let out = out.to_str().expect("utf-8 path");
    let mut recorder = start(&record_args("sim", out, "30s"));
    thread::sleep(Duration::from_millis(1500));
    recorder.signal("INT");
    let code = exit_code(&mut recorder, Duration::from_secs(10));
    assert_eq!(code, 130, "{}", recorder.report());
    let report: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    let recording = read_back(out);
    assert_eq!(report["samples"].as_u64(), Some(recording.len() as u64));
    // About a second of 200 Hz, from t = 0.
    assert!(recording.len() > 100, "{} samples", recording.len());
    assert!(recording.times[0] < 0.1, "starts at {}", recording.times[0]);
    let why = recording
        .meta
        .ended_early
        .clone()
        .expect("ended_early line");
    assert!(why.contains("interrupted by SIGINT"), "{why}");
    assert!(why.contains("at t = "), "{why}");
    assert_eq!(report["ended_early"].as_str(), Some(why.as_str()));
}

#[test]
fn a_recording_cut_short_by_a_lost_link_keeps_every_sample_and_exits_1() {
    let dir = temp_dir("record-lost");
    let out = dir.path().join("run.json");
    let out = out.to_str().expect("utf-8 path");
    let (sim, addr) = Sim::tcp(&[]);
    let link = link(addr);
    let mut args = vec!["--lost-after", "1"];
    args.extend(record_args(&link, out, "30s"));
    let mut recorder = start(&args);
    thread::sleep(Duration::from_millis(1500));
    drop(sim); // the drive's plug is pulled
    let code = exit_code(&mut recorder, Duration::from_secs(15));
    assert_eq!(code, 1, "{}", recorder.report());
    let recording = read_back(out);
    assert!(recording.len() > 100, "{} samples", recording.len());
    let why = recording.meta.ended_early.clone().expect("ended_early");
    assert!(why.contains("the link was lost"), "{why}");
    assert!(
        why.contains("closed the connection")
            || why.contains("Connection reset")
            || why.contains("no answer"),
        "the real cause: {why}"
    );
}

#[test]
fn a_recording_whose_place_goes_away_is_saved_elsewhere_and_says_where() {
    let dir = temp_dir("record-gone");
    let sub = dir.path().join("gone");
    std::fs::create_dir_all(&sub).expect("dir");
    let out = sub.join("run.csv");
    let out = out.to_str().expect("utf-8");
    let mut recorder = start(&record_args("sim", out, "1s"));
    thread::sleep(Duration::from_millis(400));
    std::fs::remove_dir_all(&sub).expect("remove the directory mid-recording");
    let code = exit_code(&mut recorder, Duration::from_secs(10));
    assert_eq!(code, 1, "{}", recorder.report());
    let report: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    let elsewhere = report["file"].as_str().expect("file").to_owned();
    assert_ne!(elsewhere, out);
    let warnings = report["warnings"].to_string();
    assert!(warnings.contains("cannot write"), "{warnings}");
    assert!(warnings.contains(&elsewhere), "{warnings}");
    let recording = read_back(&elsewhere);
    assert!(recording.len() > 150, "{} samples", recording.len());
    let _ = std::fs::remove_file(&elsewhere);
}

#[test]
fn a_recording_no_place_takes_is_said_lost_and_exits_1() {
    let dir = temp_dir("record-nowhere");
    let sub = dir.path().join("gone");
    std::fs::create_dir_all(&sub).expect("dir");
    let out = sub.join("run.csv");
    let out = out.to_str().expect("utf-8");
    let mut command = cli::command();
    // The temporary directory, the place of last resort, does not exist either.
    command
        .args(record_args("sim", out, "1s"))
        .env("TMPDIR", dir.path().join("no-tmp"));
    let mut recorder = Process::spawn("drivedeck record", &mut command);
    thread::sleep(Duration::from_millis(400));
    std::fs::remove_dir_all(&sub).expect("remove the directory mid-recording");
    let code = exit_code(&mut recorder, Duration::from_secs(10));
    assert_eq!(
        code,
        1,
        "a lost recording is no success: {}",
        recorder.report()
    );
    let report: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    assert!(report["file"].is_null(), "no file to name: {report}");
    let warnings = report["warnings"].to_string();
    assert!(warnings.contains("the recording is lost"), "{warnings}");
    assert!(warnings.contains("no-tmp"), "both places named: {warnings}");
}

/// `drivedeck move-rel` without --wait: the drive goes on moving after the command ends.
fn start_a_long_move(addr: SocketAddr) {
    let (code, stdout, stderr) =
        run(&["--link", &link(addr), "move-rel", "300000", "--speed", "60"]);
    assert_eq!(code, 0, "{stdout}{stderr}");
}

#[test]
fn ctrl_c_during_a_recording_of_a_moving_drive_halts_it_and_the_file_says_so() {
    let dir = temp_dir("record-moving");
    let out = dir.path().join("run.csv");
    let out = out.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::tcp(&[]);
    start_a_long_move(addr);
    let link = link(addr);
    let mut recorder = start(&record_args(&link, out, "30s"));
    thread::sleep(Duration::from_millis(1500));
    recorder.signal("INT");
    let code = exit_code(&mut recorder, Duration::from_secs(15));
    assert_eq!(code, 130, "{}", recorder.report());
    let report: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    let stopped = report["stopped"]
        .as_str()
        .expect("what was done to the drive");
    assert!(
        stopped.contains("halt sent; the drive confirmed it"),
        "{stopped}"
    );
    let recording = read_back(out);
    let why = recording.meta.ended_early.clone().expect("ended_early");
    assert!(why.contains("interrupted by SIGINT"), "{why}");
    assert!(why.contains("halt sent; the drive confirmed it"), "{why}");
    assert!(recording.len() > 100, "{} samples", recording.len());
    let after = status(addr);
    assert_eq!(velocity(&after), 0.0, "{after}");
}

#[test]
fn a_second_ctrl_c_while_the_drive_is_being_stopped_keeps_the_recording() {
    let dir = temp_dir("record-twice");
    let out = dir.path().join("run.csv");
    let out = out.to_str().expect("utf-8 path");
    let (sim, addr) = Sim::tcp(&[]);
    start_a_long_move(addr);
    let link = link(addr);
    let mut recorder = start(&record_args(&link, out, "30s"));
    thread::sleep(Duration::from_millis(1500));
    // A frozen drive: the stop cannot finish, and the user presses Ctrl-C again.
    sim.process.signal("STOP");
    recorder.signal("INT");
    thread::sleep(Duration::from_millis(600));
    recorder.signal("INT");
    let code = exit_code(&mut recorder, Duration::from_secs(10));
    sim.process.signal("CONT");
    assert_eq!(code, 130, "{}", recorder.report());
    assert!(
        recorder.report().contains("again: exiting now"),
        "{}",
        recorder.report()
    );
    let recording = read_back(out);
    assert!(recording.len() > 100, "{} samples", recording.len());
    let why = recording.meta.ended_early.clone().expect("ended_early");
    assert!(why.contains("interrupted by SIGINT"), "{why}");
    assert!(
        why.contains("the drive was being stopped (try to halt"),
        "the file says the stop was under way: {why}"
    );
}

#[test]
fn a_bad_out_path_fails_before_connecting() {
    let started = Instant::now();
    let (code, _, stderr) = run(&[
        "--link",
        "modbus-tcp://127.0.0.1:1",
        "record",
        "--out",
        "/nonexistent-dir/run.csv",
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("cannot write --out /nonexistent-dir/run.csv"),
        "{stderr}"
    );
    assert!(!stderr.contains("cannot connect"), "{stderr}");
    assert!(started.elapsed() < Duration::from_secs(5));
}

#[test]
fn a_slow_rate_samples_from_t_0() {
    let dir = temp_dir("record-slow");
    let out = dir.path().join("slow.csv");
    let out = out.to_str().expect("utf-8 path");
    ok(&[
        "--link",
        "sim",
        "record",
        "--rate",
        "1",
        "--duration",
        "2s",
        "--out",
        out,
    ]);
    let recording = read_back(out);
    assert_eq!(recording.len(), 3, "t = 0, 1, 2: {:?}", recording.times);
    assert!(recording.times[0] < 0.2, "{:?}", recording.times);
    assert_eq!(recording.meta.rate_hz, Some(1.0));
}

#[test]
fn the_file_says_the_rate_an_enip_io_connection_achieved() {
    let dir = temp_dir("record-enip");
    let out = dir.path().join("io.csv");
    let out = out.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::enip(&[]);
    let link = format!("enip://{addr}?udp=0&rpi=10");
    let (stdout, _) = ok(&[
        "--link",
        &link,
        "--json",
        "record",
        "--signals",
        "position,pdi_status",
        "--rate",
        "1000",
        "--duration",
        "1s",
        "--out",
        out,
    ]);
    let recording = read_back(out);
    let rate = recording.meta.rate_hz.expect("rate");
    assert!((70.0..=115.0).contains(&rate), "{rate} Hz at RPI 10 ms");
    assert_eq!(recording.meta.rate_asked_hz, Some(1000.0));
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    let warnings = report["warnings"].to_string();
    assert!(warnings.contains("one sample per RPI (10 ms"), "{warnings}");
}

#[test]
fn trace_shows_the_frames_of_a_failed_connection_before_the_error() {
    let (_sim, addr) = Sim::tcp(&[]);
    // Another client holds the drive's one Modbus TCP connection.
    let _other = std::net::TcpStream::connect(addr).expect("the first client");
    thread::sleep(Duration::from_millis(100));
    let (code, _, stderr) = run(&["--link", &link(addr), "--trace", "status"]);
    assert_eq!(code, 2, "{stderr}");
    let request = stderr.find("tx ").expect("the request frame is shown");
    let error = stderr.find("cannot connect").expect("the error");
    assert!(request < error, "{stderr}");
    assert!(stderr.contains("FC 43 request"), "{stderr}");
}

/// What a served simulator logs (at `DRIVEDECK_LOG=info`) when a second client is turned
/// away, with `env` set.
fn refusal_log(env: &[(&str, &str)]) -> String {
    let (mut sim, addr) = Sim::tcp_with(&[], |command| {
        command
            .env("DRIVEDECK_LOG", "info")
            .env_remove("NO_COLOR")
            .envs(env.iter().copied());
    });
    let _first = std::net::TcpStream::connect(addr).expect("first client");
    thread::sleep(Duration::from_millis(100));
    let _second = std::net::TcpStream::connect(addr).expect("second client");
    let process = &mut sim.process;
    eventually(
        "the log line of the refusal",
        Duration::from_secs(5),
        || {
            let report = process.report();
            report
                .contains("refused Modbus TCP client")
                .then_some(report)
        },
    )
}

#[test]
fn redirected_logs_carry_no_colour_codes() {
    // stderr is a pipe here, as when redirected to a file.
    let log = refusal_log(&[]);
    assert!(
        !log.contains('\u{1b}'),
        "escape codes in a redirected log: {log:?}"
    );
    let log = refusal_log(&[("NO_COLOR", "1")]);
    assert!(!log.contains('\u{1b}'), "{log:?}");
}

/// What `drivedeck --link sim status` logs at `DRIVEDECK_LOG=trace` on a terminal (a
/// pseudo-terminal made by util-linux's `script`), with `no_color` as NO_COLOR; `None`
/// where there is no `script`.
fn log_on_a_terminal(no_color: Option<&str>) -> Option<String> {
    let mut command = Command::new("script");
    command
        .args(["-qec"])
        .arg(format!(
            "{} --link sim status",
            env!("CARGO_BIN_EXE_drivedeck")
        ))
        .arg("/dev/null")
        .env("DRIVEDECK_LOG", "trace")
        .env_remove("NO_COLOR");
    if let Some(value) = no_color {
        command.env("NO_COLOR", value);
    }
    let out = command.output().ok()?;
    assert!(out.status.success(), "{out:?}");
    Some(String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn a_terminal_gets_colour_unless_no_color_is_set() {
    let Some(coloured) = log_on_a_terminal(None) else {
        common::skip("no `script` (util-linux) to make a terminal with");
        return;
    };
    assert!(coloured.contains("TRACE"), "{coloured:?}");
    assert!(
        coloured.contains('\u{1b}'),
        "a terminal gets colour: {coloured:?}"
    );
    let plain = log_on_a_terminal(Some("1")).expect("script ran before");
    assert!(plain.contains("TRACE"), "{plain:?}");
    assert!(!plain.contains('\u{1b}'), "NO_COLOR=1: {plain:?}");
    // no-color.org: an empty NO_COLOR is as if it were not set.
    let empty = log_on_a_terminal(Some("")).expect("script ran before");
    assert!(empty.contains('\u{1b}'), "NO_COLOR='': {empty:?}");
}

#[test]
fn trace_shows_a_refused_read_before_the_refusal_and_the_frames_of_closing() {
    let (code, _, stderr) = run(&[
        "--link",
        "canopen+sim://?node=1",
        "--trace",
        "read",
        "5FFF:00",
    ]);
    assert_eq!(code, 1, "{stderr}");
    let request = stderr
        .find("upload 5FFFh:00h")
        .unwrap_or_else(|| panic!("{stderr}"));
    let abort = stderr
        .find("SDO abort node 1 5FFFh:00h")
        .unwrap_or_else(|| panic!("{stderr}"));
    let error = stderr
        .find("drivedeck: read 5FFFh:00h: abort 06020000h")
        .unwrap_or_else(|| panic!("{stderr}"));
    assert!(request < abort && abort < error, "{stderr}");
    // Closing puts the PDO mapping back (TPDO1's COB-ID last): those frames show too.
    assert!(
        stderr[abort..].contains("download 1800h:01h"),
        "the frames of closing: {stderr}"
    );
}

#[test]
fn stdout_to_a_closed_pipe_is_no_panic() {
    let mut child = cli::command()
        .args(["od", "list"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    // Read nothing and close: every later write meets a broken pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("ends");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    let _ = std::io::stderr().flush();
}

#[test]
fn trace_shows_the_frames_of_a_failed_exchange_before_the_error() {
    let (sim, addr) = Sim::tcp(&[]);
    let link = link(addr);
    let mut mover = start(&[
        "--link",
        &link,
        "--trace",
        "--lost-after",
        "1",
        "move-rel",
        "30000",
        "--speed",
        "60",
        "--wait",
    ]);
    thread::sleep(Duration::from_millis(800));
    // A frozen drive: the socket stays open, nothing answers.
    sim.process.signal("STOP");
    let code = exit_code(&mut mover, Duration::from_secs(15));
    sim.process.signal("CONT");
    let report = mover.report();
    assert_eq!(code, 1, "{report}");
    let lines: Vec<&str> = report.lines().collect();
    let error = lines
        .iter()
        .position(|l| l.contains("the link was lost"))
        .unwrap_or_else(|| panic!("no error: {report}"));
    // The three tries of the failed exchange, sent and never answered, come before it.
    let tries: Vec<&&str> = lines[..error]
        .iter()
        .rev()
        .take_while(|l| l.starts_with("tx "))
        .collect();
    assert!(tries.len() >= 3, "{report}");
    // The same request each time (the exchange, FC 23, or the read of a signal the
    // exchange lacks, FC 43: whichever the drive froze under), a new transaction id each.
    let function = |line: &str| line.split("FC ").nth(1).map(str::to_owned);
    assert!(
        tries.iter().all(|l| function(l) == function(tries[0])
            && (l.contains("FC 23 request") || l.contains("FC 43 request"))),
        "{report}"
    );
    assert!(
        lines[error].contains("no answer within 500 ms"),
        "the real cause: {}",
        lines[error]
    );
}

#[test]
fn enable_switches_the_power_stage_on_without_moving_and_is_refused_while_turning() {
    let (_sim, addr) = Sim::tcp(&[]);
    let link = link(addr);
    let before = status(addr);
    assert_eq!(before["state"], "Switch on disabled", "{before}");
    let (text, _) = ok(&["--link", &link, "enable"]);
    assert!(
        text.contains("drive now   Operation enabled, velocity 0 rpm"),
        "{text}"
    );
    let after = status(addr);
    assert_eq!(after["state"], "Operation enabled", "{after}");
    assert_eq!(velocity(&after), 0.0, "{after}");
    assert_eq!(position(&after), position(&before), "enable moved nothing");

    // Turning: velocity 0 would brake it, so nothing is sent.
    ok(&["--link", &link, "velocity", "300", "--wait"]);
    let (code, _, stderr) = run(&["--link", &link, "enable"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("enable refused, nothing was sent"),
        "{stderr}"
    );
    assert!(velocity(&status(addr)) > 250.0, "still turning");
    ok(&["--link", &link, "halt"]);
}
