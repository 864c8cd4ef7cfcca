//! The NanoJ tab in the window, headless, against the built-in simulated drive: the
//! program named, started (and said to run), an input written and copied to an output,
//! the injected error decoded, stopped.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::ui::nanoj::NanojPanel;
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected, harness_with, step_until};

fn panel<'a>(harness: &'a Harness<'_, App>) -> &'a NanojPanel {
    harness
        .state()
        .shown()
        .panels
        .find::<NanojPanel>()
        .expect("the NanoJ tab's model")
}

fn write_input(harness: &mut Harness<'_, App>, n: u8, value: &str) {
    harness
        .get_by_label(&format!("NanoJ input {n} value"))
        .click();
    harness.run();
    harness
        .get_by_label("NanoJ input value")
        .set_text_value_accesskit(value);
    harness.run();
    harness.get_by_label("Write NanoJ input").click();
    harness.step();
}

#[test]
fn the_program_is_started_fed_an_input_its_error_decoded_and_stopped() {
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    connected(&mut harness);
    harness.get_by_label("NanoJ").click();
    harness.run();
    step_until(
        &mut harness,
        "the program read",
        Duration::from_secs(5),
        |h| panel(h).status == Some(0) && !panel(h).programs.is_empty(),
    );
    assert_eq!(panel(&harness).programs, ["demo.usr"]);
    assert!(harness.query_by_label("Program: stopped").is_some());
    assert_eq!(panel(&harness).inputs_mapped.len(), 3);

    harness.get_by_label("Start").click();
    harness.step();
    step_until(
        &mut harness,
        "running",
        Duration::from_secs(5),
        |h| matches!(&panel(h).message, Some(Ok(m)) if m == "the program runs"),
    );
    write_input(&mut harness, 1, "42");
    step_until(&mut harness, "output 1", Duration::from_secs(5), |h| {
        panel(h).outputs[0] == Some(42)
    });

    write_input(&mut harness, 3, "5");
    step_until(&mut harness, "the error", Duration::from_secs(5), |h| {
        panel(h).status == Some(2)
    });
    harness.step();
    assert!(
        harness
            .query_by_label_contains("it ran too long without yield() or sleep()")
            .is_some()
    );
    write_input(&mut harness, 3, "0");
    harness.get_by_label("Start").click();
    harness.step();
    step_until(&mut harness, "running again", Duration::from_secs(5), |h| {
        panel(h).status == Some(1)
    });
    harness.get_by_label("Stop").click();
    harness.step();
    step_until(
        &mut harness,
        "stopped",
        Duration::from_secs(5),
        |h| matches!(&panel(h).message, Some(Ok(m)) if m == "the program stopped"),
    );
}
