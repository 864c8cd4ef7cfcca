//! Leaving a drive safely, headless (egui_kittest), against the simulated drive served
//! over Modbus TCP (so the drive outlives the connection and can be looked at after):
//! Disconnect with the motor energised asks; halt (the default) and switch off reach the
//! drive before the link closes; changed objects are restored first when asked; closing
//! the window asks the same; the link-loss setting is honoured.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use common::wait_until;
use drivedeck::cia::PowerState;
use drivedeck::od::{Address, Value};
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::ui::connection_form::Bus;
use drivedeck::ui::drive::{Connection, Outcome};
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{change, connected, harness_with, start_turning, step_until, step_until_shown};

fn server() -> ServerThread {
    common::modbus_server(ServerOptions::default())
}

/// The window connected to `server` over Modbus TCP.
fn window_on(server: &ServerThread) -> Harness<'static, App> {
    let mut settings = Settings::default();
    settings.connection.bus = Bus::ModbusTcp;
    settings.connection.tcp_host = "127.0.0.1".into();
    settings.connection.tcp_port = server.addr.port().to_string();
    let mut harness = harness_with(settings, true, egui::vec2(1400.0, 900.0));
    connected(&mut harness);
    harness
}

/// The window connected to `server`, the motor turning at 300 rpm.
fn turning(server: &ServerThread) -> Harness<'static, App> {
    let mut harness = window_on(server);
    start_turning(&mut harness, 250.0);
    harness
}

fn disconnected(harness: &Harness<'_, App>) -> bool {
    matches!(
        harness.state().shown().link.connection,
        Connection::Disconnected
    )
}

/// Click `label` (Disconnect, or an answer to the question it asks) and wait until the
/// window is disconnected.
fn click_and_disconnect(harness: &mut Harness<'_, App>, label: &str) {
    harness.get_by_label(label).click();
    harness.step();
    step_until(
        harness,
        "the disconnect",
        Duration::from_secs(5),
        disconnected,
    );
}

#[test]
fn disconnect_while_turning_asks_and_the_default_halt_reaches_the_drive() {
    let server = server();
    let mut harness = turning(&server);
    harness.get_by_label("Disconnect").click();
    step_until_shown(&mut harness, "Halt, then disconnect");
    assert!(harness.state().shown().leaving.is_some(), "it asks first");
    assert!(!disconnected(&harness), "nothing happens before the answer");
    // It says what the motor does, and which button Enter presses.
    let sentence = window::text_containing(&harness, "The power stage is on: the motor is ");
    assert!(
        sentence.starts_with("The power stage is on: the motor is moving at 3"),
        "{sentence}"
    );
    harness.get_by_label("Enter presses this button");
    click_and_disconnect(&mut harness, "Halt, then disconnect");
    // The log says the drive confirmed the halt, as a success (green, not red).
    let verdict = harness
        .state()
        .shown()
        .log
        .iter()
        .find(|e| e.what == "Halt before disconnecting")
        .map(|e| e.outcome.clone());
    assert!(
        matches!(&verdict, Some(Outcome::Succeeded(text))
            if text.starts_with("confirmed by the drive: halt bit set") && text.contains("standing still")),
        "{verdict:?}"
    );
    assert!(
        !harness
            .state()
            .shown()
            .log
            .iter()
            .any(|e| matches!(e.outcome, Outcome::Failed(_))),
        "nothing logged as failed: {:#?}",
        harness.state().shown().log
    );
    // The halt bit reached the drive before the link closed: it brakes to a stop and
    // stays energised.
    let drive = server.drive();
    assert!(drive.lock().rx_image().cmd & 0x40 != 0, "halt bit written");
    wait_until("the motor at rest", Duration::from_secs(5), || {
        drive.lock().velocity_rpm().abs() < 0.5
    });
    assert_eq!(drive.lock().power_state(), PowerState::OperationEnabled);
}

#[test]
fn switch_off_with_restore_undoes_the_changes_then_switches_off() {
    let server = server();
    let mut harness = turning(&server);
    let velocity = Address::new(0x6081, 0);
    let before = server.drive().lock().read(velocity).expect("readable");
    change(&mut harness, velocity, 777);
    assert_eq!(server.drive().lock().read(velocity), Ok(Value::Uint(777)));
    harness.get_by_label("Disconnect").click();
    step_until_shown(&mut harness, "Switch off, then disconnect");
    // Restoring is offered, and on by default.
    assert!(harness.state().shown().leaving.is_some_and(|l| l.restore));
    click_and_disconnect(&mut harness, "Switch off, then disconnect");
    let drive = server.drive();
    assert_eq!(drive.lock().read(velocity), Ok(before), "restored");
    wait_until("the power stage off", Duration::from_secs(5), || {
        !drive.lock().power_state().is_energised()
    });
}

#[test]
fn leaving_it_on_keeps_it_turning_and_an_idle_drive_disconnects_without_asking() {
    let server = server();
    let mut harness = turning(&server);
    harness.get_by_label("Disconnect").click();
    step_until_shown(&mut harness, "Leave it as it is, disconnect");
    click_and_disconnect(&mut harness, "Leave it as it is, disconnect");
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        server.drive().lock().velocity_rpm() > 250.0,
        "still turning"
    );

    // A drive switched off and unchanged: no question.
    let idle = self::server();
    let mut harness = window_on(&idle);
    click_and_disconnect(&mut harness, "Disconnect");
}

#[test]
fn pressing_enter_in_the_question_halts_then_disconnects() {
    let server = server();
    let mut harness = turning(&server);
    harness.get_by_label("Disconnect").click();
    step_until_shown(&mut harness, "Enter presses this button");
    harness.key_press(egui::Key::Enter);
    harness.step();
    step_until(
        &mut harness,
        "the disconnect",
        Duration::from_secs(8),
        disconnected,
    );
    assert!(server.drive().lock().rx_image().cmd & 0x40 != 0, "halted");
}

#[test]
fn closing_the_window_while_turning_asks_too() {
    let server = server();
    let mut harness = turning(&server);
    harness
        .input_mut()
        .viewports
        .entry(egui::ViewportId::ROOT)
        .or_default()
        .events
        .push(egui::ViewportEvent::Close);
    step_until_shown(&mut harness, "Halt, then disconnect");
    let leaving = harness.state().shown().leaving.expect("asked");
    assert!(leaving.close_window);
    click_and_disconnect(&mut harness, "Halt, then disconnect");
    assert!(server.drive().lock().rx_image().cmd & 0x40 != 0, "halted");
}
