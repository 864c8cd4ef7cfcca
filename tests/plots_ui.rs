//! The plot panel, headless: pause and resume, exports through the save dialog (answered
//! by a script), no file replaced without the user's word, a trigger capturing a move and
//! the capture frozen until dismissed or re-armed, recordings opened and overlaid with no
//! drive, the two cursors, and an object added from the dictionary browser —
//! egui_kittest clicking by label, the real worker sampling the simulated drive.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use drivedeck::diagnostics::Origin;
use drivedeck::link::LinkSpec;
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::telemetry::{CaptureState, Edge, Recording};
use drivedeck::ui::plots::ScriptedPicker;
use drivedeck::ui::plots::{Alone, PlotCommand, PlotView};
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected_to, harness_with, start_turning, step_for, step_until, step_until_shown};

/// The window on the simulator, wide enough for the dictionary's Plot buttons.
fn app_harness() -> Harness<'static, App> {
    harness_with(Settings::default(), true, egui::vec2(1600.0, 1000.0))
}

/// `name` in `dir`.
fn path_in(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

/// The dialogs of this window answered by a script.
fn scripted(view: &mut PlotView) -> Arc<ScriptedPicker> {
    let picker = ScriptedPicker::new();
    view.set_files(picker.clone());
    picker
}

/// The next dialog picks `path`.
fn answer(picker: &ScriptedPicker, path: &str) {
    picker.answer(Some(PathBuf::from(path)));
}

#[test]
fn the_plot_panel_pauses_resumes_and_exports_the_visible_window() {
    let mut harness = app_harness();
    step_until(
        &mut harness,
        "samples and the identity",
        Duration::from_secs(5),
        |h| h.state().shown().scope.ring().len() > 50 && h.state().shown().link.identity.is_some(),
    );

    harness.get_by_label("Pause plot").click();
    harness.step();
    let paused_at = harness.state().plot().paused_at().expect("paused");
    let len_at_pause = harness.state().shown().scope.ring().len();
    step_for(&mut harness, Duration::from_millis(300));
    let app = harness.state();
    assert_eq!(
        app.plot().paused_at(),
        Some(paused_at),
        "the picture stays put"
    );
    assert!(
        app.shown().scope.ring().len() > len_at_pause,
        "sampling goes on underneath"
    );
    let (_, end) = app.time_range().expect("a range");
    assert_eq!(end, paused_at);

    harness.get_by_label("Resume plot").click();
    harness.step();
    step_for(&mut harness, Duration::from_millis(100));
    let app = harness.state();
    assert_eq!(app.plot().paused_at(), None);
    assert!(app.plot().follows());
    let (_, end) = app.time_range().expect("a range");
    assert!(end > paused_at, "following the newest samples again");

    // The visible window to CSV, then to JSON: units and identity in the header. The
    // dialog proposes a name with the device and the date, in the folder used last.
    let picker = scripted(&mut harness.state_mut().window_mut().plot);
    let dir = common::temp_dir("plots");
    let csv = path_in(&dir, "visible.csv");
    answer(&picker, &csv);
    harness.get_by_label("Export visible…").click();
    harness.step();
    let asked = picker.asked();
    let device = harness
        .state()
        .shown()
        .link
        .identity
        .as_ref()
        .and_then(|i| i.name.clone())
        .expect("the simulator's 1008h")
        .replace(' ', "-");
    assert!(asked[0].save);
    assert!(
        asked[0].name.starts_with(&format!("{device}_20"))
            && asked[0].name.ends_with("_visible.csv"),
        "{:?}",
        asked[0]
    );
    let text = std::fs::read_to_string(&csv).expect("the CSV was written");
    let recording = Recording::from_csv(&text).expect("our own CSV reads back");
    assert!(recording.len() > 10, "{} rows", recording.len());
    let ids: Vec<&str> = recording.channels.iter().map(|c| c.id.as_str()).collect();
    // The signals drawn: the defaults, and those the simulator delivers that appear by
    // themselves (following error, analog input); not ReturnValue or the inputs.
    assert_eq!(ids[..3], ["position", "velocity", "torque"]);
    assert!(ids.contains(&"pdi_status"), "{ids:?}");
    assert!(!ids.contains(&"return_value"), "{ids:?}");
    assert_eq!(recording.channels[0].unit, "0.1°");
    assert_eq!(recording.meta.vendor.as_deref(), Some("0000026Ch"));
    assert_eq!(recording.meta.link.as_deref(), Some("sim"));
    assert!(
        text.contains("# channel: velocity | Velocity 606Ch | rpm"),
        "{text:.600}"
    );

    let json = path_in(&dir, "visible.json");
    answer(&picker, &json);
    harness.get_by_label("Export visible…").click();
    harness.step();
    assert_eq!(
        picker.asked()[1].directory.as_deref(),
        Some(dir.path()),
        "the folder used last"
    );
    let text = std::fs::read_to_string(&json).expect("the JSON was written");
    let from_json = Recording::from_json(&text).expect("our own JSON reads back");
    assert_eq!(from_json.channels, recording.channels);
    assert!(from_json.len() >= recording.len());
}

#[test]
fn a_trigger_on_target_reached_captures_a_move_with_its_pre_trigger_history() {
    let mut harness = app_harness();
    step_until(&mut harness, "samples", Duration::from_secs(5), |h| {
        h.state().shown().scope.ring().len() > 20
    });
    {
        let form = &mut harness.state_mut().window_mut().settings.plot.trigger;
        form.threshold = true;
        form.signal = "position".into();
        form.level = "1000".into();
        form.edge = Edge::Rising;
        form.pre_s = "0.3".into();
        form.post_s = "0.3".into();
    }
    harness.step();
    harness.get_by_label("Arm").click();
    harness.step();
    assert_eq!(
        harness.state().shown().scope.capture_state(),
        CaptureState::Armed,
        "{:?}",
        harness.state().plot().message()
    );
    // The default absolute move: to 2000 (0.1°) at 200 rpm, through the level.
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the recording",
        Duration::from_secs(10),
        |h| h.state().shown().scope.recording().is_some(),
    );
    let state = harness.state().shown();
    let recording = state.scope.recording().expect("recorded");
    let at = recording.meta.trigger_time_s.expect("the trigger time");
    let first = recording.times.first().copied().unwrap_or(f64::NAN);
    let last = recording.times.last().copied().unwrap_or(f64::NAN);
    assert!(
        (at - first - 0.3).abs() < 0.05,
        "pre-trigger from {first} to {at}"
    );
    assert!(last >= at + 0.3 - 0.05, "post-trigger to {last}");
    // Before the trigger the position was below the level, at the trigger at or above.
    let position = &recording.columns[0];
    let before: Vec<f64> = recording
        .times
        .iter()
        .zip(position)
        .filter(|(t, v)| **t < at && !v.is_nan())
        .map(|(_, v)| *v)
        .collect();
    assert!(!before.is_empty() && before.iter().all(|v| *v < 1000.0));
    let at_trigger = recording
        .times
        .iter()
        .position(|t| *t == at)
        .map(|i| position[i]);
    assert!(at_trigger.is_some_and(|v| v >= 1000.0), "{at_trigger:?}");
    assert!(
        recording
            .markers
            .iter()
            .any(|m| m.text.starts_with("Profile Position absolute")),
        "the command is marked: {:?}",
        recording.markers
    );

    // Frozen on screen until dismissed: the capture, not the live history.
    assert!(harness.state().plot().review().is_some_and(|r| r.capture));
    harness.get_by_label("Dismiss");

    let dir = common::temp_dir("plots");
    let path = path_in(&dir, "triggered.csv");
    let picker = scripted(&mut harness.state_mut().window_mut().plot);
    answer(&picker, &path);
    harness.get_by_label("Save recording…").click();
    harness.step();
    assert!(picker.asked()[0].name.ends_with("_capture.csv"));
    let text = std::fs::read_to_string(&path).expect("saved");
    let back = Recording::from_csv(&text).expect("reads back");
    assert_eq!(back.meta.trigger_time_s, Some(at));
    assert_eq!(
        back.len(),
        harness
            .state()
            .shown()
            .scope
            .recording()
            .map_or(0, Recording::len)
    );
}

#[test]
fn an_object_plotted_from_the_dictionary_is_sampled_every_cycle() {
    let mut harness = app_harness();
    step_until(&mut harness, "samples", Duration::from_secs(5), |h| {
        h.state().shown().scope.ring().len() > 5
    });
    harness.state_mut().window_mut().settings.central =
        drivedeck::ui::settings::DICTIONARY.to_owned();
    harness.step();
    harness
        .get_by_label("Object filter")
        .set_text_value_accesskit("6044");
    step_until_shown(&mut harness, "Plot 6044h:00h");
    harness.get_by_label("Plot 6044h:00h").click();
    harness.step();
    harness.step();
    let message = harness.state().plot().message().cloned();
    assert!(
        matches!(&message, Some(Ok(text)) if text.contains("6044h:00h")),
        "{message:?}"
    );
    harness.state_mut().window_mut().settings.central = drivedeck::ui::settings::PLOTS.to_owned();
    // A long move (the default one lasts a fifth of a second, which a window starved on a
    // busy machine may step over): the velocity stays up long enough to be seen.
    harness
        .get_by_label("Move absolute: Target position")
        .set_text_value_accesskit("30000");
    harness.step();
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(&mut harness, "6044h to move", Duration::from_secs(5), |h| {
        let scope = &h.state().shown().scope;
        scope
            .signal("6044h_00h")
            .and_then(|s| scope.ring().latest(s.column))
            .is_some_and(|(_, v)| v > 50.0)
    });
    // A string cannot be plotted: refused with the reason.
    let _ = harness.state_mut().plot_object("1008");
    let message = harness.state().plot().message().cloned();
    assert!(
        matches!(&message, Some(Err(e)) if e.contains("not a number")),
        "{message:?}"
    );
}

/// The plot panel alone with no drive, fed samples by hand: a position ramp from 0 to
/// 2000 in 2 s, the trigger armed at 1000.
fn plots_harness() -> Harness<'static, Alone> {
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1200.0, 800.0))
        .build_ui_state(
            |ui, alone: &mut Alone| alone.ui(ui),
            Alone::new(Settings::default().plot.history_rows),
        );
    {
        let form = &mut harness.state_mut().settings.trigger;
        form.threshold = true;
        form.signal = "position".into();
        form.level = "1000".into();
        form.edge = Edge::Rising;
        form.pre_s = "0.2".into();
        form.post_s = "0.2".into();
    }
    harness.step();
    harness.get_by_label("Arm").click();
    harness.step();
    feed(&mut harness, 0..200);
    assert!(
        harness.state().drive.scope.recording().is_some(),
        "the trigger fired"
    );
    harness
}

/// Samples `range` of the ramp (every 10 ms, 10 × 0.1° a sample).
fn feed(harness: &mut Harness<'static, Alone>, range: std::ops::Range<i32>) {
    let samples = range
        .map(|i| drivedeck::worker::Sample {
            t: f64::from(i) * 0.01,
            signals: drivedeck::signal::Signals::default()
                .with(drivedeck::signal::Signal::Position, f64::from(i) * 10.0),
            ..Default::default()
        })
        .collect();
    harness
        .state_mut()
        .apply_event(drivedeck::worker::Event::Samples(samples));
    harness.step();
}

/// A few frames: a dialog's answer is taken at the end of a frame, the question or the
/// message it brings shows in the next.
fn settle(harness: &mut Harness<'_, Alone>) {
    for _ in 0..3 {
        harness.step();
    }
}

fn message(harness: &Harness<'_, Alone>) -> Result<String, String> {
    harness.state().view.message().cloned().expect("a message")
}

/// Step the panel until `done` holds (a file is read on a thread of its own).
fn step_panel_until(harness: &mut Harness<'_, Alone>, what: &str, done: impl Fn(&Alone) -> bool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while !done(harness.state()) {
        assert!(
            Instant::now() < deadline,
            "{what} did not happen; message: {:?}",
            harness.state().view.message()
        );
        std::thread::sleep(Duration::from_millis(5));
        harness.step();
    }
    harness.step();
}

#[test]
fn a_failed_save_says_where_and_why_and_keeps_the_recording_for_the_next_try() {
    let mut harness = plots_harness();
    let picker = scripted(&mut harness.state_mut().view);
    let recorded = harness.state().drive.scope.recording().map(Recording::len);

    // A directory that does not exist.
    let missing = format!("/nonexistent-drivedeck-{}/run.csv", std::process::id());
    answer(&picker, &missing);
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    settle(&mut harness);
    let error = message(&harness).expect_err("the write fails");
    assert!(
        error.starts_with(&format!(
            "cannot write {missing}: No such file or directory (os error 2)"
        )),
        "{error}"
    );
    assert!(
        error.ends_with("the recording is still here — choose another place"),
        "{error}"
    );
    harness.get_by_label(&error);
    assert_eq!(
        harness.state().drive.scope.recording().map(Recording::len),
        recorded
    );

    // A relative path (a dialog may answer one): the message names the full path.
    let relative = format!("no-such-dir-{}/run.csv", std::process::id());
    answer(&picker, &relative);
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    let error = message(&harness).expect_err("the write fails");
    let full = std::env::current_dir().expect("cwd").join(&relative);
    assert!(
        error.starts_with(&format!("cannot write {}: ", full.display())),
        "{error}"
    );

    // A directory where the file should be: asked first (it exists), then refused.
    let dir = common::temp_dir("plots");
    answer(&picker, &dir.path().to_string_lossy());
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    harness.get_by_label("Replace").click();
    settle(&mut harness);
    let error = message(&harness).expect_err("a directory is not a file");
    assert!(error.contains("it is a directory"), "{error}");

    // Cancelled: nothing written, said so.
    picker.answer(None);
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    assert_eq!(message(&harness), Ok("cancelled: nothing written".into()));

    // Another place: the same recording, whole, read back from the file; the path shown
    // with a way to its folder.
    let good = path_in(&dir, "retry.csv");
    answer(&picker, &good);
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    let saved = message(&harness).expect("saved");
    assert!(saved.contains(&good), "{saved}");
    harness.get_by_label("Open folder");
    let text = std::fs::read_to_string(&good).expect("written");
    let back = Recording::from_csv(&text).expect("reads back");
    assert_eq!(Some(back.len()), recorded);
    assert_eq!(back.channels[0].id, "position");
}

#[test]
fn no_file_is_replaced_without_the_users_word() {
    let mut harness = plots_harness();
    let picker = scripted(&mut harness.state_mut().view);
    let dir = common::temp_dir("plots");
    let path = path_in(&dir, "capture.csv");
    answer(&picker, &path);
    harness.get_by_label("Save recording…").click();
    settle(&mut harness);
    let saved = std::fs::read_to_string(&path).expect("the capture saved");

    // "Export visible" picked the same file: the question, and nothing written yet.
    answer(&picker, &path);
    harness.get_by_label("Export visible…").click();
    settle(&mut harness);
    settle(&mut harness);
    harness.get_by_label("Replace the file?");
    harness.get_by_label_contains(
        "holds the triggered recording (Save recording wrote it this session)",
    );
    assert_eq!(std::fs::read_to_string(&path).expect("there"), saved);
    harness.get_by_label("Cancel").click();
    settle(&mut harness);
    settle(&mut harness);
    assert_eq!(std::fs::read_to_string(&path).expect("there"), saved);
    assert_eq!(
        message(&harness),
        Ok(format!("nothing written: {path} kept as it was"))
    );
    assert!(harness.query_by_label("Replace the file?").is_none());

    // Another name instead: the dialog again, the capture kept, the export beside it.
    let beside = path_in(&dir, "visible.csv");
    answer(&picker, &path);
    answer(&picker, &beside);
    harness.get_by_label("Export visible…").click();
    settle(&mut harness);
    harness.get_by_label("Choose another name…").click();
    settle(&mut harness);
    assert_eq!(std::fs::read_to_string(&path).expect("there"), saved);
    assert!(Recording::from_csv(&std::fs::read_to_string(&beside).expect("exported")).is_ok());

    // Replace, said in so many words: now it is the visible window.
    answer(&picker, &path);
    harness.get_by_label("Export visible…").click();
    settle(&mut harness);
    harness.get_by_label("Replace").click();
    settle(&mut harness);
    let replaced = std::fs::read_to_string(&path).expect("there");
    assert!(
        replaced.contains("# note: the visible window of the plots"),
        "{replaced:.300}"
    );
}

#[test]
fn a_triggered_capture_stays_on_screen_until_dismissed_or_re_armed() {
    let mut harness = plots_harness();
    let span = |h: &Harness<'_, Alone>| h.state().time_range();
    let captured = span(&harness).expect("a range");
    let recording = harness
        .state()
        .drive
        .scope
        .recording()
        .cloned()
        .expect("recorded");
    let first = recording.times.first().copied().unwrap_or(f64::NAN);
    let last = recording.times.last().copied().unwrap_or(f64::NAN);
    assert_eq!(captured, (first, last));
    harness.get_by_label_contains("Frozen:");
    // Ten more seconds of samples: the capture stays put.
    for k in 0..10 {
        feed(&mut harness, 200 + k * 100..300 + k * 100);
    }
    assert_eq!(span(&harness), Some(captured));
    assert!(
        harness
            .state()
            .drive
            .scope
            .ring()
            .last_time()
            .unwrap_or(0.0)
            > 11.0
    );

    harness.get_by_label("Dismiss").click();
    harness.step();
    assert!(harness.state().view.review().is_none());
    let (_, end) = span(&harness).expect("live");
    assert!(end > 11.0, "live again: {end}");
    // The capture is still there to save.
    harness.get_by_label("Save recording…");

    // Re-arm from a frozen capture: live, waiting for the next one.
    let scope = harness.state().drive.scope.clone();
    drivedeck::ui::plots::review::freeze_capture(&mut harness.state_mut().view, &scope);
    harness.step();
    harness.get_by_label("Re-arm").click();
    harness.step();
    assert!(harness.state().view.review().is_none());
    assert_eq!(
        harness.state().drive.scope.capture_state(),
        CaptureState::Armed
    );
}

/// A recording of a move to `to` (0.1°) in 1 s with its trigger at `trigger` s, as our
/// CSV in `dir`.
fn recording_file(dir: &tempfile::TempDir, name: &str, to: f64, trigger: f64) -> String {
    let times: Vec<f64> = (0..=100).map(|i| f64::from(i) * 0.01).collect();
    let recording = Recording {
        meta: drivedeck::telemetry::Metadata {
            device_name: Some("PD4-E601L42".into()),
            trigger_time_s: Some(trigger),
            ..Default::default()
        },
        channels: vec![
            drivedeck::telemetry::ChannelInfo {
                id: "position".into(),
                name: "Position 6064h".into(),
                unit: "0.1°".into(),
            },
            drivedeck::telemetry::ChannelInfo {
                id: "pdi_status".into(),
                name: "PDI-Status".into(),
                unit: String::new(),
            },
        ],
        columns: vec![
            times.iter().map(|t| t * to).collect(),
            times
                .iter()
                .map(|t| if *t >= trigger { 9.0 } else { 1.0 })
                .collect(),
        ],
        times,
        markers: Vec::new(),
    };
    let path = path_in(dir, name);
    let text = if name.ends_with(".json") {
        recording.to_json()
    } else {
        recording.to_csv()
    };
    std::fs::write(&path, text).expect("written");
    path
}

/// The seconds the overlay is moved by.
fn overlay_offset(harness: &Harness<'_, Alone>) -> f64 {
    harness
        .state()
        .view
        .review()
        .map_or(f64::NAN, |r| r.offset_s)
}

/// The plot panel with no drive at all.
fn empty_panel() -> Harness<'static, Alone> {
    Harness::builder()
        .with_size(egui::vec2(1366.0, 768.0))
        .build_ui_state(
            |ui, alone: &mut Alone| alone.ui(ui),
            Alone::new(Settings::default().plot.history_rows),
        )
}

/// A click at `pos`: the primary button or the secondary one.
fn click_at(harness: &mut Harness<'_, Alone>, pos: egui::Pos2, button: egui::PointerButton) {
    harness
        .input_mut()
        .events
        .push(egui::Event::PointerMoved(pos));
    harness.step();
    for pressed in [true, false] {
        harness.input_mut().events.push(egui::Event::PointerButton {
            pos,
            button,
            pressed,
            modifiers: egui::Modifiers::NONE,
        });
        harness.step();
    }
}

#[test]
fn a_recording_opens_with_no_drive_and_a_second_one_overlays_it_on_the_trigger() {
    let mut harness = empty_panel();
    harness.step();
    let picker = scripted(&mut harness.state_mut().view);
    let dir = common::temp_dir("plots");
    let before = recording_file(&dir, "before.csv", 2000.0, 0.5);
    let after = recording_file(&dir, "after.json", 2400.0, 0.3);

    answer(&picker, &before);
    harness.get_by_label("Open recording…").click();
    step_panel_until(&mut harness, "the recording open", |s| {
        s.view.review().is_some()
    });
    assert!(!picker.asked()[0].save);
    harness.get_by_label("Recording: before.csv");
    assert_eq!(harness.state().time_range(), Some((0.0, 1.0)));
    let shown = harness.state().shown_scope();
    assert_eq!(shown.ring().len(), 101);
    assert!(
        harness.state().drive.scope.ring().is_empty(),
        "no drive, no live samples"
    );

    answer(&picker, &after);
    harness.get_by_label("Overlay recording…").click();
    step_panel_until(&mut harness, "the overlay", |s| {
        s.view.review().is_some_and(|r| r.overlay.is_some())
    });
    harness.get_by_label("Overlay (dashed): after.json, moved by");
    // The legend names the overlaid recording's line after its file, inside the top plot.
    harness.step();
    let entry = harness
        .get_by_role_and_label(egui::accesskit::Role::CheckBox, "after.json (dashed)")
        .rect();
    let top = harness.state().view.drawn()[0].frame;
    assert!(
        entry.top() >= top[1] && entry.bottom() <= top[3],
        "{entry:?} outside the top plot {top:?}"
    );
    let offset = overlay_offset(&harness);
    assert!((offset - 0.2).abs() < 1e-9, "trigger on trigger: {offset}");
    // A chosen offset instead, then back on the triggers.
    harness.state_mut().apply(PlotCommand::MoveOverlay(-0.5));
    harness.step();
    assert_eq!(harness.state().time_range(), Some((-0.5, 1.0)));
    harness.get_by_label("Align").click();
    harness.step();
    let offset = overlay_offset(&harness);
    assert!((offset - 0.2).abs() < 1e-9, "{offset}");

    // Two cursors: a click places A, a right click B; Δt and each signal's Δ read out.
    // Inside the top plot, at a fraction of its width (the read-out above may have
    // grown after the first click).
    let at = |h: &Harness<'_, Alone>, fraction: f32| {
        let plots = h
            .state()
            .view
            .plots_area()
            .map(|[l, t, r, b]| egui::Rect::from_min_max(egui::pos2(l, t), egui::pos2(r, b)))
            .expect("plots drawn");
        let left = plots.left() + 80.0;
        egui::pos2(
            left + (plots.width() - 100.0) * fraction,
            plots.top() + 40.0,
        )
    };
    let first = at(&harness, 0.2);
    click_at(&mut harness, first, egui::PointerButton::Primary);
    let second = at(&harness, 0.7);
    click_at(&mut harness, second, egui::PointerButton::Secondary);
    harness.step();
    let [a, b] = harness.state().view.cursors();
    let (a, b) = (a.expect("cursor A"), b.expect("cursor B"));
    assert!(a < b, "{a} {b}");
    let times = format!("A {a:.3} s  B {b:.3} s  Δt {:.3} s", b - a);
    harness.get_by_label(&times);
    let rows =
        drivedeck::ui::plots::readout::cursor_rows(harness.state().shown_scope(), Some(a), Some(b));
    let [name, at_a, at_b, delta] = &rows[0];
    harness.get_by_label(&format!("| {name}: Δ {delta}"));
    assert!(
        at_a.contains(" rev") && at_b.contains(" rev"),
        "{at_a} {at_b}"
    );
    assert!(delta.contains("° = ") && delta.ends_with(" rev"), "{delta}");
    harness.get_by_label("Clear cursors").click();
    harness.step();
    assert_eq!(harness.state().view.cursors(), [None, None]);

    // Closed: back to the (empty) live plots.
    harness.get_by_label("Close recording").click();
    harness.step();
    assert!(harness.state().view.review().is_none());
}

#[test]
fn a_file_that_is_no_recording_is_refused_with_the_reason_and_nothing_changes() {
    let mut harness = empty_panel();
    harness.step();
    let picker = scripted(&mut harness.state_mut().view);
    let dir = common::temp_dir("plots");
    let bad = path_in(&dir, "photo.csv");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR").expect("written");
    answer(&picker, &bad);
    harness.get_by_label("Open recording…").click();
    step_panel_until(&mut harness, "the refusal", |s| {
        matches!(s.view.message(), Some(Err(_)))
    });
    let error = message(&harness).expect_err("refused");
    assert!(
        error.starts_with(&format!("{bad} is not a recording")),
        "{error}"
    );
    harness.get_by_label(&error);
    assert!(harness.state().view.review().is_none());
}

/// The times of the timeline's link entries whose text starts with `text`.
fn link_entries(harness: &Harness<'_, App>, text: &str) -> Vec<Option<f64>> {
    harness
        .state()
        .shown()
        .timeline
        .entries()
        .filter(|e| e.origin == Origin::Link && e.text.starts_with(text))
        .map(|e| e.t)
        .collect()
}

#[test]
fn an_outage_keeps_the_plots_markers_and_timeline_on_one_axis_with_a_gap() {
    let server = common::modbus_server(ServerOptions::default());
    let addr = server.addr;
    let spec: LinkSpec = format!("modbus-tcp://{addr}?unit=0").parse().expect("spec");
    let mut harness = connected_to(&spec, None, egui::vec2(1366.0, 768.0));
    start_turning(&mut harness, 100.0);
    step_for(&mut harness, Duration::from_millis(300));
    let scope = &harness.state().shown().scope;
    let first = scope.ring().first_time();
    let (rows, before) = (scope.ring().len(), scope.ring().last_time().unwrap_or(0.0));
    let markers: Vec<(f64, String)> = scope.markers().map(|m| (m.t, m.text.clone())).collect();
    assert!(!markers.is_empty(), "the velocity command's marker");

    // The drive's plug pulled for a while, then back on the same address.
    drop(server);
    step_until(&mut harness, "the link lost", Duration::from_secs(5), |h| {
        h.state().shown().scope.open_gap().is_some_and(|g| g.lost)
    });
    step_for(&mut harness, Duration::from_millis(800));
    let _server =
        ServerThread::modbus_tcp(addr, ServerOptions::default()).expect("the same port again");
    step_until(
        &mut harness,
        "samples again",
        Duration::from_secs(15),
        |h| {
            let state = h.state().shown();
            state.is_connected()
                && state.scope.open_gap().is_none()
                && state.scope.ring().len() > rows + 20
        },
    );

    let state = harness.state().shown();
    let scope = &state.scope;
    assert_eq!(
        scope.ring().first_time(),
        first,
        "the history from before is kept"
    );
    let kept: Vec<(f64, String)> = scope.markers().map(|m| (m.t, m.text.clone())).collect();
    assert_eq!(kept[..markers.len()], markers[..], "and its markers");
    let gap = scope.gaps().last().cloned().expect("the outage");
    let back = gap.to.expect("closed");
    assert!(gap.lost && gap.from >= before, "{gap:?}");
    assert!(
        back - gap.from >= 0.8,
        "the outage on the one time axis: {gap:?}"
    );
    assert!(
        gap.label(back).starts_with("no link "),
        "{}",
        gap.label(back)
    );
    // The same drive: no marker says otherwise.
    assert!(
        kept.iter()
            .all(|(_, text)| !text.starts_with("another drive"))
    );
    // The fault timeline's times go on: the loss at the last sample before, the return at
    // the first one after.
    assert_eq!(link_entries(&harness, "link lost: "), [Some(gap.from)]);
    assert_eq!(link_entries(&harness, "link back after "), [Some(back)]);
    // The plots draw the whole of it: the range reaches back before the outage.
    harness.state_mut().window_mut().settings.plot.window_s = 0.0;
    harness.step();
    let (from, to) = harness.state().time_range().expect("range");
    assert!(from <= gap.from && to > back, "{from}..{to} around {gap:?}");
}

/// Step once and wait `wait` for samples: the frames the pace asked for from the step on
/// (how many, and when the last falls due), and when the step began.
fn asked_after_samples(
    harness: &mut Harness<'_, App>,
    pace: &drivedeck::ui::pace::Pace,
    wait: Duration,
) -> (u64, Option<Instant>, Instant) {
    // Samples came since the last frame, so a frame is asked for already and nothing
    // asks again until the step's frame begins.
    std::thread::sleep(Duration::from_millis(20));
    let (before, _) = pace.asked();
    let began = Instant::now();
    harness.step();
    std::thread::sleep(wait);
    let (after, due) = pace.asked();
    (after - before, due, began)
}

#[test]
fn samples_wake_the_window_at_the_redraw_rate_and_paused_plots_once_a_second() {
    use drivedeck::ui::pace::Pace;
    let pace = Arc::new(Pace::default());
    let settings = Settings {
        poll_rate: 1000.0,
        ..Settings::default()
    };
    let mut app = App::new(settings, pace.notify(), true);
    app.set_pace(Arc::clone(&pace));
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .build_ui_state(|ui, app: &mut App| app.frame(ui), app);
    window::connected(&mut harness);
    step_for(&mut harness, Duration::from_millis(100));

    // Following live samples at 1 kHz: a hundred wakes ask for one frame, not before a
    // period of the default 30 Hz after the last frame began.
    let period = Duration::from_secs_f64(1.0 / 30.0);
    let (asks, due, began) = asked_after_samples(&mut harness, &pace, Duration::from_millis(100));
    assert_eq!(asks, 1, "one frame asked for a burst of samples");
    assert!(due.is_some_and(|due| due >= began + period - Duration::from_micros(1)));

    // A slower rate from the settings.
    harness.state_mut().window_mut().settings.plot.redraw_hz = 10.0;
    let (asks, due, began) = asked_after_samples(&mut harness, &pace, Duration::from_millis(150));
    assert_eq!(asks, 1);
    assert!(due.is_some_and(|due| due >= began + Duration::from_millis(100)));

    // Paused: samples keep coming (and are recorded) but ask for a frame once a second,
    // for the status panel's figures.
    harness.get_by_label("Pause plot").click();
    harness.step();
    assert!(harness.state().plot().is_paused());
    assert!(harness.state().plots_still());
    let recorded = harness.state().shown().scope.ring().len();
    let (asks, due, began) = asked_after_samples(&mut harness, &pace, Duration::from_millis(300));
    assert_eq!(asks, 1);
    assert!(due.is_some_and(|due| due >= began + Duration::from_secs(1)));
    harness.step();
    assert!(harness.state().shown().scope.ring().len() > recorded);

    // Resumed: the redraw rate again (from the frame after the click).
    harness.get_by_label("Resume plot").click();
    harness.step();
    assert!(!harness.state().plots_still());
    harness.step();
    assert_eq!(pace.period(), Duration::from_millis(100));
}
