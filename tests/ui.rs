//! The window, headless: egui_kittest clicks by label, the real worker drives the
//! simulated drive.

mod window;

use std::time::Duration;

use drivedeck::link::{LinkInfo, LinkSpec};
use drivedeck::pdi::{Action, StatusBit};
use drivedeck::ui::state::Connection;
use drivedeck::ui::{AppState, Settings, commands};
use drivedeck::worker::Request;
use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{app_harness, harness_with, lamp, step_until};

#[test]
fn the_absolute_move_button_sends_the_command_and_the_lamps_follow() {
    let mut harness = app_harness();
    step_until(
        &mut harness,
        "connecting to the simulator",
        Duration::from_secs(5),
        |h| h.state().state.is_connected() && h.state().state.latest.is_some(),
    );
    assert!(!lamp(&harness, "Operation enabled"));
    assert!(!lamp(&harness, "Target reached"));

    // The default inputs are the spec's example: 2000 at 200.
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the move to be accepted",
        Duration::from_secs(3),
        |h| lamp(h, "Operation enabled"),
    );
    step_until(
        &mut harness,
        "the target to be reached",
        Duration::from_secs(5),
        |h| {
            lamp(h, "Target reached")
                && h.state().state.latest.and_then(|s| s.position) == Some(2000.0)
        },
    );
    let state = &harness.state().state;
    let entry = state
        .log
        .iter()
        .find(|e| e.what.starts_with("Profile Position absolute"))
        .expect("the move is logged");
    let image = entry.image.expect("the image written is logged");
    assert_eq!(image.to_bytes(), [0xD0, 0x07, 0, 0, 0xC8, 0, 0, 20]);
    assert!(
        matches!(&entry.outcome, drivedeck::ui::state::Outcome::Succeeded(text) if text.contains("2000")),
        "{:?}",
        entry.outcome
    );
    // The plot history follows the motor.
    let ring = state.scope.ring();
    assert!(ring.len() > 10);
    assert_eq!(ring.latest(0).map(|(_, v)| v), Some(2000.0));
}

#[test]
fn halt_toggle_stops_and_resumes_the_move() {
    let mut harness = app_harness();
    step_until(&mut harness, "connecting", Duration::from_secs(5), |h| {
        h.state().state.latest.is_some()
    });
    harness
        .get_by_label("Move absolute: Target position")
        .set_text_value_accesskit("30000");
    harness.step();
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the motor to move",
        Duration::from_secs(3),
        |h| {
            h.state()
                .state
                .latest
                .and_then(|s| s.velocity)
                .is_some_and(|v| v > 100.0)
        },
    );
    harness.get_by_label("Halt").click();
    harness.step();
    step_until(&mut harness, "the halt", Duration::from_secs(5), |h| {
        lamp(h, "Quick stop / halt")
            && lamp(h, "Target reached")
            && h.state().state.latest.and_then(|s| s.velocity) == Some(0.0)
    });
    assert_eq!(
        harness.get_by_label("Halt").accesskit_node().toggled(),
        Some(Toggled::True)
    );
    harness.get_by_label("Halt").click();
    harness.step();
    step_until(
        &mut harness,
        "the move to continue",
        Duration::from_secs(3),
        |h| {
            !lamp(h, "Quick stop / halt")
                && h.state()
                    .state
                    .latest
                    .and_then(|s| s.velocity)
                    .is_some_and(|v| v > 50.0)
        },
    );
}

/// A command panel that believes it is connected, so only the inputs decide.
fn commands_harness() -> Harness<'static, AppState> {
    let mut state = AppState::new(Settings::default());
    state.connection = Connection::Connected(LinkInfo {
        spec: LinkSpec::Sim,
        description: "test".into(),
        native_objects: true,
        can_inject: true,
        pdi: true,
    });
    state.torque_slope = Some(1000);
    Harness::builder()
        .with_size(egui::vec2(600.0, 800.0))
        .build_ui_state(
            |ui, state: &mut AppState| commands::commands_ui(ui, state),
            state,
        )
}

#[test]
fn an_out_of_range_set_value2_disables_the_button_and_sends_nothing() {
    let mut harness = commands_harness();
    harness.run();
    assert!(
        !harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );

    harness
        .get_by_label("Move absolute: Max speed")
        .set_text_value_accesskit("40000");
    harness.run();
    assert_eq!(
        harness.state().settings.inputs["Profile Position absolute"],
        vec!["2000".to_owned(), "40000".to_owned()]
    );
    let button = harness.get_by_label("Move absolute");
    assert!(button.accesskit_node().is_disabled());
    button.click();
    harness.run();
    assert!(
        harness.state().outbox.is_empty(),
        "{:?}",
        harness.state().outbox
    );
    // The reason is on screen: field, value and range.
    harness.get_by_label_contains("40000 does not fit PDI-SetValue2");

    // Back in range, the same click sends exactly that command.
    harness
        .get_by_label("Move absolute: Max speed")
        .set_text_value_accesskit("32767");
    harness.run();
    harness.get_by_label("Move absolute").click();
    harness.run();
    assert_eq!(
        harness.state().outbox,
        vec![Request::Command(Action::MoveAbsolute {
            target: 2000,
            speed: 32767
        })]
    );
}

#[test]
fn a_torque_command_with_slope_zero_asks_first() {
    let mut harness = commands_harness();
    harness.state_mut().torque_slope = Some(0);
    harness.run();
    harness.get_by_label("Torque").click();
    harness.run();
    assert!(harness.state().outbox.is_empty());
    harness.get_by_label_contains("torque never builds up");
    harness.get_by_label("Set slope and send").click();
    harness.run();
    let outbox = &harness.state().outbox;
    assert_eq!(outbox.len(), 2, "{outbox:?}");
    assert!(matches!(&outbox[0], Request::WriteObject { address, .. } if address.index == 0x6087));
    assert_eq!(
        outbox[1],
        Request::Command(Action::Torque {
            torque: 500,
            max_speed: 100
        })
    );
}

#[test]
fn escape_sends_quickstop_from_anywhere() {
    let mut harness = app_harness();
    step_until(&mut harness, "connecting", Duration::from_secs(5), |h| {
        h.state().state.latest.is_some()
    });
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until(
        &mut harness,
        "the motor to turn",
        Duration::from_secs(3),
        |h| {
            h.state()
                .state
                .latest
                .and_then(|s| s.velocity)
                .is_some_and(|v| v > 50.0)
        },
    );
    // Focus sits in a text box; Esc still stops.
    harness
        .get_by_label("Move absolute: Target position")
        .focus();
    harness.step();
    harness.key_press(egui::Key::Escape);
    harness.step();
    step_until(
        &mut harness,
        "the quick stop",
        Duration::from_secs(3),
        |h| !lamp(h, "Operation enabled"),
    );
    assert!(
        harness
            .state()
            .state
            .log
            .iter()
            .any(|e| e.what == "Quickstop")
    );
    assert!(!harness.state().state.bit(StatusBit::OperationEnabled));
}

#[test]
fn the_poll_rate_box_changes_the_worker_rate() {
    let mut harness = app_harness();
    step_until(&mut harness, "connecting", Duration::from_secs(5), |h| {
        h.state().state.latest.is_some()
    });
    harness.get_by_label("Poll rate").set_value_accesskit(25.0);
    harness.step();
    assert_eq!(harness.state().state.settings.poll_rate, 25.0);
    // Health comes once a second; the second report after the change shows the new rate.
    std::thread::sleep(Duration::from_millis(2200));
    step_until(
        &mut harness,
        "a health report at 25 Hz",
        Duration::from_secs(3),
        |h| {
            h.state()
                .state
                .health
                .is_some_and(|health| (15.0..32.0).contains(&health.cycles_per_second))
        },
    );
}

#[test]
fn the_connection_bar_connects_over_modbus_tcp_and_the_window_drives_the_motor() {
    use drivedeck::sim::server::ServerThread;
    use drivedeck::sim::server::modbus::Options;
    let server = ServerThread::modbus_tcp("127.0.0.1:0".parse().expect("addr"), Options::default())
        .expect("server");
    // A window that starts disconnected, as after a fresh install on a machine with a drive.
    let mut harness = harness_with(Settings::default(), false, egui::vec2(1400.0, 900.0));
    harness.run();
    harness.get_by_label("Bus").click();
    harness.run();
    harness.get_by_label("Modbus TCP").click();
    harness.run();
    harness
        .get_by_label("Connection: Host")
        .set_text_value_accesskit("127.0.0.1");
    harness
        .get_by_label("Connection: Port")
        .set_text_value_accesskit(&server.addr.port().to_string());
    harness.run();
    harness.get_by_label("Connect").click();
    harness.step();
    step_until(
        &mut harness,
        "the Modbus connection",
        Duration::from_secs(5),
        |h| {
            h.state().state.latest.is_some()
                && h.state()
                    .state
                    .link_info()
                    .is_some_and(|i| i.description.contains("Modbus TCP"))
        },
    );
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the target over Modbus",
        Duration::from_secs(5),
        |h| {
            lamp(h, "Target reached")
                && lamp(h, "Operation enabled")
                && h.state().state.latest.and_then(|s| s.position) == Some(2000.0)
        },
    );
    assert!((server.drive().lock().position() - 2000.0).abs() < 0.5);
    // The connection persists in the settings for the next start.
    assert_eq!(
        harness
            .state()
            .state
            .settings
            .connection
            .spec()
            .map(|s| s.scheme()),
        Ok("modbus-tcp")
    );
}

#[test]
fn the_window_scans_the_can_bus_connects_moves_over_pdos_and_reads_a_string() {
    let mut harness = harness_with(Settings::default(), false, egui::vec2(1400.0, 900.0));
    harness.run();
    harness.get_by_label("Bus").click();
    harness.run();
    harness.get_by_label("CANopen (simulated bus)").click();
    harness.run();
    harness
        .get_by_label("Connection: Node")
        .set_text_value_accesskit("6");
    harness.run();
    harness.get_by_label("Scan bus").click();
    harness.step();
    step_until(&mut harness, "the scan", Duration::from_secs(5), |h| {
        h.state().state.scan.is_some()
    });
    let found = harness
        .state()
        .state
        .scan
        .clone()
        .expect("scan")
        .expect("no error");
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].node, Some(6));
    assert_eq!(found[0].name.as_deref(), Some("drivedeck simulated drive"));
    harness.run();
    harness.get_by_label("Use node 6").click();
    harness.step();
    step_until(
        &mut harness,
        "the CANopen connection",
        Duration::from_secs(5),
        |h| {
            h.state().state.link_info().is_some_and(|i| {
                i.description.contains("CANopen node 6") && i.description.contains("RPDO1/TPDO1")
            }) && h.state().state.latest.is_some()
        },
    );
    // What the link itself changed (the PDO mapping) is listed, with its fate.
    let link_changes = harness.state().state.link_changes.clone();
    assert!(
        link_changes
            .iter()
            .any(|c| c.contains("PDO setting of node 6") && c.contains("put back")),
        "{link_changes:#?}"
    );
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the target over PDOs",
        // Ten seconds for a one-second move: the PDOs run at the window's 100 Hz and a
        // loaded two-core machine starves the threads now and then.
        Duration::from_secs(10),
        |h| {
            lamp(h, "Target reached")
                && h.state().state.latest.map(|s| s.tx.return_value) == Some(2000)
        },
    );
    // Any object, read the way the link does it best: 1008h over a segmented SDO upload.
    harness
        .get_by_label("Object address")
        .set_text_value_accesskit("1008");
    harness.run();
    harness.get_by_label("Read").click();
    harness.step();
    step_until(&mut harness, "the string", Duration::from_secs(3), |h| {
        h.state().state.last_object.as_ref().is_some_and(|r| {
            r.result
                == Ok(drivedeck::od::Value::Text(
                    "drivedeck simulated drive".into(),
                ))
        })
    });
}
