//! The I/O tab: the inputs as named lamps (special function, inverted), the outputs with
//! On / Off / Release (asked first), and the analog input with Plot.

use eframe::egui::{self, RichText, Ui};

use super::model::{Force, IoPanel, PHYSICAL};
use crate::od::Address;
use crate::ui::command::{Command, Said};
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, GREEN, lamp, message_ui, name_widget};

/// The id of the I/O tab.
pub const IO: &str = "io";

enum Intent {
    Ask(Force),
    Agree,
    Decline,
}

pub fn io_ui(ui: &mut Ui, drive: &mut Drive, commands: &mut Vec<Command>) {
    let panel = drive.panels.get::<IoPanel>();
    let mut intents = vec![];
    if let Some(force) = panel.asking {
        ui.horizontal_wrapped(|ui| {
            ui.label(RichText::new(IoPanel::question(force)).color(AMBER));
            if ui.button("Yes").clicked() {
                intents.push(Intent::Agree);
            }
            if ui.button("No").clicked() {
                intents.push(Intent::Decline);
            }
        });
    }
    message_ui(ui, panel.message.as_ref());
    egui::ScrollArea::vertical()
        .id_salt("io_body")
        .auto_shrink([false, false])
        .show(ui, |ui| {
            // Inputs beside outputs and the analog input where the tab is wide enough
            // for both; one under the other on a narrow window.
            let right = |ui: &mut Ui, intents: &mut Vec<Intent>, commands: &mut Vec<Command>| {
                outputs_ui(ui, panel, intents);
                ui.separator();
                analog_ui(ui, panel, commands);
            };
            if ui.available_width() >= SIDE_BY_SIDE {
                ui.horizontal_top(|ui| {
                    ui.vertical(|ui| inputs_ui(ui, panel));
                    ui.separator();
                    ui.vertical(|ui| right(ui, &mut intents, commands));
                });
            } else {
                inputs_ui(ui, panel);
                ui.separator();
                right(ui, &mut intents, commands);
            }
            if !panel.is_connected() {
                ui.colored_label(AMBER, "not connected: the values are as last read");
            }
        });
    for intent in intents {
        match intent {
            Intent::Ask(force) => panel.ask(force),
            Intent::Agree => panel.agree(),
            Intent::Decline => panel.decline(),
        }
    }
}

/// The width from which the inputs and the outputs stand side by side.
const SIDE_BY_SIDE: f32 = 680.0;

fn analog_ui(ui: &mut Ui, panel: &IoPanel, commands: &mut Vec<Command>) {
    ui.strong("Analog input 3220h:01");
    ui.horizontal(|ui| {
        ui.monospace(panel.analog.map_or("–".into(), |v| v.to_string()));
        ui.weak("digits");
        let plot = ui
            .small_button("Plot")
            .on_hover_text("Sample it every cycle and add it to the plots");
        name_widget(&plot, egui::accesskit::Role::Button, "Plot analog input");
        if plot.clicked() {
            commands.push(Command::PlotObject {
                text: Address::new(0x3220, 1).to_string(),
                from: Said::Plots,
            });
        }
    });
}

fn inputs_ui(ui: &mut Ui, panel: &IoPanel) {
    ui.strong(format!(
        "Digital inputs 60FDh{}",
        panel
            .words
            .inputs
            .map_or(String::new(), |v| format!(" = {v:08X}h"))
    ));
    for line in panel.input_lines() {
        let on = line.on.unwrap_or(false);
        lamp(
            ui,
            on,
            GREEN,
            &line.label(),
            &format!("60FDh bit {}", line.bit),
        );
    }
}

fn outputs_ui(ui: &mut Ui, panel: &IoPanel, intents: &mut Vec<Intent>) {
    ui.strong(format!(
        "Digital outputs 60FEh:01{}",
        panel
            .outputs
            .map_or(String::new(), |v| format!(" = {v:08X}h"))
    ));
    let free = panel.is_connected() && panel.asking.is_none() && panel.outputs.is_some();
    egui::Grid::new("io_outputs")
        .spacing([8.0, 3.0])
        .show(ui, |ui| {
            for n in 1..=PHYSICAL {
                let (on, forced) = panel.output(n);
                lamp(
                    ui,
                    on.unwrap_or(false),
                    GREEN,
                    &format!("output {n}"),
                    "60FEh:01",
                );
                ui.weak(if forced == Some(true) { "forced" } else { "" });
                for (text, what) in [("On", Some(true)), ("Off", Some(false)), ("Release", None)] {
                    let enabled = free && (what.is_some() || forced == Some(true));
                    let button = ui.add_enabled(enabled, egui::Button::new(text).small());
                    name_widget(
                        &button,
                        egui::accesskit::Role::Button,
                        &format!("{text} output {n}"),
                    );
                    if button.clicked() {
                        intents.push(Intent::Ask(Force {
                            output: n,
                            on: what,
                        }));
                    }
                }
                ui.end_row();
            }
        });
}
