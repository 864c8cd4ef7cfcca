//! Leaving a drive safely: on Disconnect (or closing the window) with the power stage on
//! or objects changed, the window asks what to leave behind — halt (the default), switch
//! off, or leave it on — and offers to restore what the tool changed first. Then it does
//! that in order, a step a frame: stop, give back what the panels hold (forced outputs:
//! always, whatever was answered), restore, disconnect (and close). The question itself
//! is `ui::leave`'s.
//!
//! A model: no egui here.

use super::Drive;
use super::link::Connection;
use super::log::{LogEntry, Outcome};
use crate::cia::PowerState;
use crate::pdi::{Action, StatusBit};
use crate::ui::glance::model::motion_words;
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
    /// The panels give back what they hold (forced outputs); since (window clock).
    Releasing { since: f64 },
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
/// How long giving back forced outputs may take before the window goes on anyway (and
/// says so, in red).
const RELEASE_TIMEOUT_S: f64 = 5.0;
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
    let motion = motion_words(&sample);
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

impl Drive {
    /// Whether the power stage is on (from 6041h, or the PDI bit where 6041h is unknown).
    pub fn power_stage_on(&self) -> bool {
        let Some(sample) = self.link.latest else {
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
        let restorable = self.restorable() > 0;
        let holding = !self.panels.holding().is_empty();
        self.is_connected() && (self.power_stage_on() || restorable || holding)
    }

    /// The user wants to disconnect (or close the window): ask first when the drive is
    /// energised or objects were changed; otherwise go.
    pub fn ask_to_leave(&mut self, close_window: bool) {
        let restorable = self.restorable() > 0;
        if self.needs_leave_question() {
            self.leaving = Some(Leaving {
                close_window,
                stop: StopChoice::Halt,
                restore: restorable,
                stage: Stage::Asking,
            });
        } else {
            let held = self.panels.holding();
            if !held.is_empty() {
                // Nothing can reach the drive: say what stays behind on it.
                self.log.push(LogEntry {
                    at: self.clock,
                    id: None,
                    what: "Give forced outputs back before disconnecting".to_owned(),
                    image: None,
                    outcome: Outcome::Failed(format!(
                        "not given back (no link to the drive): {} — it stays so on the drive",
                        held.join("; ")
                    )),
                });
            }
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

    /// The stop is done (or given up on): the panels give back what they hold, then
    /// restore, then disconnect.
    fn stopped(&mut self) {
        let held = self.panels.holding();
        if held.is_empty() {
            return self.released();
        }
        self.panels.let_go();
        self.info(format!(
            "giving back before disconnecting: {}",
            held.join("; ")
        ));
        if let Some(l) = self.leaving.as_mut() {
            l.stage = Stage::Releasing { since: self.clock };
        }
    }

    /// One frame of waiting for the panels to give back what they held: on when they
    /// have, the link is gone or the time is up; the log says which.
    fn releasing_step(&mut self, since: f64) {
        let held = self.panels.holding();
        let late = self.clock - since > RELEASE_TIMEOUT_S;
        let connected = self.is_connected();
        if !(held.is_empty() || late || !connected) {
            return;
        }
        let outcome = if held.is_empty() {
            Outcome::Succeeded("given back to the drive".to_owned())
        } else {
            let why = if connected {
                format!("no answer within {RELEASE_TIMEOUT_S:.0} s")
            } else {
                "the link is down".to_owned()
            };
            Outcome::Failed(format!(
                "not given back ({why}): {} — it stays so on the drive",
                held.join("; ")
            ))
        };
        self.log.push(LogEntry {
            at: self.clock,
            id: None,
            what: "Give forced outputs back before disconnecting".to_owned(),
            image: None,
            outcome,
        });
        self.released();
    }

    /// What the panels held is given back (or given up on): restore, then disconnect.
    fn released(&mut self) {
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
        let sample = self.link.latest;
        let live = self.is_live(std::time::SystemTime::now());
        // The halt still queued or running: its outcome is not in yet.
        let waiting = self.waiting().any(Request::is_urgent) || self.halt_pending();
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
        self.log.push(LogEntry {
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
            Stage::Releasing { since } => {
                self.releasing_step(since);
                false
            }
            Stage::Restoring { since } => {
                let pending = self.restorable() > 0;
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
                if self.is_connected() || matches!(self.link.connection, Connection::Failed { .. })
                {
                    self.request(Request::Disconnect);
                }
                leaving.close_window
            }
        }
    }
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
