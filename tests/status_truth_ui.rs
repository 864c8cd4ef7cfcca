//! The window's status words tell the truth, headless (egui_kittest) on the simulated
//! drive: a silent drive is not "connected" in green, a deliberate Disconnect is a calm
//! DISCONNECTED and not an alarm, a jog's release halts the drive and the halt button says
//! so as the tile does, and ReturnValue is labelled by what the PDI says it holds after
//! the command last sent.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use std::time::{Duration, SystemTime};

use drivedeck::link::{LinkInfo, LinkSpec};
use drivedeck::ui::drive::Connection;
use drivedeck::worker::Sample;
use eframe::egui;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{app_harness, connected, disconnected_harness, start_turning, step_until, velocity};

#[test]
fn a_connected_drive_that_stopped_answering_is_not_green_connected() {
    let mut harness = disconnected_harness();
    {
        let link = &mut harness.state_mut().shown_mut().link;
        link.connection = Connection::Connected(LinkInfo {
            spec: LinkSpec::Sim,
            description: "simulated drive".into(),
            native_objects: true,
            can_inject: true,
            pdi: true,
            homing_methods: None,
            commands_refused: None,
        });
        link.latest = Some(Sample::default());
        link.sampled_since_connect = true;
        link.last_sample_at = Some(SystemTime::now() - Duration::from_secs(10));
    }
    harness.run_steps(2);
    harness.get_by_label("connected, no data:");
    assert!(harness.query_by_label("connected:").is_none());
    harness.get_by_label_contains("NO DATA (last seen");
}

#[test]
fn a_deliberate_disconnect_is_a_calm_disconnected_not_an_alarm() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.get_by_label("Disconnect").click();
    step_until(&mut harness, "disconnected", Duration::from_secs(5), |h| {
        matches!(h.state().shown().link.connection, Connection::Disconnected)
    });
    harness.run_steps(3);
    harness.get_by_label("DISCONNECTED");
    assert!(
        harness.query_by_label_contains("NO LINK").is_none(),
        "no alarm for a disconnect the user asked for"
    );
}

#[test]
fn a_jog_release_halts_and_the_halt_button_says_halted_as_the_tile_does() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.key_down(egui::Key::ArrowRight);
    harness.step();
    step_until(&mut harness, "the jog", Duration::from_secs(3), |h| {
        velocity(h) > 80.0
    });
    harness.key_up(egui::Key::ArrowRight);
    harness.step();
    step_until(&mut harness, "the halt", Duration::from_secs(3), |h| {
        velocity(h) == 0.0
    });
    harness.run_steps(3);
    harness.get_by_label_contains("HALTED");
    let button = harness.get_by_label("Halted");
    assert!(
        button.accesskit_node().is_disabled(),
        "no resume of a jog nobody holds"
    );
    assert!(harness.query_by_label("Halt").is_none());
}

#[test]
fn return_value_is_labelled_by_the_command_last_sent() {
    let mut harness = app_harness();
    connected(&mut harness);
    start_turning(&mut harness, 50.0);
    harness.run_steps(2);
    harness.get_by_label("rpm (velocity)");
    // A quick stop: the PDI spec does not say what ReturnValue holds then.
    harness.key_press(egui::Key::Escape);
    harness.step();
    step_until(
        &mut harness,
        "the quick stop",
        Duration::from_secs(3),
        |h| {
            h.state().shown().last_opcode() == Some(drivedeck::pdi::Opcode::Quickstop)
                && velocity(h) == 0.0
        },
    );
    harness.run_steps(2);
    assert!(
        harness.query_by_label("rpm (velocity)").is_none(),
        "no speed unit on a value the spec does not call a speed"
    );
    // A move: the position.
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(&mut harness, "the move", Duration::from_secs(5), |h| {
        h.state().shown().last_opcode() == Some(drivedeck::pdi::Opcode::MoveAbsolute)
    });
    harness.run_steps(2);
    harness.get_by_label("0.1° (position)");
}
