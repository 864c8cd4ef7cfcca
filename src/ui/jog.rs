//! Jog buttons that move only while held: pressing starts Profile Velocity at the jog
//! speed, holding sends a keep-alive every `JOG_KEEPALIVE`, releasing halts. The Left and
//! Right arrow keys do the same while no text box has the keyboard, whether the command
//! panel is open or folded ([`jog_input`] runs every frame). The worker halts the drive by
//! itself when the keep-alives stop (a frozen window); the window stops the jog when it
//! loses focus.

use eframe::egui::{self, Key, RichText, Sense, Ui};

use super::command::Command;
use super::drive::{Drive, jog_speed};
use super::widgets::{AMBER, name_widget, named_text_edit};
use crate::worker::JOG_KEEPALIVE;

/// The jog row: the buttons, the speed, and what the jog is doing. Which button is held
/// (-1, +1, or 0): [`jog_input`] acts on it.
pub fn jog_ui(ui: &mut Ui, drive: &mut Drive) -> i32 {
    let offline = drive.offline_reason();
    let speed = jog_speed(&drive.settings.jog_speed);
    let usable = offline.is_none() && speed.is_ok();
    let mut held = 0;
    ui.horizontal(|ui| {
        ui.label(RichText::new("Jog").strong());
        for (label, direction) in [("Jog -", -1), ("Jog +", 1)] {
            let button = egui::Button::new(RichText::new(label).size(16.0))
                .min_size(egui::vec2(64.0, 28.0))
                .sense(Sense::click_and_drag());
            let response = ui
                .add_enabled(usable, button)
                .on_hover_text("Hold to move at the jog speed; release to halt")
                .on_disabled_hover_text(match (&offline, &speed) {
                    (Some(offline), _) => offline.as_str(),
                    (None, Err(e)) => e.as_str(),
                    (None, Ok(_)) => "",
                });
            name_widget(&response, egui::accesskit::Role::Button, label);
            if usable && response.is_pointer_button_down_on() {
                held = direction;
            }
        }
        named_text_edit(ui, &mut drive.settings.jog_speed, 48.0, "Jog speed");
        ui.label("rpm");
        match (&speed, drive.motion.jog) {
            (Err(e), _) => {
                ui.colored_label(AMBER, e);
            }
            (Ok(_), Some(hold)) => {
                ui.colored_label(
                    AMBER,
                    format!("jogging {}", if hold.direction < 0 { "-" } else { "+" }),
                );
            }
            (Ok(_), None) => {}
        }
    });
    // Under the buttons, so the row stays narrow enough for a narrow command panel; the
    // line stays while jogging, so nothing under it moves.
    if speed.is_ok() {
        ui.weak("Hold a button, or the Left/Right arrow key.");
    }
    held
}

/// The jog of this frame: the button `buttons` held in the command panel (0 when none, or
/// when the panel is folded), else the arrow keys unless a text box is being typed in;
/// a keep-alive while held, a halt on release. Runs every frame, panel open or not.
pub fn jog_input(ctx: &egui::Context, drive: &Drive, buttons: i32, commands: &mut Vec<Command>) {
    let speed = jog_speed(&drive.settings.jog_speed);
    let usable = drive.offline_reason().is_none() && speed.is_ok();
    let mut held = if usable { buttons } else { 0 };
    let typing = ctx.memory(|m| m.focused().is_some());
    if usable && held == 0 && !typing {
        let (left, right) =
            ctx.input(|i| (i.key_down(Key::ArrowLeft), i.key_down(Key::ArrowRight)));
        held = match (left, right) {
            (true, false) => -1,
            (false, true) => 1,
            _ => 0,
        };
    }
    // A window that loses the focus no longer sees the release: stop now, and wait for
    // the button to be let go before jogging again.
    let focus_lost = ctx.input(|i| {
        i.events
            .iter()
            .any(|e| matches!(e, egui::Event::WindowFocused(false)))
    });
    if focus_lost && drive.motion.jog.is_some() {
        commands.push(Command::JogFocusLost);
        return;
    }
    commands.push(Command::Jog {
        direction: held,
        speed: speed.unwrap_or(0),
    });
    if drive.motion.jog.is_some() || held != 0 {
        ctx.request_repaint_after(JOG_KEEPALIVE / 2);
    }
}
