//! The I/O tab in the window, headless, against the built-in simulated drive: the inputs
//! by name, an output forced only after a yes, listed in Changes, given back by
//! "Restore what I changed"; released by Release.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::ui::io_panel::IoPanel;
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected, harness_with, step_until};

fn panel<'a>(harness: &'a Harness<'_, App>) -> &'a IoPanel {
    harness
        .state()
        .shown()
        .panels
        .find::<IoPanel>()
        .expect("the I/O tab's model")
}

fn answer_yes(harness: &mut Harness<'_, App>, button: &str) {
    harness.get_by_label(button).click();
    harness.run();
    assert!(panel(harness).asking.is_some(), "asked first");
    assert!(
        harness.query_by_label("Yes").is_some(),
        "the question is on screen"
    );
    harness.get_by_label("Yes").click();
    harness.step();
}

#[test]
fn an_output_is_forced_after_a_yes_listed_in_changes_and_given_back() {
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    connected(&mut harness);
    harness.get_by_label("I/O").click();
    harness.run();
    step_until(&mut harness, "the I/O read", Duration::from_secs(5), |h| {
        panel(h).outputs.is_some() && panel(h).inputs.is_some()
    });
    assert!(
        harness
            .query_all_by_label("negative limit switch")
            .next()
            .is_some()
    );
    assert!(harness.query_all_by_label("input 1").next().is_some());

    answer_yes(&mut harness, "On output 2");
    step_until(&mut harness, "forced on", Duration::from_secs(5), |h| {
        panel(h).output(2) == (Some(true), Some(true))
    });
    assert!(harness.state().shown().changes().map_or(0, |c| c.len()) >= 1);

    // Restore what I changed gives it back.
    harness.get_by_label("Changes (2)").click();
    harness.run();
    harness.get_by_label("Restore what I changed (2)").click();
    harness.step();
    step_until(&mut harness, "given back", Duration::from_secs(5), |h| {
        panel(h).output(2) == (Some(false), Some(false))
    });

    // Forced again, then released from the tab.
    answer_yes(&mut harness, "Off output 2");
    step_until(&mut harness, "forced off", Duration::from_secs(5), |h| {
        panel(h).output(2) == (Some(false), Some(true))
    });
    answer_yes(&mut harness, "Release output 2");
    step_until(&mut harness, "released", Duration::from_secs(5), |h| {
        panel(h).output(2).1 == Some(false)
    });
}
