//! `drivedeck record`: signals to CSV and JSON with units and identity in the header,
//! an object added by address, a trigger that captures a move made by a second client
//! of the served simulator, bad input refused with a reason; a recording killed mid-way
//! leaves its samples in the file, which says it was cut; an outage of the link is
//! marked in the file at its time.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod proxy;

use std::path::Path;
use std::time::{Duration, Instant};

use common::cli::{ok, run, start};
use common::{Sim, eventually, temp_dir};
use drivedeck::telemetry::{MAX_RECORDING_BYTES, Recording, load_recording};
use proxy::{Framing, Proxy};

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

fn open(path: &Path) -> Result<Recording, String> {
    load_recording(path, MAX_RECORDING_BYTES)
}

/// SIGKILL 3 s into a 200 Hz recording: the file is there, with the samples of at least
/// half the time it ran (it is handed to the system twice a second), and it opens saying
/// it was cut. CSV and JSON side by side.
#[test]
fn a_recording_killed_mid_way_keeps_its_samples_and_says_it_was_cut() {
    let dir = temp_dir("record-killed");
    let rate = 200.0;
    let mut runs: Vec<_> = ["run.csv", "run.json"]
        .into_iter()
        .map(|name| {
            let out = dir.path().join(name);
            let recorder = start(&[
                "--link",
                "sim",
                "record",
                "--signals",
                "position,velocity,pdi_status",
                "--rate",
                "200",
                "--duration",
                "10min",
                "--out",
                out.to_str().expect("utf-8 path"),
            ]);
            (out, recorder)
        })
        .collect();
    // The recording has begun once its header is in the file.
    for (out, recorder) in &mut runs {
        eventually("the file's header", Duration::from_secs(30), || {
            assert!(recorder.running(), "ended early: {}", recorder.report());
            std::fs::metadata(&*out).ok().filter(|m| m.len() > 0)
        });
    }
    let began = Instant::now();
    std::thread::sleep(Duration::from_secs(3));
    for (out, mut recorder) in runs {
        recorder.signal("KILL");
        let elapsed = began.elapsed().as_secs_f64();
        assert!(
            recorder.wait(Duration::from_secs(10)).is_some(),
            "{}",
            recorder.report()
        );
        let recording = open(&out).unwrap_or_else(|e| panic!("{}: {e}", out.display()));
        let least = (rate * elapsed * 0.5) as usize;
        assert!(
            recording.len() >= least,
            "{}: {} samples after {elapsed:.1} s at {rate} Hz; at least {least} expected",
            out.display(),
            recording.len()
        );
        let cut = recording.meta.cut.clone().unwrap_or_default();
        assert!(
            cut.contains(&format!("cut after {} samples at t = ", recording.len()))
                && cut.contains("(the recording did not end normally)"),
            "{}: {cut:?}",
            out.display()
        );
        assert_eq!(recording.channels.len(), 3);
        assert!(recording.times.windows(2).all(|w| w[0] <= w[1]));
    }
}

/// Record through a proxy that loses six replies in a row (two failed exchanges of three
/// tries each: an outage the link gets over): the recording goes on to
/// its end, and the file marks the outage inside the jump in time and the link's return.
fn record_across_an_outage(name: &str) -> Recording {
    let dir = temp_dir("record-outage");
    let server = common::modbus_server(Default::default());
    let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
    let link = format!("modbus-tcp://{}", proxy.addr);
    let out = dir.path().join(name);
    let mut recorder = start(&[
        "--link",
        &link,
        "--json",
        "record",
        "--signals",
        "position,velocity",
        "--rate",
        "100",
        "--duration",
        "10s",
        "--out",
        out.to_str().expect("utf-8 path"),
    ]);
    // Samples are in the file (it is read as it grows) before the replies go.
    eventually("rows in the file", Duration::from_secs(30), || {
        assert!(recorder.running(), "ended early: {}", recorder.report());
        open(&out).ok().filter(|r| r.len() >= 50)
    });
    proxy.drop_next(6);
    let status = recorder.wait(Duration::from_secs(60));
    assert!(
        status.is_some_and(|s| s.success()),
        "an outage the link got over does not end the recording: {}",
        recorder.report()
    );
    assert_eq!(proxy.dropped(), 6, "{}", recorder.report());
    let recording = open(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(recording.meta.cut, None, "{name} ended normally");
    drop(server);
    recording
}

/// The outage's markers in `recording`: the one saying it began lies inside the largest
/// jump in time between two rows; the link's return is at or after the first row after
/// it, and rows follow.
fn check_outage_marks(name: &str, recording: &Recording) {
    let marks: Vec<String> = recording
        .markers
        .iter()
        .map(|m| format!("{} {}", m.t, m.text))
        .collect();
    let find = |prefix: &str| {
        recording
            .markers
            .iter()
            .find(|m| m.text.starts_with(prefix))
            .unwrap_or_else(|| panic!("{name}: no '{prefix}' marker: {marks:#?}"))
            .clone()
    };
    let outage = find("outage: an exchange with the drive failed");
    let back = find("recovered: the link recovered after 2 failed exchange");
    let times = &recording.times;
    let (before, after) = times
        .windows(2)
        .map(|w| (w[0], w[1]))
        .max_by(|a, b| (a.1 - a.0).total_cmp(&(b.1 - b.0)))
        .expect("rows");
    eprintln!("{name}: the jump in time {before}..{after}; markers {marks:#?}");
    assert!(
        before < outage.t && outage.t < after,
        "{name}: the outage at {} lies in the jump {before}..{after}: {marks:#?}",
        outage.t
    );
    assert!(
        back.t >= after && times.last().is_some_and(|last| *last > back.t),
        "{name}: the link back at {} with the row at {after}, rows after it: {marks:#?}",
        back.t
    );
}

#[test]
fn an_outage_is_marked_in_the_csv_and_the_json_at_its_time() {
    std::thread::scope(|s| {
        let csv = s.spawn(|| record_across_an_outage("outage.csv"));
        let json = s.spawn(|| record_across_an_outage("outage.json"));
        let csv = csv.join().expect("the CSV recording");
        check_outage_marks("CSV", &csv);
        let json = json.join().expect("the JSON recording");
        check_outage_marks("JSON", &json);
    });
}
