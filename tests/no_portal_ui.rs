//! Saving and opening without a desktop portal, headless (egui_kittest): where no system
//! file dialog can be shown, the window asks for the path in a field of its own (the
//! folder and the proposed name filled in), and the file is written there — nothing just
//! fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use std::time::Duration;

use drivedeck::telemetry::load_recording;
use drivedeck::ui::plots::files::ScriptedPicker;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, step_for, step_until, step_until_shown};

#[test]
fn without_a_file_dialog_the_window_asks_for_the_path_and_saves_there() {
    let mut harness = app_harness();
    connected(&mut harness);
    step_for(&mut harness, Duration::from_millis(300));
    let picker = ScriptedPicker::new();
    picker.answer_no_dialog("no file dialog could be shown: it needs the XDG desktop portal");
    picker.answer_no_dialog("no file dialog could be shown: it needs the XDG desktop portal");
    harness.state_mut().window_mut().use_files(picker.clone());
    harness.get_by_label("Export visible…").click();
    step_until_shown(&mut harness, "File path");
    let proposed = harness
        .get_by_label("File path")
        .value()
        .unwrap_or_default();
    assert!(proposed.ends_with("_visible.csv"), "{proposed}");
    harness.get_by_label_contains("Type the file's path instead");
    let dir = tempfile::tempdir().expect("a folder");
    let chosen = dir.path().join("typed.csv");
    harness
        .get_by_label("File path")
        .set_text_value_accesskit(&chosen.to_string_lossy());
    harness.run_steps(2);
    harness.get_by_label("Save").click();
    step_until(
        &mut harness,
        "the file written",
        Duration::from_secs(5),
        |_| chosen.exists(),
    );
    let written = load_recording(&chosen, u64::MAX).expect("the export");
    assert!(written.len() > 10, "{} rows", written.len());
    harness.run_steps(2);
    assert!(
        harness.query_by_label("File path").is_none(),
        "the prompt went"
    );

    // Cancel: nothing written, the plots say so.
    harness.get_by_label("Export visible…").click();
    step_until_shown(&mut harness, "File path");
    harness.get_by_label("Cancel").click();
    harness.run_steps(3);
    assert!(harness.query_by_label("File path").is_none());
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("the folder").count(),
        1,
        "only the first file"
    );
}
