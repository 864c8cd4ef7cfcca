//! Backups in the browser: dump, compare with the drive, and the restore preview and run.

use eframe::egui::{self, RichText, Ui};

use super::{Browser, Pending, Purpose, Restore, shown_in};
use crate::od::backup::{self, Backup, Comparison, Mismatch, Step, Why};
use crate::od::{Catalog, DataType, Entry, Value};
use crate::ui::widgets::{AMBER, GREEN, RED, title_with_close_ui};
use crate::worker::{ObjectPath, Request};

pub(super) fn backup_ui(ui: &mut Ui, b: &mut Browser, connected: bool) {
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("Backup").strong());
        crate::ui::widgets::named_text_edit(ui, &mut b.files.backup, 200.0, "Backup file");
        let idle = connected && b.bulk.is_none() && !b.restore.as_ref().is_some_and(|r| r.running);
        if ui
            .add_enabled(idle, egui::Button::new("Save backup"))
            .on_hover_text("Read every readable and writable configuration object and the identity into the file")
            .clicked()
        {
            let objects = backup::objects_to_read(b.catalog());
            let path = b.files.backup.trim().to_owned();
            b.comparison = None;
            b.restore = None;
            b.read_many(objects, Purpose::Backup { path });
        }
        for read in &FILE_READS {
            file_read_button_ui(ui, b, idle, read);
        }
        if ui
            .add_enabled(idle, egui::Button::new("Store to device"))
            .on_hover_text("Write 65766173h (\"save\") to 1010h:01: the drive keeps its current values after a restart")
            .clicked()
        {
            b.confirm_store = true;
        }
    });
    if b.confirm_store {
        confirm_store_ui(ui, b);
    }
}

/// "Store to device?": Store writes the save command, Cancel leaves the drive as it is.
fn confirm_store_ui(ui: &mut Ui, b: &mut Browser) {
    let modal = egui::Modal::new(egui::Id::unique("confirm_store")).show(ui.ctx(), |ui| {
        ui.heading("Store to device?");
        ui.label("Writes 65766173h (\"save\") to 1010h:01. The drive keeps every current value after a restart; this cannot be undone from here.");
        ui.horizontal(|ui| {
            if ui.button("Store").clicked() {
                b.confirm_store = false;
                let (address, value) = backup::STORE_ALL;
                b.send(Request::WriteObject {
                        address,
                        dtype: DataType::Unsigned32,
                        value: Value::Uint(u64::from(value)),
                        path: ObjectPath::Auto,
                    },
                    Pending::Store,
                );
            }
            if ui.button("Cancel").clicked() {
                b.confirm_store = false;
            }
        });
    });
    if modal.should_close() {
        b.confirm_store = false;
    }
}

/// A button that loads the backup file and reads the device's values of what it holds.
struct FileRead {
    text: &'static str,
    hover: &'static str,
    /// What the read is for: a comparison or a restore, which closes the other's view.
    purpose: fn(Box<Backup>) -> Purpose,
}

const FILE_READS: [FileRead; 2] = [
    FileRead {
        text: "Compare with file",
        hover: "Read the device and list where it differs from the file",
        purpose: Purpose::Compare,
    },
    FileRead {
        text: "Restore from file",
        hover: "Read the device, then preview exactly what a restore would write, in order",
        purpose: Purpose::Restore,
    },
];

/// The button of `read`: a click loads the file and starts the read.
fn file_read_button_ui(ui: &mut Ui, b: &mut Browser, enabled: bool, read: &FileRead) {
    if ui
        .add_enabled(enabled, egui::Button::new(read.text))
        .on_hover_text(read.hover)
        .clicked()
        && let Some(file) = b.load()
    {
        let objects = file.objects_to_read(b.catalog());
        let purpose = (read.purpose)(file);
        match purpose {
            Purpose::Compare(_) => b.restore = None,
            Purpose::Restore(_) => b.comparison = None,
            Purpose::Browse | Purpose::Backup { .. } => {}
        }
        b.read_many(objects, purpose);
    }
}

pub(super) fn comparison_ui(ui: &mut Ui, b: &mut Browser) {
    let Some((file, differences)) = &b.comparison else {
        return;
    };
    let mut close = false;
    ui.group(|ui| {
        let summary = file.identity.summary();
        close = title_with_close_ui(ui, "Device against the file", Some(&summary));
        let same = differences
            .iter()
            .filter(|d| d.device == Comparison::Same)
            .count();
        let skipped = differences
            .iter()
            .filter(|d| matches!(d.device, Comparison::Skipped(_)))
            .count();
        ui.label(format!(
            "{same} of {} objects are the same; {skipped} entries of the file skipped (not settings: never compared nor restored)",
            differences.len() - skipped
        ));
        egui::Grid::new("comparison").striped(true).show(ui, |ui| {
            for title in ["Object", "Name", "File", "Device"] {
                ui.label(RichText::new(title).strong());
            }
            ui.end_row();
            for d in differences.iter().filter(|d| d.device != Comparison::Same) {
                ui.monospace(d.address.to_string());
                ui.label(&d.name);
                ui.label(b.shown(d.address, &d.file));
                match &d.device {
                    Comparison::Differs(v) => ui.colored_label(AMBER, b.shown(d.address, v)),
                    Comparison::Unreadable(reason) => ui.colored_label(RED, reason),
                    Comparison::Skipped(reason) => ui.weak(format!("skipped: {reason}")),
                    Comparison::Same => ui.label(""),
                };
                ui.end_row();
            }
        });
    });
    if close {
        b.comparison = None;
    }
}

pub(super) fn restore_ui(ui: &mut Ui, b: &mut Browser, connected: bool) {
    let Some(restore) = &b.restore else {
        return;
    };
    let mut close = false;
    let mut start = false;
    let mut force = restore.force;
    ui.group(|ui| {
        let from = format!("from {}", restore.backup.identity.summary());
        close = title_with_close_ui(ui, "Restore preview", Some(&from));
        if restore.steps.is_empty() {
            ui.label("The device already matches the file: nothing to write.");
        }
        match &restore.mismatch {
            Some(m @ Mismatch::OtherProduct(_)) => {
                ui.colored_label(
                    RED,
                    format!("{}: its settings may mean something else here.", m.text()),
                );
                ui.checkbox(&mut force, "Restore onto this other kind of device anyway");
            }
            Some(m @ Mismatch::OtherUnit(_)) => {
                ui.colored_label(
                    AMBER,
                    format!(
                        "{} (a replacement takes its predecessor's settings so).",
                        m.text()
                    ),
                );
            }
            None => {}
        }
        restore_steps_ui(ui, b.catalog(), restore);
        skipped_ui(ui, b.catalog(), restore);
        let allowed = force || !matches!(restore.mismatch, Some(Mismatch::OtherProduct(_)));
        let can = connected
            && allowed
            && !restore.running
            && !restore.steps.is_empty()
            && restore.results.iter().all(Option::is_none);
        if ui
            .add_enabled(
                can,
                egui::Button::new(format!("Restore {} writes", restore.steps.len())),
            )
            .clicked()
        {
            start = true;
        }
    });
    if let Some(restore) = b.restore.as_mut() {
        restore.force = force;
    }
    if close {
        b.restore = None;
        return;
    }
    if start && let Some(restore) = b.restore.as_mut() {
        restore.confirm = true;
    }
    if b.restore.as_ref().is_some_and(|r| r.confirm) {
        confirm_restore_ui(ui, b);
    }
}

/// The writes a restore makes, in order: the value now and the one written, why, and how
/// each went.
fn restore_steps_ui(ui: &mut Ui, catalog: &Catalog, restore: &Restore) {
    egui::Grid::new("restore_steps")
        .striped(true)
        .show(ui, |ui| {
            for title in ["#", "Object", "Name", "Now", "Writes", "Why", "Result"] {
                ui.label(RichText::new(title).strong());
            }
            ui.end_row();
            for (n, (step, result)) in restore.steps.iter().zip(&restore.results).enumerate() {
                ui.label((n + 1).to_string());
                ui.monospace(step.address.to_string());
                ui.label(&step.name);
                ui.label(
                    step.before
                        .as_ref()
                        .map(|v| shown_in(catalog, step.address, v))
                        .unwrap_or_default(),
                );
                ui.label(shown_in(catalog, step.address, &step.value));
                match (&step.why, &step.warning) {
                    (_, Some(warning)) => ui.colored_label(AMBER, warning),
                    (Why::Procedure(text), None) => ui.weak(*text),
                    (Why::Restore, None) => ui.weak("as in the file"),
                };
                match result {
                    None => ui.label(""),
                    Some(Ok(())) => ui.colored_label(GREEN, "written"),
                    Some(Err(e)) => ui.colored_label(RED, e),
                };
                ui.end_row();
            }
        });
}

/// The saved objects a restore leaves alone, each with its name and the reason.
fn skipped_ui(ui: &mut Ui, catalog: &Catalog, restore: &Restore) {
    for (address, reason) in &restore.skipped {
        let name = catalog
            .get(*address)
            .map(Entry::full_name)
            .or_else(|| {
                restore
                    .backup
                    .entries()
                    .find(|(a, _)| a == address)
                    .map(|(_, o)| o.name.clone())
            })
            .unwrap_or_default();
        ui.colored_label(AMBER, format!("{address} {name} skipped: {reason}"));
    }
}

/// "Restore from the file?": Write them starts the restore, Cancel goes back to the preview.
fn confirm_restore_ui(ui: &mut Ui, b: &mut Browser) {
    let count = b.restore.as_ref().map_or(0, |r| r.steps.len());
    let modal = egui::Modal::new(egui::Id::unique("confirm_restore")).show(ui.ctx(), |ui| {
        ui.heading("Restore from the file?");
        ui.label(format!(
            "{count} writes, in the order listed. Settings that change how the drive is reached come last."
        ));
        let mut go = false;
        let mut cancel = false;
        ui.horizontal(|ui| {
            go = ui.button("Write them").clicked();
            cancel = ui.button("Cancel").clicked();
        });
        (go, cancel)
    });
    let (go, cancel) = modal.inner;
    if cancel || modal.should_close() {
        if let Some(r) = b.restore.as_mut() {
            r.confirm = false;
        }
    } else if go {
        start_restore(b);
    }
}

/// Send every step's write, in order; the results come back one by one.
fn start_restore(b: &mut Browser) {
    let steps: Vec<Step> = match b.restore.as_mut() {
        Some(r) => {
            r.confirm = false;
            r.running = true;
            r.steps.clone()
        }
        None => vec![],
    };
    for (n, step) in steps.into_iter().enumerate() {
        b.send(
            Request::WriteObject {
                address: step.address,
                dtype: step.dtype,
                value: step.value,
                path: ObjectPath::Auto,
            },
            Pending::RestoreStep(n),
        );
    }
}
