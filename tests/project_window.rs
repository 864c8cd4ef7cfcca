//! A project in the window, headless (egui_kittest) with real workers: opening one lists
//! every drive with its name, options and watched objects and connects each; each drive's
//! identity (1018h) is compared with the project's — a changed device, a drive that does
//! not answer and one the project has no identity for are each said in that drive's log
//! and row; the window's drives save as a project that opens again the same, and the
//! saved identities are then the same device; a project is not opened over connected
//! drives; the "Project" menu saves through the file dialog, asking before it replaces
//! another file.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use std::sync::Arc;
use std::time::Duration;

use drivedeck::od::Address;
use drivedeck::od::backup::DeviceIdentity;
use drivedeck::project::{self, Drive, Format, Pin, Project};
use drivedeck::ui::Drive as DriveModel;
use drivedeck::ui::drive::Outcome;
use drivedeck::ui::plots::files::ScriptedPicker;
use drivedeck::ui::{App, Settings};
use drivedeck::worker::LinkLossAction;
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::step_until;

/// A port nothing listens on: a drive that does not answer.
fn closed_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let port = listener.local_addr().expect("its address").port();
    drop(listener);
    port
}

/// X axis: the simulated drive, with a serial number it does not have; Y axis: a
/// simulated CANopen node the project has no identity for; Z axis: nothing at the address.
fn machine() -> Project {
    let mut x = Drive::new("X axis", "sim://".parse().expect("spec"));
    x.options.poll_rate = 50.0;
    x.options.on_link_loss = LinkLossAction::SwitchOff;
    x.options.lost_after = 4;
    x.watch = vec![Pin {
        address: Address::new(0x6041, 0),
        format: Format::Bits,
    }];
    x.identity = Some(DeviceIdentity {
        vendor: Some(0x26C),
        serial: Some(0xDEAD_BEEF),
        ..DeviceIdentity::default()
    });
    let y = Drive::new("Y axis", "canopen+sim://?node=2".parse().expect("spec"));
    let z = Drive::new(
        "Z axis",
        format!("modbus-tcp://127.0.0.1:{}", closed_port())
            .parse()
            .expect("spec"),
    );
    let mut project = Project::new(vec![x, y, z]).expect("a project");
    project.plot = Some(serde_json::json!({"window_s": 4.0}));
    project
}

fn harness(app: App) -> Harness<'static, App> {
    Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .build_ui_state(|ui, app: &mut App| app.frame(ui), app)
}

fn drive<'a>(harness: &'a Harness<'_, App>, index: usize) -> &'a DriveModel {
    harness.state().drive(index).expect("the drive")
}

/// The outcome of drive `index`'s project check in its log.
fn check_entry(state: &DriveModel) -> Option<Outcome> {
    state
        .log
        .iter()
        .rev()
        .find(|e| e.what.starts_with("project check"))
        .map(|e| e.outcome.clone())
}

#[test]
fn a_project_opens_every_drive_and_says_per_drive_what_differs() {
    let dir = tempfile::tempdir().expect("a folder");
    let project = machine();
    let mut app = App::with_project(
        Settings::default(),
        Arc::new(|| {}),
        &project,
        Some(dir.path().join("machine.json")),
        Some("Y axis"),
    );
    app.remember_projects_in(dir.path().to_path_buf());
    let mut harness = harness(app);
    // Every drive listed by its name, the one asked for shown.
    let names: Vec<String> = harness
        .state()
        .drives()
        .map(|(name, _)| name.to_owned())
        .collect();
    assert_eq!(names, ["X axis", "Y axis", "Z axis"]);
    assert_eq!(harness.state().selected(), 1);
    // Each drive's own options and watched objects; the plot layout shared.
    let x = drive(&harness, 0);
    assert_eq!(x.settings.poll_rate, 50.0);
    assert_eq!(x.settings.on_link_loss, LinkLossAction::SwitchOff);
    assert_eq!(x.settings.lost_after, 4);
    assert_eq!(x.settings.watch.pins.len(), 1);
    assert!(drive(&harness, 1).settings.watch.pins.is_empty());
    assert_eq!(harness.state().settings().plot.window_s, 4.0);

    step_until(
        &mut harness,
        "every drive's project check",
        Duration::from_secs(10),
        |h| (0..3).all(|i| check_entry(drive(h, i)).is_some()),
    );
    // X axis: the serial number differs, named with both values; its row says so.
    match check_entry(drive(&harness, 0)) {
        Some(Outcome::Failed(text)) => {
            assert!(text.contains("not the device the project saw"), "{text}");
            assert!(text.contains("serial number changed 0xDEADBEEF"), "{text}");
        }
        other => panic!("X axis: {other:?}"),
    }
    // Y axis: nothing to compare with, what it reports said in amber.
    match check_entry(drive(&harness, 1)) {
        Some(Outcome::Caution(text)) => assert!(text.contains("no identity stored"), "{text}"),
        other => panic!("Y axis: {other:?}"),
    }
    // Z axis: no answer, and why.
    match check_entry(drive(&harness, 2)) {
        Some(Outcome::Failed(text)) => assert!(text.contains("no answer"), "{text}"),
        other => panic!("Z axis: {other:?}"),
    }
    harness.run_steps(2);
    // The rows (and the selected drive's log) say it.
    for text in [
        "not the project's device: serial number changed",
        "identity not in the project yet",
    ] {
        assert!(
            harness.query_all_by_label_contains(text).count() >= 1,
            "{text}"
        );
    }

    // Saved: the same drives, options and pins; the identities as read now.
    let saved_at = dir.path().join("saved.json");
    let said = harness
        .state_mut()
        .save_project(&saved_at)
        .expect("the project saves");
    assert!(said.contains("saved 3 drive(s)"), "{said}");
    assert_eq!(
        project::recent::last_project_in(dir.path()).as_deref(),
        Some(std::path::absolute(&saved_at).expect("absolute").as_path())
    );
    let again = project::open(&saved_at).expect("it opens");
    assert_eq!(
        again.drives.iter().map(|d| &d.name).collect::<Vec<_>>(),
        project.drives.iter().map(|d| &d.name).collect::<Vec<_>>()
    );
    for (was, now) in project.drives.iter().zip(&again.drives) {
        assert_eq!(was.link, now.link);
        assert_eq!(was.options, now.options);
        assert_eq!(was.watch, now.watch);
    }
    let x_now = again.drives[0].identity.clone().expect("X axis's identity");
    assert_eq!(x_now.vendor, Some(0x26C));
    assert_ne!(x_now.serial, Some(0xDEAD_BEEF));
    assert!(again.drives[1].identity.is_some(), "Y axis's identity");
    assert_eq!(again.drives[2].identity, None, "Z axis never answered");
    assert_eq!(
        again.plot.as_ref().map(|p| p["window_s"].clone()),
        Some(4.0.into())
    );

    // Opening a project over connected drives is refused, and nothing changes.
    let refused = harness.state_mut().open_project(&again, None);
    assert!(
        refused
            .as_ref()
            .is_err_and(|e| e.contains("disconnect every drive first")),
        "{refused:?}"
    );
    assert_eq!(harness.state().drives().count(), 3);
}

#[test]
fn a_saved_project_reopens_as_the_same_devices() {
    let dir = tempfile::tempdir().expect("a folder");
    let mut x = Drive::new("X axis", "sim://".parse().expect("spec"));
    x.options.poll_rate = 50.0;
    let y = Drive::new("Y axis", "sim://".parse().expect("spec"));
    let project = Project::new(vec![x, y]).expect("a project");
    let first = |project: &Project| {
        let mut app = App::with_project(Settings::default(), Arc::new(|| {}), project, None, None);
        app.remember_projects_in(dir.path().to_path_buf());
        harness(app)
    };
    let mut harness_a = first(&project);
    step_until(
        &mut harness_a,
        "both identities read",
        Duration::from_secs(10),
        |h| (0..2).all(|i| check_entry(drive(h, i)).is_some()),
    );
    let path = dir.path().join("machine.json");
    harness_a
        .state_mut()
        .save_project(&path)
        .expect("the project saves");
    drop(harness_a);

    let saved = project::open(&path).expect("it opens");
    let mut harness_b = first(&saved);
    step_until(
        &mut harness_b,
        "both checks",
        Duration::from_secs(10),
        |h| (0..2).all(|i| check_entry(drive(h, i)).is_some()),
    );
    for i in 0..2 {
        match check_entry(drive(&harness_b, i)) {
            Some(Outcome::Succeeded(text)) => {
                assert!(text.contains("the device the project saw"), "{text}")
            }
            other => panic!("drive {i}: {other:?}"),
        }
        assert_eq!(drive(&harness_b, i).project_warning(), None);
    }
}

#[test]
fn the_project_menu_saves_through_the_dialog_and_asks_before_replacing_a_file() {
    let dir = tempfile::tempdir().expect("a folder");
    let other = dir.path().join("notes.json");
    std::fs::write(&other, "my notes").expect("a file of the user's");
    let mut app = App::new(Settings::default(), Arc::new(|| {}), true);
    app.remember_projects_in(dir.path().to_path_buf());
    let picker = ScriptedPicker::new();
    picker.answer(Some(other.clone()));
    picker.answer(Some(other.clone()));
    app.window_mut().plot.set_files(picker.clone());
    let mut harness = harness(app);
    harness.run_steps(2);

    let save_as = |harness: &mut Harness<'_, App>| {
        harness.get_by_label("Project").click();
        harness.run_steps(2);
        harness.get_by_label("Save project as…").click();
        harness.run_steps(3);
    };
    // The dialog picks a file that is there: the window asks; Cancel keeps it.
    save_as(&mut harness);
    assert_eq!(picker.asked().len(), 1);
    assert!(picker.asked()[0].save);
    harness.get_by_label_contains("exists already");
    harness.get_by_label("Cancel").click();
    harness.run_steps(2);
    assert_eq!(
        std::fs::read_to_string(&other).expect("the file"),
        "my notes"
    );
    let (_, said) = harness.state().project_file();
    assert!(
        matches!(said, Some(Ok(text)) if text.contains("kept as it was")),
        "{said:?}"
    );

    // Again, and Replace: the project is written there and is the window's project now.
    save_as(&mut harness);
    harness.get_by_label("Replace").click();
    harness.run_steps(2);
    let written = project::open(&other).expect("a project now");
    assert_eq!(written.drives.len(), 1);
    assert_eq!(harness.state().project_file().0, Some(other.as_path()));
}
