//! CANopen over slcan on a pseudo-terminal pair, the way a technician's USB adapter is
//! seen: `drivedeck sim --slcan A --node 5` is the simulated drive behind an emulated
//! adapter on one end, our master (the worker, and the window) is the slcan host on the
//! other. Needs socat: skipped with a reason without it, and required in CI.

mod common;
mod probe;

use std::path::Path;
use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{Process, PtyPair};
use drivedeck::cia::AbortCode;
use drivedeck::link::LinkSpec;
use drivedeck::link::Refusal;
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::{Action, StatusBit};
use drivedeck::ui::{App, Settings};
use drivedeck::worker::{CommandProgress, Event, ObjectError, ObjectPath, Request};
use eframe::egui;
use egui::accesskit::Toggled;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use probe::Probe;

/// `drivedeck sim --slcan PATH --node N` as its own process, ready once it says so.
fn serve_node(path: &Path, node: u8) -> Process {
    let mut command = Command::new(env!("CARGO_BIN_EXE_drivedeck"));
    command
        .arg("sim")
        .arg("--slcan")
        .arg(path)
        .args(["--node", &node.to_string()]);
    let mut process = Process::spawn("drivedeck sim --slcan", &mut command);
    let banner = process.expect_line("the slcan banner", Duration::from_secs(10));
    assert!(
        banner.contains(&format!("CANopen node {node}"))
            && banner.contains("emulated slcan adapter"),
        "{banner}; {}",
        process.report()
    );
    process
}

fn slcan_spec(path: &Path, node: u8) -> LinkSpec {
    format!(
        "canopen+slcan://{}?bitrate=1000000&node={node}",
        path.display()
    )
    .parse()
    .expect("spec")
}

#[test]
fn the_worker_moves_the_motor_over_slcan_pdos_and_reads_a_string() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = serve_node(&pair.a, 5);
    let mut probe = Probe::connected(slcan_spec(&pair.b, 5));
    let info = probe
        .seen
        .iter()
        .find_map(|e| match e {
            Event::Connected(info) => Some(info.clone()),
            _ => None,
        })
        .expect("connected");
    assert!(
        info.description.contains("CANopen node 5")
            && info.description.contains("RPDO1/TPDO1")
            && info.description.contains("slcan"),
        "{}",
        info.description
    );
    let id = probe.send(Request::Command(Action::MoveAbsolute {
        target: 2000,
        speed: 200,
    }));
    assert_eq!(
        probe.outcome(id, Duration::from_secs(15)),
        CommandProgress::Done { return_value: 2000 }
    );
    let at = probe.sample_where("target reached", Duration::from_secs(5), |s| {
        s.tx.status.is_set(StatusBit::TargetReached) && s.tx.return_value == 2000
    });
    assert!(at.tx.status.is_set(StatusBit::OperationEnabled));
    // A segmented SDO upload through the adapter, and an expedited one.
    assert_eq!(
        probe.read(
            Address::new(0x1008, 0),
            DataType::VisibleString,
            ObjectPath::Auto
        ),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    assert_eq!(
        probe.read(
            Address::new(0x1018, 1),
            DataType::Unsigned32,
            ObjectPath::Native
        ),
        Ok(Value::Uint(0x26C))
    );
    let missing = probe
        .read(
            Address::new(0x1018, 9),
            DataType::Unsigned32,
            ObjectPath::Native,
        )
        .expect_err("no such subindex");
    assert_eq!(
        missing,
        ObjectError::Refused(Refusal::Abort(AbortCode::NO_SUBINDEX))
    );
    // The motor's position follows over the bus, by whatever path the link has for it.
    probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(2000.0)
    });
}

#[test]
fn a_scan_over_slcan_finds_the_node_with_its_identity() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = serve_node(&pair.a, 9);
    let mut probe = Probe::new();
    let id = probe.send(Request::Scan(slcan_spec(&pair.b, 1)));
    let found = match probe.wait(
        "the scan",
        Duration::from_secs(30),
        |e| matches!(e, Event::Scanned { id: i, .. } if *i == id),
    ) {
        Event::Scanned { result, .. } => result.expect("a scan without errors"),
        _ => unreachable!(),
    };
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].node, Some(9));
    assert_eq!(found[0].vendor, Some(0x26C));
    assert_eq!(found[0].name.as_deref(), Some("drivedeck simulated drive"));
}

/// Whether a status lamp is lit (lamps are read-only checkboxes to accessibility).
fn lamp(harness: &Harness<'_, App>, label: &str) -> bool {
    harness
        .get_by_role_and_label(egui::accesskit::Role::CheckBox, label)
        .accesskit_node()
        .toggled()
        == Some(Toggled::True)
}

fn step_until(
    harness: &mut Harness<'_, App>,
    what: &str,
    timeout: Duration,
    done: impl Fn(&Harness<'_, App>) -> bool,
) {
    let deadline = Instant::now() + timeout;
    while !done(harness) {
        assert!(
            Instant::now() < deadline,
            "{what} did not happen within {timeout:?}; log: {:#?}",
            harness.state().state.log
        );
        std::thread::sleep(Duration::from_millis(10));
        harness.step();
    }
}

#[test]
fn the_window_connects_over_slcan_and_moves_the_motor() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _node = serve_node(&pair.a, 5);
    let app = App::new(Settings::default(), Arc::new(|| {}), false);
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .build_ui_state(|ui, app: &mut App| app.frame(ui), app);
    harness.run();
    harness.get_by_label("Bus").click();
    harness.run();
    harness.get_by_label("CANopen (slcan)").click();
    harness.run();
    harness
        .get_by_label("Connection: Port")
        .set_text_value_accesskit(pair.b.to_str().expect("utf-8 path"));
    harness
        .get_by_label("Connection: Bit rate")
        .set_text_value_accesskit("1000000");
    harness
        .get_by_label("Connection: Node")
        .set_text_value_accesskit("5");
    harness.run();
    harness.get_by_label("Connect").click();
    harness.step();
    step_until(
        &mut harness,
        "the slcan connection",
        Duration::from_secs(10),
        |h| {
            h.state().state.link_info().is_some_and(|i| {
                i.description.contains("CANopen node 5") && i.description.contains("RPDO1/TPDO1")
            }) && h.state().state.latest.is_some()
        },
    );
    harness.get_by_label("Move absolute").click();
    harness.step();
    step_until(
        &mut harness,
        "the target over slcan",
        Duration::from_secs(15),
        |h| {
            lamp(h, "Target reached")
                && h.state().state.latest.map(|s| s.tx.return_value) == Some(2000)
        },
    );
    harness
        .get_by_label("Object address")
        .set_text_value_accesskit("1008");
    harness.run();
    harness.get_by_label("Read").click();
    harness.step();
    step_until(&mut harness, "the string", Duration::from_secs(5), |h| {
        h.state()
            .state
            .last_object
            .as_ref()
            .is_some_and(|r| r.result == Ok(Value::Text("drivedeck simulated drive".into())))
    });
    // Disconnect releases the port and puts the node's mapping back. The motor is
    // energised after the move: the window asks what to leave behind; halt.
    harness.get_by_label("Disconnect").click();
    step_until(
        &mut harness,
        "the leave dialog",
        Duration::from_secs(3),
        |h| h.query_by_label("Halt, then disconnect").is_some(),
    );
    harness.get_by_label("Halt, then disconnect").click();
    harness.step();
    step_until(
        &mut harness,
        "the disconnection",
        Duration::from_secs(5),
        |h| h.state().state.link_info().is_none(),
    );
}
