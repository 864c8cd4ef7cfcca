//! The Changes tab: every object the tool changed on the drive, with its value before and
//! now, what the link itself changed, and "Restore what I changed".

use eframe::egui::{self, RichText, Ui};

use super::model::Changes;
use crate::od;
use crate::ui::command::Command;
use crate::ui::drive::Drive;
use crate::ui::widgets::AMBER;

/// The id of the log's tab of changes.
pub const CHANGES: &str = "changes";

pub fn changes_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let connected = drive.is_connected();
    let own_changes = drive.link.own_changes.clone();
    let changes = drive.panels.get::<Changes>();
    let restorable = changes.restorable();
    ui.horizontal(|ui| {
        let button = ui
            .add_enabled(
                connected && restorable > 0,
                egui::Button::new(format!("Restore what I changed ({restorable})")),
            )
            .on_hover_text("Write every old value back, the newest change first")
            .on_disabled_hover_text("nothing to restore, or not connected");
        if button.clicked() {
            commands.push(Command::RestoreChanges);
        }
        ui.weak(
            "Objects written this session (dictionary, command panel, torque slope); PDO \
             mappings are restored by the CANopen link itself on disconnect.",
        );
    });
    egui::ScrollArea::vertical()
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("changes_grid")
                .num_columns(4)
                .striped(true)
                .spacing([12.0, 2.0])
                .show(ui, |ui| {
                    if changes.is_empty() && own_changes.is_empty() {
                        ui.weak("nothing changed on the drive this session");
                        ui.end_row();
                    }
                    for change in &own_changes {
                        ui.weak("link");
                        ui.label(change);
                        ui.end_row();
                    }
                    for change in &changes.entries {
                        ui.monospace(change.address.to_string());
                        ui.label(
                            od::builtin()
                                .get(change.address)
                                .map(|e| e.full_name())
                                .unwrap_or_default(),
                        );
                        match &change.before {
                            Some(before) => ui.label(format!("was {before}")),
                            None => ui.colored_label(
                                AMBER,
                                "was unknown (could not be read first): not restored",
                            ),
                        };
                        ui.label(RichText::new(format!("now {}", change.after)).strong());
                        ui.end_row();
                    }
                });
        });
}
