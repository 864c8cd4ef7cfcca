//! CANopen end to end over the in-memory bus: our master against the simulated node, the
//! PDI on PDOs (and over SDO where the mapping is refused), SDO object access, the scan,
//! EMCY, the mapping put back on disconnect.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::time::{Duration, Instant};

use drivedeck::cia::AbortCode;
use drivedeck::link::canopen::client::CanopenLink;
use drivedeck::link::canopen::{CanBus, MemoryBus, MemoryPort};
use drivedeck::link::{CanopenOptions, Link, LinkSpec, Notice, NoticeKind, Refusal};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::{Action, Failure, RxImage, StatusBit};
use drivedeck::proto::canopen::CanFrame;
use drivedeck::proto::canopen::sdo::{SdoClient, SdoEvent};
use drivedeck::sim::Drive;
use drivedeck::sim::Injection;
use drivedeck::sim::server::SharedDrive;
use drivedeck::sim::server::canopen::{Node, run_node};
use drivedeck::worker::{CommandProgress, Event, ObjectError, ObjectPath, Request};
use probe::Probe;

fn spec(node: u8) -> LinkSpec {
    format!("canopen+sim://?node={node}").parse().expect("spec")
}

/// A memory bus with a simulated node on it; returns the bus and the node's drive.
fn bus_with_node(node: u8, fixed_mapping: bool) -> (MemoryBus, SharedDrive) {
    let bus = MemoryBus::new();
    let drive = SharedDrive::new(Drive::new());
    let served = drive.clone();
    let port = bus.port();
    let built = {
        let mut d = drive.lock();
        Node::new(node, &mut d).with_fixed_mapping(fixed_mapping)
    };
    tokio::spawn(async move {
        let _ = run_node(port, built, served).await;
    });
    (bus, drive)
}

/// One SDO upload on a bare bus port, as an independent check of what the node holds.
async fn raw_upload(bus: &MemoryBus, node: u8, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
    let mut port = bus.port();
    let mut client = SdoClient::new(node);
    port.send(&client.upload(index, sub)).await.expect("send");
    loop {
        let frame = tokio::time::timeout(Duration::from_secs(1), port.recv())
            .await
            .expect("an answer")
            .expect("frame");
        match client.on_frame(&frame) {
            SdoEvent::Uploaded(data) => return Ok(data),
            SdoEvent::Aborted(code) => return Err(code),
            SdoEvent::Send(next) => port.send(&next).await.expect("send"),
            _ => {}
        }
    }
}

/// Our master on `bus`, connected to node `node` with the default options.
async fn connect(bus: &MemoryBus, node: u8) -> CanopenLink<MemoryPort> {
    let options = CanopenOptions {
        node,
        ..CanopenOptions::default()
    };
    CanopenLink::connect(spec(node), bus.port(), options)
        .await
        .expect("connect")
}

fn u32_le(data: &[u8]) -> u32 {
    u32::from_le_bytes(data.try_into().expect("4 bytes"))
}

#[test]
fn the_pdi_runs_on_the_pdos_spec_section_3_maps() {
    common::runtime().block_on(async {
        let (bus, drive) = bus_with_node(3, false);
        let mut link = connect(&bus, 3).await;
        let notices = link.take_notices();
        assert!(
            notices
                .iter()
                .any(|n| n.text.contains("mapped the PDI: RPDO1")),
            "{notices:?}"
        );
        assert!(link.info().description.contains("PDI on RPDO1/TPDO1"));
        // The mapping the node holds now is exactly spec section 3's.
        let entry = |index, sub| {
            let bus = bus.clone();
            async move { u32_le(&raw_upload(&bus, 3, index, sub).await.expect("read")) }
        };
        assert_eq!(entry(0x1600, 1).await, 0x2291_0120);
        assert_eq!(entry(0x1600, 4).await, 0x2291_0408);
        assert_eq!(entry(0x1A00, 1).await, 0x2292_0110);
        assert_eq!(entry(0x1A00, 2).await, 0x603F_0010);
        assert_eq!(entry(0x1A00, 3).await, 0x2292_0220);
        assert_eq!(entry(0x1400, 1).await, 0x203);
        assert_eq!(entry(0x1800, 1).await, 0x183);
        // A move through the RPDO; its acknowledgement and progress come on the TPDO.
        let rx = RxImage::new(
            Action::MoveAbsolute {
                target: 1200,
                speed: 300,
            }
            .set_values(),
            drivedeck::pdi::Command::new(drivedeck::pdi::Opcode::MoveAbsolute),
        );
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let exchange = link.exchange(Some(&rx)).await.expect("exchange");
            if exchange.tx.status.is_set(StatusBit::TargetReached)
                && exchange.tx.return_value == 1200
            {
                break;
            }
            assert!(Instant::now() < deadline, "no target: {:?}", exchange.tx);
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        assert!((drive.lock().position() - 1200.0).abs() < 0.5);
        // The frames went by as the spec says: RPDO on 203h with 8 bytes little-endian.
        let trace = link.take_trace();
        assert!(
            trace
                .iter()
                .any(|t| t.sent && t.raw == "203#B00400002C010014"),
            "{:?}",
            trace.iter().map(|t| &t.raw).collect::<Vec<_>>()
        );
        assert!(trace.iter().any(|t| !t.sent && t.raw.starts_with("183#")));
    });
}

#[test]
fn disconnecting_puts_the_previous_mapping_back() {
    common::runtime().block_on(async {
        let (bus, _drive) = bus_with_node(1, false);
        let before = raw_upload(&bus, 1, 0x1400, 1).await.expect("read");
        assert_eq!(u32_le(&before), 0x8000_0201, "invalid before");
        let mut link = CanopenLink::connect(spec(1), bus.port(), CanopenOptions::default())
            .await
            .expect("connect");
        assert_eq!(
            u32_le(&raw_upload(&bus, 1, 0x1400, 1).await.expect("read")),
            0x201
        );
        link.close().await.expect("close");
        assert_eq!(raw_upload(&bus, 1, 0x1400, 1).await.expect("read"), before);
        assert_eq!(raw_upload(&bus, 1, 0x1600, 0).await.expect("read"), vec![0]);
        assert_eq!(
            u32_le(&raw_upload(&bus, 1, 0x1800, 1).await.expect("read")),
            0x8000_0181
        );
        // keep_pdo leaves it.
        let options = CanopenOptions {
            keep_pdo: true,
            ..CanopenOptions::default()
        };
        let mut link = CanopenLink::connect(spec(1), bus.port(), options)
            .await
            .expect("connect");
        link.close().await.expect("close");
        assert_eq!(
            u32_le(&raw_upload(&bus, 1, 0x1400, 1).await.expect("read")),
            0x201
        );
    });
}

#[test]
fn self_start_sets_1f80h_lists_it_and_puts_it_back() {
    common::runtime().block_on(async {
        let (bus, _drive) = bus_with_node(1, false);
        let before = raw_upload(&bus, 1, 0x1F80, 0).await.expect("read");
        assert_eq!(u32_le(&before) & 0x08, 0, "not self-starting before");
        let options = CanopenOptions {
            self_start: true,
            ..CanopenOptions::default()
        };
        let mut link = CanopenLink::connect(spec(1), bus.port(), options)
            .await
            .expect("connect");
        assert_eq!(
            u32_le(&raw_upload(&bus, 1, 0x1F80, 0).await.expect("read")),
            0x08
        );
        let notices = link.take_notices();
        assert!(
            notices.iter().any(|n| n.text.contains("set 1F80h = 08h")),
            "{notices:?}"
        );
        let changes = link.own_changes();
        assert!(
            changes
                .iter()
                .any(|c| c.starts_with("1F80h:00h") && c.contains("put back")),
            "{changes:#?}"
        );
        assert!(changes.iter().any(|c| c.starts_with("1400h:01h")));
        link.close().await.expect("close");
        assert_eq!(raw_upload(&bus, 1, 0x1F80, 0).await.expect("read"), before);
        assert_eq!(
            u32_le(&raw_upload(&bus, 1, 0x1400, 1).await.expect("read")),
            0x8000_0201,
            "the mapping is back too"
        );
    });
}

#[test]
fn a_refused_mapping_runs_the_pdi_over_sdo() {
    common::runtime().block_on(async {
        let (bus, drive) = bus_with_node(2, true);
        let mut link = connect(&bus, 2).await;
        let notices = link.take_notices();
        assert!(
            notices
                .iter()
                .any(|n| n.text.contains("refused the PDI mapping") && n.text.contains("06010002h")),
            "{notices:?}"
        );
        assert!(link.info().description.contains("PDI over SDO"));
        let rx = RxImage::new(
            Action::Velocity { speed: 120 }.set_values(),
            drivedeck::pdi::Command::new(drivedeck::pdi::Opcode::Velocity),
        );
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let exchange = link.exchange(Some(&rx)).await.expect("exchange");
            if exchange.tx.status.is_set(StatusBit::TargetReached) {
                break;
            }
            assert!(Instant::now() < deadline);
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        assert!((drive.lock().velocity_rpm() - 120.0).abs() < 6.0);
    });
}

#[test]
fn a_node_without_the_pdi_still_gives_its_objects() {
    common::runtime().block_on(async {
        // A bare SDO server with a tiny dictionary: an independent CANopen device.
        struct Tiny;
        impl drivedeck::proto::canopen::sdo::ObjectAccess for Tiny {
            fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
                match (index, sub) {
                    (0x1018, 1) => Ok(vec![0x78, 0x56, 0x34, 0x12]),
                    (0x1008, 0) => Ok(b"Some other device".to_vec()),
                    _ => Err(AbortCode::NO_OBJECT),
                }
            }
            fn write(&mut self, _: u16, _: u8, _: &[u8]) -> Result<(), AbortCode> {
                Err(AbortCode::READ_ONLY)
            }
        }
        let bus = MemoryBus::new();
        let mut port = bus.port();
        tokio::spawn(async move {
            let mut server = drivedeck::proto::canopen::sdo::SdoServer::new(9);
            while let Ok(frame) = port.recv().await {
                if let Some(answer) = server.on_request(&frame, &mut Tiny) {
                    let _ = port.send(&answer).await;
                }
            }
        });
        let mut link = connect(&bus, 9).await;
        assert!(!link.info().pdi);
        assert_eq!(
            link.read_object(Address::new(0x1008, 0), DataType::VisibleString)
                .await
                .expect("link"),
            Ok(Value::Text("Some other device".into()))
        );
        assert_eq!(
            link.read_object(Address::new(0x1018, 1), DataType::Unsigned32)
                .await
                .expect("link"),
            Ok(Value::Uint(0x1234_5678))
        );
    });
}

#[test]
fn nobody_on_the_bus_is_a_clear_error() {
    common::runtime().block_on(async {
        let bus = MemoryBus::new();
        let options = CanopenOptions {
            node: 42,
            ..CanopenOptions::default()
        };
        let error = CanopenLink::connect(spec(42), bus.port(), options)
            .await
            .expect_err("nobody");
        let text = error.to_string();
        assert!(
            text.contains("node 42") && text.contains("no answer within 500 ms"),
            "{text}"
        );
    });
}

#[test]
fn the_scan_finds_every_node_with_its_identity() {
    common::runtime().block_on(async {
        let (bus, _a) = bus_with_node(4, false);
        let drive = SharedDrive::new(Drive::new());
        let port = bus.port();
        let served = drive.clone();
        tokio::spawn(async move {
            let _ = drivedeck::sim::server::canopen::run(port, 17, served).await;
        });
        tokio::time::sleep(Duration::from_millis(20)).await;
        let found = drivedeck::link::canopen::scan::scan(&mut bus.port())
            .await
            .expect("scan");
        let nodes: Vec<u8> = found.iter().filter_map(|d| d.node).collect();
        assert_eq!(nodes, [4, 17]);
        for device in &found {
            assert_eq!(device.vendor, Some(0x26C));
            assert_eq!(device.product, Some(0x42));
            assert_eq!(device.name.as_deref(), Some("drivedeck simulated drive"));
        }
    });
}

#[test]
fn a_node_that_refuses_the_identity_read_is_listed_with_its_abort_code() {
    common::runtime().block_on(async {
        let bus = MemoryBus::new();
        // Node 9 answers every SDO request with abort 06020000h (object does not exist).
        let mut node = bus.port();
        tokio::spawn(async move {
            while let Ok(frame) = node.recv().await {
                if frame.cob_id() == Some(0x609) {
                    let d = frame.data();
                    let abort = [0x80, d[1], d[2], d[3], 0x00, 0x00, 0x02, 0x06];
                    let answer = CanFrame::new(0x589, &abort).expect("a frame");
                    if node.send(&answer).await.is_err() {
                        break;
                    }
                }
            }
        });
        tokio::time::sleep(Duration::from_millis(20)).await;
        let found = drivedeck::link::canopen::scan::scan(&mut bus.port())
            .await
            .expect("scan");
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].node, Some(9));
        let refused = found[0].refused.as_deref().unwrap_or_default();
        assert!(refused.contains("SDO abort 06020000h"), "{refused}");
    });
}

// --- through the worker, as the window and the CLI use it -------------------------------

#[test]
fn the_worker_moves_the_motor_over_canopen_and_reads_strings() {
    let mut probe = Probe::connected(spec(1));
    probe.move_absolute(2000, 200);
    assert_eq!(
        probe.device_name(ObjectPath::Auto),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    assert_eq!(probe.vendor_id(ObjectPath::Pdi), Ok(Value::Uint(0x26C)));
    let missing = probe.read(
        Address::new(0x1018, 9),
        DataType::Unsigned32,
        ObjectPath::Native,
    );
    assert_eq!(
        missing,
        Err(ObjectError::Refused(Refusal::Abort(AbortCode::NO_SUBINDEX)))
    );
    // Statusword, position, velocity… come by SDO in turn, one a cycle: the position read
    // after the move settled says 2000 (one read during the last approach may say less).
    probe.sample_where("the position at the target", Duration::from_secs(3), |s| {
        s.position() == Some(2000.0)
    });
    probe.sample_where("a statusword", Duration::from_secs(3), |s| {
        s.statusword().is_some()
    });
}

#[test]
fn a_fault_on_the_node_arrives_as_emcy_and_fails_the_move() {
    let mut probe = Probe::connected(spec(5));
    let id = probe.start(Action::Velocity { speed: 100 });
    probe.send(Request::Inject {
        injection: Injection::OverCurrent,
        active: true,
    });
    assert_eq!(
        probe.outcome(id, Duration::from_secs(10)),
        CommandProgress::Failed(Failure::DriveFault { error_code: 0x2300 })
    );
    let emcy = probe.wait("the EMCY", Duration::from_secs(2), |e| {
        matches!(
            e,
            Event::Notice(Notice {
                kind: NoticeKind::Emcy { node: 5, .. },
                ..
            })
        )
    });
    assert!(
        matches!(&emcy, Event::Notice(Notice { kind: NoticeKind::Emcy { error_code: 0x2300, .. }, text })
            if text.contains("2300h")),
        "{emcy:?}"
    );
}

#[test]
fn frames_are_traced_when_asked() {
    let mut probe = Probe::connected(spec(1));
    probe.send(Request::SetTrace(true));
    probe.send(Request::ReadObject {
        address: Address::new(0x1018, 1),
        dtype: Some(DataType::Unsigned32),
        path: ObjectPath::Native,
    });
    let frames = probe.wait(
        "traced SDO frames",
        Duration::from_secs(2),
        |e| matches!(e, Event::Frames(f) if f.iter().any(|r| r.raw == "601#4018100100000000")),
    );
    let Event::Frames(frames) = frames else {
        unreachable!()
    };
    let request = frames
        .iter()
        .find(|r| r.raw == "601#4018100100000000")
        .expect("request");
    assert_eq!(request.text, "SDO request node 1: upload 1018h:01h");
    assert!(
        request.log_line().ends_with(" vcan0 601#4018100100000000"),
        "{}",
        request.log_line()
    );
    assert!(frames.iter().any(|r| r.raw == "581#431810016C020000"));
}

#[test]
fn what_closing_did_reaches_the_log() {
    // The link put its PDI mapping on the node; disconnecting puts the old one back and
    // says so (it is not dropped on the floor).
    let mut probe = Probe::connected(spec(3));
    probe.send(Request::Disconnect);
    probe.wait(
        "the restore report",
        Duration::from_secs(5),
        |e| matches!(e, Event::Notice(n) if n.text.contains("restored the PDO mapping of node 3")),
    );
}
