//! The state tile in view: the words large and coloured, Enable and Clear error beside
//! them, the limit switch, a warning and why the drive last stopped under them.

use std::time::{Duration, SystemTime};

use eframe::egui::{self, Color32, RichText, Ui};

use super::model::{Tone, doing, limit_words};
use crate::cia::ErrorCode;
use crate::pdi::{Action, StatusBit};
use crate::ui::command::Command;
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, BLUE, GREEN, RED, clipped_label};
use crate::worker::Request;

/// The colour of a tone.
pub fn tone_color(tone: Tone) -> Color32 {
    match tone {
        Tone::Go => GREEN,
        Tone::Held => AMBER,
        Tone::Off => BLUE,
        Tone::Alarm => RED,
    }
}

/// The tile, Enable and Clear error beside it, and the lines under it.
pub fn state_tile_ui(ui: &mut Ui, drive: &Drive, commands: &mut Vec<Command>) {
    let now = SystemTime::now();
    let glance = drive.glance(now);
    let color = tone_color(glance.tone);
    egui::Frame::new()
        .fill(color.gamma_multiply(0.16))
        .stroke(egui::Stroke::new(1.5, color))
        .corner_radius(5.0)
        .inner_margin(egui::Margin::symmetric(10, 6))
        .show(ui, |ui| {
            ui.set_width(ui.available_width());
            ui.horizontal_wrapped(|ui| {
                ui.label(
                    RichText::new(&glance.headline)
                        .size(22.0)
                        .strong()
                        .color(color),
                )
                .on_hover_text(&glance.detail);
            });
            clipped_label(ui, RichText::new(&glance.detail).small(), 2);
            ui.horizontal(|ui| {
                enable_button_ui(ui, drive, now, commands);
                if glance.fault {
                    clear_error_button_ui(ui, drive, commands);
                }
            });
        });
    tile_lines_ui(ui, drive);
    if drive.latest().is_some() && !drive.is_live(now) {
        // "last seen … ago" keeps counting while nothing else repaints.
        ui.ctx().request_repaint_after(Duration::from_millis(250));
    }
}

/// The limit switch that blocks travel, a warning, and why the drive last stopped.
fn tile_lines_ui(ui: &mut Ui, drive: &Drive) {
    if let Some(sample) = drive.latest() {
        if let Some(limit) = limit_words(&sample) {
            clipped_label(ui, RichText::new(limit).color(AMBER).strong(), 3);
        }
        let code = ErrorCode(sample.tx.error_code);
        if sample.tx.status.is_set(StatusBit::Warning) && code.0 != 0 && !doing(&sample).2 {
            clipped_label(
                ui,
                RichText::new(format!("Warning {:04X}h {}", code.0, code.meaning())).color(AMBER),
                2,
            );
        }
    }
    if let Some(why) = &drive.motion.why {
        // What to do leads the words (the protocol's detail comes last), so the rows shown
        // say it; the whole text is on hover.
        clipped_label(ui, RichText::new(format!("Why: {why}")).color(AMBER), 4).on_hover_text(why);
    }
}

/// Enable: Profile Velocity at 0 rpm switches the power stage on and holds the motor.
fn enable_button_ui(ui: &mut Ui, drive: &Drive, now: SystemTime, commands: &mut Vec<Command>) {
    let blocker = drive.enable_blocker(now);
    let button =
        egui::Button::new(RichText::new("Enable").strong()).min_size(egui::vec2(80.0, 26.0));
    let response = ui
        .add_enabled(blocker.is_none(), button)
        .on_hover_text(
            "Switch the power stage on without moving: Profile Velocity (PDI-Cmd 23) at 0 rpm, \
             as PDI spec §2.2.2 suggests. The motor then holds its position, energised.",
        )
        .on_disabled_hover_text(blocker.unwrap_or_default());
    if response.clicked() {
        commands.push(Command::Request(Request::Command(Action::Velocity {
            speed: 0,
        })));
    }
}

/// Clear Error (PDI-Cmd 2), beside the fault it clears.
fn clear_error_button_ui(ui: &mut Ui, drive: &Drive, commands: &mut Vec<Command>) {
    let offline = drive.offline_reason();
    let button = egui::Button::new(RichText::new("Clear error").strong().color(Color32::WHITE))
        .fill(RED)
        .min_size(egui::vec2(100.0, 26.0));
    let response = ui
        .add_enabled(offline.is_none(), button)
        .on_hover_text("Clear Error (PDI-Cmd 2): clears the fault once its cause is gone")
        .on_disabled_hover_text(offline.unwrap_or_default());
    if response.clicked() {
        commands.push(Command::Request(Request::Command(Action::ClearError)));
    }
}
