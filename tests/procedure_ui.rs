//! The Procedure tab in the window, headless, against the built-in simulated drive: the
//! shipped ten-step example loaded, run with the operator's Yes clicked, every step
//! passed (the identity skipped: a simulated drive stands in) and the record written;
//! Esc aborts a run with the record saying so; a bad file is refused with its line.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::path::Path;
use std::time::Duration;

use drivedeck::procedure::Record;
use drivedeck::ui::procedure::ProcedurePanel;
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{connected, harness_with, step_until};

fn panel<'a>(harness: &'a Harness<'_, App>) -> &'a ProcedurePanel {
    harness
        .state()
        .shown()
        .panels
        .find::<ProcedurePanel>()
        .expect("the Procedure tab's model")
}

/// The window on the built-in simulated drive, the Procedure tab open, the example
/// procedure (edited by `edit`) copied into `dir` and loaded.
fn loaded(dir: &Path, edit: impl Fn(String) -> String) -> Harness<'static, App> {
    let text = std::fs::read_to_string("assets/procedures/axis-commissioning.toml").unwrap();
    let path = dir.join("axis.toml");
    std::fs::write(&path, edit(text)).unwrap();
    std::fs::copy(
        "assets/procedures/axis-backup.json",
        dir.join("axis-backup.json"),
    )
    .unwrap();
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    connected(&mut harness);
    window::load_procedure(&mut harness, &path, &dir.join("record.html"));
    harness
}

#[test]
fn the_example_runs_to_a_passed_record_with_the_operators_yes_clicked() {
    let dir = common::temp_dir("procedure-ui");
    let mut harness = loaded(dir.path(), |t| t);
    assert!(
        matches!(&panel(&harness).message, Some(Ok(m)) if m.contains("10 step(s), checked")),
        "{:?}",
        panel(&harness).message
    );
    assert_eq!(
        harness.query_all_by_label("waiting").count(),
        10,
        "the steps listed"
    );
    harness.get_by_label_contains("Run on ").click();
    harness.step();
    step_until(&mut harness, "the question", Duration::from_secs(20), |h| {
        h.query_by_label("Yes").is_some()
    });
    harness.get_by_label("Yes").click();
    harness.step();
    step_until(
        &mut harness,
        "the run's end",
        Duration::from_secs(60),
        |h| panel(h).record.is_some(),
    );
    let record = panel(&harness).record.clone().unwrap();
    let verdicts: Vec<&str> = record.drives[0]
        .steps
        .iter()
        .map(|s| s.verdict.word())
        .collect();
    assert_eq!(
        verdicts,
        [
            "skipped", "passed", "passed", "passed", "passed", "passed", "passed", "passed",
            "passed", "passed"
        ],
        "{:#?}",
        record.drives[0].steps
    );
    assert_eq!(record.operator, "Kittest");
    assert!(matches!(&panel(&harness).message, Some(Ok(m)) if m.contains("passed")));
    // The record on disk, sealed.
    let json = std::fs::read_to_string(dir.path().join("record.json")).unwrap();
    let on_disk: Record = serde_json::from_str(&json).unwrap();
    assert!(on_disk.verify());
    assert!(dir.path().join("record.html").exists());
    // The verdicts in the tab.
    assert_eq!(harness.query_all_by_label("passed").count(), 9);
}

#[test]
fn esc_aborts_a_run_and_the_record_says_so() {
    let dir = common::temp_dir("procedure-ui-esc");
    let mut harness = loaded(dir.path(), |t| t.replace("cycles = 2", "cycles = 20"));
    harness.get_by_label_contains("Run on ").click();
    harness.step();
    step_until(&mut harness, "the question", Duration::from_secs(20), |h| {
        h.query_by_label("Yes").is_some()
    });
    harness.get_by_label("Yes").click();
    harness.step();
    step_until(
        &mut harness,
        "the test move",
        Duration::from_secs(20),
        |h| panel(h).run().and_then(|r| r.current()) == Some(4),
    );
    harness.key_press(egui::Key::Escape);
    harness.step();
    step_until(&mut harness, "the abort", Duration::from_secs(5), |h| {
        panel(h).record.is_some()
    });
    let record = panel(&harness).record.clone().unwrap();
    let steps = &record.drives[0].steps;
    assert_eq!(steps[4].verdict.word(), "aborted");
    assert!(steps[4].note.contains("Esc"), "{}", steps[4].note);
    assert!(steps[5..].iter().all(|s| s.verdict.word() == "skipped"));
    assert_eq!(record.verdict.word(), "aborted");
    assert!(matches!(&panel(&harness).message, Some(Err(m)) if m.contains("aborted")));
}

#[test]
fn a_bad_file_is_refused_with_its_line() {
    let dir = common::temp_dir("procedure-ui-bad");
    let harness = loaded(dir.path(), |t| {
        t.replace("input = \"positive limit switch\"", "input = \"left foot\"")
    });
    assert!(
        matches!(&panel(&harness).message, Some(Err(m)) if m.contains("line 70 (step 7, input): unknown input")),
        "{:?}",
        panel(&harness).message
    );
    assert!(panel(&harness).procedure.is_none());
    assert!(
        harness
            .get_by_label_contains("Run on ")
            .accesskit_node()
            .is_disabled()
    );
}

#[test]
fn drive_in_a_backup_path_is_the_drive_s_file_name_as_on_the_command_line() {
    let dir = common::temp_dir("procedure-ui-drive-stem");
    let mut harness = loaded(dir.path(), |t| {
        t.replace(
            "file = \"axis-backup.json\"",
            "file = \"{drive}-backup.json\"",
        )
    });
    let name = harness.state().shown().name.clone();
    let stem = drivedeck::project::file_stem(&name);
    assert_ne!(
        stem, name,
        "a name with a character a file name avoids: {name}"
    );
    std::fs::copy(
        dir.path().join("axis-backup.json"),
        dir.path().join(format!("{stem}-backup.json")),
    )
    .unwrap();
    harness.get_by_label_contains("Run on ").click();
    harness.step();
    assert!(
        matches!(&panel(&harness).message, Some(Ok(m)) if m.ends_with("started")),
        "the backup {stem}-backup.json was found: {:?}",
        panel(&harness).message
    );
    harness.get_by_label("Abort").click();
    harness.step();
}
