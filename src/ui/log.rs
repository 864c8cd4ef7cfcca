//! The log's own tabs: every request with the image it wrote and how the drive answered,
//! and the bus frames with their export.

use eframe::egui::{self, RichText, Ui};

use super::drive::{Drive, LogEntry, Outcome};
use super::widgets::{AMBER, GREEN, RED, log_grid_ui};

/// The id of the log's tab of commands.
pub use super::window::COMMANDS;
/// The id of the log's tab of bus frames.
pub const FRAMES: &str = "frames";

/// Every request of the drive with the image it wrote and how the drive answered.
pub fn commands_ui(ui: &mut Ui, drive: &Drive) {
    // Long lines wrap within the panel instead of running off its right edge: what was
    // done gets up to half the width, how the drive answered the rest.
    let width = ui.available_width();
    // The fixed columns (the time, the image) as wide as their widest text, so the two
    // wrapping ones share what is left and a row never runs off the panel.
    let mono = egui::TextStyle::Monospace.resolve(ui.style());
    let measure = |text: &str| {
        ui.painter()
            .layout_no_wrap(text.to_owned(), mono.clone(), egui::Color32::WHITE)
            .size()
            .x
    };
    let fixed = measure("12345.678") + measure("cmd 123 [00 00 00 00 00 00 00 00]");
    let spacing = ui.spacing().item_spacing.x * 4.0;
    let left = (width - fixed - spacing).max(320.0);
    let widths = Widths {
        what: (left * 0.55).max(160.0),
        outcome: (left * 0.45).max(160.0),
    };
    log_grid_ui(ui, "log_grid", 4, |ui| {
        for entry in &drive.log {
            log_entry_ui(ui, entry, widths);
            ui.end_row();
        }
    });
}

/// The widest the wrapping columns of the log may get.
#[derive(Clone, Copy)]
struct Widths {
    what: f32,
    outcome: f32,
}

/// `text` wrapped at `width`.
fn wrapped(ui: &mut Ui, text: impl Into<egui::WidgetText>, width: f32) -> egui::Response {
    ui.scope(|ui| {
        ui.set_max_width(width);
        ui.add(egui::Label::new(text).wrap())
    })
    .inner
}

/// One request: when, what, the image it wrote, and how the drive answered.
fn log_entry_ui(ui: &mut Ui, entry: &LogEntry, widths: Widths) {
    ui.monospace(format!("{:8.3}", entry.at));
    wrapped(ui, &entry.what, widths.what);
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
    let w = widths.outcome;
    match &entry.outcome {
        Outcome::Queued => ui.weak("queued"),
        Outcome::Sent => ui.label("sent"),
        Outcome::Accepted => ui.colored_label(AMBER, "accepted, running"),
        Outcome::Succeeded(text) => wrapped(ui, RichText::new(text).color(GREEN), w),
        Outcome::Failed(text) => wrapped(ui, RichText::new(text).color(RED).strong(), w),
        Outcome::Caution(text) => wrapped(ui, RichText::new(text).color(AMBER), w),
        Outcome::Superseded(text) => wrapped(ui, RichText::new(text).weak(), w)
            .on_hover_text("A newer command took its place; not a fault"),
        Outcome::Info => ui.weak("·"),
    };
}

/// The bus frames, decoded, with the export to a candump-style log.
pub fn frames_ui(ui: &mut Ui, drive: &mut Drive, path: &mut String) {
    ui.horizontal(|ui| {
        ui.checkbox(&mut drive.settings.record_frames, "Record frames")
            .on_hover_text("Every frame sent and received, decoded (NMT, SDO, PDO, EMCY, heartbeat; Modbus function codes)");
        ui.label(format!("{} kept", drive.frames.len()));
        ui.separator();
        super::widgets::named_text_edit(ui, path, 220.0, "Frame log file");
        if ui
            .add_enabled(!drive.frames.is_empty(), egui::Button::new("Export"))
            .on_hover_text("Write the frames kept to this file: candump's log format for CAN, one line per frame")
            .clicked()
        {
            let text: String = drive.frames.iter().map(|f| f.log_line() + "\n").collect();
            let path = path.clone();
            match crate::file::write_whole(std::path::Path::new(&path), text) {
                Ok(()) => drive.info(format!("{} frames written to {path}", drive.frames.len())),
                Err(e) => drive.info(format!("could not write {path}: {e}")),
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
            drive.frames.len(),
            |ui, rows| {
                for frame in drive.frames.range(rows) {
                    ui.horizontal(|ui| {
                        ui.monospace(if frame.sent { "tx" } else { "rx" });
                        ui.monospace(&frame.raw);
                        ui.label(&frame.text);
                    });
                }
            },
        );
}
