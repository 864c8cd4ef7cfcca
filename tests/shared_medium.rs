//! Several drives on one medium, each driven by its own worker thread as the window drives
//! them, drivedeck's client side sharing the medium:
//!
//! * three `canopen+sim` nodes on one in-memory CAN bus, one reader of the bus for the
//!   three links: all three moved at once with SDO reads of each in between, each ends
//!   at its own target;
//! * two nodes of `drivedeck sim --slcan A --node 5 --node 6` through one slcan adapter
//!   (a pty pair from socat): the second link joins the first's port, both move, a scan
//!   while they run finds both;
//! * two slaves of `drivedeck sim --modbus-rtu A --slave 1 --slave 2` on one pty line,
//!   the port opened once for both, both move;
//! * two nodes of `drivedeck sim --can vcan0 --node 5 --node 6` through one SocketCAN
//!   interface, where the machine has vcan0 (skipped, and said so, where it has not);
//! * a drive lost mid-run (a node's cable pulled, a slave that stops answering) is
//!   reported on its own link, naming the cause, while the others finish their moves.
//!
//! Without socat the pty tests pass without running and say `SKIPPED …` in the output;
//! with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) they fail.
//!
//! `cargo test --test shared_medium -- --ignored --nocapture` prints the cycle rate of
//! each drive with one, two and three drives on one medium (a measurement, no test).

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{PtyPair, Sim};
use drivedeck::link::LinkSpec;
use drivedeck::link::canopen::shared::open_buses;
use drivedeck::link::modbus::line::open_lines;
use drivedeck::od::{Address, DataType};
use drivedeck::pdi::Action;
use drivedeck::sim::Injection;
use drivedeck::worker::{CommandProgress, Config, Event, ObjectPath, Request, Worker};
use probe::Probe;

/// Time a move may take on a loaded machine (the moves here take about a second).
const PATIENCE: Duration = Duration::from_secs(20);

fn spec(text: &str) -> LinkSpec {
    text.parse().expect("spec")
}

/// A worker at `poll_rate` exchanges per second connected to `spec`, its first sample in.
fn probe_at(spec: LinkSpec, poll_rate: f64) -> Probe {
    let config = Config {
        poll_rate,
        ..Config::default()
    };
    let mut probe = Probe {
        worker: Worker::spawn(config, Arc::new(|| {})).expect("worker thread"),
        seen: vec![],
        last: None,
    };
    let connected = probe.connect(spec.clone());
    assert!(
        matches!(connected, Event::Connected(_)),
        "{spec}: {connected:?}"
    );
    probe
}

/// The position, 6064h, read over the link's own object access (SDO, FC 43).
fn position(probe: &mut Probe) -> i128 {
    match probe.read(
        Address::new(0x6064, 0),
        DataType::Integer32,
        ObjectPath::Native,
    ) {
        Ok(value) => value.as_i128().expect("a number"),
        Err(e) => panic!("reading the position: {e}; seen: {:#?}", probe.notices()),
    }
}

/// Move every drive to its own target at once, reading each one's position over its own
/// object access while they move; each must end at its own target.
fn move_all_at_once(probes: &mut [Probe], targets: &[i32]) {
    let ids: Vec<_> = probes
        .iter()
        .zip(targets)
        .map(|(probe, &target)| {
            probe.send(Request::Command(Action::MoveAbsolute {
                target,
                speed: 300,
            }))
        })
        .collect();
    // Interleaved reads of every drive while all of them move.
    for _ in 0..3 {
        for probe in probes.iter_mut() {
            position(probe);
        }
    }
    for ((probe, id), &target) in probes.iter_mut().zip(ids).zip(targets) {
        let outcome = probe.outcome(id, PATIENCE);
        assert_eq!(
            outcome,
            CommandProgress::Done {
                return_value: target
            },
            "the move to {target}; notices: {:#?}",
            probe.notices()
        );
    }
    for (probe, &target) in probes.iter_mut().zip(targets) {
        assert_eq!(position(probe), i128::from(target));
        probe.never_dropped();
    }
}

#[test]
fn three_workers_move_three_nodes_on_one_in_memory_bus_at_once() {
    let mut probes: Vec<Probe> = [11, 12, 13]
        .into_iter()
        .map(|node| probe_at(spec(&format!("canopen+sim://?node={node}")), 100.0))
        .collect();
    // One bus, one reader: the three links joined the first's.
    let memory: Vec<String> = open_buses()
        .into_iter()
        .filter(|k| k.starts_with("memory:"))
        .collect();
    assert_eq!(memory.len(), 1, "{memory:?}");
    move_all_at_once(&mut probes, &[3000, -2000, 5000]);
}

#[test]
fn a_node_whose_cable_is_pulled_is_lost_alone_and_the_others_finish() {
    let mut probes: Vec<Probe> = [21, 22, 23]
        .into_iter()
        .map(|node| probe_at(spec(&format!("canopen+sim://?node={node}")), 100.0))
        .collect();
    let targets = [4000, 6000, -4000];
    let ids: Vec<_> = probes
        .iter()
        .zip(targets)
        .map(|(probe, target)| {
            probe.send(Request::SetLostAfter(2));
            probe.send(Request::Command(Action::MoveAbsolute {
                target,
                speed: 200,
            }))
        })
        .collect();
    for (probe, id) in probes.iter_mut().zip(&ids) {
        probe.accepted(*id);
    }
    // Node 22's cable is pulled while all three move.
    probes[1].send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    let reason = probes[1].lost(Duration::from_secs(10));
    assert!(reason.contains("node 22"), "{reason}");
    for i in [0, 2] {
        let outcome = probes[i].outcome(ids[i], PATIENCE);
        assert_eq!(
            outcome,
            CommandProgress::Done {
                return_value: targets[i]
            },
            "notices: {:#?}",
            probes[i].notices()
        );
        assert_eq!(position(&mut probes[i]), i128::from(targets[i]));
        probes[i].never_dropped();
    }
}

#[test]
fn two_workers_share_one_slcan_adapter_and_both_move() {
    let Some(pty) = PtyPair::new() else {
        return;
    };
    let _sim = Sim::slcan_nodes(&pty.a, &[5, 6], &[]);
    let b = pty.b.display().to_string();
    let mut probes: Vec<Probe> = [5, 6]
        .into_iter()
        .map(|node| probe_at(spec(&format!("canopen+slcan://{b}?node={node}")), 100.0))
        .collect();
    let slcan: Vec<String> = open_buses()
        .into_iter()
        .filter(|k| k.starts_with("slcan:"))
        .collect();
    assert_eq!(slcan.len(), 1, "{slcan:?}");
    move_all_at_once(&mut probes, &[2500, -1500]);
    // A scan through a connected link, and one from a worker with no link, both hear every
    // node on the adapter they share.
    let adapter = spec(&format!("canopen+slcan://{b}?node=5"));
    for scanner in [&mut probes[1], &mut Probe::new()] {
        let found = scanner
            .scan(Request::Scan(adapter.clone()), Duration::from_secs(10))
            .expect("the scan");
        let nodes: Vec<u8> = found.iter().filter_map(|d| d.node).collect();
        assert_eq!(nodes, [5, 6], "{found:?}");
    }
    for probe in probes.iter_mut() {
        probe.never_dropped();
    }
    // A second link for a node already open on the adapter is refused, naming it.
    let mut again = Probe::new();
    match again.connect(spec(&format!("canopen+slcan://{b}?node=5"))) {
        Event::ConnectFailed { error, .. } => {
            assert!(error.text.contains("node 5"), "{error}");
        }
        other => panic!("a second link to node 5: {other:?}"),
    }
}

#[test]
fn two_workers_share_one_socketcan_interface_where_vcan0_exists() {
    if !std::path::Path::new("/sys/class/net/vcan0").exists() {
        common::skip(
            "two drives on one SocketCAN interface: no vcan0 on this machine (modprobe vcan; ip link add vcan0 type vcan; ip link set vcan0 up)",
        );
        return;
    }
    let _sim = Sim::can_nodes("vcan0", &[5, 6]);
    let mut probes: Vec<Probe> = [5, 6]
        .into_iter()
        .map(|node| {
            probe_at(
                spec(&format!("canopen+socketcan://vcan0?node={node}")),
                100.0,
            )
        })
        .collect();
    let shared: Vec<String> = open_buses()
        .into_iter()
        .filter(|k| k.contains("vcan0"))
        .collect();
    assert_eq!(shared.len(), 1, "{shared:?}");
    move_all_at_once(&mut probes, &[2000, -1000]);
    for probe in probes.iter_mut() {
        probe.never_dropped();
    }
}

fn rtu(path: &std::path::Path, slave: u8, baud: u32) -> LinkSpec {
    spec(&format!(
        "modbus-rtu://{}?baud={baud}&parity=even&slave={slave}",
        path.display()
    ))
}

#[test]
fn two_workers_share_one_rtu_line_and_both_move() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _sim = Sim::rtu(&pair.a, &["--slave", "1", "--slave", "2"]);
    let mut probes: Vec<Probe> = [1, 2]
        .into_iter()
        .map(|slave| probe_at(rtu(&pair.b, slave, 19200), 100.0))
        .collect();
    let key = format!(
        "rtu:{}",
        drivedeck::link::same_file(&pair.b.display().to_string())
    );
    assert_eq!(
        open_lines().iter().filter(|k| **k == key).count(),
        1,
        "{:?}",
        open_lines()
    );
    move_all_at_once(&mut probes, &[1500, -2500]);
    // Another baud rate on the same line is refused, naming both.
    let mut other = Probe::new();
    match other.connect(rtu(&pair.b, 3, 9600)) {
        Event::ConnectFailed { error, .. } => {
            assert!(
                error.text.contains("19200") && error.text.contains("9600"),
                "{error}"
            );
        }
        event => panic!("another baud rate: {event:?}"),
    }
}

/// The far end of an RTU line in this process: the simulated drives `slaves` on `path`,
/// until `silence` names one to stop answering (the others go on, same drives).
fn rtu_far_end(
    path: std::path::PathBuf,
    slaves: Vec<u8>,
) -> (std::sync::mpsc::Sender<u8>, std::thread::JoinHandle<()>) {
    use drivedeck::sim::Drive;
    use drivedeck::sim::server::SharedDrive;
    use drivedeck::sim::server::modbus::ServerOptions;
    use drivedeck::sim::server::modbus_rtu::{RtuOptions, open_serial, serve_rtu};
    let (silence, silenced) = std::sync::mpsc::channel::<u8>();
    let thread = std::thread::spawn(move || {
        let runtime = common::runtime();
        runtime.block_on(async move {
            let options = RtuOptions {
                path: path.display().to_string(),
                baud: 19200,
                parity: drivedeck::link::Parity::Even,
                stop_bits: 1,
            };
            let mut drives: Vec<(u8, SharedDrive)> = slaves
                .into_iter()
                .map(|s| (s, SharedDrive::new(Drive::new())))
                .collect();
            loop {
                let port = open_serial(&options).expect("the far end");
                let server =
                    tokio::spawn(serve_rtu(port, drives.clone(), ServerOptions::default()));
                let gone = loop {
                    match silenced.try_recv() {
                        Ok(slave) => break Some(slave),
                        Err(std::sync::mpsc::TryRecvError::Empty) => {
                            tokio::time::sleep(Duration::from_millis(10)).await;
                        }
                        Err(std::sync::mpsc::TryRecvError::Disconnected) => break None,
                    }
                };
                server.abort();
                let _ = server.await;
                match gone {
                    Some(slave) => drives.retain(|(s, _)| *s != slave),
                    None => return,
                }
            }
        });
    });
    (silence, thread)
}

#[test]
fn a_slave_that_stops_answering_is_lost_alone_and_the_other_finishes() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let (silence, far_end) = rtu_far_end(pair.a.clone(), vec![1, 2]);
    let mut probes: Vec<Probe> = [1, 2]
        .into_iter()
        .map(|slave| probe_at(rtu(&pair.b, slave, 19200), 100.0))
        .collect();
    let targets = [3000, -3000];
    let ids: Vec<_> = probes
        .iter()
        .zip(targets)
        .map(|(probe, target)| {
            probe.send(Request::SetLostAfter(2));
            probe.send(Request::Command(Action::MoveAbsolute {
                target,
                speed: 200,
            }))
        })
        .collect();
    for (probe, id) in probes.iter_mut().zip(&ids) {
        probe.accepted(*id);
    }
    let before = probes[0].seen.len();
    silence.send(2).expect("the far end");
    let reason = probes[1].lost(Duration::from_secs(10));
    assert!(
        reason.contains("slave 2") && reason.contains("no answer"),
        "{reason}"
    );
    let outcome = probes[0].outcome(ids[0], PATIENCE);
    assert_eq!(
        outcome,
        CommandProgress::Done {
            return_value: targets[0]
        },
        "notices: {:#?}",
        probes[0].notices()
    );
    assert_eq!(position(&mut probes[0]), i128::from(targets[0]));
    probes[0].never_dropped_since(before);
    drop(probes);
    drop(silence);
    far_end.join().expect("the far end");
}

/// The cycles per second of each of `probes` over a few seconds of exchanges.
fn rates(probes: &mut [Probe]) -> Vec<f64> {
    let mut rates = vec![Vec::new(); probes.len()];
    let until = Instant::now() + Duration::from_secs(4);
    while Instant::now() < until {
        for (probe, rates) in probes.iter_mut().zip(rates.iter_mut()) {
            while let Ok(event) = probe.worker.recv_timeout(Duration::from_millis(5)) {
                if let Event::Health(health) = event {
                    rates.push(health.cycles_per_second);
                }
            }
        }
    }
    rates
        .into_iter()
        .map(|r| {
            // The first second may include the connection.
            let r: Vec<f64> = r.into_iter().skip(1).collect();
            r.iter().sum::<f64>() / r.len().max(1) as f64
        })
        .collect()
}

#[test]
#[ignore = "a measurement: run with --ignored --nocapture"]
fn cycle_rates_with_one_two_three_drives_on_one_medium() {
    for count in 1..=3u8 {
        let mut probes: Vec<Probe> = (0..count)
            .map(|i| probe_at(spec(&format!("canopen+sim://?node={}", 31 + i)), 2000.0))
            .collect();
        println!(
            "in-memory CAN, {count} drive(s): {:?} cycles/s",
            rates(&mut probes)
        );
    }
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let _sim = Sim::rtu(
        &pair.a,
        &[
            "--slave", "1", "--slave", "2", "--slave", "3", "--baud", "115200",
        ],
    );
    for count in 1..=3u8 {
        let mut probes: Vec<Probe> = (1..=count)
            .map(|slave| probe_at(rtu(&pair.b, slave, 115_200), 2000.0))
            .collect();
        println!(
            "Modbus RTU 115200 on one pty line, {count} drive(s): {:?} cycles/s",
            rates(&mut probes)
        );
    }
}
