//! Stopping the drive on the way out of a command (a signal, a --wait that timed out),
//! by the `--on-exit` policy, and saying honestly what came of it.

use std::time::{Duration, Instant};

use super::session::Session;
use crate::pdi::{Action, StatusBit};
use crate::worker::{CommandProgress, Event, LinkLossAction, Request};

/// How long the way out waits for a stop to finish (the drive brakes on its ramp).
pub const STOP_WAIT: Duration = Duration::from_secs(10);

impl Session {
    /// Stop the drive on the way out by `action` (the `--on-exit` policy), and say
    /// honestly what came of it: acknowledged and stopped, still braking, or not reached.
    /// Signals are not caught from here on: a second Ctrl-C ends the process at once.
    pub(super) fn stop_drive(&mut self, action: LinkLossAction, wait: Duration) -> String {
        self.interruptible = false;
        let (what, request) = match action {
            LinkLossAction::Nothing => {
                return format!(
                    "the drive is left as it is (--on-exit leave): {}",
                    self.motion_now()
                );
            }
            LinkLossAction::Halt => ("halt", Request::Halt),
            LinkLossAction::SwitchOff => ("switch-off", Request::Command(Action::SwitchOff)),
        };
        match self.send(request) {
            Ok(id) => self.await_stop(what, id, wait),
            Err(f) => format!(
                "no {what} could be sent ({}): the drive may still be moving; stop it at the machine",
                f.message
            ),
        }
    }

    /// Wait up to `wait` for the stop request `id` (a `what`) to finish, and say what came
    /// of it. A refused halt (no travel command to halt) becomes a quick stop.
    fn await_stop(&mut self, mut what: &'static str, mut id: u64, wait: Duration) -> String {
        let mut instead = String::new();
        let mut acknowledged = false;
        let deadline = Instant::now() + wait;
        loop {
            let event = match self.next(deadline) {
                Ok(event) => event,
                Err(f) => {
                    let sent = format!("{instead}{what} sent");
                    return self.unfinished(&sent, acknowledged, wait, &f.message);
                }
            };
            match event {
                // The halt bit acts on a travel command only: homing and auto setup stop
                // with a quick stop.
                Event::Rejected { id: i, reason, .. } if i == id && what == "halt" => {
                    instead = format!("no halt ({reason}), so ");
                    what = "quick stop";
                    match self.send(Request::Command(Action::Quickstop)) {
                        Ok(next) => id = next,
                        Err(f) => {
                            return format!(
                                "{instead}no quick stop could be sent either ({}): stop the drive at the machine",
                                f.message
                            );
                        }
                    }
                }
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return format!(
                        "the {what} was refused ({reason}): the drive may still be moving; stop it at the machine"
                    );
                }
                Event::Progress { id: i, progress } if i == id => match progress {
                    CommandProgress::Accepted => acknowledged = true,
                    CommandProgress::Done { .. } => {
                        self.refresh();
                        return format!(
                            "{instead}{what} sent; the drive confirmed it: {}",
                            self.motion_now()
                        );
                    }
                    other => {
                        return format!("{instead}{what} sent, but {other}: {}", self.motion_now());
                    }
                },
                _ => {}
            }
        }
    }

    /// The waiting for a stop (`sent`) ended before it finished, for `why`.
    fn unfinished(&self, sent: &str, acknowledged: bool, wait: Duration, why: &str) -> String {
        if acknowledged {
            format!(
                "{sent} and acknowledged, but not finished within {:.1} s ({why}): {}",
                wait.as_secs_f64(),
                self.motion_now()
            )
        } else {
            format!(
                "{sent}, but the drive did not acknowledge it ({why}): it may still be moving; stop it at the machine"
            )
        }
    }

    /// Whether the drive may be moving: the newest sample shows the motor turning, or
    /// its power stage is on and this link does not deliver the velocity.
    pub(super) fn is_moving_or_unknown(&self) -> bool {
        match self.latest {
            Some(s) if s.velocity().is_none() => s.tx.status.is_set(StatusBit::OperationEnabled),
            Some(_) => self.is_moving(),
            None => false,
        }
    }

    /// Whether the newest sample shows the motor turning.
    pub(super) fn is_moving(&self) -> bool {
        self.latest
            .and_then(|s| s.velocity())
            .is_some_and(|v| v.abs() >= 1.0)
    }

    /// What the newest sample says about motion and power, in words.
    pub(super) fn motion_now(&self) -> String {
        let Some(sample) = self.latest else {
            return "no status since".into();
        };
        let power = if sample.tx.status.is_set(StatusBit::OperationEnabled) {
            "power stage on"
        } else {
            "power stage off"
        };
        let halted = if sample.tx.status.is_set(StatusBit::QsHaltBit) {
            ", halt bit set"
        } else {
            ""
        };
        match sample.velocity() {
            Some(v) if v.abs() < crate::signal::AT_REST_RPM => {
                format!("it stands still ({power}{halted})")
            }
            Some(v) => format!("it still turns at {v:.0} rpm ({power}{halted})"),
            None => format!("{power}{halted}"),
        }
    }
}
