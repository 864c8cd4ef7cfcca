//! Our Modbus client against the simulated drive served on real loopback sockets, and the
//! failures a technician meets: a gateway without FC 23, a device without FC 43, a second
//! client, a drive that dies or goes silent mid-move, garbage on the wire.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::time::{Duration, Instant};

use drivedeck::cia::AbortCode;
use drivedeck::link::modbus::client::{DEFAULT_TIMEOUT, ModbusLink};
use drivedeck::link::{Link, LinkSpec, Refusal};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::{Action, Failure, StatusBit};
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::modbus::ServerOptions;
use drivedeck::worker::{CommandProgress, Event, ObjectError, ObjectPath, Sample};
use probe::Probe;

fn spec(addr: SocketAddr) -> LinkSpec {
    format!("modbus-tcp://{addr}").parse().expect("spec")
}

#[test]
fn a_move_over_modbus_tcp_reaches_its_target() {
    let server = common::modbus_server(ServerOptions::default());
    let mut probe = Probe::connected(spec(server.addr));
    probe.move_absolute(2000, 200);
    // Statusword, mode and position come along in the process image at 5000.
    let sample = probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(2000.0)
    });
    assert!(sample.tx.status.is_set(StatusBit::TargetReached));
    assert_eq!(sample.statusword().map(|w| w & 0x6F), Some(0x27));
    assert_eq!(sample.mode(), Some(1));
    // The simulated drive agrees.
    assert!((server.drive().lock().position() - 2000.0).abs() < 0.5);
    // Velocity and torque are not in the factory image: they come over FC 43, in turn,
    // each sample holding only what was measured in its cycle.
    let samples = probe.samples();
    let with = |f: fn(&Sample) -> bool| samples.iter().filter(|s| f(s)).count();
    assert!(
        with(|s| s.velocity().is_some_and(|v| v > 10.0)) > 5,
        "velocity during the move"
    );
    assert!(with(|s| s.torque().is_some()) > 5, "torque");
    assert!(with(|s| s.velocity().is_none()) > 5, "not every cycle");
}

#[test]
fn objects_over_fc_43_and_over_the_pdi() {
    let server = common::modbus_server(ServerOptions::default());
    let mut probe = Probe::connected(spec(server.addr));
    let vendor = Address::new(0x1018, 1);
    assert_eq!(
        probe.read(vendor, DataType::Unsigned32, ObjectPath::Native),
        Ok(Value::Uint(0x26C))
    );
    assert_eq!(
        probe.read(vendor, DataType::Unsigned32, ObjectPath::Pdi),
        Ok(Value::Uint(0x26C))
    );
    // Strings only over FC 43.
    assert_eq!(
        probe.device_name(ObjectPath::Auto),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    // Write, read back.
    assert_eq!(
        probe.write(
            Address::new(0x6087, 0),
            DataType::Unsigned32,
            Value::Uint(1234),
            ObjectPath::Native
        ),
        Ok(())
    );
    assert_eq!(
        probe.read(
            Address::new(0x6087, 0),
            DataType::Unsigned32,
            ObjectPath::Pdi
        ),
        Ok(Value::Uint(1234))
    );
    // Refusals carry the abort code both ways: the device's answer to FC 43, and the
    // PDI's OD Read refused with PdiStatusError and the code as the return value.
    let missing = probe.read(
        Address::new(0x2FFF, 0),
        DataType::Unsigned32,
        ObjectPath::Native,
    );
    assert_eq!(
        missing,
        Err(ObjectError::Refused(Refusal::Abort(AbortCode::NO_OBJECT)))
    );
    let missing = probe.read(
        Address::new(0x2FFF, 0),
        DataType::Unsigned32,
        ObjectPath::Pdi,
    );
    assert_eq!(
        missing,
        Err(ObjectError::Pdi(CommandProgress::Failed(
            Failure::Refused {
                code: AbortCode::NO_OBJECT.0
            }
        )))
    );
    assert_eq!(
        probe.write(
            vendor,
            DataType::Unsigned32,
            Value::Uint(1),
            ObjectPath::Native
        ),
        Err(ObjectError::Refused(Refusal::Abort(AbortCode::READ_ONLY)))
    );
}

#[test]
fn a_gateway_without_fc_23_gets_fc_16_and_fc_4() {
    let options = ServerOptions {
        fc23: false,
        ..ServerOptions::default()
    };
    let server = common::modbus_server(options);
    let mut probe = Probe::connected(spec(server.addr));
    assert!(matches!(
        probe.command(
            Action::MoveRelative {
                distance: 900,
                speed: 300,
            },
            Duration::from_secs(10)
        ),
        CommandProgress::Done { .. }
    ));
    assert!(
        probe
            .notices()
            .iter()
            .any(|n| n.contains("does not support FC 23") && n.contains("FC 16 then FC 4")),
        "{:?}",
        probe.notices()
    );
    let changed = probe.seen.iter().find_map(|e| match e {
        Event::LinkChanged(info) => Some(info.description.clone()),
        _ => None,
    });
    assert!(
        changed
            .expect("the link describes itself anew")
            .contains("FC 16 + FC 4")
    );
}

#[test]
fn a_device_without_fc_43_reads_objects_through_the_pdi() {
    let options = ServerOptions {
        fc43: false,
        ..ServerOptions::default()
    };
    let server = common::modbus_server(options);
    let mut probe = Probe::connected(spec(server.addr));
    assert_eq!(probe.vendor_id(ObjectPath::Auto), Ok(Value::Uint(0x26C)));
    assert!(
        probe
            .notices()
            .iter()
            .any(|n| n.contains("does not support FC 43"))
    );
    // Asked for FC 43 explicitly, the refusal says so.
    let native = probe.vendor_id(ObjectPath::Native);
    assert_eq!(native, Err(ObjectError::Refused(Refusal::NotSupported)));
}

#[test]
fn a_second_client_is_told_the_one_connection_is_taken() {
    let server = common::modbus_server(ServerOptions::default());
    let _first = Probe::connected(spec(server.addr));
    let failed = Probe::new().connect(spec(server.addr));
    let Event::ConnectFailed { error, .. } = failed else {
        panic!("a second client got in: {failed:?}");
    };
    assert!(
        error.text.contains("allows one Modbus TCP connection"),
        "{error}"
    );
}

#[test]
fn max_clients_lets_more_in() {
    let options = ServerOptions {
        max_clients: 2,
        ..ServerOptions::default()
    };
    let server = common::modbus_server(options);
    let _first = Probe::connected(spec(server.addr));
    let _second = Probe::connected(spec(server.addr));
}

#[test]
fn a_drive_that_dies_mid_move_shows_disconnected_within_a_second_and_comes_back() {
    let server = common::modbus_server(ServerOptions::default());
    let addr = server.addr;
    let mut probe = Probe::connected(spec(addr));
    let id = probe.start(Action::MoveAbsolute {
        target: 30_000,
        speed: 100,
    });
    let killed = Instant::now();
    drop(server);
    let outcome = probe.outcome(id, Duration::from_secs(2));
    assert!(
        matches!(&outcome, CommandProgress::LinkLost { reason } if reason.contains("halt")),
        "{outcome:?}"
    );
    probe.lost(Duration::from_secs(2));
    assert!(
        killed.elapsed() < Duration::from_secs(1),
        "{:?}",
        killed.elapsed()
    );
    // The worker keeps trying and reconnects once the drive is back on the same port.
    probe.retrying(Duration::from_secs(2));
    let _back =
        ServerThread::modbus_tcp(addr, ServerOptions::default()).expect("the same port again");
    probe.reconnected(Duration::from_secs(10));
    // Nothing from before is replayed: the fresh drive stands still, switched off.
    let sample = probe.settle(Duration::from_millis(300));
    assert!(!sample.tx.status.is_set(StatusBit::OperationEnabled));
}

/// A TCP server that accepts and then answers with `reply` to everything (None = silence).
fn fake_server(reply: Option<Vec<u8>>) -> SocketAddr {
    let listener = TcpListener::bind(common::loopback()).expect("bind");
    let addr = listener.local_addr().expect("addr");
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { continue };
            let reply = reply.clone();
            std::thread::spawn(move || {
                let mut buf = [0u8; 512];
                while let Ok(n) = stream.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    if let Some(reply) = &reply {
                        let _ = stream.write_all(reply);
                    }
                }
            });
        }
    });
    addr
}

#[test]
fn a_silent_device_times_out_naming_the_request() {
    let addr = fake_server(None);
    let runtime = common::runtime();
    let error = runtime
        .block_on(ModbusLink::connect(&spec(addr), Duration::from_millis(200)))
        .expect_err("no answer");
    let text = error.to_string();
    assert!(text.contains("no answer within 200 ms"), "{text}");
    assert!(text.contains("FC 43"), "{text}");
}

#[test]
fn garbage_replies_are_reported_not_panicked_on() {
    // Protocol id 1234h: not Modbus TCP.
    let addr = fake_server(Some(vec![
        0x00, 0x01, 0x12, 0x34, 0x00, 0x03, 0x00, 0x83, 0x02,
    ]));
    let runtime = common::runtime();
    let error = runtime
        .block_on(ModbusLink::connect(&spec(addr), DEFAULT_TIMEOUT))
        .expect_err("garbage");
    assert!(error.to_string().contains("garbage"), "{error}");
    // Arbitrary bytes in every shape: an error each time, never a panic.
    for seed in 0u8..40 {
        let junk: Vec<u8> = (0..(seed as usize % 17 + 1))
            .map(|i| seed.wrapping_mul(31).wrapping_add(i as u8 * 7))
            .collect();
        let addr = fake_server(Some(junk));
        let result = runtime.block_on(ModbusLink::connect(&spec(addr), Duration::from_millis(150)));
        let error = result
            .expect_err("junk never makes a working link")
            .to_string();
        assert!(
            error.contains("garbage") || error.contains("no answer") || error.contains("malformed"),
            "{error}"
        );
    }
}

#[test]
fn fc_101_reads_the_whole_dictionary() {
    let server = common::modbus_server(ServerOptions::default());
    let runtime = common::runtime();
    let entries = runtime.block_on(async {
        let mut link = ModbusLink::connect(&spec(server.addr), DEFAULT_TIMEOUT)
            .await
            .expect("link");
        link.read_dictionary().await.expect("no link error")
    });
    let entries = entries.expect("FC 101 is supported");
    let count = server.drive().lock().addresses().count();
    // Every readable object arrives (only write-only ones are left out).
    assert!(
        entries.len() > 300 && entries.len() <= count,
        "{} of {count}",
        entries.len()
    );
    let vendor = entries
        .iter()
        .find(|(a, _)| *a == Address::new(0x1018, 1))
        .map(|(_, data)| data.clone());
    assert_eq!(vendor, Some(vec![0x6C, 0x02, 0, 0]));
}

#[test]
fn a_failed_move_over_modbus_reports_the_fault() {
    let server = common::modbus_server(ServerOptions::default());
    let mut probe = Probe::connected(spec(server.addr));
    let id = probe.start(Action::Velocity { speed: 100 });
    server
        .drive()
        .lock()
        .inject(drivedeck::sim::Injection::UnderVoltage);
    assert_eq!(
        probe.outcome(id, Duration::from_secs(5)),
        CommandProgress::Failed(Failure::DriveFault { error_code: 0x3100 })
    );
    // The link itself is fine: the drive's refusal is data.
    let link_open = Instant::now();
    probe.sample_where("the fault bit", Duration::from_secs(1), |s| {
        s.tx.status.is_set(StatusBit::Fault)
    });
    assert!(link_open.elapsed() < Duration::from_secs(1));
}

#[test]
fn one_link_directly_exchanges_and_reads_back_the_rx_image() {
    let server = common::modbus_server(ServerOptions::default());
    let runtime = common::runtime();
    runtime.block_on(async {
        let mut link = ModbusLink::connect(&spec(server.addr), DEFAULT_TIMEOUT)
            .await
            .expect("link");
        let rx = drivedeck::pdi::RxImage {
            values: drivedeck::pdi::SetValues {
                value1: 0x1018,
                value2: 0x1018,
                value3: 1,
            },
            cmd: 14,
        };
        let first = link.exchange(Some(&rx)).await.expect("exchange");
        // FC 23 writes before it reads: the OD-Read is already answered.
        assert_eq!(first.tx.return_value, 0x26C);
        assert_eq!(link.read_rx().await.expect("read back"), Some(rx));
        assert!(link.info().description.contains("FC 23"));
    });
}
