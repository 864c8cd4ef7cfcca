//! The state tile: what the drive is and does, in words, large and coloured, always in
//! view (the fixed head of the status panel): DISABLED, ENABLED, MOVING +300 rpm, HALTED,
//! QUICK STOP, FAULT 2300h with its meaning, NO LINK with when the drive was last seen.
//! Beside it Enable (on without moving, PDI spec §2.2.2) and, while a fault is active,
//! Clear error; under it the limit switch that blocks travel and why the drive last
//! stopped or refused.

use std::time::{Duration, SystemTime};

use eframe::egui::{self, Color32, RichText, Ui};

use super::state::{AppState, Connection, age_text};
use super::widgets::{AMBER, BLUE, GREEN, RED, clipped_label};
use crate::cia::{ErrorCode, PowerState};
use crate::pdi::{Action, StatusBit};
use crate::signal::AT_REST_RPM;
use crate::worker::{Request, Sample};

/// How the tile is coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tone {
    /// Energised and doing what it was told.
    Go,
    /// Stopped on purpose (halt, quick stop): energised, waiting.
    Held,
    /// Power stage off.
    Off,
    /// A fault, or no link.
    Alarm,
}

impl Tone {
    pub fn color(self) -> Color32 {
        match self {
            Tone::Go => GREEN,
            Tone::Held => AMBER,
            Tone::Off => BLUE,
            Tone::Alarm => RED,
        }
    }
}

/// The tile's words.
#[derive(Clone, Debug, PartialEq)]
pub struct Glance {
    /// "MOVING +300 rpm", "FAULT 2300h output current too large", "NO LINK (…)".
    pub headline: String,
    pub tone: Tone,
    /// The CiA 402 state and its meaning, or the last known state while there is no link.
    pub detail: String,
    /// A fault is active (Clear error is offered).
    pub fault: bool,
}

/// What a sample says the drive does: headline, tone, and whether it is a fault.
pub fn doing(sample: &Sample) -> (String, Tone, bool) {
    let status = sample.tx.status;
    let power = sample.statusword().and_then(PowerState::from_statusword);
    let fault = match power {
        Some(p) => matches!(p, PowerState::Fault | PowerState::FaultReactionActive),
        None => status.is_set(StatusBit::Fault),
    };
    if fault {
        let code = ErrorCode(sample.tx.error_code);
        let headline = if code.0 == 0 {
            "FAULT".to_owned()
        } else {
            format!("FAULT {:04X}h {}", code.0, code.meaning())
        };
        return (headline, Tone::Alarm, true);
    }
    let enabled = match power {
        Some(p) => p == PowerState::OperationEnabled,
        None => status.is_set(StatusBit::OperationEnabled),
    };
    let quick_stop = match power {
        Some(p) => p == PowerState::QuickStopActive,
        None => !enabled && status.is_set(StatusBit::QsHaltBit),
    };
    if quick_stop {
        return ("QUICK STOP".to_owned(), Tone::Held, false);
    }
    if !enabled {
        return ("DISABLED".to_owned(), Tone::Off, false);
    }
    let halt = status.is_set(StatusBit::QsHaltBit);
    match sample.velocity() {
        Some(v) if v.abs() >= AT_REST_RPM => {
            let verb = if halt { "HALTING" } else { "MOVING" };
            (format!("{verb} {v:+.0} rpm"), Tone::Go, false)
        }
        _ if halt => ("HALTED".to_owned(), Tone::Held, false),
        _ => ("ENABLED".to_owned(), Tone::Go, false),
    }
}

/// The CiA 402 state in words, or what PDI-Status alone tells.
fn power_words(sample: &Sample) -> String {
    match sample.statusword().and_then(PowerState::from_statusword) {
        Some(power) => format!("{}: {}", power.name(), power.meaning()),
        None => "CiA 402 state unknown (6041h not read): from PDI-Status".to_owned(),
    }
}

/// What the motor does, for a sentence: "moving at 300 rpm", "standing still".
pub fn motion_words(sample: &Sample) -> String {
    let halt = sample.tx.status.is_set(StatusBit::QsHaltBit);
    match sample.velocity() {
        Some(v) if v.abs() >= AT_REST_RPM && halt => format!("braking, at {v:.0} rpm"),
        Some(v) if v.abs() >= AT_REST_RPM => format!("moving at {v:.0} rpm"),
        Some(_) if halt => "halted, standing still".to_owned(),
        Some(_) => "standing still".to_owned(),
        None => "at an unknown speed (606Ch not read)".to_owned(),
    }
}

/// The limit switch that blocks travel, named by its input and the direction it blocks.
pub fn limit_words(sample: &Sample) -> Option<String> {
    let reached = sample.tx.status.is_set(StatusBit::LimitReached);
    let inputs = sample.digital_inputs();
    let (negative, positive) = match inputs {
        Some(di) => (di & 1 != 0, di & 2 != 0),
        None => (false, false),
    };
    Some(match (negative, positive) {
        (true, true) => "Both limit switches active (60FDh bits 0 and 1): travel is blocked in both directions".to_owned(),
        (true, false) => "Negative limit switch active (60FDh bit 0): travel in the negative (-) direction is blocked; move + to leave it".to_owned(),
        (false, true) => "Positive limit switch active (60FDh bit 1): travel in the positive (+) direction is blocked; move - to leave it".to_owned(),
        (false, false) if !reached => return None,
        (false, false) if inputs.is_some() => "Limit reached (PDI-Status), but no limit switch input is active in 60FDh: a software position limit (607Dh)?".to_owned(),
        (false, false) => "Limit reached (PDI-Status): which switch is unknown, 60FDh is not read on this link".to_owned(),
    })
}

impl AppState {
    /// The tile's words at `now`.
    pub fn glance(&self, now: SystemTime) -> Glance {
        let last_known = self
            .latest
            .map(|s| format!("last known: {}", doing(&s).0))
            .unwrap_or_else(|| "no state known yet".to_owned());
        if !self.is_live(now) {
            let age = self.sample_age(now).map(age_text);
            let seen = match &age {
                Some(age) => format!("last seen {age}"),
                None => "never seen".to_owned(),
            };
            let headline = match &self.connection {
                Connection::Connected(_) if !self.sampled_since_connect => {
                    "WAITING FOR DATA".to_owned()
                }
                Connection::Connected(_) => format!("NO DATA ({seen})"),
                Connection::Connecting(_) if self.latest.is_none() => "CONNECTING…".to_owned(),
                _ => format!("NO LINK ({seen})"),
            };
            return Glance {
                headline,
                tone: Tone::Alarm,
                detail: last_known,
                fault: false,
            };
        }
        let Some(sample) = self.latest else {
            return Glance {
                headline: "WAITING FOR DATA".to_owned(),
                tone: Tone::Alarm,
                detail: last_known,
                fault: false,
            };
        };
        let (headline, tone, fault) = doing(&sample);
        Glance {
            headline,
            tone,
            detail: power_words(&sample),
            fault,
        }
    }

    /// Why Enable cannot be pressed now; `None` when it can.
    pub fn enable_blocker(&self, now: SystemTime) -> Option<String> {
        if let Some(offline) = self.offline_reason() {
            return Some(offline);
        }
        if self.link_info().is_some_and(|i| !i.pdi) {
            return Some("this device has no Plug & Drive interface".to_owned());
        }
        if !self.is_live(now) {
            return Some("the drive's state is not known now".to_owned());
        }
        let sample = self.latest?;
        match doing(&sample) {
            (_, _, true) => Some("a fault is active: Clear error first".to_owned()),
            (headline, Tone::Go, _) => Some(format!("already enabled ({headline})")),
            _ => None,
        }
    }
}

/// The tile, Enable and Clear error beside it, and the lines under it.
pub fn state_tile_ui(ui: &mut Ui, state: &mut AppState) {
    let now = SystemTime::now();
    let glance = state.glance(now);
    let color = glance.tone.color();
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
                enable_button_ui(ui, state, now);
                if glance.fault {
                    clear_error_button_ui(ui, state);
                }
            });
        });
    tile_lines_ui(ui, state);
    if state.latest.is_some() && !state.is_live(now) {
        // "last seen … ago" keeps counting while nothing else repaints.
        ui.ctx().request_repaint_after(Duration::from_millis(250));
    }
}

/// The limit switch that blocks travel, a warning, and why the drive last stopped.
fn tile_lines_ui(ui: &mut Ui, state: &AppState) {
    if let Some(sample) = state.latest {
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
    if let Some(why) = &state.why {
        clipped_label(ui, RichText::new(format!("Why: {why}")).color(AMBER), 3);
    }
}

/// Enable: Profile Velocity at 0 rpm switches the power stage on and holds the motor.
fn enable_button_ui(ui: &mut Ui, state: &mut AppState, now: SystemTime) {
    let blocker = state.enable_blocker(now);
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
        state.request(Request::Command(Action::Velocity { speed: 0 }));
    }
}

/// Clear Error (PDI-Cmd 2), beside the fault it clears.
fn clear_error_button_ui(ui: &mut Ui, state: &mut AppState) {
    let offline = state.offline_reason();
    let button = egui::Button::new(RichText::new("Clear error").strong().color(Color32::WHITE))
        .fill(RED)
        .min_size(egui::vec2(100.0, 26.0));
    let response = ui
        .add_enabled(offline.is_none(), button)
        .on_hover_text("Clear Error (PDI-Cmd 2): clears the fault once its cause is gone")
        .on_disabled_hover_text(offline.unwrap_or_default());
    if response.clicked() {
        state.request(Request::Command(Action::ClearError));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Status, TxImage};
    use crate::signal::{Signal, Signals};

    /// A sample with Limit reached as given and the digital inputs 60FDh if read.
    fn sample(limit_reached: bool, inputs: Option<u32>) -> Sample {
        let mut signals = Signals::default();
        if let Some(di) = inputs {
            signals.set(Signal::DigitalInputs, f64::from(di));
        }
        let status = if limit_reached {
            StatusBit::LimitReached.mask()
        } else {
            0
        };
        Sample {
            tx: TxImage {
                status: Status(status),
                error_code: 0,
                return_value: 0,
            },
            signals,
            ..Default::default()
        }
    }

    #[test]
    fn each_limit_switch_is_named_with_the_direction_it_blocks() {
        let words = |reached, inputs| limit_words(&sample(reached, inputs));
        let negative = words(true, Some(0b01)).expect("named");
        assert!(
            negative.starts_with("Negative limit switch active (60FDh bit 0)")
                && negative.contains("negative (-) direction is blocked; move + to leave it"),
            "{negative}"
        );
        let positive = words(true, Some(0b10)).expect("named");
        assert!(
            positive.starts_with("Positive limit switch active (60FDh bit 1)")
                && positive.contains("move - to leave it"),
            "{positive}"
        );
        // Other inputs (bit 2 homing switch and up) do not count as limit switches.
        let both = words(true, Some(0b111)).expect("named");
        assert!(both.starts_with("Both limit switches active"), "{both}");
        // A switch pressed while nothing is moving is still worth a line.
        assert!(words(false, Some(0b01)).is_some());
        assert_eq!(words(false, Some(0b100)), None, "no switch, no limit");
        assert_eq!(words(false, None), None);
        let software = words(true, Some(0)).expect("said");
        assert!(
            software.contains("software position limit (607Dh)"),
            "{software}"
        );
        let unknown = words(true, None).expect("said");
        assert!(
            unknown.contains("60FDh is not read on this link"),
            "{unknown}"
        );
    }
}
