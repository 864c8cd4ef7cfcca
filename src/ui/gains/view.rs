//! The Gains tab: a table of the gains and limits by group — address, name, value (click
//! to edit: checked as typed, Enter asks to confirm, Esc drops it), unit, factory value,
//! range — with "Read again" and the last write's outcome.

use eframe::egui::{self, RichText, Ui};

use super::housekeeping::Housekeeping;
use super::model::GainsPanel;
use crate::od::{Address, Value};
use crate::ui::drive::Drive;
use crate::ui::test_run::{TEST, TestRuns};
use crate::ui::widgets::{AMBER, RED, message_ui, name_widget};

/// The id of the Gains tab.
pub const GAINS: &str = "gains";

/// What the user asked for in this frame, done once the table is drawn.
enum Intent {
    Ask(Housekeeping),
    Agree,
    Decline,
    ReadAll,
    Edit(Address),
    Typed(String),
    Submit,
    Confirm,
    /// Write, then run the Test tab's test again (and show it).
    ConfirmAndTest,
    Cancel,
    Focused,
}

/// The tab; `central` is the window's central tab (Write and test again shows the Test
/// tab).
pub fn gains_ui(ui: &mut Ui, drive: &mut Drive, central: &mut String) {
    let panel = drive.panels.get::<GainsPanel>();
    let mut intents = Vec::new();
    ui.horizontal(|ui| {
        let idle = panel.is_connected() && panel.reading == 0;
        if ui
            .add_enabled(idle, egui::Button::new("Read again"))
            .on_hover_text("Read every gain and limit from the drive")
            .on_disabled_hover_text("not connected, or reading")
            .clicked()
        {
            intents.push(Intent::ReadAll);
        }
        if panel.reading > 0 {
            ui.spinner();
            ui.weak(format!("reading ({} to go)", panel.reading));
        } else if !panel.is_connected() {
            ui.weak("not connected: the values are as last read");
        }
        ui.separator();
        let free = panel.is_connected() && !panel.restarting() && panel.asking.is_none();
        for what in [
            Housekeeping::Store,
            Housekeeping::Defaults,
            Housekeeping::Reboot,
        ] {
            if ui
                .add_enabled(free, egui::Button::new(what.button()))
                .on_hover_text(what.question())
                .on_disabled_hover_text("not connected, a restart under way, or a question open")
                .clicked()
            {
                intents.push(Intent::Ask(what));
            }
        }
        if panel.restarting() {
            ui.spinner();
        }
    });
    if let Some(what) = panel.asking {
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new(what.question()).color(AMBER));
            if ui.button("Yes").clicked() {
                intents.push(Intent::Agree);
            }
            if ui.button("No").clicked() {
                intents.push(Intent::Decline);
            }
        });
    }
    ui.horizontal_wrapped(|ui| message_ui(ui, panel.message.as_ref()));
    ui.weak(
        "Click a value to change it. The manuals give no units for 3210h; the simulated \
         drive uses these gains once closed loop runs (after an auto setup).",
    );
    egui::ScrollArea::both()
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("gains_grid")
                .num_columns(6)
                .striped(true)
                .spacing([12.0, 3.0])
                .show(ui, |ui| table_ui(ui, panel, &mut intents));
        });
    for intent in intents {
        let panel = drive.panels.get::<GainsPanel>();
        match intent {
            Intent::Ask(what) => panel.ask(what),
            Intent::Agree => panel.agree(),
            Intent::Decline => panel.decline(),
            Intent::ReadAll => panel.read_all(),
            Intent::Edit(address) => panel.start_edit(address),
            Intent::Typed(text) => panel.typed(text),
            Intent::Submit => panel.submit(),
            Intent::Confirm => panel.confirm(),
            Intent::ConfirmAndTest => {
                panel.confirm();
                // The write is asked for first (the Gains model before the Test's): the
                // run starts on the new value.
                let tests = drive.panels.get::<TestRuns>();
                tests.start();
                *central = TEST.to_owned();
                break;
            }
            Intent::Cancel => panel.cancel(),
            Intent::Focused => panel.focused(),
        }
    }
}

fn table_ui(ui: &mut Ui, panel: &GainsPanel, intents: &mut Vec<Intent>) {
    for heading in ["Address", "Name", "Value", "Unit", "Factory", "Range"] {
        ui.strong(heading);
    }
    ui.end_row();
    let mut group = "";
    let mut object = None;
    for row in &panel.rows {
        if row.group != group {
            group = row.group;
            ui.label(RichText::new(group).strong().italics());
            ui.end_row();
        }
        // An object with subindices: its name once, above them.
        if !row.object.is_empty() && object != Some(row.address.index) {
            object = Some(row.address.index);
            ui.weak(format!("{:04X}h", row.address.index));
            ui.label(RichText::new(&row.object).strong());
            ui.end_row();
        }
        ui.monospace(row.address.to_string());
        ui.label(&row.name);
        match panel.edit.as_ref().filter(|e| e.address == row.address) {
            Some(edit) => edit_ui(ui, edit, row.value.as_ref(), panel.is_connected(), intents),
            None => value_ui(ui, panel, row, intents),
        }
        ui.label(&row.unit);
        ui.weak(
            row.factory
                .as_ref()
                .map(Value::to_string)
                .unwrap_or_default(),
        );
        ui.weak(&row.range);
        ui.end_row();
    }
}

fn value_ui(ui: &mut Ui, panel: &GainsPanel, row: &super::GainRow, intents: &mut Vec<Intent>) {
    match (&row.value, &row.refused) {
        (Some(value), _) => {
            let differs = row.factory.as_ref().is_some_and(|f| f != value);
            let mut text = RichText::new(value.to_string()).monospace();
            if differs {
                text = text.strong();
            }
            let writing = panel.writing == Some(row.address);
            let response = ui
                .add_enabled(
                    panel.is_connected() && panel.writing.is_none(),
                    egui::Button::new(text).frame(false),
                )
                .on_hover_text(if differs {
                    "Differs from the factory value. Click to change it"
                } else {
                    "Click to change it"
                });
            name_widget(
                &response,
                egui::accesskit::Role::Button,
                &format!("{} value", row.address),
            );
            if writing {
                ui.spinner();
            }
            if response.clicked() {
                intents.push(Intent::Edit(row.address));
            }
        }
        (None, Some(why)) => {
            ui.colored_label(AMBER, "not on this drive")
                .on_hover_text(why);
        }
        (None, None) => {
            ui.weak("–");
        }
    }
}

/// Whether `key` went down in this frame, even if a shortcut consumed it (Esc is the
/// Quickstop whatever has focus: it stops the drive and drops the edit).
fn pressed(ui: &Ui, key: egui::Key) -> bool {
    ui.input(|i| {
        i.raw
            .events
            .iter()
            .any(|e| matches!(e, egui::Event::Key { key: k, pressed: true, .. } if *k == key))
    })
}

fn edit_ui(
    ui: &mut Ui,
    edit: &super::GainEdit,
    now: Option<&Value>,
    connected: bool,
    intents: &mut Vec<Intent>,
) {
    ui.vertical(|ui| {
        if let Some(value) = &edit.confirming {
            let was = now.map_or_else(|| "unknown".to_owned(), Value::to_string);
            ui.label(format!("Write {value} (now {was})?"));
            ui.horizontal(|ui| {
                if ui
                    .add_enabled(connected, egui::Button::new("Write it"))
                    .on_disabled_hover_text("not connected")
                    .clicked()
                {
                    intents.push(Intent::Confirm);
                }
                if ui
                    .add_enabled(connected, egui::Button::new("Write and test again"))
                    .on_hover_text("Write it, then run the Test tab's test as it is set there")
                    .on_disabled_hover_text("not connected")
                    .clicked()
                {
                    intents.push(Intent::ConfirmAndTest);
                }
                if ui.button("Cancel").clicked() || pressed(ui, egui::Key::Escape) {
                    intents.push(Intent::Cancel);
                }
            });
            return;
        }
        let mut text = edit.text.clone();
        let response = ui
            .horizontal(|ui| {
                let response = ui
                    .add(
                        egui::TextEdit::singleline(&mut text)
                            .id(egui::Id::unique(("gains_edit", edit.address)))
                            .desired_width(110.0),
                    )
                    .on_hover_text(
                        "Enter asks to write; Esc cancels and quick-stops the drive, Cancel \
                         only cancels",
                    );
                name_widget(&response, egui::accesskit::Role::TextInput, "new value");
                if ui.button("Cancel").clicked() {
                    intents.push(Intent::Cancel);
                }
                response
            })
            .inner;
        if edit.focus {
            response.request_focus();
            intents.push(Intent::Focused);
        }
        if text != edit.text {
            intents.push(Intent::Typed(text));
        }
        if response.lost_focus() && pressed(ui, egui::Key::Enter) {
            intents.push(Intent::Submit);
        } else if pressed(ui, egui::Key::Escape) {
            intents.push(Intent::Cancel);
        }
        if let Some(error) = &edit.error {
            ui.colored_label(RED, error);
        }
    });
}
