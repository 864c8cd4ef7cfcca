//! One bad datagram is not a lost link either. A UDP proxy between the worker's scanner and
//! the simulated adapter (tests/proxy/udp.rs) drops, doubles and reorders class 1 I/O
//! datagrams during a move: the move reaches its target, the stale ones are dropped and
//! reported; T→O silence beyond the connection timeout is a lost link, named, and
//! reconnecting opens the connection again. And the lost-after count holds on the links
//! besides Modbus TCP: EtherNet/IP explicit messages (through the TCP proxy) and Modbus RTU
//! (through the serial proxy) count as lost after exactly the configured number of failed
//! exchanges in a row, never before.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod probe;
mod proxy;

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use drivedeck::link::LinkSpec;
use drivedeck::pdi::Action;
use drivedeck::worker::{CommandProgress, Request};
use probe::Probe;
use proxy::udp::{Mishap, UdpProxy, Way};
use proxy::{Framing, Noise, Proxy, SerialProxy};

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

// ---------------------------------------------------------------- class 1 I/O datagrams

#[test]
fn a_class_1_move_gets_over_a_lost_a_doubled_and_a_reordered_datagram() {
    let server = common::enip_adapter();
    let proxy = UdpProxy::start(server.addr);
    let mut probe = Probe::connected(class1(proxy.addr));
    let description = probe.link_info().description;
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
    probe.accepted(id);
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
    common::wait_until("every mishap done", Duration::from_secs(5), || {
        proxy.applied(Way::TtoO).len() == 3 && proxy.applied(Way::OtoT).len() == 3
    });
    assert_eq!(
        proxy.applied(Way::TtoO),
        [Mishap::Reorder, Mishap::Duplicate, Mishap::Drop]
    );
    // The stale image and the copy are dropped, and said.
    probe.expect_notice(&["class 1 I/O: 1 T→O datagram came out of order and was dropped"]);
    probe.expect_notice(&["class 1 I/O: 1 T→O datagram came twice and the copy was dropped"]);
    probe.never_dropped_since(from);
    assert_eq!(proxy.opens(), opens, "never reconnected");
}

#[test]
fn t_to_o_silence_beyond_the_connection_timeout_is_a_lost_link_that_reconnecting_reopens() {
    let server = common::enip_adapter();
    let proxy = UdpProxy::start(server.addr);
    let mut probe = Probe::connected(class1(proxy.addr));
    let opens = proxy.opens();
    proxy.silence_until_reopened();
    let reason = probe.lost(Duration::from_secs(5));
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
    let info = probe.reconnected(Duration::from_secs(5));
    assert!(
        info.description.contains("class 1 I/O at 10 ms"),
        "{}; notices: {:#?}",
        info.description,
        probe.notices()
    );
    assert_eq!(proxy.opens(), opens + 1);
    let before = proxy.passed(Way::TtoO);
    common::wait_until("T→O datagrams again", Duration::from_secs(5), || {
        proxy.passed(Way::TtoO) > before + 5
    });
}

#[test]
fn an_adapter_still_silent_when_the_connection_is_opened_again_is_a_failed_try_not_polling_for_good()
 {
    let server = common::enip_adapter();
    let proxy = UdpProxy::start(server.addr);
    let mut probe = Probe::connected(class1(proxy.addr));
    let opens = proxy.opens();
    // Nothing from the adapter for 4 s: the connection times out after 640 ms, and the
    // first reopen gets no data either. Before, that reopen fell back to explicit
    // messages for the rest of the session: the outage ended at once and unseen, and
    // class 1 never came back.
    proxy.hold_for(Way::TtoO, Duration::from_secs(4));
    let reason = probe.lost(Duration::from_secs(5));
    assert!(reason.contains("no T→O datagram"), "{reason}");
    let failed = probe.wait("a reopen that failed", Duration::from_secs(10), |e| {
        matches!(e, drivedeck::worker::Event::ConnectFailed { error, .. } if error.text.contains("again yet"))
    });
    let drivedeck::worker::Event::ConnectFailed {
        error, retry_in, ..
    } = failed
    else {
        unreachable!()
    };
    assert!(
        error
            .text
            .contains("the I/O connection could not be opened again yet")
            && error.text.contains("no data reached UDP"),
        "{error:?}"
    );
    assert!(retry_in.is_some(), "tried again");
    let info = probe.reconnected(Duration::from_secs(15));
    assert!(
        info.description.contains("class 1 I/O at 10 ms"),
        "{}; notices: {:#?}",
        info.description,
        probe.notices()
    );
    assert!(
        proxy.opens() >= opens + 2,
        "a reopen during the silence and one after it"
    );
    assert!(
        probe.notice_with(&["over explicit messages"]).is_none(),
        "{:#?}",
        probe.notices()
    );
    let before = proxy.passed(Way::TtoO);
    common::wait_until("T→O datagrams again", Duration::from_secs(5), || {
        proxy.passed(Way::TtoO) > before + 5
    });
}

// ---------------------------------------------------------------- the lost-after count

/// EtherNet/IP explicit messages: one failed exchange is three tries in 1 s.
const ENIP_EXCHANGE: Duration = Duration::from_secs(1);

fn enip_explicit_lost_after(lost_after: u32) {
    let server = common::enip_adapter();
    let proxy = Proxy::start(server.addr, Framing::Enip);
    let (mut probe, _) = Probe::turning(enip_explicit(proxy.addr), lost_after);
    let cut = Instant::now();
    proxy.drop_all();
    probe.lost_after_exactly(lost_after, cut, ENIP_EXCHANGE);
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
    let server = common::enip_adapter();
    let proxy = Proxy::start(server.addr, Framing::Enip);
    let (mut probe, _) = Probe::turning(enip_explicit(proxy.addr), 3);
    let from = probe.seen.len();
    // Each failed exchange is three tries: six replies lost are two exchanges.
    proxy.drop_next(6);
    probe.expect_notice(&["recovered after 2 failed exchange"]);
    assert_eq!(proxy.dropped(), 6);
    probe.never_dropped_since(from);
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
    let (mut probe, _) = Probe::turning(rtu(&host.a), lost_after);
    let from = probe.seen.len();
    if got_over > 0 {
        // Three tries of each exchange, each reply lost.
        for n in 1..=u64::from(3 * got_over) {
            proxy.noise_in(n, Noise::Lost);
        }
        probe.expect_notice(&[&format!("recovered after {got_over} failed exchange")]);
        probe.never_dropped_since(from);
    }
    if then_silent {
        // Every reply lost (more than the exchanges and the halt can ask for).
        let cut = Instant::now();
        for n in 1..=200 {
            proxy.noise_in(n, Noise::Lost);
        }
        probe.lost_after_exactly(lost_after, cut, RTU_EXCHANGE);
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
