//! Leaving a drive safely: on Disconnect (or closing the window) with the power stage on
//! or objects changed, the window asks what to leave behind — halt (the default), switch
//! off, or leave it on — and offers to restore what the tool changed first. Then it does
//! that in order: stop, restore, disconnect (and close).

use eframe::egui::{self, RichText, Ui};

use super::state::{AppState, LogEntry, Outcome};
use super::widgets::{AMBER, RED};
use crate::cia::PowerState;
use crate::pdi::{Action, StatusBit};
use crate::worker::{Request, Sample};

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
    /// The halt or switch-off went out; waiting until the drive shows it (window clock).
    Stopping { since: f64 },
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
/// How long the window waits for the drive to show the halt (or switch-off) before it
/// disconnects anyway (and says so, in red).
pub const STOP_TIMEOUT_S: f64 = 5.0;

/// What the drive showed of the stop asked for before disconnecting: the log line's
/// words and its colour.
fn stop_verdict(stop: StopChoice, sample: Option<Sample>, live: bool) -> Outcome {
    let Some(sample) = sample.filter(|_| live) else {
        return Outcome::Failed(
            "not confirmed: no live status from the drive (the link is down)".to_owned(),
        );
    };
    let status = sample.tx.status;
    let motion = super::glance::motion_words(&sample);
    if stop == StopChoice::SwitchOff {
        return match sample.statusword().and_then(PowerState::from_statusword) {
            Some(state) if !state.is_energised() => Outcome::Succeeded(format!(
                "confirmed by the drive: power stage off ({}), {motion}",
                state.name()
            )),
            None if !status.is_set(StatusBit::OperationEnabled) => Outcome::Succeeded(format!(
                "confirmed by the drive: PdiStatusOperationEnabled clear, {motion}"
            )),
            _ => Outcome::Failed(format!(
                "not confirmed: the power stage is still on after {STOP_TIMEOUT_S:.0} s, {motion}"
            )),
        };
    }
    let halt_bit = status.is_set(StatusBit::QsHaltBit);
    match (halt_bit, at_rest(&sample)) {
        (true, true) => Outcome::Succeeded(format!(
            "confirmed by the drive: halt bit set (PdiStatusQsHaltBit), {motion}"
        )),
        (true, false) => Outcome::Caution(format!(
            "halt bit set by the drive (PdiStatusQsHaltBit), but still {motion} after {STOP_TIMEOUT_S:.0} s"
        )),
        (false, true) => Outcome::Caution(format!(
            "the drive shows no halt bit, but the motor is {motion}"
        )),
        (false, false) => Outcome::Failed(format!(
            "not confirmed: no halt bit from the drive within {STOP_TIMEOUT_S:.0} s, motor {motion}"
        )),
    }
}

/// Whether the motor stands still: speed under half an rpm, or (speed unknown) the
/// target reached.
fn at_rest(sample: &Sample) -> bool {
    sample
        .at_rest()
        .unwrap_or_else(|| sample.tx.status.is_set(StatusBit::TargetReached))
}

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

    /// Whether leaving this drive needs the question: connected, and energised or with
    /// objects changed that could be restored.
    pub fn needs_leave_question(&self) -> bool {
        let restorable = self.changes.iter().any(|c| c.before.is_some());
        self.is_connected() && (self.power_stage_on() || restorable)
    }

    /// The user wants to disconnect (or close the window): ask first when the drive is
    /// energised or objects were changed; otherwise go.
    pub fn ask_to_leave(&mut self, close_window: bool) {
        let restorable = self.changes.iter().any(|c| c.before.is_some());
        if self.needs_leave_question() {
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

    /// Whether the question waits for this drive's answer.
    pub fn is_asked_to_leave(&self) -> bool {
        self.leaving.is_some_and(|l| l.stage == Stage::Asking)
    }

    /// The user chose: stop the motor now, then restore, then disconnect.
    pub fn confirm_leave(&mut self, stop: StopChoice, restore: bool) {
        let Some(leaving) = self.leaving.as_mut() else {
            return;
        };
        leaving.stop = stop;
        leaving.restore = restore;
        leaving.stage = Stage::Stopping { since: self.clock };
        match stop {
            StopChoice::Halt => self.request(Request::Halt),
            StopChoice::SwitchOff => self.request(Request::Command(Action::SwitchOff)),
            StopChoice::LeaveOn => self.stopped(),
        }
    }

    /// The stop is done (or given up on): restore, then disconnect.
    fn stopped(&mut self) {
        let Some(leaving) = self.leaving.as_mut() else {
            return;
        };
        if leaving.restore {
            leaving.stage = Stage::Restoring { since: self.clock };
            self.restore_changes();
        } else {
            leaving.stage = Stage::Disconnecting;
        }
    }

    /// One frame of waiting for the stop: on when the drive shows it, the stop command
    /// is over, the link is gone or the time is up; the log says what the drive showed.
    fn stopping_step(&mut self, stop: StopChoice, since: f64) {
        let sample = self.latest;
        let live = self.is_live(std::time::SystemTime::now());
        // The halt still queued or running: its outcome is not in yet.
        let waiting = self.outbox.iter().any(Request::is_urgent) || self.halt_pending();
        let shown = match stop {
            StopChoice::Halt => sample.is_some_and(|s| {
                (s.tx.status.is_set(StatusBit::QsHaltBit) || !waiting) && at_rest(&s)
            }),
            StopChoice::SwitchOff => !self.power_stage_on(),
            StopChoice::LeaveOn => true,
        };
        let late = self.clock - since > STOP_TIMEOUT_S;
        if !(shown || late || !self.is_connected()) {
            return;
        }
        let what = match stop {
            StopChoice::SwitchOff => "Switch off before disconnecting",
            _ => "Halt before disconnecting",
        };
        self.push_log(LogEntry {
            at: self.clock,
            id: None,
            what: what.to_owned(),
            image: None,
            outcome: stop_verdict(stop, sample, live),
        });
        self.stopped();
    }

    /// One frame of leaving. `true` when the window may close now.
    pub fn leave_step(&mut self) -> bool {
        let Some(leaving) = self.leaving else {
            return false;
        };
        match leaving.stage {
            Stage::Asking => false,
            Stage::Stopping { since } => {
                self.stopping_step(leaving.stop, since);
                false
            }
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

/// What the motor does, for the question: "The power stage is on: the motor is moving
/// at 300 rpm."; `None` while the power stage is off.
pub fn motor_sentence(state: &AppState) -> Option<String> {
    if !state.power_stage_on() {
        return None;
    }
    let motion = state
        .latest
        .map(|s| super::glance::motion_words(&s))
        .unwrap_or_default();
    let now = std::time::SystemTime::now();
    Some(
        match state.sample_age(now).filter(|_| !state.is_live(now)) {
            Some(age) => format!(
                "The power stage was on ({}): the motor was {motion}.",
                super::state::age_text(age)
            ),
            None => format!("The power stage is on: the motor is {motion}."),
        },
    )
}

/// The user's answer to the question.
enum Answer {
    Stop(StopChoice),
    Cancel,
}

/// How the question ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answered {
    /// A stop was chosen: every drive asked is on its way out.
    Going,
    Cancelled,
}

/// A drive the question may be about: its name and its state.
pub struct Named<'a> {
    pub name: &'a str,
    pub state: &'a mut AppState,
}

/// The question, while it is asked, once for every drive that waits for it (closing the
/// window with several drives energised asks once for all of them).
pub fn leave_dialog(ctx: &egui::Context, drives: &mut [Named<'_>]) -> Option<Answered> {
    let several = drives.len() > 1;
    let asked: Vec<usize> = (0..drives.len())
        .filter(|&i| drives[i].state.is_asked_to_leave())
        .collect();
    let first = drives.get(*asked.first()?)?;
    let leaving = first.state.leaving?;
    let mut restore = leaving.restore;
    let answer = {
        let shown: Vec<(&str, &AppState)> = asked
            .iter()
            .map(|&i| (drives[i].name, &*drives[i].state))
            .collect();
        egui::Modal::new(egui::Id::unique("leave_dialog"))
            .show(ctx, |ui: &mut Ui| {
                leave_question_ui(ui, &shown, several, leaving.close_window, &mut restore)
            })
            .inner
    };
    for &i in &asked {
        let state = &mut *drives[i].state;
        if let Some(l) = state.leaving.as_mut() {
            l.restore = restore;
        }
        match answer {
            Some(Answer::Cancel) => state.leaving = None,
            Some(Answer::Stop(stop)) => state.confirm_leave(stop, restore),
            None => {}
        }
    }
    match answer {
        Some(Answer::Cancel) => Some(Answered::Cancelled),
        Some(Answer::Stop(_)) => Some(Answered::Going),
        None => None,
    }
}

/// The dialog's content: what each motor asked about does, restore or not, and the three
/// ways to go. With `several` drives in the window, each sentence names its drive.
fn leave_question_ui(
    ui: &mut Ui,
    drives: &[(&str, &AppState)],
    several: bool,
    close_window: bool,
    restore: &mut bool,
) -> Option<Answer> {
    let mut answer = None;
    ui.set_max_width(460.0);
    let heading = match (close_window, drives) {
        (true, _) => "Close drivedeck".to_owned(),
        (false, [(name, _)]) if several => format!("Disconnect {name}"),
        (false, _) => "Disconnect".to_owned(),
    };
    ui.heading(heading);
    let mut energised = false;
    for (name, state) in drives {
        if let Some(sentence) = motor_sentence(state) {
            energised = true;
            ui.colored_label(
                AMBER,
                if several {
                    format!("{name}: {sentence}")
                } else {
                    sentence
                },
            );
        }
    }
    if energised {
        ui.label("What should stay behind?");
    }
    let restorable: usize = drives
        .iter()
        .map(|(_, state)| state.changes.iter().filter(|c| c.before.is_some()).count())
        .sum();
    let with_changes = drives
        .iter()
        .filter(|(_, state)| state.changes.iter().any(|c| c.before.is_some()))
        .count();
    if restorable > 0 {
        let on = if with_changes > 1 {
            format!(" on {with_changes} drives")
        } else {
            String::new()
        };
        ui.checkbox(
            restore,
            format!("First restore what I changed ({restorable} objects{on}, newest first)"),
        );
    }
    let each = if drives.len() > 1 { " each" } else { "" };
    ui.add_space(6.0);
    ui.horizontal(|ui| {
        let halt = ui.button(RichText::new(format!("Halt{each}, then disconnect")).strong());
        ui.weak("Enter presses this button");
        // Enter takes the default.
        if halt.clicked() || ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            answer = Some(Answer::Stop(StopChoice::Halt));
        }
    });
    if ui
        .button(RichText::new(format!("Switch off{each}, then disconnect")).color(RED))
        .on_hover_text("Power stage off: the motor coasts and holds no torque")
        .clicked()
    {
        answer = Some(Answer::Stop(StopChoice::SwitchOff));
    }
    if ui
        .button("Leave it as it is, disconnect")
        .on_hover_text("The drive keeps doing what it does")
        .clicked()
    {
        answer = Some(Answer::Stop(StopChoice::LeaveOn));
    }
    ui.separator();
    if ui.button("Cancel").clicked() {
        answer = Some(Answer::Cancel);
    }
    answer
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Status, TxImage};
    use crate::signal::{Signal, Signals};

    /// A sample with these PDI-Status bits, statusword and speed.
    fn sample(bits: &[StatusBit], statusword: u16, rpm: f64) -> Sample {
        Sample {
            tx: TxImage {
                status: Status(bits.iter().fold(0, |word, bit| word | bit.mask())),
                error_code: 0,
                return_value: 0,
            },
            signals: Signals::default()
                .with(Signal::Velocity, rpm)
                .with(Signal::Statusword, f64::from(statusword)),
            ..Default::default()
        }
    }

    #[test]
    fn the_halt_verdict_is_green_only_when_the_drive_shows_the_halt_bit_at_rest() {
        let on = [StatusBit::OperationEnabled, StatusBit::QsHaltBit];
        let halted = sample(&on, 0x0637, 0.0);
        let verdict = stop_verdict(StopChoice::Halt, Some(halted), true);
        assert!(
            matches!(&verdict, Outcome::Succeeded(t) if t == "confirmed by the drive: halt bit set (PdiStatusQsHaltBit), halted, standing still"),
            "{verdict:?}"
        );
        let braking = sample(&on, 0x0637, 120.0);
        assert!(matches!(
            stop_verdict(StopChoice::Halt, Some(braking), true),
            Outcome::Caution(t) if t.contains("still braking, at 120 rpm")
        ));
        let turning = sample(&[StatusBit::OperationEnabled], 0x0637, 300.0);
        assert!(matches!(
            stop_verdict(StopChoice::Halt, Some(turning), true),
            Outcome::Failed(t) if t.contains("no halt bit") && t.contains("moving at 300 rpm")
        ));
        // Without live status nothing is confirmed, whatever the last sample said.
        assert!(matches!(
            stop_verdict(StopChoice::Halt, Some(halted), false),
            Outcome::Failed(t) if t.contains("no live status")
        ));
        let off = sample(&[], 0x0250, 0.0);
        assert!(matches!(
            stop_verdict(StopChoice::SwitchOff, Some(off), true),
            Outcome::Succeeded(t) if t.starts_with("confirmed by the drive: power stage off (Switch on disabled)")
        ));
    }
}
