//! The window, headless, for the UI tests: an `App` in an egui_kittest harness with the
//! real worker, stepping it in real time until something happens, and what a technician
//! does in it (pick a bus, fill in fields, read an object) and reads off it (lamps,
//! velocity).

#![allow(dead_code)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use drivedeck::link::LinkSpec;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::ui::connection_form::ConnectionForm;
use drivedeck::ui::{App, Settings, WorkerClock};
use drivedeck::worker::{ObjectPath, Request};
use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};

/// The window with `settings`, connecting to their link when `connect`.
pub fn harness_with(settings: Settings, connect: bool, size: egui::Vec2) -> Harness<'static, App> {
    let app = App::new(settings, Arc::new(|| {}), connect);
    Harness::builder()
        .with_size(size)
        .build_ui_state(|ui, app: &mut App| app.frame(ui), app)
}

/// The window on the built-in simulated drive with its worker on simulated time: waiting
/// for a move, a ramp or a health report costs no real time (the simulated clock jumps
/// ahead whenever the worker only waits). For tests that wait for an end state only: the
/// drive may pass through a state between two frames.
pub fn sim_time_harness() -> Harness<'static, App> {
    let app = App::with_clock(
        Settings::default(),
        Arc::new(|| {}),
        true,
        WorkerClock { simulated: true },
    );
    Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .build_ui_state(|ui, app: &mut App| app.frame(ui), app)
}

/// The window as it opens by default: on the built-in simulated drive.
pub fn app_harness() -> Harness<'static, App> {
    harness_with(Settings::default(), true, egui::vec2(1400.0, 900.0))
}

/// The window as after a fresh install on a machine with a drive: not connected.
pub fn disconnected_harness() -> Harness<'static, App> {
    let mut harness = harness_with(Settings::default(), false, egui::vec2(1400.0, 900.0));
    harness.run();
    harness
}

/// The window connected to `spec` (its connection bar filled in from it), at `size`, with
/// its first sample in.
pub fn connected_to(
    spec: &LinkSpec,
    lost_after: Option<u32>,
    size: egui::Vec2,
) -> Harness<'static, App> {
    let mut settings = Settings::default();
    settings.connection = ConnectionForm::from_spec(spec, settings.connection);
    if let Some(lost_after) = lost_after {
        settings.lost_after = lost_after;
    }
    let mut harness = harness_with(settings, true, size);
    connected(&mut harness);
    harness
}

/// Step the window in real time until `done` holds; on a timeout the log, the plot
/// panel's message and the fault timeline say what happened instead.
pub fn step_until(
    harness: &mut Harness<'_, App>,
    what: &str,
    timeout: Duration,
    done: impl Fn(&Harness<'_, App>) -> bool,
) {
    let deadline = Instant::now() + timeout;
    while !done(harness) {
        let app = harness.state();
        let drive = app.shown();
        assert!(
            Instant::now() < deadline,
            "{what} did not happen within {timeout:?}; plot message: {:?}; browser message: {:?}; timeline: {:#?}; log: {:#?}",
            app.plot().message(),
            drive.browser.message,
            drive.timeline.entries().collect::<Vec<_>>(),
            drive.log
        );
        std::thread::sleep(Duration::from_millis(10));
        harness.step();
    }
}

/// Step the window in real time for `time`.
pub fn step_for(harness: &mut Harness<'_, App>, time: Duration) {
    let until = Instant::now() + time;
    while Instant::now() < until {
        std::thread::sleep(Duration::from_millis(10));
        harness.step();
    }
}

/// Wait until the window has its first sample from the drive.
pub fn connected(harness: &mut Harness<'_, App>) {
    step_until(harness, "connecting", Duration::from_secs(5), |h| {
        h.state().shown().latest().is_some()
    });
}

/// Whether a status lamp is lit (lamps are read-only checkboxes to accessibility).
pub fn lamp<State>(harness: &Harness<'_, State>, label: &str) -> bool {
    harness
        .get_by_role_and_label(egui::accesskit::Role::CheckBox, label)
        .accesskit_node()
        .toggled()
        == Some(Toggled::True)
}

/// Step until a widget labelled `label` is on screen (a dialog that opens, a row that
/// a filter brings): the live plots keep repainting, so `Harness::run` may not settle.
/// Two frames more: a dialog's first frame only measures it, and it moves to its place
/// in the next (a click at the first frame's place would miss a wide dialog's button).
pub fn step_until_shown(harness: &mut Harness<'_, App>, label: &str) {
    step_until(
        harness,
        &format!("'{label}' on screen"),
        Duration::from_secs(3),
        |h| h.query_by_label(label).is_some(),
    );
    harness.run_steps(2);
}

/// Pick `bus` in the connection bar.
pub fn choose_bus(harness: &mut Harness<'_, App>, bus: &str) {
    harness.get_by_label("Bus").click();
    harness.run();
    harness.get_by_label(bus).click();
    harness.run();
}

/// Type into each field named by its label, then let the window take them.
pub fn fill(harness: &mut Harness<'_, App>, fields: &[(&str, &str)]) {
    for (label, text) in fields {
        harness.get_by_label(label).set_text_value_accesskit(text);
    }
    harness.run();
}

/// Read the object at `address` (as typed) with the window's Read button, and wait until
/// the window shows `expected`.
pub fn read_object(
    harness: &mut Harness<'_, App>,
    address: &str,
    expected: &Value,
    timeout: Duration,
) {
    fill(harness, &[("Object address", address)]);
    harness.get_by_label("Read").click();
    harness.step();
    step_until(harness, &format!("{address} read"), timeout, |h| {
        h.state()
            .shown()
            .motion
            .last_object
            .as_ref()
            .is_some_and(|r| r.result.as_ref() == Ok(expected))
    });
}

/// The window's worker writes `value` (UNSIGNED32) to `address`; wait until the window
/// lists it as the one change made.
pub fn change(harness: &mut Harness<'_, App>, address: Address, value: u64) {
    harness
        .state_mut()
        .shown_mut()
        .request(Request::WriteObject {
            address,
            dtype: DataType::Unsigned32,
            value: Value::Uint(value),
            path: ObjectPath::Auto,
        });
    step_until(harness, "the change", Duration::from_secs(3), |h| {
        h.state().shown().changes().map_or(0, |c| c.len()) == 1
    });
}

/// Click "Velocity" (the default 300 rpm) and wait until the motor turns faster than
/// `above` rpm.
pub fn start_turning(harness: &mut Harness<'_, App>, above: f64) {
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until(harness, "the motor to turn", Duration::from_secs(5), |h| {
        velocity(h) > above
    });
}

/// The newest velocity the window shows (NaN before there is one).
pub fn velocity(harness: &Harness<'_, App>) -> f64 {
    harness
        .state()
        .shown()
        .latest()
        .and_then(|s| s.velocity())
        .unwrap_or(f64::NAN)
}

/// The newest position the window shows (NaN before there is one).
pub fn position(harness: &Harness<'_, App>) -> f64 {
    harness
        .state()
        .shown()
        .latest()
        .and_then(|s| s.position())
        .unwrap_or(f64::NAN)
}

/// The whole text of the first widget whose label contains `text` (a label keeps its
/// text as its value to accessibility, a button as its label).
pub fn text_containing<State>(harness: &Harness<'_, State>, text: &str) -> String {
    let node = harness.get_by_label_contains(text);
    let node = node.accesskit_node();
    node.value()
        .or_else(|| node.label())
        .unwrap_or_default()
        .to_string()
}

/// Open the Procedure tab and load `procedure` there, its record to go to `record` (the
/// operator "Kittest").
pub fn load_procedure(
    harness: &mut Harness<'_, App>,
    procedure: &std::path::Path,
    record: &std::path::Path,
) {
    harness.get_by_label("Procedure").click();
    harness.run();
    {
        let model = harness
            .state_mut()
            .shown_mut()
            .panels
            .get::<drivedeck::ui::procedure::ProcedurePanel>();
        model.path = procedure.display().to_string();
        model.record_path = record.display().to_string();
        model.operator = "Kittest".into();
    }
    harness.get_by_label("Load").click();
    harness.run();
}
