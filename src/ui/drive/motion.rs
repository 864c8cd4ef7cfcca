//! What the window knows of the motion it commands on a drive: the halt toggle, why the
//! drive last stopped or refused, the torque slope a torque command needs, the last object
//! read or written from the command panel, and a jog held. The user's requests go out
//! through [`Drive::request`], which keeps these in step.
//!
//! A model: no egui here.

use std::time::SystemTime;

use super::Drive;
use super::link::clock_text;
use super::requests::Owner;
use crate::od::{Address, Value};
use crate::pdi::Action;
use crate::ui::command::Command;
use crate::worker::{JOG_KEEPALIVE, ObjectError, Request, RequestId};

/// 6087h, Torque Slope: read on connect, so a torque command with slope 0 can be warned
/// about before it is sent.
pub const TORQUE_SLOPE: Address = Address::new(0x6087, 0);

/// Fastest jog the box accepts, rpm.
pub const JOG_MAX_SPEED: i32 = 3000;

/// A value read from the drive for the command panel (the OD-Read box, "any object").
#[derive(Clone, Debug, PartialEq)]
pub struct ReadBack {
    pub address: Address,
    pub result: Result<Value, ObjectError>,
}

/// A torque command waiting for the user's answer because 6087h is 0.
#[derive(Clone, Debug, PartialEq)]
pub struct TorqueWarning {
    pub action: Action,
}

/// A jog held in the window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JogHold {
    /// -1 or +1.
    pub direction: i32,
    pub speed: i32,
    /// When the last jog request or keep-alive went out (the window's clock).
    pub sent_at: f64,
}

/// The motion the window commands on a drive.
#[derive(Clone, Debug, Default)]
pub struct Motion {
    /// Whether the user holds the halt toggle on.
    pub halt_engaged: bool,
    /// The halt request still running.
    pub(super) halt_request: Option<RequestId>,
    /// Why the drive last stopped or refused, in one line for the state tile (a quick
    /// stop sent, a command refused); cleared by the next command.
    pub why: Option<String>,
    /// 6087h as last read (None = unknown).
    pub torque_slope: Option<i64>,
    pub torque_warning: Option<TorqueWarning>,
    /// The last OD-Read/OD-Write result of the command panel.
    pub last_object: Option<ReadBack>,
    /// A jog button (or arrow key) held.
    pub jog: Option<JogHold>,
    /// A stop ended the jog: nothing jogs again until the button is released.
    pub jog_blocked: bool,
}

/// The jog speed as typed, or why it cannot be used.
pub fn jog_speed(text: &str) -> Result<i32, String> {
    text.trim()
        .parse::<i32>()
        .ok()
        .filter(|v| (1..=JOG_MAX_SPEED).contains(v))
        .ok_or_else(|| format!("jog speed '{text}' is not 1 to {JOG_MAX_SPEED} rpm"))
}

impl Drive {
    /// Queue a request of the user's for the worker: the halt toggle, the jog and the
    /// reason on the state tile follow it.
    pub fn request(&mut self, request: Request) {
        let motion = &mut self.motion;
        match &request {
            Request::Command(action)
                if (action.opcode().is_travel()
                    || matches!(action, Action::Quickstop | Action::SwitchOff)) =>
            {
                motion.halt_engaged = false;
                if matches!(action, Action::Quickstop | Action::SwitchOff) {
                    // A stop ends the jog; holding on does not start it again.
                    if motion.jog.take().is_some() {
                        motion.jog_blocked = true;
                    }
                }
            }
            Request::Jog { .. } => motion.halt_engaged = false,
            Request::Halt => motion.halt_engaged = true,
            Request::Resume => motion.halt_engaged = false,
            _ => {}
        }
        self.note_why(&request);
        self.requests.push(Owner::User, request);
    }

    /// A stop from the window, put ahead of everything waiting.
    pub fn stop_now(&mut self, action: Action) {
        self.request(Request::Command(action));
        if let Some(stop) = self.requests.take_last() {
            self.requests.push_first(stop.0, stop.1);
        }
    }

    /// A stop sent from the window is the reason for what follows; any other command
    /// makes the last reason old news.
    fn note_why(&mut self, request: &Request) {
        let at = clock_text(SystemTime::now());
        match request {
            Request::Command(Action::Quickstop) => {
                self.motion.why = Some(format!("Quickstop sent from this window at {at}"));
            }
            Request::Command(Action::SwitchOff) => {
                self.motion.why = Some(format!("Switch off sent from this window at {at}"));
            }
            Request::Command(_) | Request::Halt | Request::Resume | Request::Jog { .. } => {
                self.motion.why = None;
            }
            _ => {}
        }
    }

    /// Whether a halt the window sent is still queued or running.
    pub fn halt_pending(&self) -> bool {
        self.motion.halt_request.is_some()
    }

    /// One frame of the jog: `direction` is what is held now (0: nothing).
    pub fn jog_step(&mut self, direction: i32, speed: i32) {
        let keepalive = JOG_KEEPALIVE.as_secs_f64();
        if self.motion.jog_blocked {
            if direction == 0 {
                self.motion.jog_blocked = false;
            }
            return;
        }
        match (self.motion.jog, direction) {
            (None, 0) => {}
            (None, d) => self.start_jog(d, speed),
            (Some(_), 0) => {
                self.motion.jog = None;
                self.request(Request::JogStop);
            }
            (Some(hold), d) if d != hold.direction || speed != hold.speed => {
                self.start_jog(d, speed)
            }
            (Some(hold), _) => {
                if self.clock - hold.sent_at >= keepalive {
                    self.requests.push(Owner::Window, Request::JogKeepAlive);
                    self.motion.jog = Some(JogHold {
                        sent_at: self.clock,
                        ..hold
                    });
                }
            }
        }
    }

    /// The window lost the focus while a jog was held: it no longer sees the release, so
    /// the jog stops now and waits for the button to be let go.
    pub fn jog_focus_lost(&mut self) {
        if self.motion.jog.is_some() {
            self.jog_step(0, 0);
            self.motion.jog_blocked = true;
        }
    }

    fn start_jog(&mut self, direction: i32, speed: i32) {
        self.motion.jog = Some(JogHold {
            direction,
            speed,
            sent_at: self.clock,
        });
        self.request(Request::Jog {
            speed: direction * speed,
        });
    }

    /// Send a command the user asked for, stopping first to warn about a torque command
    /// that cannot work (6087h is 0 or unknown).
    pub fn send_command(&mut self, request: Request) {
        if let Request::Command(action @ Action::Torque { .. }) = request
            && self.motion.torque_slope.is_none_or(|slope| slope <= 0)
        {
            self.motion.torque_warning = Some(TorqueWarning { action });
            return;
        }
        self.request(request);
    }
}

impl Drive {
    /// Apply a user's command that is this drive's (a request, a command to send, a jog,
    /// a fault to inject, a restore, connecting, leaving); any other comes back for the
    /// window to apply.
    pub fn apply_command(&mut self, command: Command) -> Option<Command> {
        match command {
            Command::Connect(spec) => self.ask(Request::Connect(spec)),
            Command::Disconnect => self.ask_to_leave(false),
            Command::Request(request) => self.request(request),
            Command::SendCommand(request) => self.send_command(request),
            Command::RestoreChanges => self.restore_changes(),
            Command::Inject { injection, active } => {
                if !injection.is_link() {
                    if active {
                        self.link.injected.push(injection);
                    } else {
                        self.link.injected.retain(|i| *i != injection);
                    }
                }
                self.request(Request::Inject { injection, active });
            }
            Command::Jog { direction, speed } => self.jog_step(direction, speed),
            Command::JogFocusLost => self.jog_focus_lost(),
            other => return Some(other),
        }
        None
    }
}
