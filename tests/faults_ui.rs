//! The fault timeline in the window, headless: a following error injected into the
//! simulated drive appears with its code and meaning, from PDI-Status, 603Fh, 1001h and
//! the 1003h history; "Show" puts the plots at that moment; the export writes CSV.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::diagnostics::{Origin, Severity};
use drivedeck::sim::Injection;
use drivedeck::ui::App;
use drivedeck::ui::settings::PLOTS;
use drivedeck::worker::Request;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, step_until};

fn has(harness: &Harness<'_, App>, origin: Origin, text: &str) -> bool {
    harness
        .state()
        .shown()
        .timeline
        .entries()
        .any(|e| e.origin == origin && e.text.contains(text))
}

#[test]
fn a_following_error_lands_on_the_timeline_with_its_code_and_meaning() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.step();
    assert!(
        harness.state().shown().timeline.is_empty(),
        "a healthy drive: nothing on the timeline"
    );
    harness.state_mut().shown_mut().request(Request::Inject {
        injection: Injection::FollowingError,
        active: true,
    });
    step_until(
        &mut harness,
        "the fault edges",
        Duration::from_secs(3),
        |h| has(h, Origin::PdiStatus, "Fault set") && has(h, Origin::ErrorCode, "8611h"),
    );
    step_until(
        &mut harness,
        "1001h and 1003h read",
        Duration::from_secs(3),
        |h| has(h, Origin::ErrorHistory, "8611h") && has(h, Origin::ErrorRegister, ""),
    );
    let state = harness.state().shown();
    let code = state
        .timeline
        .entries()
        .find(|e| e.origin == Origin::ErrorCode)
        .expect("603Fh entry");
    assert_eq!(code.severity, Severity::Fault);
    assert!(
        code.text.to_lowercase().contains("following error"),
        "{}",
        code.text
    );
    let at = code.t.expect("a time on the samples' clock");
    let history = state
        .timeline
        .entries()
        .find(|e| e.origin == Origin::ErrorHistory)
        .expect("1003h entry");
    assert!(
        history.text.starts_with("1003h:01h error #"),
        "{}",
        history.text
    );

    // The Faults tab lists them; "Show" puts the plots at that moment.
    let tab = format!("Faults ({})", harness.state().shown().timeline.len());
    harness.get_by_label(&tab).click();
    harness.step();
    harness.get_by_label("Show entry 1").click();
    harness.step();
    let app = harness.state();
    assert_eq!(app.settings().central, PLOTS);
    let highlight = app.plot().highlight().expect("marked on the plots");
    assert!((highlight - at).abs() < 0.5, "{highlight} vs {at}");
    assert!(app.plot().paused_at().is_some(), "held still to look at it");

    // Exported as CSV.
    let dir = common::temp_dir("faults");
    let path = dir.path().join("timeline.csv");
    harness.state_mut().window_mut().settings.timeline_path = path.to_string_lossy().into_owned();
    harness.get_by_label("Export timeline").click();
    harness.step();
    let csv = std::fs::read_to_string(&path).expect("exported");
    assert!(
        csv.starts_with("time_s,wall_clock,severity,origin,text\n"),
        "{csv}"
    );
    assert!(csv.contains(",fault,603Fh,8611h"), "{csv}");
}

#[test]
fn the_changes_tab_lists_what_was_written_and_restores_it() {
    use drivedeck::od::{Address, Value};
    let mut harness = app_harness();
    connected(&mut harness);
    let velocity = Address::new(0x6081, 0);
    window::change(&mut harness, velocity, 1234);
    let before = harness
        .state()
        .shown()
        .changes()
        .expect("the Changes tab's model")
        .entries[0]
        .before
        .clone()
        .expect("read before the write");
    assert_ne!(before, Value::Uint(1234));
    harness.get_by_label("Changes (1)").click();
    harness.step();
    harness.get_by_label("Restore what I changed (1)").click();
    harness.step();
    step_until(&mut harness, "the restore", Duration::from_secs(3), |h| {
        h.state().shown().changes().is_some_and(|c| c.is_empty())
    });
    assert!(
        harness
            .state()
            .shown()
            .log
            .iter()
            .any(|e| e.what == format!("write {before} to {velocity}")),
        "{:#?}",
        harness.state().shown().log
    );
}

#[test]
fn a_superseded_move_is_not_a_fault_but_a_refused_command_is() {
    use drivedeck::ui::drive::Outcome;
    let mut harness = app_harness();
    connected(&mut harness);
    // A long relative move (ten turns at 200 rpm), replaced by the next one while it runs.
    harness
        .get_by_label("Move relative: Distance")
        .set_text_value_accesskit("36000");
    harness.step();
    harness.get_by_label("Move relative").click();
    harness.step();
    step_until(
        &mut harness,
        "the move to run",
        Duration::from_secs(3),
        |h| window::velocity(h) > 50.0,
    );
    harness.get_by_label("Move relative").click();
    harness.step();
    let moves = |h: &Harness<'_, App>| -> Vec<Outcome> {
        h.state()
            .shown()
            .log
            .iter()
            .filter(|e| e.what.starts_with("Profile Position relative"))
            .map(|e| e.outcome.clone())
            .collect()
    };
    step_until(
        &mut harness,
        "the first move to be replaced",
        Duration::from_secs(3),
        |h| moves(h).first().is_some_and(|o| !o.is_open()),
    );
    let first = moves(&harness)[0].clone();
    assert!(
        !matches!(first, Outcome::Failed(_) | Outcome::Succeeded(_)),
        "superseded is neither a failure nor done: {first:?}"
    );
    harness.step();
    assert!(
        !has(&harness, Origin::Command, "superseded"),
        "{:#?}",
        harness
            .state()
            .shown()
            .timeline
            .entries()
            .collect::<Vec<_>>()
    );

    // A command the drive refuses (travel while a fault is active) still is a fault.
    harness.state_mut().shown_mut().request(Request::Inject {
        injection: Injection::OverCurrent,
        active: true,
    });
    step_until(&mut harness, "the fault", Duration::from_secs(3), |h| {
        window::lamp(h, "Fault")
    });
    harness.get_by_label("Velocity").click();
    harness.step();
    step_until(
        &mut harness,
        "the refusal on the timeline",
        Duration::from_secs(3),
        |h| has(h, Origin::Command, "refused"),
    );
    assert!(!has(&harness, Origin::Command, "superseded"));
}

/// The time of the first timeline entry from `origin` whose text contains `text`.
fn time_of(harness: &Harness<'_, App>, origin: Origin, text: &str) -> Option<f64> {
    harness
        .state()
        .shown()
        .timeline
        .entries()
        .find(|e| e.origin == origin && e.text.contains(text))
        .and_then(|e| e.t)
}

#[test]
fn the_timeline_keeps_its_entries_and_its_clock_across_a_lost_link() {
    let mut harness = app_harness();
    connected(&mut harness);
    harness.state_mut().shown_mut().request(Request::Inject {
        injection: Injection::FollowingError,
        active: true,
    });
    step_until(&mut harness, "the fault", Duration::from_secs(3), |h| {
        has(h, Origin::PdiStatus, "Fault set")
    });
    let fault = time_of(&harness, Origin::PdiStatus, "Fault set").expect("a time");

    // The simulated cable pulled for 3 s; the worker reconnects by itself.
    harness.state_mut().shown_mut().request(Request::Inject {
        injection: Injection::LinkLoss,
        active: true,
    });
    step_until(
        &mut harness,
        "the fault seen again",
        Duration::from_secs(10),
        |h| has(h, Origin::PdiStatus, "active on connecting"),
    );
    let lost = time_of(&harness, Origin::Link, "link lost").expect("a time");
    let still = time_of(&harness, Origin::PdiStatus, "active on connecting").expect("a time");
    // The entries from before stay, and the times go on from them.
    assert_eq!(
        time_of(&harness, Origin::PdiStatus, "Fault set"),
        Some(fault)
    );
    assert!(fault <= lost, "{fault} then {lost}");
    assert!(
        still - lost >= 2.5,
        "3 s without the link: {lost} then {still}"
    );
    let back = time_of(&harness, Origin::Link, "link back after").expect("the return");
    assert!(
        back - lost >= 2.5 && still >= back,
        "{lost}, {back}, {still}"
    );
}
