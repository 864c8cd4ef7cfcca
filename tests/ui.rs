//! The window, headless: egui_kittest clicks by label, the real worker drives the
//! simulated drive.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::link::{LinkInfo, LinkSpec};
use drivedeck::od::Value;
use drivedeck::pdi::{Action, StatusBit};
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::ui::drive::Connection;
use drivedeck::ui::settings::DriveSettings;
use drivedeck::ui::{Command, Drive, commands};
use drivedeck::worker::Request;
use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{
    app_harness, choose_bus, connected, connected_to, disconnected_harness, fill, lamp, position,
    read_object, sim_time_harness, start_turning, step_until, velocity,
};

#[test]
fn the_absolute_move_button_sends_the_command_and_the_lamps_follow() {
    // Only the end state is asserted: on simulated time the move takes no real time.
    let mut harness = sim_time_harness();
    step_until(
        &mut harness,
        "connecting to the simulator",
        Duration::from_secs(5),
        |h| h.state().shown().is_connected() && h.state().shown().latest().is_some(),
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
        |h| lamp(h, "Target reached") && position(h) == 2000.0,
    );
    let state = harness.state().shown();
    let entry = state
        .log
        .iter()
        .find(|e| e.what.starts_with("Profile Position absolute"))
        .expect("the move is logged");
    let image = entry.image.expect("the image written is logged");
    assert_eq!(image.to_bytes(), [0xD0, 0x07, 0, 0, 0xC8, 0, 0, 20]);
    assert!(
        matches!(&entry.outcome, drivedeck::ui::drive::Outcome::Succeeded(text) if text.contains("2000")),
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
    connected(&mut harness);
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
        |h| velocity(h) > 100.0,
    );
    harness.get_by_label("Halt").click();
    harness.step();
    step_until(&mut harness, "the halt", Duration::from_secs(5), |h| {
        lamp(h, "Quick stop / halt") && lamp(h, "Target reached") && velocity(h) == 0.0
    });
    // The button says it is halted, and that pressing it resumes.
    let halted = harness.get_by_label("Halted — press to resume");
    assert_eq!(halted.accesskit_node().toggled(), Some(Toggled::True));
    halted.click();
    harness.step();
    step_until(
        &mut harness,
        "the move to continue",
        Duration::from_secs(3),
        |h| !lamp(h, "Quick stop / halt") && velocity(h) > 50.0,
    );
}

/// A drive's panels fed by hand, without a worker: drawn, and what the user asked of
/// them applied to the drive as the window applies it.
struct Fed {
    drive: Drive,
    collapsed: bool,
}

impl Fed {
    fn new() -> Fed {
        Fed {
            drive: Drive::new("Drive 1".into(), 0, DriveSettings::default(), 10_000, &[]),
            collapsed: false,
        }
    }

    /// The user's commands of a frame, applied to the drive.
    fn apply(&mut self, commands: Vec<Command>) {
        for command in commands {
            self.drive.apply_command(command);
        }
    }

    /// The requests waiting for the worker.
    fn outbox(&self) -> Vec<Request> {
        self.drive.waiting().cloned().collect()
    }
}

/// The command panel of `fed`, its commands applied.
fn commands_panel_ui(ui: &mut egui::Ui, fed: &mut Fed) {
    let mut asked = Vec::new();
    commands::commands_ui(ui, &mut fed.drive, &mut fed.collapsed, &mut asked);
    fed.apply(asked);
}

/// A command panel that believes it is connected, so only the inputs decide.
fn commands_harness() -> Harness<'static, Fed> {
    let mut fed = Fed::new();
    fed.drive.link.connection = Connection::Connected(LinkInfo {
        spec: LinkSpec::Sim,
        description: "test".into(),
        native_objects: true,
        can_inject: true,
        pdi: true,
        homing_methods: None,
        commands_refused: None,
    });
    fed.drive.motion.torque_slope = Some(1000);
    Harness::builder()
        .with_size(egui::vec2(600.0, 800.0))
        .build_ui_state(commands_panel_ui, fed)
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
        harness.state().drive.settings.inputs["Profile Position absolute"],
        vec!["2000".to_owned(), "40000".to_owned()]
    );
    let button = harness.get_by_label("Move absolute");
    assert!(button.accesskit_node().is_disabled());
    button.click();
    harness.run();
    assert!(
        harness.state().outbox().is_empty(),
        "{:?}",
        harness.state().outbox()
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
        harness.state().outbox(),
        vec![Request::Command(Action::MoveAbsolute {
            target: 2000,
            speed: 32767
        })]
    );
}

#[test]
fn a_torque_command_with_slope_zero_asks_first() {
    let mut harness = commands_harness();
    harness.state_mut().drive.motion.torque_slope = Some(0);
    harness.run();
    harness.get_by_label("Torque").click();
    harness.run();
    assert!(harness.state().outbox().is_empty());
    harness.get_by_label_contains("torque never builds up");
    harness.get_by_label("Set slope and send").click();
    harness.run();
    let outbox = &harness.state().outbox();
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
    connected(&mut harness);
    start_turning(&mut harness, 50.0);
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
            .shown()
            .log
            .iter()
            .any(|e| e.what == "Quickstop")
    );
    assert!(!harness.state().shown().bit(StatusBit::OperationEnabled));
}

#[test]
fn the_poll_rate_box_changes_the_worker_rate() {
    // On simulated time: the health reports' seconds pass without real waiting.
    let mut harness = sim_time_harness();
    connected(&mut harness);
    harness.get_by_label("Poll rate").set_value_accesskit(25.0);
    harness.step();
    assert_eq!(harness.state().shown().settings.poll_rate, 25.0);
    // Health comes once a (simulated) second; a report after the change shows the new
    // rate.
    step_until(
        &mut harness,
        "a health report at 25 Hz",
        Duration::from_secs(3),
        |h| {
            h.state()
                .shown()
                .link
                .health
                .is_some_and(|health| (15.0..32.0).contains(&health.cycles_per_second))
        },
    );
}

#[test]
fn the_connection_bar_connects_over_modbus_tcp_and_the_window_drives_the_motor() {
    let server = common::modbus_server(ServerOptions::default());
    // A window that starts disconnected, as after a fresh install on a machine with a drive.
    let mut harness = disconnected_harness();
    choose_bus(&mut harness, "Modbus TCP");
    fill(
        &mut harness,
        &[
            ("Connection: Host", "127.0.0.1"),
            ("Connection: Port", &server.addr.port().to_string()),
        ],
    );
    harness.get_by_label("Connect").click();
    harness.step();
    step_until(
        &mut harness,
        "the Modbus connection",
        Duration::from_secs(5),
        |h| {
            h.state().shown().latest().is_some()
                && h.state()
                    .shown()
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
        |h| lamp(h, "Target reached") && lamp(h, "Operation enabled") && position(h) == 2000.0,
    );
    assert!((server.drive().lock().position() - 2000.0).abs() < 0.5);
    // The connection persists in the settings for the next start.
    assert_eq!(
        harness
            .state()
            .shown()
            .settings
            .connection
            .spec()
            .map(|s| s.scheme()),
        Ok("modbus-tcp")
    );
}

#[test]
fn the_window_scans_the_can_bus_connects_moves_over_pdos_and_reads_a_string() {
    let mut harness = disconnected_harness();
    choose_bus(&mut harness, "CANopen (simulated bus)");
    fill(&mut harness, &[("Connection: Node", "6")]);
    harness.get_by_label("Scan bus").click();
    harness.step();
    step_until(&mut harness, "the scan", Duration::from_secs(5), |h| {
        h.state().shown().scan.is_some()
    });
    let found = harness
        .state()
        .shown()
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
            h.state().shown().link_info().is_some_and(|i| {
                i.description.contains("CANopen node 6") && i.description.contains("RPDO1/TPDO1")
            }) && h.state().shown().latest().is_some()
        },
    );
    // What the link itself changed (the PDO mapping) is listed, with its fate.
    let link_changes = harness.state().shown().link.own_changes.clone();
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
                && h.state().shown().latest().map(|s| s.tx.return_value) == Some(2000)
        },
    );
    // Any object, read the way the link does it best: 1008h over a segmented SDO upload.
    read_object(
        &mut harness,
        "1008",
        &Value::Text("drivedeck simulated drive".into()),
        Duration::from_secs(3),
    );
}

/// The status panel, the command panel and the stop strip of a window fed by hand.
fn panels_harness() -> Harness<'static, Fed> {
    let harness = Harness::builder()
        .with_size(egui::vec2(1100.0, 900.0))
        .build_ui_state(
            |ui, fed: &mut Fed| {
                let mut asked = Vec::new();
                let offline = fed.drive.offline_reason().unwrap_or_default();
                let connected = fed.drive.is_connected();
                if let Some(stop) =
                    drivedeck::ui::connection::stop_buttons_ui(ui, connected, &offline, &[])
                {
                    asked.push(Command::Request(Request::Command(stop)));
                }
                ui.columns(2, |columns| {
                    drivedeck::ui::status::status_ui(&mut columns[0], &fed.drive, &mut asked);
                    commands::commands_ui(
                        &mut columns[1],
                        &mut fed.drive,
                        &mut fed.collapsed,
                        &mut asked,
                    );
                });
                fed.apply(asked);
            },
            Fed::new(),
        );
    // Tooltips at once, so a test can read them.
    harness
        .ctx
        .all_styles_mut(|style| style.interaction.tooltip_delay = 0.0);
    harness
}

/// The lamps drawn lit in the last frame (coloured circles), with their alpha.
fn lit_lamp_alphas(harness: &Harness<'_, Fed>) -> Vec<u8> {
    harness
        .output()
        .shapes
        .iter()
        .filter_map(|clipped| match &clipped.shape {
            egui::Shape::Circle(circle) => Some(circle.fill),
            _ => None,
        })
        .filter(|fill| fill.a() > 0 && !(fill.r() == fill.g() && fill.g() == fill.b()))
        .map(|fill| fill.a())
        .collect()
}

/// A live panel: no banner, the lit lamps at full strength, the buttons enabled.
fn shows_live(harness: &Harness<'_, Fed>) {
    assert!(harness.query_by_label_contains("NO LINK").is_none());
    assert!(
        harness
            .query_by_label_contains("WAITING FOR DATA")
            .is_none()
    );
    let live = lit_lamp_alphas(harness);
    assert!(
        !live.is_empty() && live.iter().all(|a| *a == 255),
        "{live:?}"
    );
    assert!(
        !harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );
}

fn operation_enabled_sample(t: f64) -> drivedeck::worker::Sample {
    use drivedeck::pdi::{Status, TxImage};
    use drivedeck::signal::Signal;
    drivedeck::worker::Sample {
        t,
        tx: TxImage {
            status: Status(StatusBit::OperationEnabled.mask() | StatusBit::TargetReached.mask()),
            error_code: 0,
            return_value: 0,
        },
        signals: drivedeck::signal::Signals::default()
            .with(Signal::Position, 1234.0)
            .with(Signal::Velocity, 0.0)
            .with(Signal::Statusword, f64::from(0x0627))
            .with(Signal::Mode, 1.0),
        ..Default::default()
    }
}

fn sim_info() -> LinkInfo {
    LinkInfo {
        spec: LinkSpec::Sim,
        description: "simulated drive".into(),
        native_objects: true,
        can_inject: true,
        pdi: true,
        homing_methods: None,
        commands_refused: None,
    }
}

#[test]
fn a_lost_link_leaves_the_last_state_dimmed_as_last_seen_and_the_buttons_say_why() {
    use drivedeck::worker::Event;
    let mut harness = panels_harness();
    harness.step();
    // Never connected: nothing to show, and nothing can be sent.
    harness.get_by_label_contains("NO LINK — never connected");
    assert!(
        harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );

    harness
        .state_mut()
        .drive
        .apply(Event::Connected(sim_info()));
    harness.step();
    harness.get_by_label_contains("WAITING FOR DATA");
    harness
        .state_mut()
        .drive
        .apply(Event::Samples(vec![operation_enabled_sample(1.0)]));
    harness.step();
    // Live: no banner, lamps at full strength, the buttons enabled.
    assert!(lamp(&harness, "Operation enabled"));
    shows_live(&harness);

    harness.state_mut().drive.apply(Event::Disconnected {
        reason: Some("connection reset by peer".into()),
    });
    harness.step();
    // The last known state stays, dimmed, with when it was seen.
    let banner = harness
        .get_by_label_contains("NO LINK — last seen at ")
        .accesskit_node()
        .value()
        .unwrap_or_default();
    assert!(
        banner.contains(" UTC (") && banner.ends_with(" s ago)"),
        "{banner}"
    );
    assert!(
        lamp(&harness, "Operation enabled"),
        "the last known lamps stay"
    );
    harness.get_by_label("Operation enabled (last known)");
    harness.get_by_label("1234");
    let dimmed = lit_lamp_alphas(&harness);
    assert!(
        !dimmed.is_empty() && dimmed.iter().all(|a| *a < 160),
        "lit lamps drawn faint: {dimmed:?}"
    );
    // Every button that would send is disabled, and the panel says why.
    let reason = "not connected: the link was lost (connection reset by peer)";
    for label in ["Move absolute", "Halt", "Jog +", "Jog -", "Velocity"] {
        assert!(
            harness.get_by_label(label).accesskit_node().is_disabled(),
            "{label}"
        );
    }
    // Quickstop and Switch off stay on screen (disabled: there is no link to send on).
    assert!(
        harness
            .get_by_label("QUICKSTOP (Esc)")
            .accesskit_node()
            .is_disabled()
    );
    harness.get_by_label("Switch off (Shift+Esc)");
    assert_eq!(
        harness.query_all_by_label_contains(reason).count(),
        2,
        "status and commands panels"
    );
    // The tooltip of a disabled button says the same.
    harness.get_by_label("Move absolute").hover();
    harness.step();
    harness.step();
    assert_eq!(
        harness.query_all_by_label_contains(reason).count(),
        3,
        "the tooltip of the disabled button"
    );

    // Reconnecting: still the old values until the first sample of the new link.
    harness.get_by_label("Drive status").hover();
    harness
        .state_mut()
        .drive
        .apply(Event::Connecting(LinkSpec::Sim));
    harness.step();
    harness.get_by_label_contains("NO LINK — last seen at ");
    assert_eq!(
        harness
            .query_all_by_label_contains("reconnecting…: the link was lost")
            .count(),
        2
    );
    harness
        .state_mut()
        .drive
        .apply(Event::Connected(sim_info()));
    harness.step();
    harness.get_by_label_contains("WAITING FOR DATA — connected; last seen at ");
    harness
        .state_mut()
        .drive
        .apply(Event::Samples(vec![operation_enabled_sample(0.01)]));
    harness.step();
    shows_live(&harness);
    assert!(harness.query_by_label_contains("not connected").is_none());
}

#[test]
fn the_window_shows_a_drive_whose_server_died_as_last_seen_and_comes_back_live() {
    let server = common::modbus_server(ServerOptions::default());
    let addr = server.addr;
    let spec: LinkSpec = format!("modbus-tcp://{addr}?unit=0").parse().expect("spec");
    let mut harness = connected_to(&spec, None, egui::vec2(1366.0, 768.0));
    harness.step();
    assert!(harness.query_by_label_contains("NO LINK").is_none());
    assert!(
        !harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );

    // The drive's plug pulled: the server and its connections are gone.
    drop(server);
    step_until(
        &mut harness,
        "the window to show the link lost",
        Duration::from_secs(5),
        |h| {
            h.query_by_label_contains("NO LINK — last seen at ")
                .is_some()
        },
    );
    assert!(
        harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );
    assert!(harness.get_by_label("Jog +").accesskit_node().is_disabled());
    assert!(harness.get_by_label("Halt").accesskit_node().is_disabled());
    harness.get_by_label("QUICKSTOP (Esc)");
    // The last values stay on screen, and the commands panel says why nothing goes out.
    harness.get_by_label("Position 6064h");
    assert_eq!(
        harness
            .query_all_by_label_contains("not connected: the link was lost")
            .count(),
        2,
        "the status and the commands panel"
    );

    // The drive back on the same address: the worker reconnects, the panel is live again.
    let _server =
        ServerThread::modbus_tcp(addr, ServerOptions::default()).expect("the same port again");
    step_until(
        &mut harness,
        "the window to be live again",
        Duration::from_secs(15),
        |h| {
            h.state().shown().is_connected()
                // The state tile and the status panel's banner both say so until then.
                && h.query_all_by_label_contains("NO LINK").next().is_none()
                && h.query_all_by_label_contains("WAITING FOR DATA").next().is_none()
        },
    );
    assert!(
        !harness
            .get_by_label("Move absolute")
            .accesskit_node()
            .is_disabled()
    );
}

#[test]
fn escape_with_a_drop_down_open_stops_and_closes_it() {
    let mut harness = app_harness();
    connected(&mut harness);
    start_turning(&mut harness, 50.0);
    harness.get_by_label("Bus").click();
    harness.run_steps(2);
    assert!(
        harness.query_by_label("Modbus TCP").is_some(),
        "the drop-down is open"
    );
    harness.key_press(egui::Key::Escape);
    harness.run_steps(2);
    assert!(
        harness.query_by_label("Modbus TCP").is_none(),
        "Esc closed the drop-down"
    );
    step_until(
        &mut harness,
        "the quick stop",
        Duration::from_secs(3),
        |h| !lamp(h, "Operation enabled"),
    );
}

#[test]
fn jogging_or_halting_moves_nothing_in_the_command_panel() {
    let mut harness = commands_harness();
    harness.run();
    let before = harness.get_by_label("Move absolute").rect();
    let halt = harness.get_by_label("Halt").rect();
    harness.state_mut().drive.motion.jog = Some(drivedeck::ui::drive::JogHold {
        direction: 1,
        speed: 100,
        sent_at: 0.0,
    });
    harness.run_steps(2);
    assert_eq!(
        harness.get_by_label("Move absolute").rect(),
        before,
        "a jog moves nothing under it"
    );
    harness.state_mut().drive.motion.jog = None;
    harness.state_mut().drive.motion.halt_engaged = true;
    harness.run_steps(2);
    let halted = harness.get_by_label("Halted — press to resume").rect();
    assert_eq!(halted.width(), halt.width(), "the toggle keeps its width");
    assert_eq!(harness.get_by_label("Move absolute").rect(), before);
    harness.get_by_label("or send a new travel command");
}
