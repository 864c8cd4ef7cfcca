//! The window, headless, for the UI tests: an `App` in an egui_kittest harness with the
//! real worker, and stepping it in real time until something happens.

#![allow(dead_code)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use drivedeck::ui::{App, Settings};
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

/// The window as it opens by default: on the built-in simulated drive.
pub fn app_harness() -> Harness<'static, App> {
    harness_with(Settings::default(), true, egui::vec2(1400.0, 900.0))
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
        let state = &harness.state().state;
        assert!(
            Instant::now() < deadline,
            "{what} did not happen within {timeout:?}; plot message: {:?}; timeline: {:#?}; log: {:#?}",
            state.plot.message,
            state.timeline.entries().collect::<Vec<_>>(),
            state.log
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
        h.state().state.latest.is_some()
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
pub fn step_until_shown(harness: &mut Harness<'_, App>, label: &str) {
    step_until(
        harness,
        &format!("'{label}' on screen"),
        Duration::from_secs(3),
        |h| h.query_by_label(label).is_some(),
    );
}
