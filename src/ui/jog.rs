//! Jog buttons that move only while held: pressing starts Profile Velocity at the jog
//! speed, holding sends a keep-alive every `JOG_KEEPALIVE`, releasing halts. The Left and
//! Right arrow keys do the same while no text box has the keyboard. The worker halts the
//! drive by itself when the keep-alives stop (a frozen window); the window stops the jog
//! when it loses focus.

use eframe::egui::{self, Key, RichText, Sense, Ui};

use super::state::AppState;
use super::widgets::{AMBER, name_widget, named_text_edit};
use crate::worker::{JOG_KEEPALIVE, Request};

/// Fastest jog the box accepts, rpm.
pub const JOG_MAX_SPEED: i32 = 3000;

/// A jog held in the window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JogHold {
    /// -1 or +1.
    pub direction: i32,
    pub speed: i32,
    /// When the last jog request or keep-alive went out (the window's clock).
    pub sent_at: f64,
}

/// The jog speed as typed, or why it cannot be used.
pub fn jog_speed(text: &str) -> Result<i32, String> {
    text.trim()
        .parse::<i32>()
        .ok()
        .filter(|v| (1..=JOG_MAX_SPEED).contains(v))
        .ok_or_else(|| format!("jog speed '{text}' is not 1 to {JOG_MAX_SPEED} rpm"))
}

impl AppState {
    /// One frame of the jog: `direction` is what is held now (0: nothing).
    pub fn jog_step(&mut self, direction: i32, speed: i32) {
        let keepalive = JOG_KEEPALIVE.as_secs_f64();
        if self.jog_blocked {
            if direction == 0 {
                self.jog_blocked = false;
            }
            return;
        }
        match (self.jog, direction) {
            (None, 0) => {}
            (None, d) => self.start_jog(d, speed),
            (Some(_), 0) => {
                self.jog = None;
                self.request(Request::JogStop);
            }
            (Some(hold), d) if d != hold.direction || speed != hold.speed => {
                self.start_jog(d, speed)
            }
            (Some(hold), _) => {
                if self.clock - hold.sent_at >= keepalive {
                    self.outbox.push(Request::JogKeepAlive);
                    self.jog = Some(JogHold {
                        sent_at: self.clock,
                        ..hold
                    });
                }
            }
        }
    }

    fn start_jog(&mut self, direction: i32, speed: i32) {
        self.jog = Some(JogHold {
            direction,
            speed,
            sent_at: self.clock,
        });
        self.request(Request::Jog {
            speed: direction * speed,
        });
    }
}

pub fn jog_ui(ui: &mut Ui, state: &mut AppState) {
    let offline = state.offline_reason();
    let speed = jog_speed(&state.settings.jog_speed);
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
        named_text_edit(ui, &mut state.settings.jog_speed, 48.0, "Jog speed");
        ui.label("rpm");
        match (&speed, state.jog) {
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
    // Under the buttons, so the row stays narrow enough for a narrow command panel.
    if speed.is_ok() && state.jog.is_none() {
        ui.weak("Hold a button, or the Left/Right arrow key.");
    }
    // The arrow keys, unless a text box is being typed in.
    let typing = ui.ctx().memory(|m| m.focused().is_some());
    if usable && held == 0 && !typing {
        let (left, right) = ui.input(|i| (i.key_down(Key::ArrowLeft), i.key_down(Key::ArrowRight)));
        held = match (left, right) {
            (true, false) => -1,
            (false, true) => 1,
            _ => 0,
        };
    }
    // A window that loses the focus no longer sees the release: stop now, and wait for
    // the button to be let go before jogging again.
    let focus_lost = ui.input(|i| {
        i.events
            .iter()
            .any(|e| matches!(e, egui::Event::WindowFocused(false)))
    });
    if focus_lost && state.jog.is_some() {
        state.jog_step(0, 0);
        state.jog_blocked = true;
        return;
    }
    let speed = speed.unwrap_or(0);
    state.jog_step(if usable { held } else { 0 }, speed);
    if state.jog.is_some() {
        ui.ctx().request_repaint_after(JOG_KEEPALIVE / 2);
    }
}
