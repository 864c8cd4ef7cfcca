//! The Gains tab in the window, headless, against the built-in simulated drive: the gains
//! are read on connecting, a value is changed by a click, typing, Enter and the
//! confirmation, the drive holds it and the Changes tab lists it; a bad value is refused
//! as it is typed and Esc drops the edit.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::od::{Address, Value};
use drivedeck::ui::gains::GainsPanel;
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{connected, harness_with, step_until};

const VELOCITY_P: Address = Address::new(0x3210, 3);

fn gains_tab() -> Harness<'static, App> {
    let mut harness = harness_with(Settings::default(), true, egui::vec2(1366.0, 768.0));
    harness.run();
    connected(&mut harness);
    harness.get_by_label("Gains").click();
    harness.run();
    step_until(
        &mut harness,
        "the gains read",
        Duration::from_secs(5),
        |h| value(h, VELOCITY_P).is_some(),
    );
    harness
}

fn value(harness: &Harness<'_, App>, address: Address) -> Option<Value> {
    harness
        .state()
        .shown()
        .panels
        .find::<GainsPanel>()
        .and_then(|p| p.row(address))
        .and_then(|r| r.value.clone())
}

#[test]
fn a_gain_is_changed_by_a_click_typing_enter_and_the_confirmation() {
    let mut harness = gains_tab();
    assert_eq!(value(&harness, VELOCITY_P), Some(Value::Uint(12000)));
    harness.get_by_label("3210h:03h value").click();
    harness.run();
    harness
        .get_by_label("new value")
        .set_text_value_accesskit("48000");
    harness.run();
    harness.key_press(egui::Key::Enter);
    harness.run();
    assert!(
        harness
            .query_by_label_contains("Write 48000 (now 12000)?")
            .is_some(),
        "asks first"
    );
    harness.get_by_label("Write it").click();
    harness.step();
    step_until(&mut harness, "the write", Duration::from_secs(5), |h| {
        value(h, VELOCITY_P) == Some(Value::Uint(48000))
            && h.state().shown().changes().map_or(0, |c| c.len()) == 1
    });
    assert!(
        harness
            .query_by_label_contains("written; the Changes tab can undo it")
            .is_some()
    );
}

#[test]
fn a_bad_value_is_refused_as_typed_and_esc_drops_the_edit() {
    let mut harness = gains_tab();
    harness.get_by_label("3210h:03h value").click();
    harness.run();
    harness
        .get_by_label("new value")
        .set_text_value_accesskit("-5");
    harness.run();
    let edit = harness
        .state()
        .shown()
        .panels
        .find::<GainsPanel>()
        .and_then(|p| p.edit.clone())
        .expect("editing");
    assert!(edit.error.is_some(), "{edit:?}");
    harness.key_press(egui::Key::Escape);
    harness.run();
    let panel = harness.state().shown().panels.find::<GainsPanel>().unwrap();
    assert!(panel.edit.is_none());
    assert_eq!(harness.state().shown().changes().map_or(0, |c| c.len()), 0);
}

/// The window's worker writes 3210h:03; wait until the tab shows it.
fn write_gain(harness: &mut Harness<'_, App>, gain: u64) {
    harness
        .state_mut()
        .shown_mut()
        .request(drivedeck::worker::Request::WriteObject {
            address: VELOCITY_P,
            dtype: drivedeck::od::DataType::Unsigned32,
            value: Value::Uint(gain),
            path: drivedeck::worker::ObjectPath::Auto,
        });
    step_until(harness, "the write", Duration::from_secs(5), |h| {
        value(h, VELOCITY_P) == Some(Value::Uint(gain))
    });
}

fn message(harness: &Harness<'_, App>) -> Option<Result<String, String>> {
    harness
        .state()
        .shown()
        .panels
        .find::<GainsPanel>()
        .and_then(|p| p.message.clone())
}

/// Click `button`, answer the question with Yes, and wait until the tab says `said`.
fn housekeeping(
    harness: &mut Harness<'_, App>,
    button: &str,
    said: &str,
) -> Result<String, String> {
    harness.get_by_label(button).click();
    harness.step();
    harness.step();
    assert!(
        harness.query_by_label("Yes").is_some(),
        "{button}: asked first"
    );
    harness.get_by_label("Yes").click();
    harness.step();
    step_until(harness, said, Duration::from_secs(20), |h| {
        message(h).is_some_and(|m| m.as_ref().unwrap_or_else(|e| e).contains(said))
    });
    harness.step();
    message(harness).expect("a message")
}

#[test]
fn store_restart_and_factory_values_say_whether_the_values_came_back() {
    let mut harness = gains_tab();
    window::change(&mut harness, VELOCITY_P, 48000);
    // Not stored: the restart loses it, and the tab says so.
    let said = housekeeping(&mut harness, "Restart drive", "the drive is back");
    let said = said.expect_err("a value did not come back");
    assert!(said.contains("3210h:03h is 12000 (was 48000)"), "{said}");
    assert_eq!(value(&harness, VELOCITY_P), Some(Value::Uint(12000)));

    // Stored, then restarted: it comes back.
    write_gain(&mut harness, 48000);
    let said = housekeeping(&mut harness, "Store", "stored: the values");
    assert!(said.is_ok(), "{said:?}");
    let said = housekeeping(&mut harness, "Restart drive", "the drive is back");
    assert!(
        said.as_ref()
            .is_ok_and(|s| s.contains("came back as it was")),
        "{said:?}"
    );
    assert_eq!(value(&harness, VELOCITY_P), Some(Value::Uint(48000)));

    // The factory values, with a restart.
    let said = housekeeping(&mut harness, "Restore factory values", "the drive is back");
    assert!(
        said.as_ref()
            .is_ok_and(|s| s.contains("factory values") && s.contains("3210h:03h is 12000")),
        "{said:?}"
    );
    assert_eq!(value(&harness, VELOCITY_P), Some(Value::Uint(12000)));
}
