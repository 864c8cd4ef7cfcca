//! The plot panel, headless: pause and resume, exports, a trigger capturing a move, and
//! an object added from the dictionary browser — egui_kittest clicking by label, the real
//! worker sampling the simulated drive.

mod common;
mod window;

use std::time::Duration;

use drivedeck::diagnostics::Origin;
use drivedeck::link::LinkSpec;
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::telemetry::{CaptureState, Edge, Recording};
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected_to, harness_with, start_turning, step_for, step_until, step_until_shown};

/// The window on the simulator, wide enough for the dictionary's Plot buttons.
fn app_harness() -> Harness<'static, App> {
    harness_with(Settings::default(), true, egui::vec2(1600.0, 1000.0))
}

/// `name` in `dir`, as typed into the path box.
fn path_in(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

#[test]
fn the_plot_panel_pauses_resumes_and_exports_the_visible_window() {
    let mut harness = app_harness();
    step_until(
        &mut harness,
        "samples and the identity",
        Duration::from_secs(5),
        |h| h.state().state.scope.ring().len() > 50 && h.state().state.plot.identity.is_some(),
    );

    harness.get_by_label("Pause plot").click();
    harness.step();
    let paused_at = harness.state().state.plot.paused_at.expect("paused");
    let len_at_pause = harness.state().state.scope.ring().len();
    step_for(&mut harness, Duration::from_millis(300));
    let state = &harness.state().state;
    assert_eq!(
        state.plot.paused_at,
        Some(paused_at),
        "the picture stays put"
    );
    assert!(
        state.scope.ring().len() > len_at_pause,
        "sampling goes on underneath"
    );
    let (_, end) = drivedeck::ui::plots::time_range(state).expect("a range");
    assert_eq!(end, paused_at);

    harness.get_by_label("Resume plot").click();
    harness.step();
    step_for(&mut harness, Duration::from_millis(100));
    let state = &harness.state().state;
    assert_eq!(state.plot.paused_at, None);
    assert!(state.plot.follow);
    let (_, end) = drivedeck::ui::plots::time_range(state).expect("a range");
    assert!(end > paused_at, "following the newest samples again");

    // The visible window to CSV, then to JSON: units and identity in the header.
    let dir = common::temp_dir("plots");
    let csv = path_in(&dir, "visible.csv");
    harness.state_mut().state.settings.plot.export_path = csv.clone();
    harness.get_by_label("Export visible").click();
    harness.step();
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
    harness.state_mut().state.settings.plot.export_path = json.clone();
    harness.get_by_label("Export visible").click();
    harness.step();
    let text = std::fs::read_to_string(&json).expect("the JSON was written");
    let from_json = Recording::from_json(&text).expect("our own JSON reads back");
    assert_eq!(from_json.channels, recording.channels);
    assert!(from_json.len() >= recording.len());
}

#[test]
fn a_trigger_on_target_reached_captures_a_move_with_its_pre_trigger_history() {
    let mut harness = app_harness();
    step_until(&mut harness, "samples", Duration::from_secs(5), |h| {
        h.state().state.scope.ring().len() > 20
    });
    {
        let form = &mut harness.state_mut().state.settings.plot.trigger;
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
        harness.state().state.scope.capture_state(),
        CaptureState::Armed,
        "{:?}",
        harness.state().state.plot.message
    );
    // The default absolute move: to 2000 (0.1°) at 200 rpm, through the level.
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the recording",
        Duration::from_secs(10),
        |h| h.state().state.scope.recording().is_some(),
    );
    let state = &harness.state().state;
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

    let dir = common::temp_dir("plots");
    let path = path_in(&dir, "triggered.csv");
    harness.state_mut().state.settings.plot.export_path = path.clone();
    harness.get_by_label("Save recording").click();
    harness.step();
    let text = std::fs::read_to_string(&path).expect("saved");
    let back = Recording::from_csv(&text).expect("reads back");
    assert_eq!(back.meta.trigger_time_s, Some(at));
    assert_eq!(
        back.len(),
        harness
            .state()
            .state
            .scope
            .recording()
            .map_or(0, Recording::len)
    );
}

#[test]
fn an_object_plotted_from_the_dictionary_is_sampled_every_cycle() {
    let mut harness = app_harness();
    step_until(&mut harness, "samples", Duration::from_secs(5), |h| {
        h.state().state.scope.ring().len() > 5
    });
    harness.state_mut().state.settings.central = drivedeck::ui::state::Central::Dictionary;
    harness.step();
    harness
        .get_by_label("Object filter")
        .set_text_value_accesskit("6044");
    step_until_shown(&mut harness, "Plot 6044h:00h");
    harness.get_by_label("Plot 6044h:00h").click();
    harness.step();
    harness.step();
    let message = harness.state().state.plot.message.clone();
    assert!(
        matches!(&message, Some(Ok(text)) if text.contains("6044h:00h")),
        "{message:?}"
    );
    harness.state_mut().state.settings.central = drivedeck::ui::state::Central::Plots;
    // A long move (the default one lasts a fifth of a second, which a window starved on a
    // busy machine may step over): the velocity stays up long enough to be seen.
    harness
        .get_by_label("Move absolute: Target position")
        .set_text_value_accesskit("30000");
    harness.step();
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(&mut harness, "6044h to move", Duration::from_secs(5), |h| {
        let scope = &h.state().state.scope;
        scope
            .signal("6044h_00h")
            .and_then(|s| scope.ring().latest(s.column))
            .is_some_and(|(_, v)| v > 50.0)
    });
    // A string cannot be plotted: refused with the reason.
    harness.state_mut().state.watch_object("1008");
    let message = harness.state().state.plot.message.clone();
    assert!(
        matches!(&message, Some(Err(e)) if e.contains("not a number")),
        "{message:?}"
    );
}

/// The plot panel alone, fed samples by hand: a position ramp from 0 to 2000 in 2 s.
fn plots_harness() -> Harness<'static, drivedeck::ui::AppState> {
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1200.0, 800.0))
        .build_ui_state(
            |ui, state: &mut drivedeck::ui::AppState| drivedeck::ui::plots::plots_ui(ui, state),
            drivedeck::ui::AppState::new(Settings::default()),
        );
    {
        let form = &mut harness.state_mut().settings.plot.trigger;
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
    let samples = (0..200)
        .map(|i| drivedeck::worker::Sample {
            t: f64::from(i) * 0.01,
            signals: drivedeck::signal::Signals::default()
                .with(drivedeck::signal::Signal::Position, f64::from(i) * 10.0),
            ..Default::default()
        })
        .collect();
    harness
        .state_mut()
        .apply(drivedeck::worker::Event::Samples(samples));
    harness.step();
    assert!(
        harness.state().scope.recording().is_some(),
        "the trigger fired"
    );
    harness
}

fn message(harness: &Harness<'_, drivedeck::ui::AppState>) -> Result<String, String> {
    harness.state().plot.message.clone().expect("a message")
}

#[test]
fn a_failed_save_says_where_and_why_and_keeps_the_recording_for_the_next_try() {
    let mut harness = plots_harness();
    let recorded = harness.state().scope.recording().map(Recording::len);

    // A directory that does not exist, typed in full.
    let missing = format!("/nonexistent-drivedeck-{}/run.csv", std::process::id());
    harness.state_mut().settings.plot.export_path = missing.clone();
    harness.get_by_label("Save recording").click();
    harness.step();
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
        harness.state().scope.recording().map(Recording::len),
        recorded
    );

    // A relative path: the message names the full path it meant.
    let relative = format!("no-such-dir-{}/run.csv", std::process::id());
    harness.state_mut().settings.plot.export_path = relative.clone();
    harness.get_by_label("Save recording").click();
    harness.step();
    let error = message(&harness).expect_err("the write fails");
    let full = std::env::current_dir().expect("cwd").join(&relative);
    assert!(
        error.starts_with(&format!("cannot write {}: ", full.display())),
        "{error}"
    );

    // A directory where the file should be.
    let dir = common::temp_dir("plots");
    harness.state_mut().settings.plot.export_path = dir.path().to_string_lossy().into_owned();
    harness.get_by_label("Save recording").click();
    harness.step();
    let error = message(&harness).expect_err("a directory is not a file");
    assert!(error.contains("it is a directory"), "{error}");

    // Another place: the same recording, whole, read back from the file.
    let good = path_in(&dir, "retry.csv");
    harness.state_mut().settings.plot.export_path = good.clone();
    harness.get_by_label("Save recording").click();
    harness.step();
    let saved = message(&harness).expect("saved");
    assert!(saved.contains(&good), "{saved}");
    let text = std::fs::read_to_string(&good).expect("written");
    let back = Recording::from_csv(&text).expect("reads back");
    assert_eq!(Some(back.len()), recorded);
    assert_eq!(back.channels[0].id, "position");

    // Export visible does not write over the recording just saved…
    harness.get_by_label("Export visible").click();
    harness.step();
    let refused = message(&harness).expect_err("refused");
    assert!(
        refused.contains("holds the triggered recording"),
        "{refused}"
    );
    assert_eq!(std::fs::read_to_string(&good).expect("still there"), text);
    // …but writes elsewhere, and Save recording may write its own file again.
    let visible = path_in(&dir, "retry-visible.csv");
    harness.state_mut().settings.plot.export_path = visible.clone();
    harness.get_by_label("Export visible").click();
    harness.step();
    message(&harness).expect("exported");
    assert!(std::fs::metadata(&visible).is_ok());
    harness.state_mut().settings.plot.export_path = good.clone();
    harness.get_by_label("Save recording").click();
    harness.step();
    message(&harness).expect("saved again over its own file");
}

/// The times of the timeline's link entries whose text starts with `text`.
fn link_entries(harness: &Harness<'_, App>, text: &str) -> Vec<Option<f64>> {
    harness
        .state()
        .state
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
    let scope = &harness.state().state.scope;
    let first = scope.ring().first_time();
    let (rows, before) = (scope.ring().len(), scope.ring().last_time().unwrap_or(0.0));
    let markers: Vec<(f64, String)> = scope.markers().map(|m| (m.t, m.text.clone())).collect();
    assert!(!markers.is_empty(), "the velocity command's marker");

    // The drive's plug pulled for a while, then back on the same address.
    drop(server);
    step_until(&mut harness, "the link lost", Duration::from_secs(5), |h| {
        h.state().state.scope.open_gap().is_some_and(|g| g.lost)
    });
    step_for(&mut harness, Duration::from_millis(800));
    let _server =
        ServerThread::modbus_tcp(addr, ServerOptions::default()).expect("the same port again");
    step_until(
        &mut harness,
        "samples again",
        Duration::from_secs(15),
        |h| {
            let state = &h.state().state;
            state.is_connected()
                && state.scope.open_gap().is_none()
                && state.scope.ring().len() > rows + 20
        },
    );

    let state = &harness.state().state;
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
    harness.state_mut().state.settings.plot.window_s = 0.0;
    harness.step();
    let (from, to) = drivedeck::ui::plots::time_range(&harness.state().state).expect("range");
    assert!(from <= gap.from && to > back, "{from}..{to} around {gap:?}");
}
