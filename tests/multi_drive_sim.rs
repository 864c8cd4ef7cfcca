//! Several simulated drives at once, each its own drive behind its own address on one
//! medium, mastered by the library's own clients:
//!
//! * three `canopen+sim` nodes opened side by side in one process share one in-memory CAN
//!   bus: each answers only its own SDOs, moving one leaves the others standing, and all
//!   three move at once with SDO reads interleaved between their PDOs;
//! * `drivedeck sim --modbus-rtu A --slave 5 --slave 6`: two drives on one pty line (socat),
//!   our RTU client talks to slave 5, then to slave 6, then to 5 again;
//! * python-canopen masters `drivedeck sim --slcan A --node 5 --node 6` on one slcan pty;
//! * two `--modbus-tcp` ports and two `--enip` adapters are two drives each, and
//!   `--verbose` names each drive's line by its port.
//!
//! Without socat or the Python peer the pty tests pass without running and say `SKIPPED …`
//! in the output; with `DRIVEDECK_REQUIRE_PEERS=1` (CI, `.ci/run`) they fail.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::json;

use common::{PtyPair, Sim};
use drivedeck::connect::{self, AnyLink};
use drivedeck::link::{Link, LinkSpec};
use drivedeck::od::{Address, DataType};
use drivedeck::pdi::{Action, Command, Opcode, RxImage, StatusBit};

/// Time a move may take on a loaded machine (the moves here take about a second).
const PATIENCE: Duration = Duration::from_secs(20);

fn sim_node(node: u8) -> LinkSpec {
    format!("canopen+sim://?node={node}").parse().expect("spec")
}

fn rtu_spec(path: &Path, slave: u8) -> LinkSpec {
    format!(
        "modbus-rtu://{}?baud=19200&parity=even&slave={slave}",
        path.display()
    )
    .parse()
    .expect("spec")
}

/// An absolute move to `target` at `speed` rpm as the PDI-Cmd (the toggle bit tells a new
/// command of the same opcode from the last one).
fn move_to(target: i32, speed: i16, toggle: bool) -> RxImage {
    let mut command = Command::new(Opcode::MoveAbsolute);
    command.toggle = toggle;
    RxImage::new(Action::MoveAbsolute { target, speed }.set_values(), command)
}

/// One SDO (or register) read of an object, as a number.
async fn read(link: &mut AnyLink, index: u16, sub: u8, dtype: DataType) -> i128 {
    let value = link
        .read_object(Address::new(index, sub), dtype)
        .await
        .expect("the link")
        .expect("the drive's answer");
    value.as_i128().expect("a number")
}

async fn position(link: &mut AnyLink) -> i128 {
    read(link, 0x6064, 0, DataType::Integer32).await
}

/// Whether the drive finished the move to `target` (as its PDI says).
async fn arrived(link: &mut AnyLink, rx: &RxImage, target: i32) -> bool {
    let tx = link.exchange(Some(rx)).await.expect("exchange").tx;
    tx.status.is_set(StatusBit::TargetReached) && tx.return_value == target
}

/// Move one drive to `target` and wait until it is there.
async fn move_alone(link: &mut AnyLink, target: i32, toggle: bool) {
    let rx = move_to(target, 300, toggle);
    let deadline = Instant::now() + PATIENCE;
    while !arrived(link, &rx, target).await {
        assert!(Instant::now() < deadline, "no arrival at {target}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

#[test]
fn three_simulated_nodes_on_one_in_memory_bus_move_at_once_with_interleaved_sdo_reads() {
    common::runtime().block_on(async {
        let nodes = [5u8, 6, 7];
        let mut links = Vec::new();
        for node in nodes {
            links.push(connect::open(&sim_node(node)).await.expect("connect"));
        }
        // One bus: a scan finds all three nodes.
        let found = connect::scan(&sim_node(5)).await.expect("scan");
        let on_the_bus: Vec<u8> = found.iter().filter_map(|d| d.node).collect();
        assert_eq!(on_the_bus, nodes);
        // Each link reaches its own node: 1014h (the EMCY COB-ID) is 80h + node id.
        for (link, node) in links.iter_mut().zip(nodes) {
            let emcy = read(link, 0x1014, 0, DataType::Unsigned32).await;
            assert_eq!(emcy, 0x80 + i128::from(node));
        }
        // Moving node 5 leaves nodes 6 and 7 standing: three drives, not one.
        move_alone(&mut links[0], 1500, false).await;
        assert_eq!(position(&mut links[0]).await, 1500);
        assert_eq!(position(&mut links[1]).await, 0);
        assert_eq!(position(&mut links[2]).await, 0);
        // All three at once, each to its own target; between their PDOs, SDO reads of
        // every node's position, in turn.
        let targets = [-800, 2400, 900];
        let commands: Vec<RxImage> = targets.iter().map(|&t| move_to(t, 200, true)).collect();
        let starts = [1500i128, 0, 0];
        let mut done = [false; 3];
        let mut all_on_the_way = false;
        let deadline = Instant::now() + PATIENCE;
        while done != [true; 3] {
            assert!(Instant::now() < deadline, "not all arrived: {done:?}");
            let mut on_the_way = 0;
            for k in 0..3 {
                done[k] = arrived(&mut links[k], &commands[k], targets[k]).await;
                let now = position(&mut links[k]).await;
                let (low, high) = if starts[k] < i128::from(targets[k]) {
                    (starts[k], i128::from(targets[k]))
                } else {
                    (i128::from(targets[k]), starts[k])
                };
                assert!((low..=high).contains(&now), "node {}: {now}", nodes[k]);
                if low < now && now < high {
                    on_the_way += 1;
                }
            }
            all_on_the_way |= on_the_way == 3;
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        assert!(
            all_on_the_way,
            "the three drives never moved at the same time"
        );
        // One medium: node 5's link heard the other nodes' TPDOs (186h, 187h) go by.
        let heard: Vec<u16> = links[0]
            .take_trace()
            .iter()
            .filter_map(|r| r.can.as_ref().and_then(|(frame, _)| frame.cob_id()))
            .collect();
        assert!(
            heard.contains(&0x186) && heard.contains(&0x187),
            "{heard:x?}"
        );
        for (link, target) in links.iter_mut().zip(targets) {
            assert_eq!(position(link).await, i128::from(target));
        }
    });
}

#[test]
fn two_rtu_slaves_on_one_pty_line_are_two_drives() {
    let Some(pair) = PtyPair::new() else {
        return;
    };
    let sim = Sim::rtu(&pair.a, &["--slave", "5", "--slave", "6"]);
    assert!(
        sim.banner.contains("drives on Modbus RTU")
            && sim.banner.contains("slaves 5, 6, 19200 baud"),
        "{}",
        sim.banner
    );
    common::runtime().block_on(async {
        let mut five = connect::open(&rtu_spec(&pair.b, 5)).await.expect("slave 5");
        move_alone(&mut five, 2000, false).await;
        assert_eq!(position(&mut five).await, 2000);
        drop(five);
        // Slave 6 on the same line is another drive: it stood still, and moves on its own.
        let mut six = connect::open(&rtu_spec(&pair.b, 6)).await.expect("slave 6");
        assert_eq!(position(&mut six).await, 0);
        move_alone(&mut six, -700, false).await;
        assert_eq!(position(&mut six).await, -700);
        drop(six);
        let mut five = connect::open(&rtu_spec(&pair.b, 5))
            .await
            .expect("slave 5 again");
        assert_eq!(position(&mut five).await, 2000);
        drop(five);
        // Nobody answers another address on the line.
        let error = connect::open(&rtu_spec(&pair.b, 7))
            .await
            .expect_err("no slave 7");
        assert!(error.to_string().contains("slave 7"), "{error}");
    });
    drop(sim);
}

#[test]
fn python_canopen_masters_two_simulated_nodes_on_one_slcan_pty() {
    let Some(python) = common::python_canopen() else {
        return;
    };
    let Some(pty) = PtyPair::new() else {
        return;
    };
    let mut sim = Sim::slcan_nodes(&pty.a, &[5, 6], &[]);
    let got = common::try_run_peer(
        &python,
        "canopen_two_nodes.py",
        &[pty.b.to_str().expect("utf-8 path")],
        Duration::from_secs(60),
    )
    .unwrap_or_else(|e| panic!("{e}\n{}", sim.process.report()));
    let mut rest = got.clone();
    let mut take = |key: &str| {
        rest.as_object_mut()
            .and_then(|o| o.remove(key))
            .unwrap_or_else(|| panic!("no {key} in {got}"))
    };
    let five = take("node_5_moved");
    let six = take("node_6_moved");
    assert_eq!(
        rest,
        json!({
            // python-canopen's scanner (SDO 1000h to ids 1-127) hears both nodes.
            "scanner_nodes": [5, 6],
            // NMT reset communication and NMT start, each sent once to all (node id 0).
            "booted": [5, 6],
            "operational": [5, 6],
            // Each node answers its own SDOs, from its own dictionary.
            "emcy_cob_1014": {"5": 0x85, "6": 0x86},
            "heartbeat_1017": {"5": 45, "6": 46},
        })
    );
    // Node 5 went to 1200 (through positions on the way) while node 6 stood at 0; then
    // node 6 to -600 while node 5 stayed at 1200.
    assert_eq!(
        five,
        json!({"position": 1200, "on_the_way": true, "node_6_seen_at": [0]})
    );
    assert_eq!(
        six,
        json!({"position": -600, "on_the_way": true, "node_5_seen_at": [1200]})
    );
}

/// The address in a "serving the simulated drive on Modbus TCP ADDR (…)" line.
fn tcp_address(banner: &str) -> String {
    banner
        .split("Modbus TCP ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {banner:?}"))
        .to_owned()
}

#[test]
fn two_modbus_tcp_ports_are_two_drives_and_verbose_names_each() {
    let (mut sim, first) = Sim::tcp(&["--modbus-tcp", "127.0.0.1:0", "--verbose"]);
    let second = sim
        .process
        .expect_line("the second port's banner", Duration::from_secs(10));
    let second = tcp_address(&second);
    common::runtime().block_on(async {
        let spec =
            |addr: &str| -> LinkSpec { format!("modbus-tcp://{addr}").parse().expect("spec") };
        let mut one = connect::open(&spec(&first.to_string()))
            .await
            .expect("the first drive");
        move_alone(&mut one, 1000, false).await;
        let mut two = connect::open(&spec(&second))
            .await
            .expect("the second drive");
        assert_eq!(position(&mut two).await, 0);
    });
    // --verbose: a line per drive a second, each starting with the port it is served on.
    let deadline = Instant::now() + PATIENCE;
    let (mut moved, mut stood) = (false, false);
    while !(moved && stood) {
        assert!(Instant::now() < deadline, "{}", sim.process.report());
        let Some(line) = sim.process.line(Duration::from_secs(2)) else {
            continue;
        };
        moved |=
            line.starts_with(&format!("Modbus TCP {first}:")) && line.contains("position 1000 ");
        stood |= line.starts_with(&format!("Modbus TCP {second}:")) && line.contains("position 0 ");
    }
}

#[test]
fn two_enip_adapters_are_two_drives() {
    let (mut sim, first) = Sim::enip(&["--enip", "127.0.0.1:0"]);
    let second = sim
        .process
        .expect_line("the second adapter's banner", Duration::from_secs(10));
    let second = second
        .split("EtherNet/IP ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {second:?}"))
        .to_owned();
    common::runtime().block_on(async {
        let spec = |addr: &str| -> LinkSpec {
            format!("enip://{addr}?io=explicit").parse().expect("spec")
        };
        let mut one = connect::open(&spec(&first.to_string()))
            .await
            .expect("the first adapter");
        let mut two = connect::open(&spec(&second))
            .await
            .expect("the second adapter");
        move_alone(&mut one, -400, false).await;
        assert_eq!(position(&mut one).await, -400);
        assert_eq!(position(&mut two).await, 0);
    });
}
