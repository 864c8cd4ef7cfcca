//! One bad frame is not a lost link. A proxy between the worker and the simulated drive
//! drops, delays, corrupts, duplicates or re-numbers one reply during a move (Modbus TCP,
//! EtherNet/IP explicit messages), and a serial proxy puts noise on Modbus RTU and slcan:
//! the move still reaches its target, the log names what happened, and only the
//! configured number of failed exchanges in a row makes the link count as lost.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;
mod proxy;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use drivedeck::link::LinkSpec;
use drivedeck::pdi::Action;
use drivedeck::worker::{CommandProgress, Event};
use probe::Probe;
use proxy::{Fault, Framing, Noise, Proxy, SerialProxy};

fn modbus(addr: SocketAddr) -> LinkSpec {
    format!("modbus-tcp://{addr}").parse().expect("spec")
}

fn enip_explicit(addr: SocketAddr) -> LinkSpec {
    format!("enip://{addr}?io=explicit").parse().expect("spec")
}

/// One turn at 120 rpm: about half a second of motion, plenty of exchanges to spoil.
const A_MOVE: Action = Action::MoveRelative {
    distance: 3600,
    speed: 120,
};

/// Start a move, spoil one reply with `spoil`, and check the move reaches its target on
/// the same connection. Returns the probe for more checks.
fn move_through(spec: LinkSpec, spoil: impl FnOnce()) -> Probe {
    let mut probe = Probe::connected(spec);
    let id = probe.start(A_MOVE);
    spoil();
    let outcome = probe.outcome(id, Duration::from_secs(15));
    assert!(
        matches!(outcome, CommandProgress::Done { .. }),
        "the move did not survive one bad frame: {outcome:?}; notices: {:#?}",
        probe.notices()
    );
    probe.never_dropped();
    probe
}

/// Keep the link exchanging (the worker polls on its own) until the proxy has applied
/// `count` spoilings: a move may end before the last one was due on a loaded machine, and
/// each must still be got over.
fn until_applied(probe: &mut Probe, count: usize, applied: impl Fn() -> usize) {
    if applied() >= count {
        return;
    }
    probe.wait(
        "every spoiling applied by the proxy",
        Duration::from_secs(15),
        |_| applied() >= count,
    );
    probe.never_dropped();
}

/// A notice that says `words` (all of them).
fn named(probe: &Probe, words: &[&str]) -> bool {
    probe.notice_with(words).is_some()
}

/// FC 23, the process-image exchange of every cycle.
const FC_23: u8 = 0x17;

fn modbus_move_through(fault: Fault) -> (Probe, Proxy) {
    let server = common::modbus_server(Default::default());
    let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
    let probe = move_through(modbus(proxy.addr), || proxy.fault_on(5, fault, FC_23));
    assert_eq!(
        proxy.applied(),
        vec![fault],
        "the proxy did not spoil a reply"
    );
    drop(server);
    (probe, proxy)
}

#[test]
fn modbus_tcp_a_lost_reply_is_sent_again() {
    let (probe, _) = modbus_move_through(Fault::Drop);
    assert!(
        named(&probe, &["no answer within", "answered on try 2"]),
        "{:#?}",
        probe.notices()
    );
}

#[test]
fn modbus_tcp_a_late_reply_is_taken_or_skipped() {
    // Later than one try (a third of 500 ms), sooner than the whole timeout.
    modbus_move_through(Fault::Delay(Duration::from_millis(300)));
    // Later than all three tries: that exchange fails, the next one works.
    let (probe, _) = modbus_move_through(Fault::Delay(Duration::from_millis(700)));
    assert!(
        named(&probe, &["an exchange with the drive failed", "no answer"]),
        "{:#?}",
        probe.notices()
    );
    let mut probe = probe;
    probe.expect_notice(&["recovered after 1 failed exchange"]);
}

#[test]
fn modbus_tcp_a_corrupted_reply_is_sent_again() {
    let (probe, _) = modbus_move_through(Fault::Corrupt);
    assert!(
        named(&probe, &["a corrupted reply", "answered on try 2"]),
        "{:#?}",
        probe.notices()
    );
    let (probe, _) = modbus_move_through(Fault::BreakFraming);
    assert!(
        named(&probe, &["garbage instead of a Modbus TCP frame"]),
        "{:#?}",
        probe.notices()
    );
}

#[test]
fn modbus_tcp_a_reply_for_another_transaction_is_discarded() {
    let (probe, _) = modbus_move_through(Fault::WrongId);
    assert!(
        named(&probe, &["a reply for another transaction", "discarded"]),
        "{:#?}",
        probe.notices()
    );
    // A reply that comes twice: the second copy is a late answer, skipped.
    modbus_move_through(Fault::Duplicate);
}

#[test]
fn modbus_tcp_one_exception_is_the_drives_answer_not_a_lost_link() {
    let (probe, _) = modbus_move_through(Fault::Exception(0x06));
    assert!(
        named(
            &probe,
            &["an exchange with the drive failed", "exception 06h", "busy"]
        ),
        "{:#?}",
        probe.notices()
    );
    assert!(
        !probe.notices().iter().any(|n| n.contains("malformed")),
        "an exception is an answer: {:#?}",
        probe.notices()
    );
}

#[test]
fn two_failed_exchanges_in_a_row_are_not_yet_a_lost_link() {
    let server = common::modbus_server(Default::default());
    let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
    // Each failed exchange is three tries: six replies lost are two exchanges.
    let mut probe = move_through(modbus(proxy.addr), || proxy.drop_next(6));
    assert_eq!(proxy.dropped(), 6);
    probe.expect_notice(&["recovered after 2 failed exchange"]);
}

/// Every reply lost from mid-move on: the link counts as lost after exactly `lost_after`
/// failed exchanges, and the message says so and what was done to the drive.
fn lost_after(lost_after: u32) {
    let server = common::modbus_server(Default::default());
    let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
    let (mut probe, id) = Probe::turning(modbus(proxy.addr), lost_after);
    let cut = Instant::now();
    proxy.drop_all();
    // Three tries of 500 ms per failed exchange (plus the halt attempt), never fewer.
    probe.lost_after_exactly(lost_after, cut, Duration::from_millis(500));
    let failed = probe.notices();
    assert!(
        failed
            .iter()
            .any(|n| n.contains("an exchange with the drive failed")),
        "{failed:#?}"
    );
    // The command running then ends with the same, whole reason.
    let ended = probe.seen.iter().find_map(|e| match e {
        Event::Progress {
            id: i,
            progress: CommandProgress::LinkLost { reason },
        } if *i == id => Some(reason.clone()),
        _ => None,
    });
    let ended = ended.expect("the velocity command ends with the link");
    assert!(ended.contains("exchanges failed in a row"), "{ended}");
    assert!(ended.contains("halt"), "{ended}");
}

#[test]
fn a_link_lost_during_a_move_whose_last_halt_gets_through_says_the_drive_took_it() {
    let server = common::modbus_server(Default::default());
    let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
    let (mut probe, _) = Probe::turning(modbus(proxy.addr), 1);
    // One request's three tries are lost; the next frame, the last halt, goes through.
    proxy.drop_next(3);
    let reason = probe.lost(Duration::from_secs(10));
    assert!(
        reason
            .to_lowercase()
            .contains("a halt was sent and the drive"),
        "the last halt reached the drive: {reason}"
    );
    assert!(!reason.contains("at the machine"), "{reason}");
    drop(probe);
    // Found halted by a new connection.
    let mut after = Probe::connected(modbus(server.addr));
    after.wait("a sample", Duration::from_secs(3), |e| {
        matches!(e, Event::Samples(_))
    });
    let halted = after.last.expect("a sample");
    assert!(
        halted
            .tx
            .status
            .is_set(drivedeck::pdi::StatusBit::QsHaltBit),
        "{halted:?}"
    );
}

#[test]
fn the_link_counts_as_lost_after_three_failed_exchanges_by_default() {
    lost_after(3);
}

#[test]
fn the_link_counts_as_lost_after_the_configured_number_of_failed_exchanges() {
    lost_after(5);
}

fn enip_move_through(fault: Fault) -> Probe {
    let server = common::enip_adapter();
    let proxy = Proxy::start(server.addr, Framing::Enip);
    let probe = move_through(enip_explicit(proxy.addr), || proxy.fault_in(8, fault));
    assert_eq!(
        proxy.applied(),
        vec![fault],
        "the proxy did not spoil a reply"
    );
    probe
}

#[test]
fn enip_explicit_a_lost_or_corrupted_reply_is_sent_again() {
    let probe = enip_move_through(Fault::Drop);
    assert!(
        named(&probe, &["no answer within", "answered on try 2"]),
        "{:#?}",
        probe.notices()
    );
    let probe = enip_move_through(Fault::Corrupt);
    assert!(
        named(&probe, &["a corrupted reply", "answered on try 2"]),
        "{:#?}",
        probe.notices()
    );
    let probe = enip_move_through(Fault::BreakFraming);
    assert!(
        named(&probe, &["more than any adapter sends"]),
        "{:#?}",
        probe.notices()
    );
    enip_move_through(Fault::Delay(Duration::from_millis(500)));
    enip_move_through(Fault::Duplicate);
}

#[test]
fn enip_a_reply_with_another_session_or_command_is_rejected_by_name() {
    let probe = enip_move_through(Fault::WrongId);
    assert!(
        named(&probe, &["session handle", "rejected"]),
        "{:#?}",
        probe.notices()
    );
    let probe = enip_move_through(Fault::WrongCommand);
    assert!(
        named(&probe, &["RegisterSession", "rejected"]),
        "{:#?}",
        probe.notices()
    );
}

fn rtu(path: &std::path::Path) -> LinkSpec {
    format!("modbus-rtu://{}?baud=115200&slave=5", path.display())
        .parse()
        .expect("spec")
}

#[test]
fn modbus_rtu_noise_and_a_crc_error_are_got_over() {
    let (Some(host), Some(device)) = (common::PtyPair::new(), common::PtyPair::new()) else {
        return;
    };
    let _sim = common::Sim::rtu(&device.a, &["--baud", "115200"]);
    let proxy = SerialProxy::start(&host.b, &device.b, false);
    let mut probe = move_through(rtu(&host.a), || {
        proxy.noise_in(3, Noise::Before);
        proxy.noise_in(9, Noise::Flip);
        proxy.noise_in(15, Noise::Lost);
        proxy.noise_in(21, Noise::Garbage);
    });
    until_applied(&mut probe, 4, || proxy.applied().len());
    assert_eq!(
        proxy.applied(),
        vec![Noise::Before, Noise::Flip, Noise::Lost, Noise::Garbage]
    );
    // Noise before a reply is skipped (resynchronised); a CRC error, a lost reply and
    // garbage instead of one are each sent again, and named.
    assert!(
        named(&probe, &["a garbled answer", "CRC"]),
        "{:#?}",
        probe.notices()
    );
    assert!(
        named(&probe, &["no answer within", "answered on try 2"]),
        "{:#?}",
        probe.notices()
    );
}

#[test]
fn slcan_a_garbled_line_is_skipped() {
    let (Some(host), Some(device)) = (common::PtyPair::new(), common::PtyPair::new()) else {
        return;
    };
    let _sim = common::Sim::slcan(&device.a, 1, &[]);
    let proxy = SerialProxy::start(&host.b, &device.b, true);
    let spec: LinkSpec = format!("canopen+slcan://{}?node=1", host.a.display())
        .parse()
        .expect("spec");
    let mut probe = move_through(spec, || {
        proxy.noise_in(2, Noise::Garbage);
        proxy.noise_in(5, Noise::Flip);
        proxy.noise_in(9, Noise::Lost);
        proxy.noise_in(12, Noise::Before);
    });
    until_applied(&mut probe, 4, || proxy.applied().len());
    assert_eq!(
        proxy.applied(),
        vec![Noise::Garbage, Noise::Flip, Noise::Lost, Noise::Before]
    );
}

mod window;

/// The window's "after N failures" setting reaches the worker: with 1, one exchange whose
/// three tries all go unanswered loses the link; with the default 3 the same is got over.
#[test]
fn the_windows_lost_after_setting_decides_when_the_link_counts_as_lost() {
    use drivedeck::ui::drive::Connection;
    for (lost_after, survives) in [(1u32, false), (3, true)] {
        let server = common::modbus_server(Default::default());
        let proxy = Proxy::start(server.addr, Framing::ModbusTcp);
        let mut harness = window::connected_to(
            &modbus(proxy.addr),
            Some(lost_after),
            eframe::egui::vec2(1366.0, 768.0),
        );
        // Let the setting go out before the trouble starts.
        window::step_for(&mut harness, Duration::from_millis(200));
        proxy.drop_next(3);
        window::step_until(
            &mut harness,
            "the three lost replies",
            Duration::from_secs(5),
            |_| proxy.dropped() >= 3,
        );
        window::step_for(&mut harness, Duration::from_millis(700));
        let state = harness.state().shown();
        let lost = state.log.iter().any(|e| e.what.starts_with("link lost"));
        assert_eq!(
            !lost, survives,
            "lost after {lost_after}: {:?}; {:#?}",
            state.link.connection, state.log
        );
        if survives {
            assert!(matches!(state.link.connection, Connection::Connected(_)));
        }
        drop(harness);
        drop(server);
    }
}
