//! `drivedeck spectrum`: a resonance found in a recording by its frequency and amplitude;
//! a recording taken by `drivedeck record` is read; what cannot give a spectrum is refused
//! with what is wrong.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::fmt::Write;

use common::cli::{fails, json, run};

/// A velocity recording at about 500 Hz (the worker's jitter on the times): a 12.5 Hz
/// ringing of amplitude 3 rpm and a 40 Hz one of 0.5 rpm on 100 rpm.
fn ringing_csv() -> String {
    let mut text = String::from("t [s],velocity [rpm],position [0.1°]\n");
    for i in 0..2000 {
        let jitter = [0.0, 0.00004, -0.00003, 0.00002][i % 4];
        let t = i as f64 * 0.002 + jitter;
        let v = 100.0
            + 3.0 * (std::f64::consts::TAU * 12.5 * t).sin()
            + 0.5 * (std::f64::consts::TAU * 40.0 * t).sin();
        writeln!(text, "{t},{v},{}", i * 10).unwrap();
    }
    text
}

#[test]
fn a_resonance_in_a_recording_is_found_by_its_frequency_and_amplitude() {
    let dir = common::temp_dir("spectrum");
    let path = dir.path().join("ringing.csv");
    std::fs::write(&path, ringing_csv()).unwrap();
    let file = path.to_str().unwrap();
    let report = json(&["spectrum", file, "--signal", "velocity", "--peaks", "2"]);
    let peaks = report["peaks"].as_array().expect("peaks");
    assert_eq!(peaks.len(), 2, "{report:#}");
    let f = |i: usize| peaks[i]["frequency_hz"].as_f64().unwrap();
    let a = |i: usize| peaks[i]["amplitude"].as_f64().unwrap();
    assert!((f(0) - 12.5).abs() < 0.1, "{report:#}");
    assert!((a(0) - 3.0).abs() < 0.3, "{report:#}");
    assert!((f(1) - 40.0).abs() < 0.1, "{report:#}");
    assert!((a(1) - 0.5).abs() < 0.1, "{report:#}");
    assert!((report["rate_hz"].as_f64().unwrap() - 500.0).abs() < 15.0);
    assert!(report.get("amplitudes").is_none(), "bins only with --bins");

    // The span and the window chosen; every bin on request; the text form.
    let report = json(&[
        "spectrum", file, "--signal", "velocity", "--from", "1", "--to", "3", "--window",
        "blackman", "--bins",
    ]);
    assert_eq!(report["window"], "blackman");
    assert!(report["from_s"].as_f64().unwrap() >= 1.0);
    assert!(report["to_s"].as_f64().unwrap() <= 3.0);
    let bins = report["amplitudes"].as_array().expect("bins").len();
    assert_eq!(bins, report["frequencies_hz"].as_array().unwrap().len());
    let (code, out, err) = run(&["spectrum", file, "--signal", "VELOCITY"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("hann window") && out.contains("12.5"), "{out}");
}

#[test]
fn a_recording_taken_by_drivedeck_record_gives_a_spectrum() {
    let dir = common::temp_dir("spectrum");
    let path = dir.path().join("run.json");
    let file = path.to_str().unwrap();
    let (code, out, err) = run(&[
        "--link",
        "sim",
        "record",
        "--signals",
        "velocity",
        "--rate",
        "200",
        "--duration",
        "1s",
        "--out",
        file,
    ]);
    assert_eq!(code, 0, "{out}{err}");
    let report = json(&["spectrum", file, "--signal", "velocity"]);
    assert!(report["points"].as_u64().unwrap() >= 100, "{report:#}");
}

#[test]
fn what_cannot_give_a_spectrum_is_refused_with_what_is_wrong() {
    let dir = common::temp_dir("spectrum");
    let path = dir.path().join("ringing.csv");
    std::fs::write(&path, ringing_csv()).unwrap();
    let file = path.to_str().unwrap();
    let said = fails(&["spectrum", file, "--signal", "torque"], 2);
    assert!(
        said.contains("no signal \"torque\"") && said.contains("velocity, position"),
        "{said}"
    );
    let said = fails(
        &[
            "spectrum", file, "--signal", "velocity", "--from", "3", "--to", "2",
        ],
        2,
    );
    assert!(said.contains("--from 3 is not before --to 2"), "{said}");
    let said = fails(
        &["spectrum", file, "--signal", "velocity", "--from", "10"],
        2,
    );
    assert!(said.contains("no samples between 10 and the end"), "{said}");
    let said = fails(
        &["spectrum", file, "--signal", "velocity", "--to", "0.01"],
        2,
    );
    assert!(said.contains("a spectrum needs at least 16"), "{said}");
    let said = fails(
        &[
            "spectrum", file, "--signal", "velocity", "--window", "kaiser",
        ],
        2,
    );
    assert!(said.contains("no window \"kaiser\""), "{said}");
    let missing = dir.path().join("none.csv");
    let said = fails(
        &[
            "spectrum",
            missing.to_str().unwrap(),
            "--signal",
            "velocity",
        ],
        2,
    );
    assert!(said.contains("cannot open"), "{said}");
}
