//! The worker thread driving the simulated drive on real time: what a user of the window
//! or the CLI sees happen.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod probe;

use std::sync::Arc;
use std::time::Duration;

use drivedeck::cia::AbortCode;
use drivedeck::link::{ErrorKind, LinkSpec, Refusal};
use drivedeck::od::{Address, DataType, Value};
use drivedeck::pdi::{Action, Failure, StatusBit};
use drivedeck::sim::Injection;
use drivedeck::worker::{
    CommandProgress, Config, Event, ObjectError, ObjectPath, Rejection, Request, Worker,
};
use probe::Probe;

#[test]
fn a_move_reaches_its_target_and_raises_target_reached() {
    let mut probe = Probe::on_simulated_time();
    let id = probe.send(Request::Command(Action::MoveAbsolute {
        target: 2000,
        speed: 200,
    }));
    probe.wait(
        "the image sent",
        Duration::from_secs(2),
        |e| matches!(e, Event::Sent { id: i, image, .. } if *i == id && image.cmd == 20),
    );
    probe.accepted(id);
    let outcome = probe.outcome(id, Duration::from_secs(10));
    assert_eq!(outcome, CommandProgress::Done { return_value: 2000 });
    let sample = probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(2000.0)
    });
    assert!(sample.tx.status.is_set(StatusBit::TargetReached));
    assert!(sample.tx.status.is_set(StatusBit::OperationEnabled));
    assert_eq!(sample.statusword().map(|w| w & 0x6F), Some(0x27));
}

#[test]
fn on_simulated_time_a_long_move_waits_no_real_time() {
    // Nine turns at 10 rpm: almost a minute of the drive's time, well within the probe's
    // ten seconds of real time only because the worker's clock jumps ahead.
    let mut probe = Probe::on_simulated_time();
    let id = probe.send(Request::Command(Action::MoveAbsolute {
        target: 32_000,
        speed: 10,
    }));
    let outcome = probe.outcome(id, Duration::from_secs(10));
    assert_eq!(
        outcome,
        CommandProgress::Done {
            return_value: 32_000
        }
    );
    let sample = probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(32_000.0)
    });
    assert!(sample.t > 50.0, "the drive's time: {} s", sample.t);
}

#[test]
fn simulated_time_is_refused_for_a_real_link() {
    let config = drivedeck::worker::Config {
        simulated_time: true,
        ..Default::default()
    };
    let worker =
        drivedeck::worker::Worker::spawn(config, std::sync::Arc::new(|| {})).expect("worker");
    let spec: LinkSpec = "modbus-tcp://127.0.0.1:1".parse().expect("spec");
    worker.send(Request::Connect(spec)).expect("sent");
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        match worker.recv_timeout(left) {
            Ok(Event::ConnectFailed {
                error, retry_in, ..
            }) => {
                assert!(
                    error.text.contains("cannot run on simulated time"),
                    "{error}"
                );
                assert_eq!(retry_in, None);
                break;
            }
            Ok(_) => {}
            Err(e) => panic!("no refusal: {e}"),
        }
    }
}

#[test]
fn halt_stops_and_resume_continues() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    probe.start(Action::MoveAbsolute {
        target: 20_000,
        speed: 300,
    });
    probe.settle(Duration::from_millis(300));
    let halt = probe.send(Request::Halt);
    let halted = probe.outcome(halt, Duration::from_secs(5));
    assert!(matches!(halted, CommandProgress::Done { .. }), "{halted:?}");
    let stopped = probe.sample_where("the motor at rest", Duration::from_secs(5), |s| {
        s.velocity() == Some(0.0)
    });
    assert!(stopped.tx.status.is_set(StatusBit::QsHaltBit));
    let at = stopped.position().expect("position");
    assert!(at > 0.0 && at < 20_000.0, "{at}");
    // The halt reported where the motor came to rest.
    assert!(
        matches!(halted, CommandProgress::Done { return_value } if (f64::from(return_value) - at).abs() < 2.0)
    );
    let resume = probe.send(Request::Resume);
    assert_eq!(
        probe.outcome(resume, Duration::from_secs(10)),
        CommandProgress::Done {
            return_value: 20_000
        }
    );
}

#[test]
fn od_write_then_read_through_the_pdi() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let address = Address::new(0x203B, 1);
    let id = probe.send(Request::WriteObject {
        address,
        dtype: DataType::Unsigned32,
        value: Value::Uint(1000),
        path: ObjectPath::Pdi,
    });
    assert_eq!(probe.written(id), Ok(()));
    assert_eq!(
        probe.read(address, DataType::Unsigned32, ObjectPath::Pdi),
        Ok(Value::Uint(1000))
    );
    // The same object read directly agrees.
    assert_eq!(
        probe.read(address, DataType::Unsigned32, ObjectPath::Native),
        Ok(Value::Uint(1000))
    );
    // The sent image was the spec's OD-Write: SetValue2 = 203Bh, SetValue3 = 1, Cmd = 15.
    let sent = probe.seen.iter().find_map(|e| match e {
        Event::Sent { id: i, image, .. } if *i == id => Some(*image),
        _ => None,
    });
    let sent = sent.expect("the OD-Write image");
    assert_eq!(
        (
            sent.values.value1,
            sent.values.value2,
            sent.values.value3,
            sent.cmd & 0x7F
        ),
        (1000, 0x203B, 1, 15)
    );
}

#[test]
fn a_missing_object_comes_back_as_pdi_status_error_06020000h() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let result = probe.read(
        Address::new(0x2FFF, 0),
        DataType::Unsigned32,
        ObjectPath::Pdi,
    );
    assert_eq!(
        result,
        Err(ObjectError::Pdi(CommandProgress::Failed(
            Failure::Refused {
                code: AbortCode::NO_OBJECT.0,
            }
        )))
    );
    // Directly, the simulator answers the same abort.
    let direct = probe.read(
        Address::new(0x2FFF, 0),
        DataType::Unsigned32,
        ObjectPath::Native,
    );
    assert_eq!(
        direct,
        Err(ObjectError::Refused(Refusal::Abort(AbortCode::NO_OBJECT)))
    );
}

#[test]
fn quickstop_jumps_the_queue() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    probe.start(Action::Velocity { speed: 500 });
    // A queue of PDI reads, then the stop.
    let reads: Vec<u64> = (0..10)
        .map(|_| {
            probe.send(Request::ReadObject {
                address: Address::new(0x1018, 1),
                dtype: Some(DataType::Unsigned32),
                path: ObjectPath::Pdi,
            })
        })
        .collect();
    let stop = probe.send(Request::Command(Action::Quickstop));
    probe.wait(
        "the quick stop sent",
        Duration::from_secs(2),
        |e| matches!(e, Event::Sent { id, .. } if *id == stop),
    );
    let sent_before_stop = probe
        .seen
        .iter()
        .filter(|e| matches!(e, Event::Sent { id, .. } if reads.contains(id)))
        .count();
    assert!(
        sent_before_stop <= 1,
        "{sent_before_stop} reads went out before the quick stop"
    );
    assert!(matches!(
        probe.outcome(stop, Duration::from_secs(2)),
        CommandProgress::Done { .. }
    ));
    probe.sample_where("the power stage off", Duration::from_secs(5), |s| {
        !s.tx.status.is_set(StatusBit::OperationEnabled)
    });
}

#[test]
fn an_injected_fault_fails_the_move_and_clear_error_needs_the_cause_gone() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let id = probe.start(Action::MoveAbsolute {
        target: 50_000,
        speed: 100,
    });
    probe.send(Request::Inject {
        injection: Injection::OverCurrent,
        active: true,
    });
    assert_eq!(
        probe.outcome(id, Duration::from_secs(5)),
        CommandProgress::Failed(Failure::DriveFault { error_code: 0x2300 })
    );
    assert_eq!(
        probe.command(Action::ClearError, Duration::from_secs(5)),
        CommandProgress::Failed(Failure::FaultPersists { error_code: 0x2300 })
    );
    probe.send(Request::Inject {
        injection: Injection::OverCurrent,
        active: false,
    });
    assert!(matches!(
        probe.command(Action::ClearError, Duration::from_secs(5)),
        CommandProgress::Done { .. }
    ));
}

#[test]
fn requests_without_a_link_are_rejected_with_a_reason() {
    let worker = Worker::spawn(Config::default(), Arc::new(|| {})).expect("worker");
    let id = worker.send(Request::Command(Action::Nop)).expect("queued");
    let event = worker
        .recv_timeout(Duration::from_secs(2))
        .expect("an answer");
    assert_eq!(
        event,
        Event::Rejected {
            id,
            request: "NOP".into(),
            reason: Rejection::NotConnected
        }
    );
    let id = worker
        .send(Request::Connect(
            "enip://127.0.0.1:1".parse().expect("spec"),
        ))
        .expect("queued");
    let _ = id;
    let mut failed = None;
    for _ in 0..3 {
        if let Ok(Event::ConnectFailed {
            error, retry_in, ..
        }) = worker.recv_timeout(Duration::from_secs(2))
        {
            failed = Some((error, retry_in));
            break;
        }
    }
    let (error, retry_in) = failed.expect("connect failed");
    assert_eq!(error.kind, ErrorKind::Refused, "{error}");
    assert!(
        error.text.contains("refuses TCP connections") && error.text.contains("is it on"),
        "{error}"
    );
    // A drive may still be booting: it is asked again, until the user gives up.
    assert!(retry_in.is_some(), "a refused connection is retried");
    worker.send(Request::Disconnect).expect("queued");
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    loop {
        match worker.recv_timeout(Duration::from_millis(500)) {
            Ok(Event::Disconnected { reason: None }) => break,
            Ok(_) | Err(_) => assert!(
                std::time::Instant::now() < deadline,
                "the retries did not stop"
            ),
        }
    }
}

#[test]
fn health_reports_the_cycle_rate() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let health = probe.wait("health", Duration::from_secs(3), |e| {
        matches!(e, Event::Health(_))
    });
    let Event::Health(health) = health else {
        unreachable!()
    };
    // The default poll rate is 100 Hz; a loaded CI machine may fall behind a little.
    assert!(
        health.cycles_per_second > 50.0 && health.cycles_per_second < 120.0,
        "{health:?}"
    );
    assert_eq!(health.errors, 0);
}

#[test]
fn a_lost_link_ends_the_command_reports_and_reconnects_to_the_same_drive() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let id = probe.start(Action::MoveAbsolute {
        target: 20_000,
        speed: 200,
    });
    let before = probe
        .settle(Duration::from_millis(300))
        .position()
        .expect("position");
    assert!(before > 0.0);
    probe.send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    let outcome = probe.outcome(id, Duration::from_secs(2));
    assert!(
        matches!(&outcome, CommandProgress::LinkLost { reason } if reason.contains("halt")),
        "{outcome:?}"
    );
    let lost = probe.lost(Duration::from_secs(2));
    assert!(lost.contains("cable is pulled"), "{lost}");
    probe.retrying(Duration::from_secs(2));
    // Requests meanwhile get a reason, not a hang.
    let id = probe.send(Request::Command(Action::Nop));
    probe.wait("the rejection", Duration::from_secs(2), |e| {
        matches!(e, Event::Rejected { id: i, reason, .. } if *i == id && *reason == Rejection::NotConnected)
    });
    probe.reconnected(Duration::from_secs(10));
    // The same simulated drive: the move went on while the cable was out.
    let after = probe.sample_where("the position at the target", Duration::from_secs(5), |s| {
        s.position() == Some(20_000.0)
    });
    assert!(after.tx.status.is_set(StatusBit::TargetReached));
}

#[test]
fn a_command_the_drive_never_acknowledges_times_out() {
    let mut probe = Probe::on_simulated_time();
    // PDI-Ctrl off: the drive ignores 2291h, as a real one would.
    assert_eq!(
        probe.write(
            Address::new(0x2290, 0),
            DataType::Unsigned8,
            Value::Uint(0),
            ObjectPath::Native
        ),
        Ok(())
    );
    let outcome = probe.command(Action::Velocity { speed: 100 }, Duration::from_secs(3));
    let text = outcome.to_string();
    assert!(
        matches!(outcome, CommandProgress::TimedOut { .. }),
        "{outcome:?}"
    );
    assert!(
        text.contains("PdiStatusToggleCmd") && text.contains("2290h"),
        "{text}"
    );
    // The worker is still there and answers.
    let value = probe.read(
        Address::new(0x2290, 0),
        DataType::Unsigned8,
        ObjectPath::Native,
    );
    assert_eq!(value, Ok(Value::Uint(0)));
}

#[test]
fn many_objects_are_read_in_order_and_a_cancel_drops_the_rest() {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let objects: Vec<(Address, DataType)> = drivedeck::od::builtin()
        .entries()
        .filter(|e| e.access.readable())
        .map(|e| (e.address, e.dtype))
        .collect();
    assert!(objects.len() > 100, "{}", objects.len());
    let id = probe.send(Request::ReadMany {
        objects: objects.clone(),
        path: ObjectPath::Auto,
    });
    let mut got = vec![];
    while got.len() < objects.len() {
        match probe.wait(
            "the reads",
            Duration::from_secs(10),
            |e| matches!(e, Event::ObjectRead { id: i, .. } if *i == id),
        ) {
            Event::ObjectRead {
                address, result, ..
            } => got.push((address, result)),
            _ => unreachable!(),
        }
    }
    let order: Vec<Address> = got.iter().map(|(a, _)| *a).collect();
    let asked: Vec<Address> = objects.iter().map(|(a, _)| *a).collect();
    assert_eq!(order, asked, "in the order asked");
    assert!(got.iter().all(|(_, r)| r.is_ok()), "{got:?}");
    // The PDI kept running meanwhile: samples came between the reads.
    assert!(probe.seen.iter().any(|e| matches!(e, Event::Samples(_))));

    // A second bulk read, cancelled at once: every object is either read or dropped.
    let id = probe.send(Request::ReadMany {
        objects: objects.clone(),
        path: ObjectPath::Auto,
    });
    probe.send(Request::Cancel(id));
    let dropped = match probe.wait(
        "the cancellation",
        Duration::from_secs(10),
        |e| matches!(e, Event::Cancelled { id: i, .. } if *i == id),
    ) {
        Event::Cancelled { dropped, .. } => dropped,
        _ => unreachable!(),
    };
    let read = probe
        .seen
        .iter()
        .filter(|e| matches!(e, Event::ObjectRead { id: i, .. } if *i == id))
        .count();
    assert!(dropped > 0, "the cancel came before the reads");
    assert_eq!(read + dropped, objects.len());

    // More than the worker queues at once is refused with a reason.
    let id = probe.send(Request::ReadMany {
        objects: vec![(Address::new(0x6064, 0), DataType::Integer32); 10_000],
        path: ObjectPath::Auto,
    });
    let refused = probe.wait(
        "the refusal",
        Duration::from_secs(5),
        |e| matches!(e, Event::Rejected { id: i, .. } if *i == id),
    );
    assert!(
        matches!(&refused, Event::Rejected { reason: Rejection::Refused(reason), .. } if reason.contains("read them in parts")),
        "{refused:?}"
    );
}

#[test]
fn the_machines_ports_and_interfaces_come_from_the_worker() {
    // The window asks; it never lists them itself (that is I/O).
    let mut probe = Probe::new();
    probe.send(Request::ListInterfaces);
    let interfaces = probe.wait("the interfaces", Duration::from_secs(5), |e| {
        matches!(e, Event::Interfaces(_))
    });
    let Event::Interfaces(interfaces) = interfaces else {
        unreachable!()
    };
    assert!(
        interfaces.iter().any(|i| i.ip.is_loopback()),
        "loopback is an interface: {interfaces:?}"
    );
    probe.send(Request::ListSerialPorts);
    probe.wait("the serial ports", Duration::from_secs(5), |e| {
        matches!(e, Event::SerialPorts(_))
    });
}

#[test]
fn the_simulated_drive_says_which_homing_methods_it_has() {
    let probe = Probe::connected(LinkSpec::Sim);
    let methods = probe
        .link_info()
        .homing_methods
        .expect("the simulator knows its methods");
    assert!(
        methods.contains(&19) && methods.contains(&35),
        "{methods:?}"
    );
}

/// The samples among the events after the first `from`, oldest first.
fn samples_since(probe: &Probe, from: usize) -> Vec<drivedeck::worker::Sample> {
    probe.seen[from..]
        .iter()
        .filter_map(|e| match e {
            Event::Samples(s) => Some(s.clone()),
            _ => None,
        })
        .flatten()
        .collect()
}

/// Every sample time so far is later than the one before it.
fn times_increase(probe: &Probe) {
    let times: Vec<f64> = probe.samples().iter().map(|s| s.t).collect();
    assert!(
        times.windows(2).all(|w| w[0] < w[1]),
        "sample times went back: {:?}",
        times
            .windows(2)
            .find(|w| w[0] >= w[1])
            .map(|w| (w[0], w[1]))
    );
}

#[test]
fn sample_and_command_times_go_on_across_a_lost_link_and_a_new_connection() {
    let mut probe = Probe::on_simulated_time();
    let before = probe
        .sample_where("a second of samples", Duration::from_secs(5), |s| s.t > 1.0)
        .t;
    // The cable pulled for LINK_LOSS_TIME (3 s); the worker reconnects by itself.
    probe.send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    probe.lost(Duration::from_secs(5));
    let lost_at = probe.samples().last().map_or(before, |s| s.t);
    let from = probe.seen.len();
    probe.reconnected(Duration::from_secs(10));
    probe.sample_where("a sample on the link back", Duration::from_secs(5), |_| {
        true
    });
    let back = samples_since(&probe, from);
    let first = back.first().map_or(f64::NAN, |s| s.t);
    // One time axis: the outage lies on it, the new samples come after the old ones.
    assert!(
        first - lost_at >= 2.5,
        "lost at {lost_at} s, back at {first} s"
    );
    times_increase(&probe);

    // The user disconnects and connects again (a fresh simulated drive): still one axis.
    probe.send(Request::Disconnect);
    probe.wait("disconnected", Duration::from_secs(5), |e| {
        matches!(e, Event::Disconnected { reason: None })
    });
    let last = probe.samples().last().map_or(f64::NAN, |s| s.t);
    let from = probe.seen.len();
    probe.send(Request::Connect(LinkSpec::Sim));
    probe.reconnected(Duration::from_secs(5));
    probe.sample_where("a sample on the new link", Duration::from_secs(5), |_| true);
    let first = samples_since(&probe, from)
        .first()
        .map_or(f64::NAN, |s| s.t);
    assert!(
        first > last,
        "disconnected at {last} s, connected at {first} s"
    );
    times_increase(&probe);

    // A command's marker time is on the same clock: after every sample before it.
    let newest = probe.samples().last().map_or(f64::NAN, |s| s.t);
    let id = probe.send(Request::Command(Action::Velocity { speed: 100 }));
    let sent = probe.wait(
        "the image sent",
        Duration::from_secs(2),
        |e| matches!(e, Event::Sent { id: i, .. } if *i == id),
    );
    let Event::Sent { t, .. } = sent else {
        unreachable!()
    };
    assert!(
        t >= newest,
        "sent at {t} s, the newest sample at {newest} s"
    );
    let next = probe.sample_where("a sample after the command", Duration::from_secs(2), |_| {
        true
    });
    assert!(
        t <= next.t,
        "sent at {t} s, the next sample at {} s",
        next.t
    );
}

#[test]
fn a_link_lost_while_a_move_stands_at_a_limit_switch_is_not_said_to_be_during_a_move() {
    let mut probe = Probe::on_simulated_time();
    // Beyond the simulated drive's positive limit switch (3600.0°): the move stops there.
    let id = probe.send(Request::Command(Action::MoveAbsolute {
        target: 60_000,
        speed: 300,
    }));
    probe.accepted(id);
    probe.sample_where("the limit switch reached", Duration::from_secs(10), |s| {
        s.tx.status.is_set(StatusBit::LimitReached) && s.velocity() == Some(0.0)
    });
    probe.send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    let report = probe.wait(
        "the report of the loss",
        Duration::from_secs(10),
        |e| matches!(e, Event::Notice(n) if n.text.contains("the link failed")),
    );
    let Event::Notice(notice) = report else {
        unreachable!()
    };
    assert!(
        notice
            .text
            .contains("while a travel command stood at a limit switch"),
        "{}",
        notice.text
    );
    assert!(!notice.text.contains("during a move"), "{}", notice.text);
}
