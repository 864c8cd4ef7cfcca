//! One bad datagram is not a lost link either. A UDP proxy between the worker's scanner and
//! the simulated adapter (tests/proxy/udp.rs) drops, doubles and reorders class 1 I/O
//! datagrams during a move: the move reaches its target, the stale ones are dropped and
//! reported; T→O silence beyond the connection timeout is a lost link, named, and
//! reconnecting opens the connection again. And the lost-after count holds on the links
//! besides Modbus TCP: EtherNet/IP explicit messages (through the TCP proxy) and Modbus RTU
//! (through the serial proxy) count as lost after exactly the configured number of failed
//! exchanges in a row, never before.

mod common;
mod probe;
mod proxy;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use drivedeck::link::LinkSpec;
use drivedeck::pdi::Action;
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::enip::AdapterOptions;
use drivedeck::worker::{CommandProgress, Event, Request};
use probe::Probe;
use proxy::udp::{Mishap, UdpProxy, Way};
use proxy::{Framing, Noise, Proxy, SerialProxy};

fn local() -> SocketAddr {
    "127.0.0.1:0".parse().expect("address")
}

/// The adapter on loopback, its I/O on a free UDP port (the tests run in parallel).
fn adapter() -> ServerThread {
    ServerThread::enip(
        local(),
        AdapterOptions {
            io_port: 0,
            ..AdapterOptions::default()
        },
    )
    .expect("adapter")
}

/// Class 1 I/O on the PDI set at RPI 10 ms; `udp=0` announces the scanner's port, which
/// the proxy puts its own in place of.
fn class1(addr: SocketAddr) -> LinkSpec {
    format!("enip://{addr}?udp=0&io=pdi&rpi=10")
        .parse()
        .expect("spec")
}

fn enip_explicit(addr: SocketAddr) -> LinkSpec {
    format!("enip://{addr}?io=explicit").parse().expect("spec")
}

fn rtu(path: &std::path::Path) -> LinkSpec {
    format!("modbus-rtu://{}?baud=115200&slave=5", path.display())
        .parse()
        .expect("spec")
}

fn connected_description(probe: &Probe) -> String {
    probe
        .seen
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Connected(info) => Some(info.description.clone()),
            _ => None,
        })
        .expect("connected")
}

/// The link was dropped (or a reconnection was under way) after the first `from` events
/// (a connection that needed a second try to open is not the trouble under test).
fn dropped(probe: &Probe, from: usize) -> Option<&Event> {
    probe.seen[from..]
        .iter()
        .find(|e| matches!(e, Event::Disconnected { .. } | Event::ConnectFailed { .. }))
}

/// A notice with `text`, seen already or coming within a few seconds.
fn expect_notice(probe: &mut Probe, text: &str) {
    if !probe.notices().iter().any(|n| n.contains(text)) {
        probe.wait(
            text,
            Duration::from_secs(5),
            |e| matches!(e, Event::Notice(n) if n.text.contains(text)),
        );
    }
}

/// Wait (up to a few seconds) until `done`.
fn until(what: &str, done: impl Fn() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while !done() {
        assert!(Instant::now() < deadline, "{what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn accepted(probe: &mut Probe, id: u64) {
    probe.wait(
        "the command accepted",
        Duration::from_secs(3),
        |e| matches!(e, Event::Progress { id: i, progress: CommandProgress::Accepted } if *i == id),
    );
}

// ---------------------------------------------------------------- class 1 I/O datagrams

#[test]
fn a_class_1_move_gets_over_a_lost_a_doubled_and_a_reordered_datagram() {
    let server = adapter();
    let proxy = UdpProxy::start(server.addr);
    let mut probe = Probe::connected(class1(proxy.addr));
    let description = connected_description(&probe);
    assert!(
        description.contains("class 1 I/O at 10 ms"),
        "{description}"
    );
    let opens = proxy.opens();
    assert!(opens >= 1, "the connection runs through the proxy");
    let from = probe.seen.len();
    // One turn at 120 rpm: about half a second, some 50 T→O datagrams.
    let id = probe.send(Request::Command(Action::MoveRelative {
        distance: 3600,
        speed: 120,
    }));
    accepted(&mut probe, id);
    // An older image after a newer one, a copy, a datagram lost; and the outputs too.
    proxy.mishap_in(Way::TtoO, 3, Mishap::Reorder);
    proxy.mishap_in(Way::TtoO, 10, Mishap::Duplicate);
    proxy.mishap_in(Way::TtoO, 17, Mishap::Drop);
    proxy.mishap_in(Way::OtoT, 4, Mishap::Drop);
    proxy.mishap_in(Way::OtoT, 11, Mishap::Reorder);
    proxy.mishap_in(Way::OtoT, 18, Mishap::Delay(Duration::from_millis(35)));
    let outcome = probe.outcome(id, Duration::from_secs(10));
    assert!(
        matches!(outcome, CommandProgress::Done { .. }),
        "the move did not survive: {outcome:?}; notices: {:#?}",
        probe.notices()
    );
    until("every mishap done", || {
        proxy.applied(Way::TtoO).len() == 3 && proxy.applied(Way::OtoT).len() == 3
    });
    assert_eq!(
        proxy.applied(Way::TtoO),
        [Mishap::Reorder, Mishap::Duplicate, Mishap::Drop]
    );
    // The stale image and the copy are dropped, and said.
    expect_notice(
        &mut probe,
        "class 1 I/O: 1 T→O datagram came out of order and was dropped",
    );
    expect_notice(
        &mut probe,
        "class 1 I/O: 1 T→O datagram came twice and the copy was dropped",
    );
    assert!(
        dropped(&probe, from).is_none(),
        "{:?}; notices: {:#?}",
        dropped(&probe, from),
        probe.notices()
    );
    assert_eq!(proxy.opens(), opens, "never reconnected");
}

#[test]
fn t_to_o_silence_beyond_the_connection_timeout_is_a_lost_link_that_reconnecting_reopens() {
    let server = adapter();
    let proxy = UdpProxy::start(server.addr);
    let mut probe = Probe::connected(class1(proxy.addr));
    let opens = proxy.opens();
    proxy.silence_until_reopened();
    let lost = probe.wait("the link loss", Duration::from_secs(5), |e| {
        matches!(e, Event::Disconnected { reason: Some(_) })
    });
    let Event::Disconnected {
        reason: Some(reason),
    } = lost
    else {
        unreachable!()
    };
    // RPI 10 ms, the multiplier for at least 500 ms: 4 << 4 = 64 RPIs.
    assert!(
        reason
            .contains("no T→O datagram for 640 ms (64 × RPI 10 ms): the I/O connection timed out"),
        "{reason}"
    );
    assert!(reason.contains("reconnecting opens it again"), "{reason}");
    assert!(proxy.silenced() > 0);
    // The worker reconnects by itself, with class 1 I/O again (the old connection closed
    // in the adapter first, else it would refuse the new one as an ownership conflict).
    let back = probe.wait("the reconnection", Duration::from_secs(5), |e| {
        matches!(e, Event::Connected(_))
    });
    let Event::Connected(info) = back else {
        unreachable!()
    };
    assert!(
        info.description.contains("class 1 I/O at 10 ms"),
        "{}; notices: {:#?}",
        info.description,
        probe.notices()
    );
    assert_eq!(proxy.opens(), opens + 1);
    let before = proxy.passed(Way::TtoO);
    until("T→O datagrams again", || {
        proxy.passed(Way::TtoO) > before + 5
    });
}

// ---------------------------------------------------------------- the lost-after count

/// The motor turning (a velocity command accepted), `lost_after` set.
fn turning(spec: LinkSpec, lost_after: u32) -> Probe {
    let mut probe = Probe::connected(spec);
    probe.send(Request::SetLostAfter(lost_after));
    let id = probe.send(Request::Command(Action::Velocity { speed: 60 }));
    accepted(&mut probe, id);
    probe
}

/// The drive stopped answering at `cut`: the link counts as lost after exactly
/// `lost_after` failed exchanges (each at least `per_exchange`), and the message says so
/// and what was done to the drive.
fn lost_after_exactly(probe: &mut Probe, lost_after: u32, cut: Instant, per_exchange: Duration) {
    let lost = probe.wait("the link loss", Duration::from_secs(20), |e| {
        matches!(e, Event::Disconnected { reason: Some(_) })
    });
    let took = cut.elapsed();
    let Event::Disconnected {
        reason: Some(reason),
    } = lost
    else {
        unreachable!()
    };
    assert!(
        reason.contains(&format!("{lost_after} exchanges failed in a row")),
        "{reason}"
    );
    assert!(reason.contains("no answer within"), "{reason}");
    assert!(
        reason.contains("halt"),
        "what was done to the drive: {reason}"
    );
    // Never sooner than the failed exchanges before the last could take.
    assert!(
        took >= per_exchange * (lost_after - 1),
        "lost after {took:?}"
    );
    let said = format!("the link counts as lost after {lost_after} failures in a row");
    assert!(
        probe.notices().iter().any(|n| n.contains(&said)),
        "{:#?}",
        probe.notices()
    );
}

/// EtherNet/IP explicit messages: one failed exchange is three tries in 1 s.
const ENIP_EXCHANGE: Duration = Duration::from_secs(1);

fn enip_explicit_lost_after(lost_after: u32) {
    let server = adapter();
    let proxy = Proxy::start(server.addr, Framing::Enip);
    let mut probe = turning(enip_explicit(proxy.addr), lost_after);
    let cut = Instant::now();
    proxy.drop_all();
    lost_after_exactly(&mut probe, lost_after, cut, ENIP_EXCHANGE);
}

#[test]
fn enip_explicit_counts_as_lost_after_three_failed_exchanges() {
    enip_explicit_lost_after(3);
}

#[test]
fn enip_explicit_counts_as_lost_after_five_failed_exchanges_when_so_set() {
    enip_explicit_lost_after(5);
}

#[test]
fn enip_explicit_two_failed_exchanges_in_a_row_are_not_yet_a_lost_link() {
    let server = adapter();
    let proxy = Proxy::start(server.addr, Framing::Enip);
    let mut probe = turning(enip_explicit(proxy.addr), 3);
    let from = probe.seen.len();
    // Each failed exchange is three tries: six replies lost are two exchanges.
    proxy.drop_next(6);
    expect_notice(&mut probe, "recovered after 2 failed exchange");
    assert_eq!(proxy.dropped(), 6);
    assert!(
        dropped(&probe, from).is_none(),
        "{:?}; notices: {:#?}",
        dropped(&probe, from),
        probe.notices()
    );
}

/// Modbus RTU at 115200 baud: one failed exchange is three tries in 500 ms.
const RTU_EXCHANGE: Duration = Duration::from_millis(500);

/// Over Modbus RTU on a pty, with `lost_after` set: `got_over` failed exchanges in a row
/// (each reply lost) are got over; then, if `then_silent`, a drive that stops answering
/// counts as lost after exactly `lost_after`.
fn rtu_lost_after(lost_after: u32, got_over: u32, then_silent: bool) {
    let (Some(host), Some(device)) = (common::PtyPair::new(), common::PtyPair::new()) else {
        return;
    };
    let _sim = common::Sim::rtu(&device.a, &["--baud", "115200"]);
    let proxy = SerialProxy::start(&host.b, &device.b, false);
    let mut probe = turning(rtu(&host.a), lost_after);
    let from = probe.seen.len();
    if got_over > 0 {
        // Three tries of each exchange, each reply lost.
        for n in 1..=u64::from(3 * got_over) {
            proxy.noise_in(n, Noise::Lost);
        }
        expect_notice(
            &mut probe,
            &format!("recovered after {got_over} failed exchange"),
        );
        assert!(
            dropped(&probe, from).is_none(),
            "{:?}; notices: {:#?}",
            dropped(&probe, from),
            probe.notices()
        );
    }
    if then_silent {
        // Every reply lost (more than the exchanges and the halt can ask for).
        let cut = Instant::now();
        for n in 1..=200 {
            proxy.noise_in(n, Noise::Lost);
        }
        lost_after_exactly(&mut probe, lost_after, cut, RTU_EXCHANGE);
    }
}

#[test]
fn modbus_rtu_counts_as_lost_after_three_failed_exchanges_not_two() {
    rtu_lost_after(3, 2, true);
}

#[test]
fn modbus_rtu_four_failed_exchanges_are_not_lost_when_five_are_set() {
    rtu_lost_after(5, 4, false);
}

#[test]
fn modbus_rtu_counts_as_lost_after_five_failed_exchanges_when_so_set() {
    rtu_lost_after(5, 0, true);
}
