//! The Test tab in the window, headless, against the built-in simulated drive: a test move
//! runs from the form and keeps its figures, a second run is compared with it, a form
//! that cannot work is refused before anything moves, and Stop ends a run with the drive
//! halted and the steps measured so far kept.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::ui::test_run::TestRuns;
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected, fill, harness_with, step_until};

fn test_tab() -> Harness<'static, App> {
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    connected(&mut harness);
    harness.get_by_label("Test").click();
    harness.run();
    harness
}

fn runs<'a>(harness: &'a Harness<'_, App>) -> &'a TestRuns {
    harness
        .state()
        .shown()
        .panels
        .find::<TestRuns>()
        .expect("the Test tab's model")
}

fn run_once(harness: &mut Harness<'_, App>, expected_runs: usize) {
    harness.get_by_label("Run test").click();
    harness.step();
    step_until(harness, "the run", Duration::from_secs(20), |h| {
        runs(h).runs.len() == expected_runs && !runs(h).is_running()
    });
    harness.run();
}

#[test]
fn a_test_move_runs_from_the_form_and_a_second_run_is_compared_with_it() {
    let mut harness = test_tab();
    fill(
        &mut harness,
        &[
            ("test to", "1000"),
            ("test dwell", "0.1"),
            ("test cycles", "1"),
        ],
    );
    run_once(&mut harness, 1);
    let run = &runs(&harness).runs[0];
    assert!(run.ended_early.is_none(), "{:?}", run.ended_early);
    assert_eq!(run.steps.len(), 2, "{run:#?}");
    for step in &run.steps {
        assert!(step.rise_time_s.is_some_and(|r| r > 0.0), "{step:?}");
        assert!(step.time_to_target_reached_s.is_some(), "{step:?}");
    }
    assert!(run.trace.len() > 50 && run.step_starts.len() == 2);
    assert!(
        harness
            .query_by_label_contains("2 step(s) measured")
            .is_some()
    );
    assert!(
        harness.query_by_label("rise time [s]").is_some(),
        "the figures"
    );

    run_once(&mut harness, 2);
    assert_eq!(runs(&harness).compared, vec![1, 2], "both compared");
    assert!(harness.query_all_by_label("Run 2").next().is_some());

    // The newest ticked run saved as a recording.
    let dir = common::temp_dir("test-run");
    let path = dir.path().join("run2.csv");
    fill(&mut harness, &[("test run file", path.to_str().unwrap())]);
    harness.get_by_label("Save run").click();
    harness.run();
    let back = drivedeck::telemetry::load_recording(&path, 1 << 24).expect("the saved run");
    assert_eq!(back.markers.len(), 2, "a marker at each step");
    assert!(harness.query_by_label_contains("Run 2: saved").is_some());
}

#[test]
fn a_form_that_cannot_work_is_refused_before_anything_moves() {
    let mut harness = test_tab();
    fill(&mut harness, &[("test to", "0")]);
    harness.get_by_label("Run test").click();
    harness.run();
    assert!(!runs(&harness).is_running());
    assert!(
        harness
            .query_by_label_contains("the same position")
            .is_some()
    );
}

#[test]
fn stop_halts_the_drive_and_keeps_the_steps_measured() {
    let mut harness = test_tab();
    fill(
        &mut harness,
        &[
            ("test to", "30000"),
            ("test speed", "100"),
            ("test cycles", "1"),
        ],
    );
    harness.get_by_label("Run test").click();
    harness.step();
    step_until(&mut harness, "moving", Duration::from_secs(5), |h| {
        runs(h).progress().is_some_and(|p| p.contains("step 1"))
    });
    harness.get_by_label("Stop test").click();
    harness.step();
    step_until(&mut harness, "the halt", Duration::from_secs(5), |h| {
        window::velocity(h).abs() < 0.5
    });
    let run = &runs(&harness).runs[0];
    assert!(
        run.ended_early
            .as_deref()
            .is_some_and(|w| w.contains("stopped by the user")),
        "{run:?}"
    );
}

/// The worst peak following error of run `index`.
fn peak_error(harness: &Harness<'_, App>, index: usize) -> f64 {
    runs(harness).runs[index]
        .summary
        .peak_following_error
        .map(|s| s.worst.abs())
        .expect("a following error")
}

#[test]
fn four_times_the_velocity_gain_follows_more_closely_written_and_tested_again_from_the_gains_tab() {
    let mut harness = test_tab();
    // Closed loop needs the motor measured.
    harness.get_by_label("Auto setup").click();
    harness.step();
    step_until(
        &mut harness,
        "the auto setup",
        Duration::from_secs(10),
        |h| {
            h.state()
                .shown()
                .latest()
                .is_some_and(|s| s.tx.status.is_set(drivedeck::pdi::StatusBit::AutosetupDone))
        },
    );
    harness.get_by_label("Test").click();
    harness.run();
    fill(&mut harness, &[("test dwell", "0.2"), ("test cycles", "1")]);
    run_once(&mut harness, 1);

    // ×4 on the velocity loop's P, written and tested again from the Gains tab.
    harness.get_by_label("Gains").click();
    harness.run();
    step_until(&mut harness, "the gains", Duration::from_secs(5), |h| {
        h.query_by_label("3210h:03h value").is_some()
    });
    harness.get_by_label("3210h:03h value").click();
    harness.run();
    harness
        .get_by_label("new value")
        .set_text_value_accesskit("48000");
    harness.run();
    harness.key_press(egui::Key::Enter);
    harness.run();
    harness.get_by_label("Write and test again").click();
    harness.step();
    assert_eq!(
        harness
            .state()
            .shown()
            .panels
            .find::<TestRuns>()
            .map(|r| r.is_running()),
        Some(true),
        "the test runs again"
    );
    step_until(
        &mut harness,
        "the second run",
        Duration::from_secs(20),
        |h| runs(h).runs.len() == 2 && !runs(h).is_running(),
    );
    let (factory, raised) = (peak_error(&harness, 0), peak_error(&harness, 1));
    assert!(
        raised < factory,
        "peak following error with ×4: {raised}, factory: {factory}"
    );
    eprintln!("peak following error: factory gains {factory}, velocity gain ×4 {raised}");
}
