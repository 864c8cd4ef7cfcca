//! The log: every request with the image it wrote and how the drive answered.

use eframe::egui::{self, RichText, Ui};

use super::state::{AppState, Bottom, LogEntry, Outcome};
use super::widgets::{AMBER, GREEN, RED, log_grid_ui};

pub fn log_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.heading("Log");
        tabs_ui(ui, state);
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
        Bottom::Commands => log_grid_ui(ui, "log_grid", 4, |ui| {
            for entry in &state.log {
                log_entry_ui(ui, entry);
                ui.end_row();
            }
        }),
        Bottom::Frames => frames_ui(ui, state),
        Bottom::Faults => super::faults::faults_ui(ui, state),
        Bottom::Changes => super::changes::changes_ui(ui, state),
    }
}

/// The log's tabs: the commands, the bus frames, the faults and the changes (the last
/// two with how many entries they hold).
fn tabs_ui(ui: &mut Ui, state: &mut AppState) {
    let counted = |name: &str, count: usize| {
        if count == 0 {
            name.to_owned()
        } else {
            format!("{name} ({count})")
        }
    };
    let faults = counted("Faults", state.timeline.len());
    let changes = counted("Changes", state.changes.len());
    ui.selectable_value(&mut state.bottom, Bottom::Commands, "Commands");
    ui.selectable_value(&mut state.bottom, Bottom::Frames, "Bus frames");
    ui.selectable_value(&mut state.bottom, Bottom::Faults, faults);
    ui.selectable_value(&mut state.bottom, Bottom::Changes, changes);
}

/// One request: when, what, the image it wrote, and how the drive answered.
fn log_entry_ui(ui: &mut Ui, entry: &LogEntry) {
    ui.monospace(format!("{:8.3}", entry.at));
    ui.label(&entry.what);
    match entry.image {
        Some(image) => {
            let bytes: Vec<String> = image
                .to_bytes()
                .iter()
                .map(|b| format!("{b:02X}"))
                .collect();
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
        Outcome::Caution(text) => ui.colored_label(AMBER, text),
        Outcome::Superseded(text) => ui
            .weak(text)
            .on_hover_text("A newer command took its place; not a fault"),
        Outcome::Info => ui.weak("·"),
    };
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
