//! The NanoJ tab: the program's state and error in words with Start and Stop, the programs
//! on the drive, the objects mapped into and out of it, NanoJ inputs (click to change) and
//! outputs (live, each with Plot), and the uptime.

use eframe::egui::{self, RichText, Ui};

use super::model::{NanojPanel, SHOWN};
use crate::od::Address;
use crate::ui::command::{Command, Said};
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, GREEN, RED, message_ui, name_widget};

/// The id of the NanoJ tab.
pub const NANOJ: &str = "nanoj";

enum Intent {
    StartStop(bool),
    Edit(u8),
    Typed(String),
    Write,
    CancelEdit,
}

pub fn nanoj_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let panel = drive.panels.get::<NanojPanel>();
    let mut intents = vec![];
    ui.horizontal(|ui| {
        let color = match panel.status {
            Some(1) => GREEN,
            Some(s) if s >= 2 => RED,
            _ => ui.visuals().weak_text_color(),
        };
        ui.label(
            RichText::new(format!("Program: {}", panel.state()))
                .strong()
                .color(color),
        );
        let connected = panel.is_connected();
        let running = panel.status == Some(1);
        if ui
            .add_enabled(connected && !running, egui::Button::new("Start"))
            .on_hover_text("2300h bit 0 = 1: the program starts (it may take up to 200 ms)")
            .clicked()
        {
            intents.push(Intent::StartStop(true));
        }
        if ui
            .add_enabled(connected && running, egui::Button::new("Stop"))
            .on_hover_text("2300h = 0: the program stops")
            .clicked()
        {
            intents.push(Intent::StartStop(false));
        }
        if panel.asked.is_some() {
            ui.spinner();
        }
        message_ui(ui, panel.message.as_ref());
    });
    if let Some(error) = panel.error_words() {
        ui.colored_label(RED, format!("Error 2302h = {error}"));
    }
    ui.horizontal_wrapped(|ui| {
        ui.weak("Programs on the drive:");
        if panel.programs.is_empty() {
            ui.weak("none named (2304h)");
        }
        for name in &panel.programs {
            ui.monospace(name);
        }
        if let Some(up) = panel.uptime_s {
            ui.separator();
            ui.weak(format!("uptime {up} s"));
        }
    });
    ui.separator();
    egui::ScrollArea::vertical()
        .id_salt("nanoj_body")
        .auto_shrink([false, false])
        .show(ui, |ui| body_ui(ui, panel, &mut intents, commands));
    for intent in intents {
        match intent {
            Intent::StartStop(start) => panel.start_stop(start),
            Intent::Edit(n) => panel.edit_input(n),
            Intent::Typed(text) => {
                if let Some(edit) = panel.edit.as_mut() {
                    edit.1 = text;
                }
            }
            Intent::Write => panel.write_input(),
            Intent::CancelEdit => panel.edit = None,
        }
    }
}

fn input_ui(ui: &mut Ui, panel: &NanojPanel, n: u8, intents: &mut Vec<Intent>) {
    match panel.edit.as_ref().filter(|(k, _)| *k == n) {
        Some((_, text)) => {
            ui.horizontal(|ui| {
                let mut typed = text.clone();
                let field = ui.add(egui::TextEdit::singleline(&mut typed).desired_width(90.0));
                name_widget(
                    &field,
                    egui::accesskit::Role::TextInput,
                    "NanoJ input value",
                );
                if typed != *text {
                    intents.push(Intent::Typed(typed));
                }
                let write = ui.small_button("Write");
                name_widget(&write, egui::accesskit::Role::Button, "Write NanoJ input");
                if write.clicked()
                    || (field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)))
                {
                    intents.push(Intent::Write);
                }
                if ui.small_button("Cancel").clicked() {
                    intents.push(Intent::CancelEdit);
                }
            });
        }
        None => {
            let value = panel.inputs[usize::from(n - 1)];
            let button = ui
                .add_enabled(
                    panel.is_connected(),
                    egui::Button::new(
                        RichText::new(value.map_or("–".into(), |v| v.to_string())).monospace(),
                    )
                    .frame(false),
                )
                .on_hover_text("Click to change it (2400h is written by the fieldbus)");
            name_widget(
                &button,
                egui::accesskit::Role::Button,
                &format!("NanoJ input {n} value"),
            );
            if button.clicked() {
                intents.push(Intent::Edit(n));
            }
        }
    }
}

fn body_ui(
    ui: &mut Ui,
    panel: &NanojPanel,
    intents: &mut Vec<Intent>,
    commands: &mut Vec<Command>,
) {
    egui::Grid::new("nanoj_io")
        .striped(true)
        .spacing([14.0, 3.0])
        .show(ui, |ui| {
            ui.strong("NanoJ input (2400h)");
            ui.strong("value");
            ui.strong("NanoJ output (2500h)");
            ui.strong("value");
            ui.end_row();
            for n in 1..=SHOWN {
                ui.label(format!("input {n}"));
                input_ui(ui, panel, n, intents);
                ui.label(format!("output {n}"));
                ui.horizontal(|ui| {
                    let value = panel.outputs[usize::from(n - 1)];
                    ui.monospace(value.map_or("–".into(), |v| v.to_string()));
                    let plot = ui
                        .small_button("Plot")
                        .on_hover_text("Sample it every cycle and add it to the plots");
                    name_widget(
                        &plot,
                        egui::accesskit::Role::Button,
                        &format!("Plot output {n}"),
                    );
                    if plot.clicked() {
                        commands.push(Command::PlotObject {
                            text: Address::new(0x2500, n).to_string(),
                            from: Said::Plots,
                        });
                    }
                });
                ui.end_row();
            }
        });
    ui.separator();
    for (title, list) in [
        ("Mapped into the program (2310h)", &panel.inputs_mapped),
        ("Mapped out of it (2320h)", &panel.outputs_mapped),
    ] {
        ui.label(RichText::new(title).strong());
        if list.is_empty() {
            ui.weak("nothing mapped");
        }
        for (address, bits) in list.iter() {
            let name = crate::od::builtin()
                .get(*address)
                .map_or_else(String::new, |e| e.full_name());
            ui.horizontal(|ui| {
                ui.monospace(address.to_string());
                ui.label(name);
                ui.weak(format!("{bits} bits"));
            });
        }
    }
    if !panel.is_connected() {
        ui.colored_label(AMBER, "not connected: the values are as last read");
    }
}
