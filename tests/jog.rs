//! Jog with keep-alive, against the simulated drive through the real worker: it moves
//! while the keep-alives come, stops when they stop (a frozen window), stops at once on
//! release, and when the link fails mid-jog the worker tries a halt and says honestly
//! whether it reached the drive.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod probe;

use std::time::{Duration, Instant};

use drivedeck::link::{LinkSpec, Notice, NoticeKind};
use drivedeck::pdi::StatusBit;
use drivedeck::sim::Injection;
use drivedeck::worker::{CommandProgress, Event, JOG_KEEPALIVE, LinkLossAction, Request};
use probe::Probe;

/// Jog at `speed` and wait until the motor turns.
fn jogging(speed: i32) -> (Probe, u64) {
    let mut probe = Probe::connected(LinkSpec::Sim);
    let id = probe.send(Request::Jog { speed });
    probe.accepted(id);
    (probe, id)
}

/// Keep the jog alive for `time`, as a held button does.
fn hold(probe: &mut Probe, time: Duration) {
    let until = Instant::now() + time;
    while Instant::now() < until {
        probe.send(Request::JogKeepAlive);
        probe.settle(JOG_KEEPALIVE);
    }
}

#[test]
fn the_motor_jogs_while_the_keep_alives_come_and_halts_when_they_stop() {
    let (mut probe, _) = jogging(300);
    hold(&mut probe, Duration::from_millis(1200));
    let moving = probe.settle(Duration::from_millis(20));
    assert!(
        moving.velocity().is_some_and(|v| v > 250.0),
        "still jogging after 1.2 s of keep-alives: {:?}",
        moving.velocity()
    );
    assert!(
        !probe.notices().iter().any(|n| n.contains("jog halted")),
        "{:?}",
        probe.notices()
    );
    // The window freezes: no keep-alive any more.
    let frozen = Instant::now();
    probe.wait(
        "the worker's halt",
        Duration::from_secs(2),
        |e| matches!(e, Event::Notice(n) if n.kind == NoticeKind::MotorStopped && n.text.contains("jog halted: no keep-alive")),
    );
    let noticed = frozen.elapsed();
    assert!(noticed < Duration::from_millis(1500), "{noticed:?}");
    let stopped = probe.sample_where("the motor at rest", Duration::from_secs(5), |s| {
        s.velocity() == Some(0.0)
    });
    assert!(stopped.tx.status.is_set(StatusBit::QsHaltBit));
    assert!(
        stopped.tx.status.is_set(StatusBit::OperationEnabled),
        "halted, not switched off"
    );
}

#[test]
fn releasing_the_jog_halts_at_once() {
    let (mut probe, _) = jogging(-200);
    hold(&mut probe, Duration::from_millis(400));
    let moving = probe.settle(Duration::from_millis(20));
    assert!(moving.velocity().is_some_and(|v| v < -150.0), "{moving:?}");
    let stop = probe.send(Request::JogStop);
    let outcome = probe.outcome(stop, Duration::from_secs(3));
    assert!(
        matches!(outcome, CommandProgress::Done { .. }),
        "{outcome:?}"
    );
    let stopped = probe.sample_where("the motor at rest", Duration::from_secs(3), |s| {
        s.velocity() == Some(0.0)
    });
    assert!(stopped.tx.status.is_set(StatusBit::QsHaltBit));
    // Nothing more from the keep-alive watch: the jog is over.
    probe.settle(Duration::from_millis(800));
    assert!(
        !probe.notices().iter().any(|n| n.contains("jog halted")),
        "{:?}",
        probe.notices()
    );
}

#[test]
fn a_link_lost_mid_jog_gets_a_halt_attempt_and_an_honest_report() {
    // Slow enough not to reach the simulator's position limit while the cable is out.
    let (mut probe, _) = jogging(60);
    hold(&mut probe, Duration::from_millis(300));
    // The cable is pulled: the simulated drive carries on, nothing reaches it.
    probe.send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    let report = probe.wait(
        "the report of the halt attempt",
        Duration::from_secs(3),
        |e| matches!(e, Event::Notice(n) if n.kind == NoticeKind::MotorStopped && n.text.contains("the link failed during a move")),
    );
    let Event::Notice(Notice { text, .. }) = report else {
        unreachable!()
    };
    assert!(
        text.contains("did not reach the drive")
            || text.contains("got no answer")
            || text.contains("no answer confirmed it"),
        "the halt cannot have got through a pulled cable: {text}"
    );
    assert!(text.contains("may still be moving"), "{text}");
    // It really was still moving: after reconnecting, the jog's velocity is there.
    probe.reconnected(Duration::from_secs(10));
    let after = probe.settle(Duration::from_millis(200));
    assert!(after.velocity().is_some_and(|v| v > 50.0), "{after:?}");
}

#[test]
fn the_link_loss_setting_can_leave_the_drive_alone() {
    let (mut probe, _) = jogging(60);
    probe.send(Request::SetLinkLoss(LinkLossAction::Nothing));
    hold(&mut probe, Duration::from_millis(200));
    probe.send(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    let report = probe.wait(
        "the report",
        Duration::from_secs(3),
        |e| matches!(e, Event::Notice(n) if n.kind == NoticeKind::MotorStopped && n.text.contains("the link failed during a move")),
    );
    assert!(
        matches!(&report, Event::Notice(n) if n.text.contains("as set, the drive is left alone")),
        "{report:?}"
    );
}
