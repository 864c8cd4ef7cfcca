//! The watch panel in the window, headless, against the built-in simulated drive: an
//! object pinned by its address refreshes live while the motor turns and marks the change;
//! the statusword shows its bits by name; a refusal is shown in words; the pins, their
//! formats and the rate are saved with the layout and come back with it.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::od::{Address, Value};
use drivedeck::ui::Settings;
use drivedeck::ui::watch::Format;
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{
    app_harness, connected, fill, harness_with, start_turning, step_until, step_until_shown,
};

const POSITION: Address = Address::new(0x6064, 0);
const STATUSWORD: Address = Address::new(0x6041, 0);

fn pin_typed(harness: &mut Harness<'_, drivedeck::ui::App>, address: &str) {
    fill(harness, &[("watch address", address)]);
    harness.get_by_label("Pin").click();
    harness.step();
    harness.step();
}

fn reading(harness: &Harness<'_, drivedeck::ui::App>, address: Address) -> Option<Value> {
    harness
        .state()
        .shown()
        .watch
        .reading(address)
        .and_then(|r| r.result.clone().ok())
}

#[test]
fn a_pinned_position_refreshes_while_the_motor_turns() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.get_by_label("Watch (0)").click();
    harness.step();
    assert!(
        harness
            .query_by_label_contains("Nothing watched yet")
            .is_some()
    );
    pin_typed(&mut harness, "6064");
    pin_typed(&mut harness, "6041:00");
    assert!(
        harness.query_by_label("Watch (2)").is_some(),
        "the toggle counts the pins"
    );
    let settings = &harness.state().shown().settings.watch;
    assert_eq!(settings.pins.len(), 2);
    assert_eq!(
        settings.pins[1].format,
        Format::Bits,
        "6041h has named bits"
    );
    // Ten reads a second.
    harness.get_by_label("watch refresh rate").click();
    harness.step();
    harness.step();
    harness.get_by_label("10 Hz").click();
    harness.step();
    assert_eq!(harness.state().shown().settings.watch.rate, 10.0);
    step_until(
        &mut harness,
        "a first reading",
        Duration::from_secs(5),
        |h| reading(h, POSITION).is_some() && reading(h, STATUSWORD).is_some(),
    );
    assert!(
        harness
            .query_by_label_contains("operation enabled")
            .is_some(),
        "the statusword's bits by name"
    );
    let first = reading(&harness, POSITION).and_then(|v| v.as_i128());
    start_turning(&mut harness, 100.0);
    step_until(
        &mut harness,
        "the position read again",
        Duration::from_secs(5),
        |h| {
            let now = reading(h, POSITION).and_then(|v| v.as_i128());
            now.is_some() && now != first
        },
    );
    // What the last frame drew is what the state held after it.
    harness.step();
    let watch = &harness.state().shown().watch;
    let read = watch.reading(POSITION).expect("6064h read");
    assert!(read.changed_at.is_some(), "a value that changed is marked");
    let shown = format!("6064h:00h = {}", read.result.clone().expect("a value"));
    assert!(
        harness.query_by_label_contains(&shown).is_some(),
        "{shown} on screen"
    );
    // None of the watch's reads reached the command log.
    assert!(
        !harness
            .state()
            .shown()
            .log
            .iter()
            .any(|e| e.what.contains("objects")),
        "{:#?}",
        harness.state().shown().log
    );
}

#[test]
fn a_bad_address_is_named_and_kept_to_correct() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.get_by_label("Watch (0)").click();
    harness.step();
    pin_typed(&mut harness, "60g4");
    assert!(
        harness
            .query_by_label_contains("'60g4' is not an address")
            .is_some(),
        "{:?}",
        harness.state().shown().watch.message
    );
    pin_typed(&mut harness, "5FFF:33");
    assert!(
        harness
            .query_by_label_contains("5FFFh:33h is not in the dictionary shown")
            .is_some()
    );
    assert!(harness.state().shown().settings.watch.pins.is_empty());
}

#[test]
fn the_pins_are_saved_with_the_layout() {
    let mut settings = Settings::default();
    let mut watch = drivedeck::ui::watch::WatchSettings {
        address: "6041".into(),
        ..Default::default()
    };
    watch
        .pin_typed(drivedeck::od::builtin())
        .expect("pin 6041h");
    settings.watch.pins = watch.pins;
    settings.watch.pins[0].format = Format::Hex;
    settings.watch.rate = 5.0;
    // The panel was open when the window was closed.
    settings.watch.open = true;
    // What eframe stores between runs is the settings as RON; JSON has the same serde.
    let saved = serde_json::to_string(&settings).expect("settings serialise");
    let loaded: Settings = serde_json::from_str(&saved).expect("and come back");
    assert_eq!(loaded.watch, settings.watch);
    // A window opened with them shows the panel and reads the pin in hex.
    let mut harness = harness_with(loaded, true, egui::vec2(1400.0, 900.0));
    connected(&mut harness);
    step_until(&mut harness, "6041h read", Duration::from_secs(5), |h| {
        reading(h, STATUSWORD).is_some()
    });
    let value = reading(&harness, STATUSWORD)
        .and_then(|v| v.as_i128())
        .expect("a number");
    let shown = format!("6041h:00h = {value:04X}h");
    harness.step();
    assert!(
        harness.query_by_label(&shown).is_some(),
        "{shown} in the panel"
    );
    // Older settings without a watch section still load.
    let old = saved.replace("\"watch\"", "\"watch_of_the_future\"");
    let mut value: serde_json::Value = serde_json::from_str(&old).expect("json");
    if let Some(map) = value.as_object_mut() {
        map.remove("watch_of_the_future");
    }
    let older: Settings = serde_json::from_value(value).expect("loads without watch");
    assert!(older.watch.pins.is_empty());
}

#[test]
fn objects_are_pinned_from_the_dictionary_and_from_the_plots() {
    let mut harness = app_harness();
    connected(&mut harness);
    // From the dictionary: the row's Watch button pins the object and opens the panel.
    harness.state_mut().window_mut().settings.central =
        drivedeck::ui::settings::DICTIONARY.to_owned();
    harness.step();
    harness
        .get_by_label("Object filter")
        .set_text_value_accesskit("6064");
    step_until_shown(&mut harness, "Watch 6064h:00h");
    harness.get_by_label("Watch 6064h:00h").click();
    harness.step();
    harness.step();
    assert!(harness.state().shown().settings.watch.is_pinned(POSITION));
    assert!(harness.state().settings().watch_open, "the panel opens");
    assert!(
        harness
            .query_by_label_contains("watching 6064h:00h")
            .is_some(),
        "the dictionary says so"
    );
    step_until(&mut harness, "6064h read", Duration::from_secs(5), |h| {
        reading(h, POSITION).is_some()
    });
    // Pinned once: the button is disabled now, so a second pin cannot be asked from it,
    // and asked anyway it is refused in words.
    assert!(
        harness
            .get_by_label("Watch 6064h:00h")
            .accesskit_node()
            .is_disabled()
    );
    assert_eq!(
        harness.state_mut().pin_to_watch(POSITION),
        Err("6064h:00h is pinned already".to_owned())
    );

    // From the plots: an object plotted from the dictionary can be watched in numbers.
    harness
        .state_mut()
        .plot_object("6044")
        .expect("6044h plotted");
    harness.state_mut().window_mut().settings.central = drivedeck::ui::settings::PLOTS.to_owned();
    harness.step();
    harness.get_by_label("Signals").click();
    step_until_shown(&mut harness, "Watch 6044h:00h");
    harness.get_by_label("Watch 6044h:00h").click();
    harness.step();
    harness.step();
    let velocity = Address::new(0x6044, 0);
    assert!(harness.state().shown().settings.watch.is_pinned(velocity));
    assert!(
        matches!(&harness.state().plot().message(), Some(Ok(t)) if t.contains("watching 6044h:00h")),
        "{:?}",
        harness.state().plot().message()
    );
    step_until(&mut harness, "6044h read", Duration::from_secs(5), |h| {
        reading(h, velocity).is_some()
    });
    assert!(harness.query_by_label("Watch (2)").is_some());
}
