//! The log: every request with the image it wrote and how the drive answered.

use eframe::egui::{self, RichText, Ui};

use super::state::{AppState, Outcome};
use super::widgets::{AMBER, GREEN, RED};

pub fn log_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.heading("Log");
        if ui.small_button("Clear").clicked() {
            state.log.clear();
        }
    });
    egui::ScrollArea::vertical()
        .stick_to_bottom(true)
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("log_grid")
                .num_columns(4)
                .striped(true)
                .spacing([10.0, 2.0])
                .show(ui, |ui| {
                    for entry in &state.log {
                        ui.monospace(format!("{:8.3}", entry.at));
                        ui.label(&entry.what);
                        match entry.image {
                            Some(image) => {
                                let bytes: Vec<String> =
                                    image.to_bytes().iter().map(|b| format!("{b:02X}")).collect();
                                ui.monospace(format!("cmd {:3} [{}]", image.cmd, bytes.join(" ")))
                                    .on_hover_text("The RX image as written: SetValue1 (4 bytes LE), SetValue2 (2), SetValue3 (1), PDI-Cmd (1)");
                            }
                            None => {
                                ui.label("");
                            }
                        }
                        match &entry.outcome {
                            Outcome::Queued => ui.weak("queued"),
                            Outcome::Sent => ui.label("sent"),
                            Outcome::Accepted => ui.colored_label(AMBER, "accepted, running"),
                            Outcome::Succeeded(text) => ui.colored_label(GREEN, text),
                            Outcome::Failed(text) => ui.colored_label(RED, RichText::new(text).strong()),
                            Outcome::Info => ui.weak("·"),
                        };
                        ui.end_row();
                    }
                });
        });
}
