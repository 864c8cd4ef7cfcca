//! The object dictionary browser in the window, headless: filter, read, edit with a bad
//! value and a good one, read everything with progress, and a backup, change, compare and
//! restore round trip on the simulated drive.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use common::temp_dir;
use drivedeck::od::{Address, Value};
use drivedeck::ui::browser::{Message, REFRESH_AFTER, Tone};
use drivedeck::ui::{App, Settings};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use window::{connected, harness_with, step_until};

/// The window on the simulated drive with the object dictionary open.
fn browser() -> Harness<'static, App> {
    browser_with(Settings::default())
}

/// The window with `settings` on the simulated drive, the object dictionary open.
fn browser_with(settings: Settings) -> Harness<'static, App> {
    let mut harness = harness_with(settings, true, egui::vec2(1600.0, 1000.0));
    harness.run();
    connected(&mut harness);
    harness.get_by_label("Object dictionary").click();
    harness.run();
    harness
}

fn filter(harness: &mut Harness<'_, App>, text: &str) {
    harness
        .get_by_label("Object filter")
        .set_text_value_accesskit(text);
    harness.run();
}

/// Point the backup file box at `path`.
fn backup_file(harness: &mut Harness<'_, App>, path: &std::path::Path) {
    harness
        .get_by_label("Backup file")
        .set_text_value_accesskit(path.to_str().expect("utf-8"));
    harness.run();
}

/// "Compare with file", and wait for the comparison.
fn compare(harness: &mut Harness<'_, App>) {
    harness.run();
    harness.get_by_label("Compare with file").click();
    harness.step();
    step_until(harness, "the comparison", Duration::from_secs(20), |h| {
        h.state().shown().browser.comparison.is_some()
    });
}

/// "Restore from file", and wait for the preview.
fn preview_restore(harness: &mut Harness<'_, App>) {
    harness.run();
    harness.get_by_label("Restore from file").click();
    harness.step();
    step_until(harness, "the preview", Duration::from_secs(20), |h| {
        h.state().shown().browser.restore.is_some()
    });
}

/// Confirm the previewed restore of one write, and wait until it is written.
fn restore_the_one_write(harness: &mut Harness<'_, App>) {
    harness.run();
    harness.get_by_label("Restore 1 writes").click();
    harness.run();
    harness.get_by_label("Write them").click();
    harness.step();
    step_until(harness, "the restore", Duration::from_secs(10), |h| {
        h.state()
            .shown()
            .browser
            .restore
            .as_ref()
            .is_some_and(|r| r.results == vec![Some(Ok(()))])
    });
}

fn value_of(harness: &Harness<'_, App>, address: Address) -> Option<Result<Value, String>> {
    harness
        .state()
        .shown()
        .browser
        .values
        .get(&address)
        .map(|c| c.result.clone())
}

/// Labels `left` and `right` on one line, `left` first (a row of a comparison or a
/// preview).
fn side_by_side(harness: &Harness<'_, App>, left: &str, right: &str) -> bool {
    harness.query_all_by_label(left).any(|l| {
        let l = l.rect();
        harness.query_all_by_label(right).any(|r| {
            let r = r.rect();
            (l.center().y - r.center().y).abs() < 2.0 && l.right() < r.left()
        })
    })
}

/// What the browser says now.
fn said(harness: &Harness<'_, App>) -> Option<Message> {
    harness.state().shown().browser.message.clone()
}

const PROFILE_VELOCITY: Address = Address::new(0x6081, 0);

#[test]
fn the_filter_finds_objects_by_index_and_by_name() {
    let mut harness = browser();
    filter(&mut harness, "6081");
    assert!(harness.query_by_label("6081h:00h").is_some());
    assert!(harness.query_by_label("6064h:00h").is_none());
    filter(&mut harness, "position actual");
    assert!(harness.query_by_label("6064h:00h").is_some());
    assert!(harness.query_by_label("6081h:00h").is_none());
    filter(&mut harness, "1018:01");
    assert!(harness.query_by_label("1018h:01h").is_some());
    assert!(harness.query_by_label("1018h:02h").is_none());
    // Read-only rows cannot be edited.
    assert!(
        harness
            .get_by_label("Edit 1018h:01h")
            .accesskit_node()
            .is_disabled()
    );
}

#[test]
fn a_bad_value_is_refused_with_its_reason_and_a_good_one_is_written_and_read_back() {
    let mut harness = browser();
    filter(&mut harness, "6081");
    harness.get_by_label("Read 6081h:00h").click();
    harness.step();
    step_until(&mut harness, "the read", Duration::from_secs(5), |h| {
        value_of(h, PROFILE_VELOCITY).is_some()
    });
    let before = value_of(&harness, PROFILE_VELOCITY)
        .expect("read")
        .expect("value");
    harness.run();
    harness.get_by_label("Edit 6081h:00h").click();
    harness.run();
    // A negative speed does not fit UNSIGNED32: refused inline, nothing sent.
    harness
        .get_by_label("New value 6081h:00h")
        .set_text_value_accesskit("-5");
    harness.run();
    harness.get_by_label("Write 6081h:00h").click();
    harness.run();
    let error = harness
        .state()
        .shown()
        .browser
        .edit
        .as_ref()
        .and_then(|e| e.error.clone())
        .expect("an error");
    assert!(error.contains("-5"), "{error}");
    assert!(harness.state().shown().browser.confirm.is_none());
    assert!(harness.query_by_label("Write to the drive?").is_none());
    // A good one asks first, then writes, then reads back.
    harness
        .get_by_label("New value 6081h:00h")
        .set_text_value_accesskit("0x1F4");
    harness.run();
    harness.get_by_label("Write 6081h:00h").click();
    harness.run();
    assert!(harness.query_by_label("Write to the drive?").is_some());
    assert!(
        harness
            .query_by_label(&format!("{before} rpm -> 500 rpm"))
            .is_some(),
        "the confirmation shows the old and the new value, with the unit"
    );
    harness.get_by_label("Confirm write").click();
    harness.step();
    // Read back well before the table would read the row again by itself.
    step_until(
        &mut harness,
        "the write and the read back",
        Duration::from_secs_f64(REFRESH_AFTER / 2.0),
        |h| value_of(h, PROFILE_VELOCITY) == Some(Ok(Value::Uint(500))),
    );
    assert_eq!(
        harness
            .state()
            .shown()
            .browser
            .write_results
            .get(&PROFILE_VELOCITY),
        Some(&Ok(()))
    );
}

#[test]
fn read_all_fills_the_table_with_progress_and_can_be_cancelled() {
    let mut harness = browser();
    harness.get_by_label("Read all").click();
    harness.step();
    assert!(
        harness.state().shown().browser.bulk.is_some(),
        "a bulk read runs"
    );
    step_until(
        &mut harness,
        "the whole read",
        Duration::from_secs(20),
        |h| h.state().shown().browser.bulk.is_none(),
    );
    let message = said(&harness);
    assert!(
        matches!(&message, Some(m) if m.tone == Tone::Done && m.text.starts_with("read ")),
        "{message:?}"
    );
    assert!(matches!(
        value_of(&harness, Address::new(0x1018, 1)),
        Some(Ok(Value::Uint(0x26C)))
    ));
    assert!(matches!(
        value_of(&harness, Address::new(0x1008, 0)),
        Some(Ok(Value::Text(_)))
    ));
    // Again, and cancelled at once: what was not read yet is dropped. The simulator
    // answers so fast that the worker may read everything within one cycle (it spends
    // up to half of each cycle on object reads); then there is nothing left to cancel and
    // Cancel is disabled again (the row stays, so nothing moves under the pointer). The
    // worker's cancel is tested deterministically in worker_sim.rs.
    harness.run();
    assert!(
        harness
            .get_by_label("Cancel")
            .accesskit_node()
            .is_disabled()
    );
    harness.get_by_label("Read all").click();
    harness.step();
    harness.get_by_label("Cancel").click();
    harness.step();
    step_until(
        &mut harness,
        "the cancellation",
        Duration::from_secs(20),
        |h| h.state().shown().browser.bulk.is_none(),
    );
    let message = said(&harness);
    assert!(
        matches!(&message, Some(m) if m.tone == Tone::Warning && m.text.starts_with("cancelled after")) ||
            // On a fast machine everything may have been read before the cancel arrived.
            matches!(&message, Some(m) if m.tone == Tone::Done && m.text.starts_with("read ")),
        "{message:?}"
    );
}

#[test]
fn backup_change_compare_and_restore_undo_exactly_the_change() {
    let dir = temp_dir("backup");
    let path = dir.path().join("drive.json");
    let mut harness = browser();
    backup_file(&mut harness, &path);
    harness.get_by_label("Save backup").click();
    harness.step();
    step_until(
        &mut harness,
        "the backup",
        Duration::from_secs(20),
        |h| matches!(said(h), Some(m) if m.tone == Tone::Done && m.text.starts_with("saved")),
    );
    let text = std::fs::read_to_string(&path).expect("the file");
    let file = drivedeck::od::backup::Backup::from_json(&text).expect("a backup");
    assert_eq!(file.identity.vendor, Some(0x26C));
    let saved = file
        .entries()
        .find(|(a, _)| *a == PROFILE_VELOCITY)
        .map(|(_, o)| o.value.clone())
        .expect("6081h saved");

    // The technician changes one object.
    filter(&mut harness, "6081");
    harness.get_by_label("Edit 6081h:00h").click();
    harness.run();
    harness
        .get_by_label("New value 6081h:00h")
        .set_text_value_accesskit("777");
    harness.run();
    harness.get_by_label("Write 6081h:00h").click();
    harness.run();
    harness.get_by_label("Confirm write").click();
    harness.step();
    step_until(&mut harness, "the change", Duration::from_secs(5), |h| {
        value_of(h, PROFILE_VELOCITY) == Some(Ok(Value::Uint(777)))
    });

    // The comparison lists exactly that object, the file's value with its unit.
    compare(&mut harness);
    harness.run();
    let file_value = format!("{saved} rpm");
    assert!(
        side_by_side(&harness, &file_value, "777 rpm"),
        "the comparison shows {file_value} (file) and 777 rpm (drive)"
    );
    let differing: Vec<Address> = harness
        .state()
        .shown()
        .browser
        .comparison
        .as_ref()
        .map(|(_, d)| {
            d.iter()
                .filter(|d| d.device != drivedeck::od::backup::Comparison::Same)
                .map(|d| d.address)
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(differing, vec![PROFILE_VELOCITY]);

    // The restore previews exactly one write, and undoes it.
    preview_restore(&mut harness);
    let steps = harness
        .state()
        .shown()
        .browser
        .restore
        .as_ref()
        .map(|r| r.steps.clone())
        .unwrap_or_default();
    assert_eq!(steps.len(), 1, "{steps:?}");
    assert_eq!(steps[0].address, PROFILE_VELOCITY);
    assert_eq!(steps[0].before, Some(Value::Uint(777)));
    assert_eq!(steps[0].value, saved);
    harness.run();
    assert!(
        side_by_side(&harness, "777 rpm", &file_value),
        "the preview shows 777 rpm (now) and {file_value} (to write)"
    );
    restore_the_one_write(&mut harness);
    // The restore reads back what it wrote: the row shows the value from the file, without
    // a Read (well before the table would read the row again by itself).
    step_until(
        &mut harness,
        "the read back",
        Duration::from_secs_f64(REFRESH_AFTER / 2.0),
        |h| value_of(h, PROFILE_VELOCITY) == Some(Ok(saved.clone())),
    );
    let cell = harness
        .state()
        .shown()
        .browser
        .values
        .get(&PROFILE_VELOCITY)
        .cloned();
    assert_eq!(
        cell.and_then(|c| c.changed).map(|(_, before)| before),
        Some(Value::Uint(777)),
        "the row is marked as changed, from 777"
    );
}

#[test]
fn an_eds_replaces_the_catalog_in_amber_with_its_warnings_and_a_broken_path_says_why() {
    let mut harness = browser();
    let eds = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/eds/sample.eds");
    harness
        .get_by_label("EDS path")
        .set_text_value_accesskit(eds);
    harness.run();
    harness.get_by_label("Load EDS").click();
    harness.run();
    let message = said(&harness).expect("a message");
    assert!(
        message.text.contains("loaded") && message.text.contains("sample.eds"),
        "{message:?}"
    );
    // What the import skipped or guessed is counted, in amber: never success green.
    assert_eq!(message.tone, Tone::Warning, "{message:?}");
    assert_eq!(
        drivedeck::ui::browser::tone_color(message.tone),
        Some(drivedeck::ui::widgets::AMBER),
        "amber, not green"
    );
    assert!(message.text.contains("7 warning(s)"), "{message:?}");
    assert!(harness.query_by_label_contains("7 warning(s)").is_some());
    // sample.eds describes another maker's device: none of Nanotec's manufacturer
    // objects (203Bh motor data), but the CiA 301 ones it lists.
    filter(&mut harness, "203b");
    assert!(harness.query_by_label("203Bh:01h").is_none());
    filter(&mut harness, "1017");
    assert!(harness.query_by_label("1017h:00h").is_some());
    // Back to the built-in catalog.
    harness.get_by_label("Built-in").click();
    harness.run();
    filter(&mut harness, "203b:01");
    assert!(harness.query_by_label("203Bh:01h").is_some());

    harness
        .get_by_label("EDS path")
        .set_text_value_accesskit("/nonexistent/drive.eds");
    harness.run();
    harness.get_by_label("Load EDS").click();
    harness.run();
    let message = said(&harness);
    assert!(
        matches!(&message, Some(m) if m.tone == Tone::Failed && m.text.contains("/nonexistent/drive.eds")),
        "{message:?}"
    );
}

/// A hand-edited backup: one setting that differs from the drive, and entries a restore
/// must never write (commands, PDI set values and command, restore defaults, a read-only
/// object, an object the dictionary does not know).
fn crafted_backup(objects: &[(&str, &str, &str, &str, u64)]) -> String {
    let objects: Vec<serde_json::Value> = objects
        .iter()
        .map(|(address, name, dtype, kind, value)| {
            serde_json::json!({
                "address": address, "name": name, "type": dtype,
                "value": {"kind": kind, "value": value}, "shown": value.to_string(),
            })
        })
        .collect();
    serde_json::json!({
        "format": "drivedeck backup", "version": 1, "saved_at": 0, "link": "sim",
        // The simulated drive's own vendor, product and serial.
        "identity": {"vendor": 0x26C, "product": 0x42, "serial": 0x1234}, "objects": objects,
    })
    .to_string()
}

#[test]
fn the_restore_preview_skips_commands_process_data_and_read_only_objects_with_the_reason() {
    let dir = temp_dir("backup-crafted");
    let path = dir.path().join("crafted.json");
    std::fs::write(
        &path,
        crafted_backup(&[
            ("6081:00", "Profile Velocity", "UNSIGNED32", "uint", 777),
            ("6040:00", "Controlword", "UNSIGNED16", "uint", 0x000F),
            ("2291:01", "PDI-SetValue1", "INTEGER32", "int", 5000),
            ("2291:04", "PDI-Cmd", "INTEGER8", "int", 21),
            ("1011:01", "Restore all", "UNSIGNED32", "uint", 0x6461_6F6C),
            ("2300:00", "NanoJ Control", "UNSIGNED32", "uint", 1),
            ("6041:00", "Statusword", "UNSIGNED16", "uint", 0x0237),
            ("2FF0:00", "Something else", "UNSIGNED32", "uint", 7),
        ]),
    )
    .expect("write");
    let never = [
        (Address::new(0x6040, 0), "command"),
        (Address::new(0x2291, 1), "command"),
        (Address::new(0x2291, 4), "command"),
        (Address::new(0x1011, 1), "command"),
        (Address::new(0x2300, 0), "command"),
        (Address::new(0x6041, 0), "read-only"),
        (Address::new(0x2FF0, 0), "not in the dictionary"),
    ];
    let mut harness = browser();
    backup_file(&mut harness, &path);

    // The preview plans the one setting; the rest is listed as skipped, with the reason.
    preview_restore(&mut harness);
    let restore = harness
        .state()
        .shown()
        .browser
        .restore
        .clone()
        .expect("a preview");
    let planned: Vec<Address> = restore.steps.iter().map(|s| s.address).collect();
    assert_eq!(planned, vec![PROFILE_VELOCITY]);
    for (address, word) in never {
        let reason = restore
            .skipped
            .iter()
            .find(|(a, _)| *a == address)
            .map(|(_, r)| r.clone())
            .unwrap_or_else(|| panic!("{address} not skipped: {:?}", restore.skipped));
        assert!(reason.contains(word), "{address}: {reason}");
    }
    harness.run();
    assert!(
        harness
            .query_by_label_contains("6040h:00h Controlword skipped: a command (the controlword")
            .is_some(),
        "the preview shows the skipped controlword with its reason"
    );
    assert!(
        harness
            .query_by_label_contains("6041h:00h Statusword skipped: read-only")
            .is_some()
    );

    // Restoring writes that one setting.
    restore_the_one_write(&mut harness);

    // The comparison lists the same entries as skipped, not as differences.
    compare(&mut harness);
    let message = said(&harness);
    assert!(
        matches!(&message, Some(m) if m.tone == Tone::Done && m.text.contains("0 differ") && m.text.contains("7 entries skipped")),
        "{message:?}"
    );
    harness.run();
    assert!(
        harness
            .query_by_label_contains("skipped: a command (restore default parameters")
            .is_some()
    );
}

/// A backup of one changed setting (6081h = 777) whose identity `edit` changes, written
/// into `dir` as `name`: its path.
fn one_setting_backup(
    dir: &std::path::Path,
    name: &str,
    edit: impl Fn(&mut serde_json::Value),
) -> std::path::PathBuf {
    let path = dir.join(name);
    let mut file: serde_json::Value = serde_json::from_str(&crafted_backup(&[(
        "6081:00",
        "Profile Velocity",
        "UNSIGNED32",
        "uint",
        777,
    )]))
    .expect("json");
    edit(&mut file["identity"]);
    std::fs::write(&path, file.to_string()).expect("write");
    path
}

#[test]
fn a_backup_of_another_kind_of_device_is_restored_only_when_forced() {
    let dir = temp_dir("backup-other-product");
    let path = one_setting_backup(dir.path(), "other.json", |identity| {
        identity["product"] = 0x99.into();
        identity["name"] = "PD6-C8918M9504-E-08".into();
    });
    let mut harness = browser();
    backup_file(&mut harness, &path);
    preview_restore(&mut harness);
    harness.run();
    // Named in red, and the restore held back until the user says so.
    assert!(
        harness
            .query_by_label_contains(
                "the file was saved from another kind of device (PD6-C8918M9504-E-08"
            )
            .is_some(),
        "the mismatch is said"
    );
    assert!(
        harness
            .get_by_label("Restore 1 writes")
            .accesskit_node()
            .is_disabled(),
        "not without forcing"
    );
    harness
        .get_by_label("Restore onto this other kind of device anyway")
        .click();
    harness.run();
    restore_the_one_write(&mut harness);
    assert_eq!(
        harness
            .state()
            .shown()
            .browser
            .restore
            .as_ref()
            .map(|r| r.force),
        Some(true)
    );
}

#[test]
fn another_unit_of_the_same_kind_is_said_but_not_held_back() {
    let dir = temp_dir("backup-other-unit");
    let path = one_setting_backup(dir.path(), "unit.json", |identity| {
        identity["serial"] = 0x777.into();
    });
    let mut harness = browser();
    backup_file(&mut harness, &path);
    preview_restore(&mut harness);
    harness.run();
    assert!(
        harness
            .query_by_label_contains("the file was saved from another unit (serial 00000777h)")
            .is_some()
    );
    restore_the_one_write(&mut harness);
}

#[test]
fn a_file_naming_an_object_twice_is_refused_with_the_object_named() {
    let dir = temp_dir("backup-twice");
    let path = dir.path().join("twice.json");
    std::fs::write(
        &path,
        crafted_backup(&[
            ("6081:00", "Profile Velocity", "UNSIGNED32", "uint", 100),
            ("6081h:0", "Profile Velocity", "UNSIGNED32", "uint", 900),
        ]),
    )
    .expect("write");
    let mut harness = browser();
    backup_file(&mut harness, &path);
    harness.get_by_label("Restore from file").click();
    harness.run();
    let message = said(&harness);
    assert!(
        matches!(&message, Some(m) if m.tone == Tone::Failed && m.text.contains("6081h:00h") && m.text.contains("twice")),
        "{message:?}"
    );
    assert!(
        harness.state().shown().browser.bulk.is_none(),
        "nothing read"
    );
    assert!(harness.state().shown().browser.restore.is_none());
}

/// Double-click at `pos` (a row's value cell, say).
fn double_click_at(harness: &mut Harness<'_, App>, pos: egui::Pos2) {
    // The harness runs a frame per event, a quarter of a second each: the four events of a
    // double-click take longer than egui's 0.3 s between its clicks.
    harness
        .ctx
        .options_mut(|o| o.input_options.max_double_click_delay = 1.0);
    harness.hover_at(pos);
    harness.step();
    for _ in 0..2 {
        for pressed in [true, false] {
            harness.event(egui::Event::PointerButton {
                pos,
                button: egui::PointerButton::Primary,
                pressed,
                modifiers: egui::Modifiers::NONE,
            });
        }
    }
    harness.run();
}

/// The title of the dictionary's column `title`, in the header right above the row
/// `row` (the commands panel has a "Value" of its own).
fn header(harness: &Harness<'_, App>, title: &str, row: &str) -> Option<egui::Rect> {
    let row = harness.get_by_label(row).rect();
    harness
        .query_all_by_label(title)
        .map(|n| n.rect())
        .find(|r| r.bottom() <= row.top() + 1.0 && r.bottom() > row.top() - 40.0)
}

/// Scroll the table sideways by `dx` points (negative: to the right), with the wheel over
/// `label`.
fn wheel_sideways(harness: &mut Harness<'_, App>, label: &str, dx: f32) {
    harness.get_by_label(label).hover();
    harness.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Point,
        delta: egui::vec2(dx, 0.0),
        modifiers: egui::Modifiers::NONE,
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Wheel,
    });
    // The wheel is smoothed over a few frames.
    for _ in 0..30 {
        harness.step();
    }
}

#[test]
fn object_and_name_stay_in_view_while_the_other_columns_scroll_sideways() {
    let mut harness = browser();
    filter(&mut harness, "6081");
    let object = harness.get_by_label("6081h:00h").rect();
    let name = harness.get_by_label("Profile Velocity").rect();
    let value = header(&harness, "Value", "6081h:00h").expect("the Value column");
    assert!(
        header(&harness, "Limits", "6081h:00h").is_none(),
        "at 1600 px the last columns are out of view at first"
    );

    wheel_sideways(&mut harness, "Profile Velocity", -2000.0);

    // Scrolled to the right end: the last columns in view, the value cell gone left.
    assert!(
        header(&harness, "Limits", "6081h:00h").is_some(),
        "scrolled to the Limits column"
    );
    let value_now = header(&harness, "Value", "6081h:00h").map(|v| v.left());
    assert!(
        value_now.is_none_or(|x| x < value.left() - 100.0),
        "the Value column moved left: {value_now:?} from {}",
        value.left()
    );
    // The row still says which object it is, where it was.
    let object_now = harness.get_by_label("6081h:00h").rect();
    let name_now = harness.get_by_label("Profile Velocity").rect();
    // (Sideways only: the rows may move up or down as the lines above them change.)
    assert_eq!(
        object_now.x_range(),
        object.x_range(),
        "the Object column is pinned"
    );
    assert_eq!(
        name_now.x_range(),
        name.x_range(),
        "the Name column is pinned"
    );
    assert!(
        object_now.right() < name_now.left(),
        "{object_now:?} {name_now:?}"
    );
    // The Limits column is right of the pinned ones, not under them.
    let limits = header(&harness, "Limits", "6081h:00h").expect("the Limits column");
    assert!(limits.left() > name_now.right());
}

const QUICK_STOP_OPTION: Address = Address::new(0x605A, 0);

#[test]
fn a_value_is_edited_in_place_with_the_limit_error_under_the_field_as_typed() {
    let mut harness = browser();
    filter(&mut harness, "605a");
    // The row reads its value by itself.
    step_until(
        &mut harness,
        "the row's value",
        Duration::from_secs(5),
        |h| value_of(h, QUICK_STOP_OPTION).is_some(),
    );
    harness.run();
    let row = harness.get_by_label("605Ah:00h").rect();
    let value = header(&harness, "Value", "605Ah:00h").expect("the Value column");
    double_click_at(&mut harness, egui::pos2(value.center().x, row.center().y));
    let field = harness.get_by_label("New value 605Ah:00h");
    assert!(field.is_focused(), "the box has the keyboard");
    // Under it: the keys, and that Esc is also the Quickstop.
    assert!(
        harness
            .query_by_label_contains("Esc cancels and quick-stops the drive")
            .is_some()
    );
    let field = harness.get_by_label("New value 605Ah:00h");

    // 605Ah takes 0 to 6: 9 is refused as it is typed, right under the box.
    field.set_text_value_accesskit("9");
    harness.run();
    let field = harness.get_by_label("New value 605Ah:00h").rect();
    let error = harness.get_by_label_contains("9 is above").rect();
    assert!(
        error.top() >= field.bottom() - 1.0 && error.top() < field.bottom() + 24.0,
        "the error {error:?} is right under the box {field:?}"
    );
    assert!(
        (error.left() - field.left()).abs() < 16.0,
        "{error:?} {field:?}"
    );
    // Enter does not write it.
    harness.key_press(egui::Key::Enter);
    harness.run();
    assert!(harness.query_by_label("Write to the drive?").is_none());
    assert!(harness.query_by_label_contains("9 is above").is_some());

    // A good value: no error; Enter asks, then writes and reads back.
    harness
        .get_by_label("New value 605Ah:00h")
        .set_text_value_accesskit("5");
    harness.run();
    assert!(harness.query_by_label_contains("9 is above").is_none());
    harness.get_by_label("New value 605Ah:00h").focus();
    harness.run();
    harness.key_press(egui::Key::Enter);
    harness.run();
    assert!(harness.query_by_label("Write to the drive?").is_some());
    harness.get_by_label("Confirm write").click();
    harness.step();
    step_until(&mut harness, "the write", Duration::from_secs(5), |h| {
        value_of(h, QUICK_STOP_OPTION) == Some(Ok(Value::Int(5)))
    });
    harness.run();
    assert!(harness.query_by_label("New value 605Ah:00h").is_none());

    // Enter on the selected row edits it again; Esc cancels.
    harness.key_press(egui::Key::Enter);
    harness.run();
    assert!(harness.query_by_label("New value 605Ah:00h").is_some());
    harness.key_press(egui::Key::Escape);
    harness.run();
    assert!(harness.query_by_label("New value 605Ah:00h").is_none());
    assert!(harness.state().shown().browser.edit.is_none());
}

#[test]
fn the_rows_on_screen_are_read_by_themselves_at_the_rate_chosen() {
    use drivedeck::ui::browser::REFRESH_IN_FLIGHT;
    const RATE: f64 = 10.0;
    let mut settings = Settings::default();
    settings.dictionary.reads_per_second = RATE;
    let mut harness = browser_with(settings);
    let visible: Vec<Address> = harness
        .state()
        .shown()
        .browser
        .visible
        .iter()
        .copied()
        .filter(|a| {
            drivedeck::od::builtin()
                .get(*a)
                .is_some_and(|e| e.access.readable())
        })
        .collect();
    assert!(visible.len() > REFRESH_IN_FLIGHT, "{} rows", visible.len());
    let started = std::time::Instant::now();
    let sent_before = harness.state().shown().browser.refresh.sent;
    let mut most = 0;
    // The rows on screen now (as the lines above the table settle, one may go or come).
    let all_read = |h: &Harness<'_, App>| {
        let b = &h.state().shown().browser;
        b.visible
            .iter()
            .filter(|a| {
                drivedeck::od::builtin()
                    .get(**a)
                    .is_some_and(|e| e.access.readable())
            })
            .all(|a| b.values.contains_key(a))
    };
    while !all_read(&harness) {
        let b = &harness.state().shown().browser;
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the rows on screen were not read: {:?} of {:?}",
            b.values.keys().collect::<Vec<_>>(),
            b.visible,
        );
        // Never more than the rate allows since the start (plus what may go at once).
        let sent = b.refresh.sent - sent_before;
        let allowed = RATE * started.elapsed().as_secs_f64() + REFRESH_IN_FLIGHT as f64;
        assert!(sent as f64 <= allowed, "{sent} read, {allowed} allowed");
        harness.step();
        most = most.max(harness.state().shown().browser.refresh.in_flight());
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(most > 0 && most <= REFRESH_IN_FLIGHT, "{most} in flight");
    // Nothing more while they are fresh.
    let sent = harness.state().shown().browser.refresh.sent;
    window::step_for(&mut harness, Duration::from_millis(500));
    assert_eq!(harness.state().shown().browser.refresh.sent, sent);
    // The box that sets the rate is in the toolbar.
    assert!(
        harness
            .query_by_label("Auto-read objects per second")
            .is_some()
    );
}

#[test]
fn with_auto_read_off_the_rows_wait_for_a_read() {
    let mut settings = Settings::default();
    settings.dictionary.reads_per_second = 0.0;
    let mut harness = browser_with(settings);
    filter(&mut harness, "6081");
    window::step_for(&mut harness, Duration::from_millis(500));
    assert_eq!(
        value_of(&harness, PROFILE_VELOCITY),
        None,
        "not read by itself"
    );
    assert_eq!(harness.state().shown().browser.refresh.sent, 0);
    harness.get_by_label("Read 6081h:00h").click();
    harness.step();
    step_until(&mut harness, "the read", Duration::from_secs(5), |h| {
        value_of(h, PROFILE_VELOCITY).is_some()
    });
}

/// A restore preview made, then a new connection to the link `to` picks (from the window
/// as it is): the preview goes, its message stays, marked as from the earlier connection.
fn preview_goes_with_a_new_connection(
    dir: &str,
    to: impl FnOnce(&Harness<'_, App>) -> drivedeck::link::LinkSpec,
) {
    let dir = temp_dir(dir);
    let path = dir.path().join("crafted.json");
    std::fs::write(
        &path,
        crafted_backup(&[("6081:00", "Profile Velocity", "UNSIGNED32", "uint", 777)]),
    )
    .expect("write");
    let mut harness = browser();
    backup_file(&mut harness, &path);
    preview_restore(&mut harness);
    harness.run();
    assert!(harness.query_by_label("Restore 1 writes").is_some());
    let before = harness.state().shown().browser.connection();

    let spec = to(&harness);
    harness
        .state_mut()
        .shown_mut()
        .request(drivedeck::worker::Request::Connect(spec.clone()));
    step_until(
        &mut harness,
        "the new connection",
        Duration::from_secs(10),
        |h| {
            h.state().shown().browser.connection() > before
                && h.state()
                    .shown()
                    .link_info()
                    .is_some_and(|i| i.spec == spec)
        },
    );
    harness.step();
    harness.run();
    assert!(harness.state().shown().browser.restore.is_none());
    assert!(harness.query_by_label("Restore 1 writes").is_none());
    assert!(harness.query_by_label("Restore preview").is_none());
    let message = said(&harness).expect("the preview's message");
    assert!(message.earlier(harness.state().shown().browser.connection()));
    // The message about the preview says which link it came from.
    assert!(
        harness
            .query_by_label_contains("[sim, earlier connection] 1 writes would make")
            .is_some(),
        "{message:?}"
    );
}

#[test]
fn a_preview_from_another_drive_goes_when_the_link_changes() {
    preview_goes_with_a_new_connection("backup-other-drive", |_| {
        "canopen+sim://?node=3".parse().expect("a spec")
    });
}

#[test]
fn a_new_connection_to_the_same_drive_drops_the_preview_made_before() {
    preview_goes_with_a_new_connection("backup-reconnect", |h| {
        h.state()
            .shown()
            .link_info()
            .map(|i| i.spec.clone())
            .expect("connected")
    });
}

#[test]
fn rows_scrolled_into_view_are_read_by_themselves() {
    let mut harness = browser();
    let first: Vec<Address> = harness.state().shown().browser.visible.clone();
    // Down the table with the wheel over it.
    harness.get_by_label("Device Type").hover();
    for _ in 0..4 {
        harness.event(egui::Event::MouseWheel {
            unit: egui::MouseWheelUnit::Point,
            delta: egui::vec2(0.0, -600.0),
            modifiers: egui::Modifiers::NONE,
            phase: egui::TouchPhase::Move,
            source: egui::MouseWheelSource::Wheel,
        });
        for _ in 0..10 {
            harness.step();
        }
    }
    let now: Vec<Address> = harness.state().shown().browser.visible.clone();
    let new: Vec<Address> = now
        .iter()
        .copied()
        .filter(|a| !first.contains(a))
        .filter(|a| {
            drivedeck::od::builtin()
                .get(*a)
                .is_some_and(|e| e.access.readable())
        })
        .collect();
    assert!(!new.is_empty(), "scrolled: {first:?} then {now:?}");
    step_until(
        &mut harness,
        "the rows scrolled to",
        Duration::from_secs(10),
        |h| {
            let b = &h.state().shown().browser;
            new.iter().all(|a| b.values.contains_key(a))
        },
    );
}

#[test]
fn the_name_column_takes_its_share_of_a_wider_window() {
    let mut harness = browser();
    filter(&mut harness, "6081");
    let narrow = header(&harness, "Name", "6081h:00h").expect("Name");
    let value = header(&harness, "Value", "6081h:00h").expect("Value");
    harness.set_size(egui::vec2(2600.0, 1000.0));
    harness.run();
    let wide_value = header(&harness, "Value", "6081h:00h").expect("Value");
    assert!(
        wide_value.left() - narrow.left() > value.left() - narrow.left() + 20.0,
        "the Name column grew: Value from {value:?} to {wide_value:?}"
    );
}
