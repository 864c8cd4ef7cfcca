//! Several drives in one window, headless (egui_kittest), each a simulated drive of its
//! own behind its own worker: the list shows every drive's state, selecting points the
//! panels at a drive, names stay as given; Esc stops every drive ahead of what is queued
//! on each; one drive's lost link leaves the others polled; closing asks once for all;
//! the plots draw every drive's signals on one time axis, and a trigger on another drive
//! stops them on its capture.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use std::time::{Duration, SystemTime};

use drivedeck::cia::PowerState;
use drivedeck::injection::Injection;
use drivedeck::od::Address;
use drivedeck::pdi::Action;
use drivedeck::ui::App;
use drivedeck::ui::Drive;
use drivedeck::ui::drive::Connection;
use drivedeck::worker::{ObjectPath, Request};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, step_until, step_until_shown};

/// The window on the built-in simulated drive ("X axis") and a second one ("Y axis"),
/// both with their first sample in.
fn two_drives() -> Harness<'static, App> {
    let mut harness = app_harness();
    connected(&mut harness);
    harness
        .get_by_label("Drive name")
        .set_text_value_accesskit("X axis");
    harness.step();
    let added = harness
        .state_mut()
        .add_drive("Y axis".into(), "sim://")
        .expect("a second drive");
    assert_eq!(added, 1);
    step_until(
        &mut harness,
        "both drives sampled",
        Duration::from_secs(5),
        |h| (0..2).all(|i| h.state().drive(i).is_some_and(|s| s.latest().is_some())),
    );
    harness
}

fn drive<'a>(harness: &'a Harness<'_, App>, index: usize) -> &'a Drive {
    harness.state().drive(index).expect("the drive")
}

fn power(state: &Drive) -> Option<PowerState> {
    state
        .latest()
        .and_then(|s| s.statusword())
        .and_then(PowerState::from_statusword)
}

fn speed(state: &Drive) -> f64 {
    state
        .latest()
        .and_then(|s| s.velocity())
        .unwrap_or(f64::NAN)
}

/// Drive `index` told to turn at 30 rpm (slow: the simulated drive's limit switch at
/// 3600.0° is 20 s away); wait until it does.
fn turn(harness: &mut Harness<'_, App>, index: usize) {
    harness
        .state_mut()
        .drive_mut(index)
        .expect("the drive")
        .request(Request::Command(Action::Velocity { speed: 30 }));
    step_until(harness, "the motor to turn", Duration::from_secs(5), |h| {
        speed(drive(h, index)) > 25.0
    });
}

#[test]
fn the_list_shows_each_drive_selecting_points_the_panels_at_it_and_names_stay() {
    let mut harness = two_drives();
    // X axis turns, Y axis stays as it was: the rows say so.
    turn(&mut harness, 0);
    step_until(
        &mut harness,
        "the rows to differ",
        Duration::from_secs(3),
        |h| {
            let rows = h.state().drive_rows(SystemTime::now());
            rows[0].motion.starts_with("moving +30 rpm") && rows[1].motion == "still"
        },
    );
    let rows = harness.state().drive_rows(SystemTime::now());
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0].name, "X axis");
    assert_eq!(rows[0].state, "Operation enabled");
    assert_eq!(rows[1].name, "Y axis");
    assert_ne!(rows[1].state, "Operation enabled", "{rows:?}");
    assert!(
        rows.iter().all(|r| r.link == "sim" && r.fault.is_none()),
        "{rows:?}"
    );
    assert!(rows.iter().all(|r| r.position.is_some()), "{rows:?}");
    // On screen: each row's state, named by its drive, and its details.
    for row in &rows {
        harness.get_by_label(&format!("{}: {}", row.name, row.state));
    }
    harness.get_by_label_contains("moving +30 rpm");
    harness.get_by_label("QUICKSTOP ALL (Esc)");

    // Selecting Y axis points the status panel (and every other) at it.
    harness.get_by_label("Y axis").click();
    harness.run_steps(2);
    assert_eq!(harness.state().selected(), 1);
    let shown = harness.state().shown();
    assert!(
        speed(shown) < 1.0,
        "the panels show Y axis: {}",
        speed(shown)
    );
    harness.get_by_label("DISABLED");
    assert!(speed(drive(&harness, 0)) > 25.0, "X axis turns on");
    // The window's own choices stay as they were; the selected row's name is the one
    // to edit now.
    assert_eq!(
        harness.get_by_label("Drive name").value().as_deref(),
        Some("Y axis")
    );

    // Renaming is kept across selecting another drive and back.
    harness
        .get_by_label("Drive name")
        .set_text_value_accesskit("Y table");
    harness.step();
    harness.get_by_label("X axis").click();
    harness.run_steps(2);
    assert_eq!(harness.state().selected(), 0);
    let names: Vec<String> = harness
        .state()
        .drives()
        .map(|(n, _)| n.to_owned())
        .collect();
    assert_eq!(names, ["X axis", "Y table"]);
    harness.get_by_label("Y table");
    assert!(
        speed(harness.state().shown()) > 25.0,
        "the panels show X axis again"
    );
    // A name given twice is refused, and the list says why.
    assert!(harness.state_mut().rename(1, "X axis".into()).is_err());
    // As a project file would: upper and lower case aside, and names it could not hold.
    let refused = harness.state_mut().rename(1, "x AXIS".into()).unwrap_err();
    assert!(refused.to_string().contains("('X axis')"), "{refused}");
    let refused = harness.state_mut().rename(1, "Y=axis".into()).unwrap_err();
    assert!(refused.to_string().contains("has an '='"), "{refused}");
    assert!(harness.state_mut().rename(1, "Y table".into()).is_ok());
    // Each drive keeps the colour it was given when it was added, whichever is shown.
    let colors = |h: &Harness<'_, App>| -> Vec<usize> {
        h.state()
            .drive_rows(SystemTime::now())
            .iter()
            .map(|r| r.color)
            .collect()
    };
    assert_eq!(colors(&harness), [0, 1]);
    harness.get_by_label("Y table").click();
    harness.run_steps(2);
    assert_eq!(harness.state().selected(), 1);
    assert_eq!(colors(&harness), [0, 1], "selecting moves no colour");
    assert_eq!(drive(&harness, 0).color, 0);
}

#[test]
fn esc_stops_every_drive_ahead_of_what_is_queued_on_each() {
    let mut harness = two_drives();
    turn(&mut harness, 0);
    turn(&mut harness, 1);
    // Something ordinary waits on each drive when Esc comes in the same frame.
    let read = Request::ReadObject {
        address: Address::new(0x1008, 0),
        dtype: None,
        path: ObjectPath::Auto,
    };
    for i in 0..2 {
        let state = harness.state_mut().drive_mut(i).expect("drive");
        state.request(read.clone());
    }
    harness.key_press(egui::Key::Escape);
    harness.step();
    for i in 0..2 {
        let log = &drive(&harness, i).log;
        let stop = log.iter().position(|e| e.what.contains("Quickstop"));
        let ordinary = log.iter().position(|e| e.what.contains("1008"));
        assert!(
            matches!((stop, ordinary), (Some(s), Some(o)) if s < o),
            "drive {i}: the quick stop goes first: {log:#?}"
        );
    }
    step_until(
        &mut harness,
        "both drives to stop",
        Duration::from_secs(5),
        |h| {
            (0..2).all(|i| {
                let state = drive(h, i);
                // The default quick stop option (605Ah = 2) ends in Switch on disabled.
                power(state).is_some_and(|p| p != PowerState::OperationEnabled)
                    && speed(state).abs() < 1.0
            })
        },
    );
    for i in 0..2 {
        let why = drive(&harness, i).motion.why.clone().unwrap_or_default();
        assert!(why.starts_with("Quickstop sent from this window"), "{why}");
    }
}

#[test]
fn the_stop_all_button_stops_every_drive_with_switch_off() {
    let mut harness = two_drives();
    turn(&mut harness, 0);
    turn(&mut harness, 1);
    harness.get_by_label("Switch off all (Shift+Esc)").click();
    harness.step();
    step_until(
        &mut harness,
        "both power stages off",
        Duration::from_secs(5),
        |h| (0..2).all(|i| power(drive(h, i)).is_some_and(|p| !p.is_energised())),
    );
}

#[test]
fn a_drive_lost_mid_run_leaves_the_others_polled_and_is_reported() {
    let mut harness = two_drives();
    turn(&mut harness, 0);
    harness
        .state_mut()
        .drive_mut(1)
        .expect("drive")
        .request(Request::Inject {
            injection: Injection::LinkLoss,
            active: true,
        });
    step_until(&mut harness, "Y axis lost", Duration::from_secs(8), |h| {
        drive(h, 1).link.lost.is_some()
    });
    let lost_at = drive(&harness, 0).latest().map(|s| s.t).expect("a sample");
    // While Y axis is without its link, X axis is polled on: newer samples keep coming.
    step_until(
        &mut harness,
        "X axis polled on",
        Duration::from_secs(3),
        |h| {
            drive(h, 0).latest().is_some_and(|s| s.t > lost_at + 0.3)
                && drive(h, 1).link.lost.is_some()
        },
    );
    let rows = harness.state().drive_rows(SystemTime::now());
    assert_eq!(rows[0].state, "Operation enabled", "{rows:?}");
    assert!(rows[0].motion.starts_with("moving +30 rpm"), "{rows:?}");
    assert!(drive(&harness, 0).is_connected());
    assert!(
        rows[1].state == "no link" || rows[1].link.contains("link lost"),
        "the row reports the loss: {rows:?}"
    );
    let timeline: Vec<String> = drive(&harness, 1)
        .timeline
        .entries()
        .map(|e| e.text.clone())
        .collect();
    assert!(
        timeline.iter().any(|t| t.starts_with("link lost")),
        "{timeline:?}"
    );
    assert!(
        !drive(&harness, 0)
            .timeline
            .entries()
            .any(|e| e.text.starts_with("link lost")),
        "X axis lost nothing"
    );
}

#[test]
fn closing_asks_once_for_every_energised_drive_and_halts_each() {
    let mut harness = two_drives();
    turn(&mut harness, 0);
    turn(&mut harness, 1);
    harness
        .input_mut()
        .viewports
        .entry(egui::ViewportId::ROOT)
        .or_default()
        .events
        .push(egui::ViewportEvent::Close);
    step_until_shown(&mut harness, "Halt each, then disconnect");
    // One question, naming both drives and what their motors do.
    // ("was on … was moving" when the machine is so busy that the last sample is old.)
    for name in ["X axis", "Y axis"] {
        let sentence = window::text_containing(&harness, &format!("{name}: The power stage "));
        assert!(sentence.contains(" moving at 30 rpm"), "{sentence}");
    }
    assert!((0..2).all(|i| drive(&harness, i).leaving.is_some()));
    harness.get_by_label("Halt each, then disconnect").click();
    harness.step();
    step_until(
        &mut harness,
        "both drives left",
        Duration::from_secs(8),
        |h| (0..2).all(|i| matches!(drive(h, i).link.connection, Connection::Disconnected)),
    );
    for i in 0..2 {
        let log = &drive(&harness, i).log;
        assert!(
            log.iter().any(|e| e.what == "Halt before disconnecting"),
            "drive {i}: {log:#?}"
        );
    }
}

#[test]
fn the_plots_draw_every_drive_on_one_time_axis() {
    let mut harness = app_harness();
    connected(&mut harness);
    window::step_for(&mut harness, Duration::from_millis(300));
    let before = harness
        .state()
        .shown()
        .latest()
        .map(|s| s.t)
        .expect("X sampled");
    harness
        .state_mut()
        .add_drive("Y axis".into(), "sim://")
        .expect("a second drive");
    step_until(
        &mut harness,
        "Y axis sampled",
        Duration::from_secs(5),
        |h| drive(h, 1).link.connected_at.is_some(),
    );
    // Both workers count from the window's start: the drive added later starts later on
    // the same axis (on a clock of its own it would start at 0).
    let first = drive(&harness, 1)
        .link
        .connected_at
        .expect("Y's first sample");
    assert!(
        first > before,
        "one time base: Y starts at {first} s, X was at {before} s"
    );
    harness.step();
    // Only the drive shown, until another is ticked in the list.
    assert!(
        harness
            .query_by_label_contains("Y axis: Position")
            .is_none()
    );
    harness.get_by_label("Plot Y axis beside").click();
    harness.run_steps(2);
    // Each plot's legend names the drive of each line.
    harness.get_by_label_contains("Drive 1: Position");
    harness.get_by_label_contains("Y axis: Position");
}

/// The plots' rectangle at 1366×768 once samples are drawn.
fn plot_room(harness: &mut Harness<'_, App>) -> egui::Rect {
    step_until(harness, "the plots drawn", Duration::from_secs(5), |h| {
        h.state().plots_rect().is_some()
    });
    harness.run_steps(3);
    harness.state().plots_rect().expect("drawn")
}

#[test]
fn the_list_takes_no_room_from_the_plots_at_1366x768() {
    let size = egui::vec2(1366.0, 768.0);
    let mut one = window::harness_with(drivedeck::ui::Settings::default(), true, size);
    connected(&mut one);
    let alone = plot_room(&mut one);
    drop(one);
    let mut two = window::harness_with(drivedeck::ui::Settings::default(), true, size);
    connected(&mut two);
    two.state_mut()
        .add_drive("Y axis".into(), "sim://")
        .expect("a second drive");
    step_until(&mut two, "Y axis sampled", Duration::from_secs(5), |h| {
        drive(h, 1).latest().is_some()
    });
    let both = plot_room(&mut two);
    println!(
        "plots at 1366x768: one drive {:.0}x{:.0} px, two drives {:.0}x{:.0} px",
        alone.width(),
        alone.height(),
        both.width(),
        both.height()
    );
    assert!(
        (alone.width() - both.width()).abs() <= 1.0
            && (alone.height() - both.height()).abs() <= 1.0,
        "the list costs the plots room: {alone:?} alone, {both:?} with two drives"
    );
}

#[test]
fn a_trigger_on_another_drive_stops_the_plots_on_its_capture() {
    let mut harness = two_drives();
    // Armed on Y axis: position rising through 1000 (0.1°).
    harness.get_by_label("Y axis").click();
    harness.run_steps(2);
    {
        let form = &mut harness.state_mut().window_mut().settings.plot.trigger;
        form.threshold = true;
        form.signal = "position".into();
        form.level = "1000".into();
        form.edge = drivedeck::telemetry::Edge::Rising;
        form.pre_s = "0.3".into();
        form.post_s = "0.3".into();
    }
    harness.step();
    harness.get_by_label("Arm").click();
    harness.step();
    assert_eq!(
        drive(&harness, 1).scope.capture_state(),
        drivedeck::telemetry::CaptureState::Armed
    );
    // X axis on screen; Y axis moves through the level.
    harness.get_by_label("X axis").click();
    harness.run_steps(2);
    assert_eq!(harness.state().selected(), 0);
    assert!(harness.state().plot().paused_at().is_none());
    harness
        .state_mut()
        .drive_mut(1)
        .expect("Y axis")
        .request(Request::Command(Action::MoveAbsolute {
            target: 2000,
            speed: 200,
        }));
    step_until(
        &mut harness,
        "Y axis's capture",
        Duration::from_secs(10),
        |h| drive(h, 1).scope.recording().is_some() && h.state().plot().paused_at().is_some(),
    );
    let at = drive(&harness, 1)
        .scope
        .recording()
        .and_then(|r| r.meta.trigger_time_s)
        .expect("the trigger time");
    let plot = harness.state().plot();
    assert_eq!(
        plot.highlight(),
        Some(at),
        "the trigger marked on X axis's plots"
    );
    let message = format!("{:?}", plot.message());
    assert!(message.contains("Y axis's trigger fired at"), "{message}");
}

#[test]
fn exports_write_every_drive_beside_the_selected_one_and_ask_before_replacing_any() {
    use drivedeck::telemetry::load_recording;
    use drivedeck::ui::plots::files::ScriptedPicker;
    let mut harness = two_drives();
    turn(&mut harness, 1);
    window::step_for(&mut harness, Duration::from_millis(300));
    let dir = tempfile::tempdir().expect("a folder");
    let chosen = dir.path().join("visible.csv");
    let picker = ScriptedPicker::new();
    picker.answer(Some(chosen.clone()));
    picker.answer(Some(chosen.clone()));
    harness
        .state_mut()
        .window_mut()
        .plot
        .set_files(picker.clone());
    // Y axis drawn beside X axis: its file goes beside X axis's.
    harness.get_by_label("Plot Y axis beside").click();
    harness.run_steps(2);
    harness.get_by_label("Export visible…").click();
    harness.run_steps(2);
    // The selected drive's signals in the file chosen, Y axis's beside it, over one span.
    let x = load_recording(&chosen, u64::MAX).expect("X axis's file");
    let beside = dir.path().join("visible_Y_axis.csv");
    let y = load_recording(&beside, u64::MAX).expect("Y axis's file beside it");
    assert!(
        x.len() > 10 && y.len() > 10,
        "{} and {} rows",
        x.len(),
        y.len()
    );
    let span = |r: &drivedeck::telemetry::Recording| {
        (
            r.times.first().copied().unwrap_or(f64::NAN),
            r.times.last().copied().unwrap_or(f64::NAN),
        )
    };
    let ((x0, x1), (y0, y1)) = (span(&x), span(&y));
    assert!(
        y0 >= x0 - 0.02 && y1 <= x1 + 0.02,
        "X {x0}..{x1}, Y {y0}..{y1}"
    );
    // Y axis turns at 30 rpm, X axis stands: each file holds its own drive.
    let velocity = |r: &drivedeck::telemetry::Recording| {
        let column = r
            .channels
            .iter()
            .position(|c| c.id == "velocity")
            .expect("a velocity column");
        r.columns[column]
            .iter()
            .copied()
            .rev()
            .find(|v| v.is_finite())
            .unwrap_or(f64::NAN)
    };
    assert!(velocity(&y) > 25.0 && velocity(&x).abs() < 1.0);
    let said = match &harness.state().plot().message() {
        Some(Ok(text)) => text.clone(),
        other => panic!("{other:?}"),
    };
    assert!(said.contains("Y axis's signals to"), "{said}");

    // Again to the same name: both files exist, the question lists them; Cancel keeps them.
    let before = std::fs::read(&beside).expect("Y's file");
    harness.get_by_label("Export visible…").click();
    harness.run_steps(2);
    harness.get_by_label_contains("These exist already");
    harness.get_by_label("Cancel").click();
    harness.run_steps(2);
    assert_eq!(std::fs::read(&beside).expect("Y's file"), before);
}

#[test]
fn a_drive_is_added_by_its_connection_string_typed_into_the_menu() {
    let mut harness = app_harness();
    connected(&mut harness);
    assert_eq!(harness.state().drive_count(), 1);
    harness.get_by_label("+ Add drive").click();
    step_until_shown(&mut harness, "New drive's connection string");
    // A click into the box (press and release inside the menu) leaves the menu open.
    harness
        .get_by_label("New drive's connection string")
        .click();
    harness.run_steps(3);
    let field = harness.get_by_label("New drive's connection string");
    assert!(
        field.is_focused(),
        "the box has the keyboard after the click"
    );
    field.type_text("canopen+sim://?node=3");
    harness.run_steps(2);
    assert_eq!(
        harness
            .get_by_label("New drive's connection string")
            .value()
            .as_deref(),
        Some("canopen+sim://?node=3")
    );
    harness.get_by_label("Add").click();
    harness.run_steps(2);
    assert_eq!(harness.state().drive_count(), 2);
    let links: Vec<String> = harness
        .state()
        .drives()
        .filter_map(|(_, link)| link.map(|l| l.to_string()))
        .collect();
    assert!(
        links.iter().any(|l| l.contains("node=3")),
        "the new drive is on the link typed: {links:?}"
    );
    assert!(
        harness
            .query_by_label("New drive's connection string")
            .is_none(),
        "Add closes the menu"
    );
}

#[test]
fn a_sixteen_drive_machine_fits_a_laptop_screen_in_one_line_each() {
    let size = egui::vec2(1366.0, 768.0);
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, size);
    let mut harness = window::harness_with(drivedeck::ui::Settings::default(), true, size);
    connected(&mut harness);
    for n in 2..=16 {
        harness
            .state_mut()
            .add_drive(format!("D{n}"), "sim://")
            .expect("another drive");
    }
    harness.run_steps(3);
    // The list: one line per drive; the rows that show are a line high.
    let d2 = harness.get_by_label_contains("D2: ").rect();
    let d3 = harness.get_by_label_contains("D3: ").rect();
    assert!(
        d3.top() - d2.top() < 30.0,
        "one line a drive: {d2:?} {d3:?}"
    );
    // The Machine tab: every drive, whole, on screen at once.
    harness.get_by_label("Machine").click();
    harness.run_steps(3);
    for n in 2..=16 {
        let name = harness.get_by_label(&format!("Show D{n}")).rect();
        assert!(screen.contains_rect(name), "D{n} at {name:?}");
    }
    // Sorted by name, descending: D9 leads (names sort as text).
    harness.get_by_label("Sort by Drive").click();
    harness.run_steps(2);
    harness.get_by_label("Sort by Drive").click();
    harness.run_steps(2);
    let top = |h: &Harness<'_, App>, name: &str| h.get_by_label(name).rect().top();
    assert!(top(&harness, "Show D9") < top(&harness, "Show D16"));
    // A click on a name shows that drive.
    harness.get_by_label("Show D7").click();
    harness.run_steps(2);
    assert_eq!(harness.state().selected(), 6);
    // The plots draw the drive shown only, until others are ticked.
    harness.get_by_label("Plots").click();
    harness.run_steps(3);
    assert!(harness.query_by_label_contains("D2: Position").is_none());
}
