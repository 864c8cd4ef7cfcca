//! A value edited in place: a double-click on a row (or Enter on the selected one) puts a
//! box in its value cell, checked as it is typed (the type's range and the object's
//! limits) with the reason right under it; Enter asks for the confirmation and writes, Esc
//! cancels (Esc is also the Quickstop while connected, whatever has focus).

use eframe::egui::{self, Rect, RichText, Ui};

use super::panel::limits_text;
use super::table::{RowAction, row_button_ui};
use super::{Browser, Edit, Pending};
use crate::od::{Address, Entry};
use crate::ui::widgets::RED;
use crate::worker::{ObjectPath, Request};

/// The confirmation of a write: the object, its value before and after, with its unit.
pub(super) fn confirm_ui(ui: &mut Ui, b: &mut Browser) {
    let Some(confirm) = b.confirm.clone() else {
        return;
    };
    let before = confirm
        .before
        .as_ref()
        .map(|v| b.shown(confirm.address, v))
        .unwrap_or_else(|| "(not read)".into());
    let after = b.shown(confirm.address, &confirm.value);
    let modal = egui::Modal::new(egui::Id::unique("confirm_write")).show(ui.ctx(), |ui| {
        ui.heading("Write to the drive?");
        ui.label(format!("{} {}", confirm.address, confirm.name));
        ui.label(format!("{before} -> {after}"));
        let mut go = false;
        let mut cancel = false;
        ui.horizontal(|ui| {
            let write = ui.button("Write");
            crate::ui::widgets::name_widget(&write, egui::accesskit::Role::Button, "Confirm write");
            go = write.clicked();
            cancel = ui.button("Cancel").clicked();
        });
        (go, cancel)
    });
    let (go, cancel) = modal.inner;
    if go {
        b.confirm = None;
        b.edit = None;
        b.write_results.remove(&confirm.address);
        b.send(
            Request::WriteObject {
                address: confirm.address,
                dtype: confirm.dtype,
                value: confirm.value,
                path: ObjectPath::Auto,
            },
            Pending::Write {
                address: confirm.address,
            },
        );
    } else if cancel || modal.should_close() {
        b.confirm = None;
    }
}

/// The box a new value is typed into: Enter submits it, Esc cancels.
pub(super) fn edit_box_ui(
    ui: &mut Ui,
    entry: &Entry,
    edit: &Edit,
    width: f32,
    actions: &mut Vec<(Address, RowAction)>,
) {
    let mut text = edit.text.clone();
    let response = ui.add(
        egui::TextEdit::singleline(&mut text)
            .id(egui::Id::unique(("od_edit", entry.address)))
            .desired_width(width),
    );
    crate::ui::widgets::name_widget(
        &response,
        egui::accesskit::Role::TextInput,
        &format!("New value {}", entry.address),
    );
    if edit.focus {
        response.request_focus();
        actions.push((entry.address, RowAction::Focused));
    }
    if text != edit.text {
        actions.push((entry.address, RowAction::Typed(text)));
    }
    if response.lost_focus() {
        // Esc went to the Quickstop (consumed) while connected: the raw input still has it.
        let (enter, escape) = ui.input(|i| {
            let pressed = |key| {
                i.raw.events.iter().any(
                    |e| matches!(e, egui::Event::Key { key: k, pressed: true, .. } if *k == key),
                )
            };
            (pressed(egui::Key::Enter), pressed(egui::Key::Escape))
        });
        if enter {
            actions.push((entry.address, RowAction::Submit));
        } else if escape {
            actions.push((entry.address, RowAction::CancelEdit));
        }
    }
}

/// Under the box: why the text is refused, as typed, or the limits and the keys.
pub(super) fn edit_note_ui(ui: &mut Ui, rect: Rect, entry: &Entry, edit: &Edit) {
    let mut child = ui.new_child(
        egui::UiBuilder::new()
            .id_salt("od_edit_note")
            .max_rect(rect)
            .layout(egui::Layout::left_to_right(egui::Align::Center)),
    );
    child.set_clip_rect(rect.intersect(ui.clip_rect()));
    match &edit.error {
        Some(error) => {
            child
                .add(egui::Label::new(RichText::new(error).color(RED)).truncate())
                .on_hover_text(error);
        }
        None => {
            let limits = limits_text(entry);
            // Esc is the Quickstop whatever has focus (`connection::stop_keys`): said here,
            // so nobody cancels an edit by it without knowing that it stops the drive too.
            let keys = "Enter writes; Esc cancels and quick-stops the drive, Cancel only cancels";
            let hint = if limits.is_empty() {
                keys.to_owned()
            } else {
                format!("{limits}; {keys}")
            };
            child
                .add(egui::Label::new(RichText::new(&hint).weak()).truncate())
                .on_hover_text(hint);
        }
    }
}

/// While a value is typed: write it (after the confirmation), or cancel.
pub(super) fn edit_buttons_ui(ui: &mut Ui, entry: &Entry, actions: &mut Vec<(Address, RowAction)>) {
    if row_button_ui(ui, true, "Write…", "Write", entry.address).clicked() {
        actions.push((entry.address, RowAction::Submit));
    }
    if ui.small_button("Cancel").clicked() {
        actions.push((entry.address, RowAction::CancelEdit));
    }
}
