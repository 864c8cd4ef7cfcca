//! Jog and stop in the window, headless (egui_kittest) on the simulated drive: the motor
//! moves while "Jog +" is held and stops on release; the arrow keys jog too, Esc stops a
//! jog and a held key does not start it again; Esc's Quickstop goes out ahead of
//! requests already queued.

mod window;

use std::time::Duration;

use drivedeck::od::{Address, DataType};
use drivedeck::pdi::StatusBit;
use drivedeck::ui::drive::Outcome;
use drivedeck::worker::{ObjectPath, Request};
use eframe::egui;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, start_turning, step_for, step_until, velocity};

#[test]
fn the_motor_moves_while_jog_is_held_and_halts_on_release() {
    let mut harness = app_harness();
    connected(&mut harness);
    let button = harness.get_by_label("Jog +").rect().center();
    harness.hover_at(button);
    harness.drag_at(button);
    harness.step();
    step_until(&mut harness, "the jog", Duration::from_secs(3), |h| {
        velocity(h) > 80.0
    });
    // Held for well over the worker's keep-alive timeout: the window keeps it alive.
    step_for(&mut harness, Duration::from_millis(1200));
    assert!(velocity(&harness) > 80.0, "still jogging");
    assert!(
        !harness
            .state()
            .shown()
            .log
            .iter()
            .any(|e| e.what.contains("jog halted")),
        "the worker did not have to step in"
    );
    harness.drop_at(button);
    harness.step();
    step_until(
        &mut harness,
        "the halt on release",
        Duration::from_secs(3),
        |h| velocity(h) == 0.0,
    );
    let state = harness.state().shown();
    assert!(state.bit(StatusBit::QsHaltBit));
    assert!(
        state.bit(StatusBit::OperationEnabled),
        "halted, still enabled"
    );
    assert!(state.motion.jog.is_none());
    assert!(state.log.iter().any(|e| e.what == "Jog released: halt"));
}

#[test]
fn arrow_keys_jog_and_escape_stops_a_jog_for_good() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.key_down(egui::Key::ArrowLeft);
    harness.step();
    step_until(
        &mut harness,
        "the jog backwards",
        Duration::from_secs(3),
        |h| velocity(h) < -80.0,
    );
    // Esc while the arrow is still held: Quickstop, and no new jog.
    harness.key_press(egui::Key::Escape);
    harness.step();
    step_until(
        &mut harness,
        "the quick stop",
        Duration::from_secs(3),
        |h| !h.state().shown().bit(StatusBit::OperationEnabled) && velocity(h) == 0.0,
    );
    step_for(&mut harness, Duration::from_millis(400));
    assert!(velocity(&harness) == 0.0, "the held key did not jog again");
    assert!(harness.state().shown().motion.jog.is_none());
    harness.key_up(egui::Key::ArrowLeft);
    harness.step();
    assert!(
        !harness.state().shown().motion.jog_blocked,
        "released: jog works again"
    );
}

#[test]
fn arrow_keys_jog_with_the_command_panel_folded() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.get_by_label("Collapse the command panel").click();
    harness.run_steps(2);
    assert!(
        harness.query_by_label("Jog +").is_none(),
        "the panel is folded"
    );
    harness.key_down(egui::Key::ArrowRight);
    harness.step();
    step_until(
        &mut harness,
        "the jog forwards, panel folded",
        Duration::from_secs(3),
        |h| velocity(h) > 80.0,
    );
    harness.key_up(egui::Key::ArrowRight);
    harness.step();
    step_until(
        &mut harness,
        "the halt on release",
        Duration::from_secs(3),
        |h| velocity(h) == 0.0,
    );
    let state = harness.state().shown();
    assert!(state.motion.jog.is_none());
    assert!(state.log.iter().any(|e| e.what == "Jog released: halt"));
}

#[test]
fn escape_sends_quickstop_ahead_of_everything_queued() {
    let mut harness = app_harness();
    connected(&mut harness);
    start_turning(&mut harness, 50.0);
    // Twenty-eight reads through the PDI queue up (the request channel holds 32): each
    // waits for the one before, about three cycles each, so they take a while even on a
    // busy machine.
    for sub in 1..=4 {
        for _ in 0..7 {
            harness
                .state_mut()
                .shown_mut()
                .request(Request::ReadObject {
                    address: Address::new(0x1018, sub),
                    dtype: Some(DataType::Unsigned32),
                    path: ObjectPath::Pdi,
                });
        }
    }
    harness.key_press(egui::Key::Escape);
    harness.step();
    step_until(
        &mut harness,
        "the quick stop to go out",
        Duration::from_secs(2),
        |h| {
            h.state()
                .shown()
                .log
                .iter()
                .any(|e| e.what == "Quickstop" && e.outcome != Outcome::Queued)
        },
    );
    let waiting = harness
        .state()
        .shown()
        .log
        .iter()
        .filter(|e| e.what.starts_with("read 1018h") && e.outcome == Outcome::Queued)
        .count();
    assert!(
        waiting >= 14,
        "the quick stop went out while the reads queued before it still waited ({waiting} of 28)"
    );
    step_until(
        &mut harness,
        "the motor to stop",
        Duration::from_secs(3),
        |h| velocity(h) == 0.0 && !h.state().shown().bit(StatusBit::OperationEnabled),
    );
}
