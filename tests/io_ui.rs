//! The I/O tab in the window, headless, against the built-in simulated drive: the inputs
//! by name, an output forced only after a yes, listed in Changes, given back by
//! "Restore what I changed"; released by Release. Against the simulated drive served over
//! Modbus TCP (so the drive outlives the connection and can be looked at after): a forced
//! output is given back when the window disconnects or closes, whatever the user answers
//! about restoring, and the log says so.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::od::{Address, Value};
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::ui::connection_form::Bus;
use drivedeck::ui::drive::{Connection, Outcome};
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
        panel(h).outputs.is_some() && panel(h).words.inputs.is_some()
    });
    assert!(
        harness
            .query_all_by_label("negative limit switch")
            .next()
            .is_some()
    );
    // The simulated machine's normally closed limit switch on input 1.
    assert!(
        harness
            .query_all_by_label("input 1 (negative limit switch, inverted, terminal high)")
            .next()
            .is_some()
    );
    assert!(harness.query_all_by_label("input 4").next().is_some());

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

/// The window on the simulated drive served over Modbus TCP, output 2 forced on from the
/// I/O tab (and seen forced on the drive itself).
fn forced_on_a_served_drive(server: &ServerThread) -> Harness<'static, App> {
    let mut settings = Settings::default();
    settings.connection.bus = Bus::ModbusTcp;
    settings.connection.tcp_host = "127.0.0.1".into();
    settings.connection.tcp_port = server.addr.port().to_string();
    let mut harness = harness_with(settings, true, egui::vec2(1366.0, 768.0));
    connected(&mut harness);
    harness.get_by_label("I/O").click();
    harness.run();
    step_until(&mut harness, "the I/O read", Duration::from_secs(5), |h| {
        panel(h).outputs.is_some()
    });
    answer_yes(&mut harness, "On output 2");
    step_until(&mut harness, "forced on", Duration::from_secs(5), |h| {
        panel(h).output(2) == (Some(true), Some(true))
    });
    assert_eq!(outputs_on_the_drive(server), (1 << 17, 1 << 17));
    harness
}

/// 60FEh:01 and :02 as the served drive holds them.
fn outputs_on_the_drive(server: &ServerThread) -> (u64, u64) {
    let drive = server.drive().lock();
    let word = |sub| match drive.read(Address::new(0x60FE, sub)) {
        Ok(Value::Uint(v)) => v,
        other => panic!("60FEh:{sub:02X}h: {other:?}"),
    };
    (word(1), word(2))
}

/// Leave with the restore unticked and "Leave it as it is": the output is given back all
/// the same, and the log says it was.
fn leave_without_restoring(harness: &mut Harness<'_, App>, server: &ServerThread) {
    let line = window::text_containing(harness, "Output 2 is forced on by this window");
    assert!(
        line.ends_with("it is given back to the drive first, whatever you choose."),
        "{line}"
    );
    harness
        .get_by_label_contains("First restore what I changed")
        .click();
    harness.run();
    assert!(harness.state().shown().leaving.is_some_and(|l| !l.restore));
    harness
        .get_by_label("Leave it as it is, disconnect")
        .click();
    harness.step();
    step_until(harness, "the disconnect", Duration::from_secs(5), |h| {
        matches!(h.state().shown().link.connection, Connection::Disconnected)
    });
    assert_eq!(outputs_on_the_drive(server), (0, 0), "given back");
    let verdict = harness
        .state()
        .shown()
        .log
        .iter()
        .find(|e| e.what == "Give forced outputs back before disconnecting")
        .map(|e| e.outcome.clone());
    assert!(
        matches!(&verdict, Some(Outcome::Succeeded(t)) if t == "given back to the drive"),
        "{verdict:?}"
    );
}

#[test]
fn disconnect_gives_a_forced_output_back_even_without_restoring() {
    let server = common::modbus_server(ServerOptions::default());
    let mut harness = forced_on_a_served_drive(&server);
    harness.get_by_label("Disconnect").click();
    harness.run();
    leave_without_restoring(&mut harness, &server);
}

#[test]
fn closing_the_window_gives_a_forced_output_back() {
    let server = common::modbus_server(ServerOptions::default());
    let mut harness = forced_on_a_served_drive(&server);
    harness
        .input_mut()
        .viewports
        .entry(egui::ViewportId::ROOT)
        .or_default()
        .events
        .push(egui::ViewportEvent::Close);
    harness.run();
    assert!(
        harness
            .state()
            .shown()
            .leaving
            .is_some_and(|l| l.close_window)
    );
    leave_without_restoring(&mut harness, &server);
}

#[test]
fn a_force_given_back_elsewhere_is_not_held_when_leaving() {
    let server = common::modbus_server(ServerOptions::default());
    let mut harness = forced_on_a_served_drive(&server);
    // Another master (here: the drive's own dictionary) gives the output back.
    server
        .drive()
        .lock()
        .write(Address::new(0x60FE, 2), Value::Uint(0))
        .expect("written");
    step_until(&mut harness, "seen released", Duration::from_secs(5), |h| {
        panel(h).output(2).1 == Some(false)
    });
    step_until(
        &mut harness,
        "no longer held",
        Duration::from_secs(5),
        |h| h.state().shown().panels.holding().is_empty(),
    );
}

#[test]
fn a_forced_output_the_link_cannot_give_back_is_named_when_leaving() {
    let server = common::modbus_server(ServerOptions::default());
    let mut harness = forced_on_a_served_drive(&server);
    drop(server);
    step_until(
        &mut harness,
        "the link lost",
        Duration::from_secs(10),
        |h| !h.state().shown().is_connected(),
    );
    let failed = |h: &Harness<'_, App>| {
        h.state()
            .shown()
            .log
            .iter()
            .find(|e| e.what == "Give forced outputs back before disconnecting")
            .map(|e| e.outcome.clone())
    };
    harness.get_by_label("Disconnect").click();
    harness.run();
    let verdict = failed(&harness);
    assert!(
        matches!(&verdict, Some(Outcome::Failed(t))
            if t.contains("no link to the drive") && t.contains("Output 2 is forced on by this window")),
        "{verdict:?}"
    );
}
