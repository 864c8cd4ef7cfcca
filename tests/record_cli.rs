//! `drivedeck record`: signals to CSV and JSON with units and identity in the header,
//! an object added by address, a trigger that captures a move made by a second client
//! of the served simulator, and bad input refused with a reason.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::Duration;

use common::cli::{ok, run, start};
use common::{Sim, temp_dir};
use drivedeck::telemetry::Recording;

#[test]
fn record_writes_the_signals_with_units_and_identity() {
    let dir = temp_dir("record");
    let csv = dir.path().join("run.csv");
    let csv = csv.to_str().expect("utf-8 path");
    let (stdout, _) = ok(&[
        "--link",
        "sim",
        "--json",
        "record",
        "--signals",
        "position,velocity,pdi_status,2031:00",
        "--rate",
        "500",
        "--duration",
        "0.4s",
        "--out",
        csv,
    ]);
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("JSON report");
    let recording =
        Recording::from_csv(&std::fs::read_to_string(csv).expect("written")).expect("CSV");
    assert_eq!(report["samples"].as_u64(), Some(recording.len() as u64));
    assert!(recording.len() > 20, "{} rows", recording.len());
    let ids: Vec<&str> = recording.channels.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(ids, ["position", "velocity", "pdi_status", "2031h_00h"]);
    assert_eq!(recording.channels[1].unit, "rpm");
    assert_eq!(recording.meta.vendor.as_deref(), Some("0000026Ch"));
    // The rate achieved, beside the one asked for.
    assert_eq!(recording.meta.rate_asked_hz, Some(500.0));
    let rate = recording.meta.rate_hz.expect("rate");
    assert!((400.0..=510.0).contains(&rate), "{rate}");
    // Every signal came, the added object included (read every cycle on the simulator).
    for (info, column) in recording.channels.iter().zip(&recording.columns) {
        assert!(
            column.iter().any(|v| !v.is_nan()),
            "{} has no samples",
            info.id
        );
    }
    // Times are the worker's, increasing.
    assert!(recording.times.windows(2).all(|w| w[0] <= w[1]));

    let json = dir.path().join("run.json");
    let json = json.to_str().expect("utf-8 path");
    let (stdout, _) = ok(&[
        "record",
        "--signals",
        "torque",
        "--duration",
        "200ms",
        "--out",
        json,
    ]);
    assert!(stdout.starts_with("recorded "), "{stdout}");
    let recording =
        Recording::from_json(&std::fs::read_to_string(json).expect("written")).expect("JSON");
    assert_eq!(recording.channels[0].unit, "‰");
}

#[test]
fn a_trigger_captures_a_move_made_by_another_client() {
    let dir = temp_dir("record-trigger");
    let csv = dir.path().join("move.csv");
    let csv = csv.to_str().expect("utf-8 path");
    let (_sim, addr) = Sim::tcp(&["--max-clients", "2"]);
    let link = format!("modbus-tcp://{addr}");
    let mut recorder = start(&[
        "--link",
        &link,
        "--json",
        "record",
        "--signals",
        "position,velocity,pdi_status",
        "--rate",
        "500",
        "--trigger",
        "position rises 1000",
        "--pre",
        "0.2s",
        "--duration",
        "0.2s",
        "--wait",
        "20s",
        "--out",
        csv,
    ]);
    // Let the recorder connect and arm before the move.
    std::thread::sleep(Duration::from_millis(1500));
    let (code, stdout, stderr) = run(&[
        "--link", &link, "move-abs", "2000", "--speed", "300", "--wait",
    ]);
    assert_eq!(code, 0, "the move: {stdout}{stderr}");
    let ended = recorder.wait(Duration::from_secs(30));
    assert!(
        ended.is_some_and(|status| status.success()),
        "{}",
        recorder.report()
    );
    let report: serde_json::Value = serde_json::from_str(&recorder.stdout()).expect("JSON report");
    let at = report["trigger_time_s"].as_f64().expect("fired");
    let recording =
        Recording::from_csv(&std::fs::read_to_string(csv).expect("written")).expect("CSV");
    assert_eq!(recording.meta.trigger_time_s, Some(at));
    assert!(
        recording
            .meta
            .trigger
            .as_deref()
            .is_some_and(|t| t.contains("position")),
        "{:?}",
        recording.meta.trigger
    );
    let first = recording.times.first().copied().unwrap_or(f64::NAN);
    assert!((at - first - 0.2).abs() < 0.05, "pre-trigger {first}..{at}");
    let i = recording
        .times
        .iter()
        .position(|t| *t == at)
        .expect("the trigger sample is in the file");
    let position = &recording.columns[0];
    assert!(position[i] >= 1000.0, "{}", position[i]);
    assert!(
        position[..i]
            .iter()
            .filter(|v| !v.is_nan())
            .all(|v| *v < 1000.0),
        "below the level before it"
    );
}

#[test]
fn bad_record_arguments_are_refused_with_the_reason() {
    let dir = temp_dir("record-bad");
    let out = dir.path().join("x.csv");
    let out = out.to_str().expect("utf-8 path");
    for (args, expected) in [
        (vec!["--signals", "speed"], "unknown signal 'speed'"),
        (vec!["--signals", "1008:00"], "not a number"),
        (vec!["--duration", "five"], "not a duration"),
        (vec!["--rate", "5000"], "outside 1 to 2000 Hz"),
        (vec!["--trigger", "position soars 10"], "not an edge"),
        (vec!["--trigger", "velocity bit 3 rises"], "has no bits"),
    ] {
        let mut all = vec!["record", "--out", out];
        all.extend(args.iter().copied());
        let (code, stdout, stderr) = run(&all);
        assert_eq!(code, 2, "{all:?}: {stdout}{stderr}");
        assert!(stderr.contains(expected), "{all:?}: {stderr}");
    }
    assert!(!std::path::Path::new(out).exists(), "nothing written");
}
