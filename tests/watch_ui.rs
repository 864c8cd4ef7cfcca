//! The watch panel in the window, headless, against the built-in simulated drive: an
//! object pinned by its address refreshes live while the motor turns and marks the change;
//! the statusword shows its bits by name; a refusal is shown in words; the pins, their
//! formats and the rate are saved with the layout and come back with it.

mod common;
mod window;

use std::time::Duration;

use drivedeck::od::{Address, Value};
use drivedeck::ui::Settings;
use drivedeck::ui::watch::Format;
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, fill, harness_with, start_turning, step_until};

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
        .state
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
    let settings = &harness.state().state.settings.watch;
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
    assert_eq!(harness.state().state.settings.watch.rate, 10.0);
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
    let watch = &harness.state().state.watch;
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
            .state
            .log
            .iter()
            .any(|e| e.what.contains("objects")),
        "{:#?}",
        harness.state().state.log
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
        harness.state().state.watch.message
    );
    pin_typed(&mut harness, "5FFF:33");
    assert!(
        harness
            .query_by_label_contains("5FFFh:33h is not in the dictionary shown")
            .is_some()
    );
    assert!(harness.state().state.settings.watch.pins.is_empty());
}

#[test]
fn the_pins_are_saved_with_the_layout() {
    let mut settings = Settings::default();
    settings.watch.address = "6041".into();
    settings
        .watch
        .pin_typed(drivedeck::od::builtin())
        .expect("pin 6041h");
    settings.watch.pins[0].format = Format::Hex;
    settings.watch.rate = 5.0;
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
