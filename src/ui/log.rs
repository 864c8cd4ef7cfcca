//! The log: every request with the image it wrote and how the drive answered.

use eframe::egui::{self, RichText, Ui};

use super::state::{AppState, Bottom, Outcome};
use super::widgets::{AMBER, GREEN, RED};

pub fn log_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.heading("Log");
        ui.selectable_value(&mut state.bottom, Bottom::Commands, "Commands");
        ui.selectable_value(&mut state.bottom, Bottom::Frames, "Bus frames");
        let faults = state.timeline.len();
        ui.selectable_value(
            &mut state.bottom,
            Bottom::Faults,
            if faults == 0 {
                "Faults".to_owned()
            } else {
                format!("Faults ({faults})")
            },
        );
        let changes = state.changes.len();
        ui.selectable_value(
            &mut state.bottom,
            Bottom::Changes,
            if changes == 0 {
                "Changes".to_owned()
            } else {
                format!("Changes ({changes})")
            },
        );
        if ui.small_button("Clear").clicked() {
            match state.bottom {
                Bottom::Frames => state.frames.clear(),
                Bottom::Commands => state.log.clear(),
                Bottom::Faults => state.timeline.clear(),
                Bottom::Changes => state.changes.clear(),
            }
        }
    });
    match state.bottom {
        Bottom::Frames => {
            frames_ui(ui, state);
            return;
        }
        Bottom::Faults => {
            super::faults::faults_ui(ui, state);
            return;
        }
        Bottom::Changes => {
            super::changes::changes_ui(ui, state);
            return;
        }
        Bottom::Commands => {}
    }
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
                            Outcome::Superseded(text) => ui.weak(text).on_hover_text(
                                "A newer command took its place; not a fault",
                            ),
                            Outcome::Info => ui.weak("·"),
                        };
                        ui.end_row();
                    }
                });
        });
}

/// The bus frames, decoded, with the export to a candump-style log.
fn frames_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.checkbox(&mut state.settings.record_frames, "Record frames")
            .on_hover_text("Every frame sent and received, decoded (NMT, SDO, PDO, EMCY, heartbeat; Modbus function codes)");
        ui.label(format!("{} kept", state.frames.len()));
        ui.separator();
        super::widgets::named_text_edit(ui, &mut state.settings.frame_log_path, 220.0, "Frame log file");
        if ui
            .add_enabled(!state.frames.is_empty(), egui::Button::new("Export"))
            .on_hover_text("Write the frames kept to this file: candump's log format for CAN, one line per frame")
            .clicked()
        {
            let text: String = state.frames.iter().map(|f| f.log_line() + "\n").collect();
            let path = state.settings.frame_log_path.clone();
            match crate::file::write_whole(std::path::Path::new(&path), text) {
                Ok(()) => state.info(format!("{} frames written to {path}", state.frames.len())),
                Err(e) => state.info(format!("could not write {path}: {e}")),
            }
        }
    });
    egui::ScrollArea::vertical()
        .id_salt("frames_scroll")
        .stick_to_bottom(true)
        .auto_shrink([false, false])
        .show_rows(
            ui,
            ui.text_style_height(&egui::TextStyle::Monospace),
            state.frames.len(),
            |ui, rows| {
                for frame in state.frames.range(rows) {
                    ui.horizontal(|ui| {
                        ui.monospace(if frame.sent { "tx" } else { "rx" });
                        ui.monospace(&frame.raw);
                        ui.label(&frame.text);
                    });
                }
            },
        );
}
