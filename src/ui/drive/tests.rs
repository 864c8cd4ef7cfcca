use std::time::{Duration, SystemTime};

use super::*;
use crate::link::{ErrorKind, LinkFailure, LinkInfo, LinkSpec};
use crate::od::Value;
use crate::pdi::{Action, RxImage, StatusBit};
use crate::ui::connection_form::ConnectionForm;
use crate::worker::{CommandProgress, Event, RequestId, Sample};

/// A drive of the window with the default settings, as the window starts one.
fn new_drive() -> Drive {
    Drive::new(
        "Drive 1".into(),
        0,
        DriveSettings::default(),
        crate::telemetry::DEFAULT_HISTORY_ROWS,
        &[],
    )
}

fn info() -> LinkInfo {
    LinkInfo {
        spec: LinkSpec::Sim,
        description: "simulated drive".into(),
        native_objects: true,
        can_inject: true,
        pdi: true,
        homing_methods: None,
        commands_refused: None,
    }
}

#[test]
fn wall_clock_and_age_read_as_people_say_them() {
    let at = SystemTime::UNIX_EPOCH + Duration::from_secs(1_780_000_000 + 50_531);
    assert_eq!(crate::telemetry::utc_text(at), "2026-05-29T10:28:51Z");
    assert_eq!(clock_text(at), "10:28:51 UTC");
    assert_eq!(age_text(3.24), "3.2 s ago");
    assert_eq!(age_text(250.0), "4 min 10 s ago");
    assert_eq!(age_text(7300.0), "2 h 1 min ago");
}

#[test]
fn a_drive_that_stops_answering_is_stale_before_the_link_gives_up() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    state.apply(Event::Samples(vec![Sample::default()]));
    let seen = state.link.last_sample_at.expect("taken now");
    let at = |s: f64| seen + Duration::from_secs_f64(s);
    assert!(state.is_live(at(0.5)));
    assert_eq!(state.stale_line(at(0.5)), None);
    assert_eq!(state.offline_reason(), None);
    // At 100 Hz a second without samples is a silent drive, though the link is up.
    let line = state.stale_line(at(2.5)).expect("stale");
    assert!(
        line.starts_with("NO DATA — the drive stopped answering; last seen at ")
            && line.ends_with("UTC (2.5 s ago)"),
        "{line}"
    );
    // At 1 Hz three missed cycles make it so.
    state.settings.poll_rate = 1.0;
    assert!(state.is_live(at(2.5)));
    assert!(!state.is_live(at(3.5)));
}

#[test]
fn the_reason_nothing_can_be_sent_follows_the_link() {
    let mut state = new_drive();
    assert_eq!(state.offline_reason().as_deref(), Some("not connected"));
    assert_eq!(
        state.stale_line(SystemTime::now()).as_deref(),
        Some("NO LINK — never connected")
    );
    state.apply(Event::Connecting(LinkSpec::Sim));
    assert_eq!(state.offline_reason().as_deref(), Some("connecting…"));
    state.apply(Event::Connected(info()));
    state.apply(Event::Samples(vec![Sample::default()]));
    state.apply(Event::Disconnected {
        reason: Some("timed out".into()),
    });
    assert_eq!(
        state.offline_reason().as_deref(),
        Some("not connected: the link was lost (timed out)")
    );
    state.apply(Event::ConnectFailed {
        spec: LinkSpec::Sim,
        error: LinkFailure {
            kind: ErrorKind::Timeout,
            text: "timed out".into(),
        },
        retry_in: Some(Duration::from_millis(500)),
    });
    assert_eq!(
        state.offline_reason().as_deref(),
        Some("not connected: the link was lost, retrying in 0.5 s (timed out)")
    );
    state.apply(Event::Connecting(LinkSpec::Sim));
    assert_eq!(
        state.offline_reason().as_deref(),
        Some("reconnecting…: the link was lost (timed out)")
    );
    state.apply(Event::ConnectFailed {
        spec: LinkSpec::Sim,
        error: LinkFailure {
            kind: ErrorKind::Io,
            text: "connection refused".into(),
        },
        retry_in: Some(Duration::from_secs(1)),
    });
    assert_eq!(
        state.offline_reason().as_deref(),
        Some(
            "not connected: the link was lost, retrying in 1.0 s (timed out; reconnecting failed: connection refused)"
        )
    );
    let line = state.stale_line(SystemTime::now()).expect("stale");
    assert!(line.starts_with("NO LINK — last seen at "), "{line}");
    // The user's own disconnect is no loss.
    state.apply(Event::Disconnected { reason: None });
    assert_eq!(state.offline_reason().as_deref(), Some("not connected"));
}

#[test]
fn a_superseded_command_is_logged_as_such_and_kept_off_the_timeline() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    let first = Request::Command(Action::MoveRelative {
        distance: 3600,
        speed: 200,
    });
    state.handed(Owner::User, &first, Ok(1));
    state.handed(Owner::User, &first, Ok(2));
    state.apply(Event::Progress {
        id: 1,
        progress: CommandProgress::Superseded,
    });
    assert_eq!(
        state
            .log
            .iter()
            .find(|e| e.id == Some(1))
            .map(|e| &e.outcome),
        Some(&Outcome::Superseded("superseded by a newer command".into()))
    );
    assert!(
        state.timeline.is_empty(),
        "{:?}",
        state.timeline.entries().collect::<Vec<_>>()
    );
    state.apply(Event::Progress {
        id: 2,
        progress: CommandProgress::LinkLost {
            reason: "3 exchanges failed in a row; a halt was sent and the drive confirmed it"
                .into(),
        },
    });
    assert_eq!(state.timeline.len(), 1, "a real failure still is");
}

#[test]
fn every_connection_string_survives_the_connection_bar() {
    for text in [
        "sim",
        "modbus-tcp://10.0.0.1:502?unit=3&words=low",
        "modbus-rtu:///dev/ttyUSB1?baud=115200&parity=none&stop=2&slave=7&words=low",
        "canopen+socketcan://can1?node=4&pdo=2&keep_pdo=1",
        "canopen+slcan://COM5?bitrate=500000&node=9",
        "canopen+sim://?node=6&keep_pdo=1",
        "canopen+sim://?node=7&self_start=1",
        "canopen+slcan://COM5?bitrate=500000&node=9&keep_pdo=1&self_start=1",
        "enip://192.168.2.100:44818?io=common&rpi=4&cmd_at=8&config=0&udp=0",
        "enip://[::1]:2000?io=explicit&rpi=10",
    ] {
        let spec: LinkSpec = text.parse().expect(text);
        let form = ConnectionForm::from_spec(&spec, ConnectionForm::default());
        assert_eq!(form.spec(), Ok(spec), "{text}");
    }
}

/// A sample at `t` with `status` as PDI-Status.
fn sample_at(t: f64, status: u16) -> Sample {
    Sample {
        t,
        tx: crate::pdi::TxImage {
            status: crate::pdi::Status(status),
            ..crate::pdi::TxImage::default()
        },
        ..Sample::default()
    }
}

/// Samples every 10 ms from `from` to `to` (inclusive, the worker's clock).
fn samples(from: f64, to: f64, status: u16) -> Event {
    let n = ((to - from) * 100.0).round() as u32;
    Event::Samples(
        (0..=n)
            .map(|i| sample_at(from + f64::from(i) * 0.01, status))
            .collect(),
    )
}

#[test]
fn a_reconnect_keeps_the_history_with_a_gap_and_the_timeline_goes_on() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    state.apply(samples(0.0, 1.0, 0));
    state.apply(Event::Sent {
        id: 1,
        t: 0.5,
        what: "Velocity: 300 rpm".into(),
        image: RxImage::default(),
    });
    state.apply(samples(1.01, 2.0, StatusBit::Warning.mask()));
    state.apply(Event::Disconnected {
        reason: Some("timed out".into()),
    });
    let gap = state.scope.open_gap().cloned().expect("a gap while lost");
    assert_eq!((gap.from, gap.lost), (2.0, true));
    state.apply(Event::Connecting(LinkSpec::Sim));
    state.apply(Event::Connected(info()));
    // The worker's clock went on through the outage.
    state.apply(samples(14.3, 15.0, 0));
    assert_eq!(state.scope.ring().len(), 101 + 100 + 71, "nothing erased");
    assert_eq!(state.scope.markers().count(), 1, "the command's marker");
    let gaps: Vec<_> = state.scope.gaps().cloned().collect();
    assert_eq!(gaps.len(), 1);
    assert_eq!(gaps[0].to, Some(14.3));
    assert_eq!(state.link.connected_at, Some(14.3));
    let entries: Vec<(Option<f64>, String)> = state
        .timeline
        .entries()
        .map(|e| (e.t, e.text.clone()))
        .collect();
    let texts: Vec<&str> = entries.iter().map(|(_, text)| text.as_str()).collect();
    assert!(texts[0].starts_with("Warning set"), "{texts:?}");
    assert_eq!(entries[1].0, Some(2.0));
    assert_eq!(texts[1], "link lost: timed out");
    assert_eq!(entries[2].0, Some(14.3));
    assert_eq!(texts[2], "link back after 12.3 s without samples");
    assert_eq!(texts.len(), 3, "{texts:?}");
    let times: Vec<f64> = entries.iter().filter_map(|(t, _)| *t).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{entries:?}");
}

/// The identity read the window asks for on connecting, handed to the worker as `id`
/// (whatever else waits gets ids of its own), answered with `serial`.
fn identify(state: &mut Drive, id: RequestId, serial: u32) {
    for (n, (owner, request)) in state.take_requests(false).into_iter().enumerate() {
        let sent = if owner == Owner::Identity {
            id
        } else {
            1000 + id * 100 + n as u64
        };
        state.handed(owner, &request, Ok(sent));
    }
    for (address, _) in crate::od::backup::IDENTITY {
        let value = match address.index {
            0x1018 if address.sub == 4 => Value::Uint(u64::from(serial)),
            0x1018 => Value::Uint(u64::from(address.sub)),
            _ => Value::Text("PD4-C".into()),
        };
        state.apply(Event::ObjectRead {
            id,
            address,
            result: Ok(value),
        });
    }
}

#[test]
fn another_drive_keeps_the_history_and_is_marked_from_its_first_sample() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    identify(&mut state, 10, 0x1234);
    state.apply(samples(0.0, 1.0, 0));
    // The same drive again: no marker.
    state.apply(Event::Disconnected {
        reason: Some("timed out".into()),
    });
    state.apply(Event::Connected(info()));
    state.apply(samples(2.0, 3.0, 0));
    identify(&mut state, 11, 0x1234);
    assert_eq!(state.scope.markers().count(), 0);

    // The user connects to another drive (another link and serial number).
    state.apply(Event::Disconnected { reason: None });
    let other: LinkSpec = "modbus-tcp://10.0.0.1:502?unit=0".parse().expect("spec");
    state.apply(Event::Connected(LinkInfo {
        spec: other,
        ..info()
    }));
    state.apply(samples(10.0, 10.5, 0));
    identify(&mut state, 12, 0x5678);
    assert_eq!(state.scope.ring().len(), 101 + 101 + 51, "nothing erased");
    let marker = state.scope.markers().next().cloned().expect("a marker");
    assert_eq!(marker.t, 10.0, "at the first sample of the other drive");
    assert!(
        marker
            .text
            .starts_with("another drive: PD4-C serial 00005678h on modbus-tcp://10.0.0.1:502"),
        "{}",
        marker.text
    );
    let gap = state.scope.gaps().last().cloned().expect("the disconnect");
    assert_eq!((gap.from, gap.to, gap.lost), (3.0, Some(10.0), false));
    let entry = state.timeline.entries().last().cloned().expect("an entry");
    assert!(
        entry.text.contains("before: PD4-C serial 00001234h on sim"),
        "{}",
        entry.text
    );
    assert_eq!(entry.t, Some(10.0));
    // An export reaching back before the other drive says so.
    let rec = state
        .scope
        .export(0.0, 11.0, state.scope.meta.clone(), false);
    assert!(
        rec.meta
            .note
            .is_some_and(|n| n.contains("are of another drive")),
    );
}

#[test]
fn why_the_drive_stood_goes_with_the_link_it_stood_on() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    state.motion.why = Some("Quickstop sent from this window at 10:00:00 UTC".into());
    state.apply(Event::Disconnected {
        reason: Some("connection reset".into()),
    });
    assert!(state.motion.why.is_some(), "kept while the link is down");
    state.apply(Event::Connected(info()));
    assert_eq!(
        state.motion.why, None,
        "a reconnect starts without the old why"
    );
}

/// An outage the link gets over (failed exchanges, then the link back) and a reply sent
/// again are markers on the plots, so in the exported CSV and JSON at their time; other
/// notices are not.
#[test]
fn an_outage_the_link_got_over_is_marked_in_the_exports() {
    let mut state = new_drive();
    state.apply(Event::Connected(info()));
    state.apply(samples(0.0, 1.0, 0));
    state.apply(Event::Notice(crate::link::Notice::info(
        "an exchange with the drive failed: no answer within 500 ms; trying again (the link counts as lost after 3 failures in a row)",
    )));
    state.apply(samples(4.0, 5.0, 0));
    state.apply(Event::Notice(crate::link::Notice::info(
        "the link recovered after 2 failed exchange(s) in a row",
    )));
    state.apply(Event::Notice(crate::link::Notice::info(
        "link: no answer within 166 ms, answered on try 2",
    )));
    state.apply(Event::Notice(crate::link::Notice::info(
        "PDO mapping changed",
    )));
    let recording = state
        .scope
        .export(0.0, 5.0, crate::telemetry::Metadata::default(), true);
    let marks: Vec<(f64, &str)> = recording
        .markers
        .iter()
        .map(|m| (m.t, m.text.split(':').next().unwrap_or_default()))
        .collect();
    assert_eq!(
        marks,
        [(1.0, "outage"), (5.0, "recovered"), (5.0, "retry")],
        "{:?}",
        recording.markers
    );
    for text in [recording.to_csv(), recording.to_json()] {
        assert!(
            text.contains("outage: an exchange with the drive failed"),
            "{text}"
        );
    }
}
