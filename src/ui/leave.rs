//! Leaving a drive safely: on Disconnect (or closing the window) with the power stage on
//! or objects changed, the window asks what to leave behind — halt (the default), switch
//! off, or leave it on — and offers to restore what the tool changed first. Then it does
//! that in order: stop, restore, disconnect (and close).

use eframe::egui::{self, RichText, Ui};

use super::state::AppState;
use super::widgets::{AMBER, RED};
use crate::cia::PowerState;
use crate::pdi::{Action, StatusBit};
use crate::worker::Request;

/// What stays of the motor when the tool lets go.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopChoice {
    /// Halt bit: brake on the ramp, stay energised.
    #[default]
    Halt,
    /// Power stage off.
    SwitchOff,
    /// As it is.
    LeaveOn,
}

/// Where leaving stands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stage {
    /// The dialog is open.
    Asking,
    /// Writing the old values back; since (window clock).
    Restoring { since: f64 },
    /// All done: disconnect (and close) now.
    Disconnecting,
}

/// Leaving in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaving {
    pub close_window: bool,
    pub stop: StopChoice,
    pub restore: bool,
    pub stage: Stage,
}

/// How long restoring may take before the window disconnects anyway (and says so).
const RESTORE_TIMEOUT_S: f64 = 10.0;

impl AppState {
    /// Whether the power stage is on (from 6041h, or the PDI bit where 6041h is unknown).
    pub fn power_stage_on(&self) -> bool {
        let Some(sample) = self.latest else {
            return false;
        };
        match sample.statusword().and_then(PowerState::from_statusword) {
            Some(state) => state.is_energised(),
            None => sample.tx.status.is_set(StatusBit::OperationEnabled),
        }
    }

    /// The user wants to disconnect (or close the window): ask first when the drive is
    /// energised or objects were changed; otherwise go.
    pub fn ask_to_leave(&mut self, close_window: bool) {
        let restorable = self.changes.iter().any(|c| c.before.is_some());
        if self.is_connected() && (self.power_stage_on() || restorable) {
            self.leaving = Some(Leaving {
                close_window,
                stop: StopChoice::Halt,
                restore: restorable,
                stage: Stage::Asking,
            });
        } else {
            self.leaving = Some(Leaving {
                close_window,
                stop: StopChoice::LeaveOn,
                restore: false,
                stage: Stage::Disconnecting,
            });
        }
    }

    /// The user chose: stop the motor now, then restore, then disconnect.
    pub fn confirm_leave(&mut self, stop: StopChoice, restore: bool) {
        let Some(leaving) = self.leaving.as_mut() else {
            return;
        };
        leaving.stop = stop;
        leaving.restore = restore;
        leaving.stage = Stage::Restoring { since: self.clock };
        let close_window = leaving.close_window;
        match stop {
            StopChoice::Halt => self.request(Request::Halt),
            StopChoice::SwitchOff => self.request(Request::Command(Action::SwitchOff)),
            StopChoice::LeaveOn => {}
        }
        if restore {
            self.restore_changes();
        } else if let Some(l) = self.leaving.as_mut() {
            l.stage = Stage::Disconnecting;
            l.close_window = close_window;
        }
    }

    /// One frame of leaving. `true` when the window may close now.
    pub fn leave_step(&mut self) -> bool {
        let Some(leaving) = self.leaving else {
            return false;
        };
        match leaving.stage {
            Stage::Asking => false,
            Stage::Restoring { since } => {
                let pending = self.changes.iter().any(|c| c.before.is_some());
                let late = self.clock - since > RESTORE_TIMEOUT_S;
                if late {
                    self.info(format!(
                        "not every change was restored within {RESTORE_TIMEOUT_S:.0} s; disconnecting anyway (see the Changes tab)"
                    ));
                }
                if (!pending || late || !self.is_connected())
                    && let Some(l) = self.leaving.as_mut()
                {
                    l.stage = Stage::Disconnecting;
                }
                false
            }
            Stage::Disconnecting => {
                self.leaving = None;
                if self.is_connected()
                    || matches!(self.connection, super::state::Connection::Failed { .. })
                {
                    self.request(Request::Disconnect);
                }
                leaving.close_window
            }
        }
    }
}

/// The question, while it is asked.
pub fn leave_dialog(ctx: &egui::Context, state: &mut AppState) {
    let Some(leaving) = state.leaving else {
        return;
    };
    if leaving.stage != Stage::Asking {
        return;
    }
    let restorable = state.changes.iter().filter(|c| c.before.is_some()).count();
    let mut restore = leaving.restore;
    let mut choice = None;
    let mut cancel = false;
    egui::Modal::new(egui::Id::unique("leave_dialog")).show(ctx, |ui: &mut Ui| {
        ui.set_max_width(460.0);
        ui.heading(if leaving.close_window {
            "Close drivedeck"
        } else {
            "Disconnect"
        });
        if state.power_stage_on() {
            ui.colored_label(
                AMBER,
                "The power stage is on: the motor is energised. What should stay behind?",
            );
        }
        if restorable > 0 {
            ui.checkbox(
                &mut restore,
                format!("First restore what I changed ({restorable} objects, newest first)"),
            );
        }
        ui.add_space(6.0);
        let halt = ui.button(RichText::new("Halt, then disconnect").strong());
        if halt.clicked() {
            choice = Some(StopChoice::Halt);
        }
        // Enter takes the default.
        if ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            choice = Some(StopChoice::Halt);
        }
        if ui
            .button(RichText::new("Switch off, then disconnect").color(RED))
            .on_hover_text("Power stage off: the motor coasts and holds no torque")
            .clicked()
        {
            choice = Some(StopChoice::SwitchOff);
        }
        if ui
            .button("Leave it as it is, disconnect")
            .on_hover_text("The drive keeps doing what it does")
            .clicked()
        {
            choice = Some(StopChoice::LeaveOn);
        }
        ui.separator();
        if ui.button("Cancel").clicked() {
            cancel = true;
        }
    });
    if let Some(l) = state.leaving.as_mut() {
        l.restore = restore;
    }
    if cancel {
        state.leaving = None;
    } else if let Some(stop) = choice {
        state.confirm_leave(stop, restore);
    }
}
