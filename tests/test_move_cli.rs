//! `drivedeck test-move`: the figures of every step of a back-and-forth test, against the
//! simulated drive; bad input refused before anything moves; a limit switch in the way
//! and a Ctrl-C end it with the steps measured so far and the drive stopped.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::Duration;

use common::Sim;
use common::cli::{fails, json, run, start};

#[test]
fn every_step_of_a_test_move_has_its_figures_and_the_summary_covers_them() {
    let report = json(&[
        "--link",
        "sim",
        "test-move",
        "--from",
        "0",
        "--to",
        "2000",
        "--speed",
        "300",
        "--dwell",
        "0.3",
        "--cycles",
        "2",
    ]);
    let steps = report["steps"].as_array().expect("steps");
    assert_eq!(steps.len(), 4, "{report:#}");
    for (i, step) in steps.iter().enumerate() {
        let (from, to) = if i % 2 == 0 { (0, 2000) } else { (2000, 0) };
        assert_eq!(step["from"], from, "{step:#}");
        assert_eq!(step["to"], to, "{step:#}");
        assert_eq!(step["cycle"], i as u64 / 2 + 1, "{step:#}");
        let figure = |name: &str| step[name].as_f64().unwrap_or(f64::NAN);
        // A trapezoid profile at 300 rpm over 200°: well under a second, no overshoot.
        for name in ["rise_time_s", "settling_time_s", "time_to_target_reached_s"] {
            let value = figure(name);
            assert!(value > 0.0 && value < 2.0, "{name} = {value}: {step:#}");
        }
        assert!(
            figure("rise_time_s") < figure("settling_time_s"),
            "{step:#}"
        );
        assert_eq!(figure("overshoot"), 0.0, "{step:#}");
        assert!(
            figure("steady_state_error").abs() <= figure("band"),
            "{step:#}"
        );
        assert!(figure("peak_following_error") > 0.0, "{step:#}");
    }
    assert_eq!(report["summary"]["rise_time_s"]["steps"], 4, "{report:#}");
    assert!(report.get("ended_early").is_none(), "{report:#}");
}

#[test]
fn a_test_move_that_cannot_work_is_refused_before_anything_moves() {
    for (args, said) in [
        (
            &["--from", "5", "--to", "5", "--speed", "100"][..],
            "the same position",
        ),
        (
            &["--from", "0", "--to", "5", "--speed", "0"][..],
            "--speed 0",
        ),
        (
            &[
                "--from", "0", "--to", "5", "--speed", "100", "--cycles", "0",
            ][..],
            "--cycles 0 is out of range",
        ),
        (
            &["--from", "0", "--to", "5", "--speed", "99999"][..],
            "99999",
        ),
    ] {
        let mut all = vec!["--link", "sim", "test-move"];
        all.extend_from_slice(args);
        let stderr = fails(&all, 2);
        assert!(stderr.contains(said), "{args:?}: {stderr}");
    }
}

#[test]
fn a_limit_switch_in_the_way_ends_the_test_naming_it() {
    // The simulated drive's positive limit switch is at +36000 (0.1°).
    let (code, stdout, stderr) = run(&[
        "--link",
        "sim",
        "test-move",
        "--from",
        "0",
        "--to",
        "60000",
        "--speed",
        "600",
    ]);
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(
        stderr.contains("the test move ended early after 0 step(s)")
            && stderr.contains("limit switch"),
        "{stderr}"
    );
}

#[test]
fn ctrl_c_ends_a_test_move_with_the_steps_so_far_and_the_drive_halted() {
    let (_sim, addr) = Sim::tcp(&["--max-clients", "2"]);
    let link = format!("modbus-tcp://{addr}");
    let mut test = start(&[
        "--link",
        &link,
        "--json",
        "test-move",
        "--from",
        "0",
        "--to",
        "20000",
        "--speed",
        "300",
        "--dwell",
        "0.2",
        "--cycles",
        "50",
    ]);
    // The first steps take a second or two each.
    std::thread::sleep(Duration::from_millis(4000));
    test.signal("INT");
    let status = test
        .wait(Duration::from_secs(20))
        .unwrap_or_else(|| panic!("still running: {}", test.report()));
    assert_eq!(status.code(), Some(130), "{}", test.report());
    let report: serde_json::Value = serde_json::from_str(&test.stdout()).expect("a JSON report");
    let steps = report["steps"].as_array().expect("steps").len();
    assert!(steps >= 1, "{report:#}");
    let why = report["ended_early"].as_str().unwrap_or_default();
    assert!(
        why.contains("interrupted by SIGINT") && why.contains("halt"),
        "{why}"
    );
    // The drive stands still.
    let status = json(&["--link", &link, "status"]);
    assert_eq!(status["velocity"].as_f64(), Some(0.0), "{status:#}");
}

#[test]
fn velocity_steps_have_their_figures_on_the_velocity() {
    let report = json(&[
        "--link",
        "sim",
        "test-velocity",
        "--speed",
        "300",
        "--hold",
        "0.2",
    ]);
    assert_eq!(report["signal"], "velocity", "{report:#}");
    let steps = report["steps"].as_array().expect("steps");
    let ends: Vec<(i64, i64)> = steps
        .iter()
        .map(|s| {
            (
                s["from"].as_i64().unwrap_or(0),
                s["to"].as_i64().unwrap_or(0),
            )
        })
        .collect();
    assert_eq!(ends, [(0, 300), (300, -300), (-300, 0)], "{report:#}");
    for step in steps {
        let rise = step["rise_time_s"].as_f64().unwrap_or(f64::NAN);
        let settle = step["settling_time_s"].as_f64().unwrap_or(f64::NAN);
        assert!(rise > 0.0 && rise <= settle && settle < 5.0, "{step:#}");
    }
    // The reversal takes twice the ramp of a start from standstill.
    let rise = |i: usize| steps[i]["rise_time_s"].as_f64().unwrap_or(f64::NAN);
    assert!((rise(1) / rise(0) - 2.0).abs() < 0.2, "{report:#}");
    let stderr = fails(&["--link", "sim", "test-velocity", "--speed", "0"], 2);
    assert!(stderr.contains("makes no step"), "{stderr}");
}

#[test]
fn a_kept_run_opens_as_a_recording_with_a_marker_and_the_figures_at_each_step() {
    let dir = common::temp_dir("test-move-record");
    for name in ["run.csv", "run.json"] {
        let path = dir.path().join(name);
        let path = path.to_str().expect("utf-8 path");
        let report = json(&[
            "--link",
            "sim",
            "test-move",
            "--from",
            "0",
            "--to",
            "1000",
            "--speed",
            "300",
            "--dwell",
            "0.2",
            "--cycles",
            "2",
            "--record",
            path,
        ]);
        assert_eq!(report["recorded"], path, "{report:#}");
        let recording = drivedeck::telemetry::load_recording(
            std::path::Path::new(path),
            drivedeck::telemetry::MAX_RECORDING_BYTES,
        )
        .expect("the run opens");
        assert_eq!(recording.meta.cut, None, "{name}");
        let steps: Vec<&str> = recording
            .markers
            .iter()
            .map(|m| m.text.as_str())
            .filter(|t| t.starts_with("cycle "))
            .collect();
        assert_eq!(steps.len(), 4, "{name}: {:?}", recording.markers);
        assert!(
            steps[1].starts_with("cycle 1: 1000 → 0: rise "),
            "{steps:?}"
        );
        let ids: Vec<&str> = recording.channels.iter().map(|c| c.id.as_str()).collect();
        assert_eq!(
            ids,
            ["position", "velocity", "following_error", "pdi_status"]
        );
        // 200 samples a second over four steps of well over half a second.
        assert!(recording.len() > 300, "{name}: {} rows", recording.len());
    }
}

/// (peak following error, overshoot) at worst over a test move 0 ↔ 2000 at 300 rpm on a
/// simulated drive served on Modbus TCP after its auto setup (closed loop from then on),
/// with 3210h:03 (the velocity loop's P) at `gain`.
fn move_figures(gain: u32) -> (f64, f64) {
    let (_sim, addr) = Sim::tcp(&[]);
    let link = format!("modbus-tcp://{addr}");
    let (code, out, err) = run(&["--link", &link, "auto-setup", "--wait"]);
    assert_eq!(code, 0, "{out}{err}");
    let (code, out, err) = run(&["--link", &link, "write", "3210:03", &gain.to_string()]);
    assert_eq!(code, 0, "{out}{err}");
    let report = json(&[
        "--link",
        &link,
        "test-move",
        "--from",
        "0",
        "--to",
        "2000",
        "--speed",
        "300",
        "--cycles",
        "1",
    ]);
    let worst = |name: &str| {
        report["steps"]
            .as_array()
            .expect("steps")
            .iter()
            .filter_map(|s| s[name].as_f64())
            .fold(f64::MIN, f64::max)
    };
    (worst("peak_following_error"), worst("overshoot"))
}

#[test]
fn the_velocity_gain_changes_the_figures_of_a_test_move_once_the_loop_is_closed() {
    let (error, overshoot) = move_figures(12000);
    let (error_up, _) = move_figures(48000);
    let (error_down, overshoot_down) = move_figures(3000);
    assert!(
        error_up < error && error < error_down,
        "peak following error ×4 {error_up}, factory {error}, ÷4 {error_down}"
    );
    assert!(
        overshoot_down > overshoot,
        "overshoot ÷4 {overshoot_down}, factory {overshoot}"
    );
}

#[test]
fn a_load_the_simulated_drive_cannot_have_is_refused_with_its_range() {
    let said = fails(
        &[
            "sim",
            "--modbus-tcp",
            "127.0.0.1:0",
            "--load-inertia",
            "200",
        ],
        2,
    );
    assert!(said.contains("outside 0 to 100"), "{said}");
    let said = fails(
        &[
            "sim",
            "--modbus-tcp",
            "127.0.0.1:0",
            "--load-torque",
            "-5000",
        ],
        2,
    );
    assert!(said.contains("outside -1000 to 1000"), "{said}");
}
