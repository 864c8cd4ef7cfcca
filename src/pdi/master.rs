//! `PdiMaster`: the sans-IO state machine every link drives.
//!
//! The link exchanges process images; the master decides what the next RX image is and
//! judges every TX image that comes back. It never touches a clock: the caller passes
//! `now` in, so tests step time by hand.
//!
//! The rules, from spec sections 2.2 and 2.3:
//! * a command is *accepted* when PdiStatusToggleCmd differs from its value before the
//!   command was sent, and *failed* when PdiStatusError is set in that same image (the
//!   ReturnValue then holds the error code);
//! * the same command byte twice is one command to the drive, so the master flips
//!   ToggleCmd (bit 7) whenever a new command has the opcode of the last one sent;
//! * halt adds bit 6 to the travel command; resetting it resumes the old target, and
//!   resetting it while flipping ToggleCmd takes the new set values (spec 2.2.14);
//! * *done* is the status bit the command implies (TargetReached, HomingDone,
//!   AutosetupDone). Those bits may still be set from an earlier command, so a bit counts
//!   only once it has been seen clear after the acknowledgement, or has stayed set for
//!   the settle time.

use std::fmt;
use std::time::{Duration, Instant};

use super::{Action, Command, Error, Opcode, RxImage, SetValues, Status, StatusBit, TxImage};
use crate::cia::{AbortCode, ErrorCode};

/// Timeouts of the master. Defaults suit every bus: a drive answers a PDI command within a
/// few cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    /// How long a command may wait for PdiStatusToggleCmd to flip.
    pub ack_timeout: Duration,
    /// How long a done bit that was already set must stay set to count (see module docs).
    pub settle: Duration,
    /// How long a command may take to finish after its acknowledgement; `None` waits as long
    /// as it takes (the GUI), a script gives a bound.
    pub done_timeout: Option<Duration>,
}

impl Default for Timing {
    fn default() -> Self {
        Self {
            ack_timeout: Duration::from_millis(1000),
            settle: Duration::from_millis(150),
            done_timeout: None,
        }
    }
}

/// How often the drive's RX image is read back while a command runs, and while idle.
pub const READ_BACK_RUNNING: Duration = Duration::from_millis(250);
pub const READ_BACK_IDLE: Duration = Duration::from_secs(1);

/// How often commands the drive took from another master are reported at most.
pub const FOREIGN_REPORT_EVERY: Duration = Duration::from_secs(5);

/// Why a command did not succeed, from the drive's own images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// PdiStatusError was set with the acknowledgement; `code` is PDI-ReturnValue as u32.
    Refused { code: u32 },
    /// PdiStatusFault rose while the command ran; `error_code` is 603Fh.
    DriveFault { error_code: u16 },
    /// Clear Error was acknowledged but the fault stays: its cause is still present.
    FaultPersists { error_code: u16 },
    /// The drive left Operation enabled while a travel command ran (switched off or quick
    /// stopped by someone else, or a fault reaction).
    PowerLost,
    /// PdiStatusToggleCmd flipped although we sent no new command: the drive took a
    /// command from somewhere else (another master writing the PDI image), or a frame
    /// carrying the status was forged or corrupted. `flips` counts them so far.
    AnotherMaster { flips: u32 },
}

impl Failure {
    /// For a refusal, the CiA 301 abort code text when the ReturnValue is one.
    pub fn abort_text(&self) -> Option<&'static str> {
        match self {
            Failure::Refused { code } => AbortCode(*code).text(),
            _ => None,
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::Refused { code } => {
                write!(f, "refused by the drive (PdiStatusError): ReturnValue ")?;
                match AbortCode(*code).text() {
                    Some(text) => write!(f, "{code:08X}h: {text}"),
                    None => write!(f, "{code:08X}h (not a CiA 301 abort code)"),
                }
            }
            Failure::DriveFault { error_code } => {
                write!(f, "drive fault while running: 603Fh = {}", ErrorCode(*error_code))
            }
            Failure::FaultPersists { error_code } => write!(
                f,
                "the fault persists because its cause is still present: 603Fh = {}",
                ErrorCode(*error_code)
            ),
            Failure::PowerLost => f.write_str(
                "the drive left Operation enabled while the command ran (switched off, quick stop or fault)",
            ),
            Failure::AnotherMaster { flips } => write!(
                f,
                "another master writes the PDI image: the drive took {flips} command(s) this \
                 master did not send (PdiStatusToggleCmd flipped on its own, or 2291h read \
                 back held another image), so what it does is not what was asked, and this \
                 master leaves it to the other (no halt sent over its command); stop the other \
                 master (a PLC, Plug & Drive Studio, a second drivedeck) or command the drive \
                 from it (or a frame carrying the status was forged or corrupted)"
            ),
        }
    }
}

/// What the master learned from the images, in the order it happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The drive detected the command (PdiStatusToggleCmd flipped, no PdiStatusError).
    Accepted {
        tag: u64,
    },
    /// The command finished; `return_value` is PDI-ReturnValue of that image (the value read
    /// for OD-Read, the actual value of the mode otherwise).
    Done {
        tag: u64,
        return_value: i32,
    },
    Failed {
        tag: u64,
        failure: Failure,
    },
    TimedOut {
        tag: u64,
        waiting_for: Waiting,
        after: Duration,
    },
    /// A newer command replaced this one before it finished.
    Superseded {
        tag: u64,
        acknowledged: bool,
    },
    /// The drive's last command byte was unknown and equal to ours, so the master flipped
    /// ToggleCmd and sent the command again.
    Resent {
        tag: u64,
    },
}

impl Progress {
    pub fn tag(&self) -> u64 {
        match *self {
            Progress::Accepted { tag }
            | Progress::Done { tag, .. }
            | Progress::Failed { tag, .. }
            | Progress::TimedOut { tag, .. }
            | Progress::Superseded { tag, .. }
            | Progress::Resent { tag } => tag,
        }
    }

    /// Whether the command is over (nothing more will be reported for its tag).
    pub fn is_final(&self) -> bool {
        !matches!(self, Progress::Accepted { .. } | Progress::Resent { .. })
    }
}

/// What a command waits for after its acknowledgement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Waiting {
    Acknowledgement,
    Bit(StatusBit),
    /// Halt: QsHaltBit and TargetReached (the axis stopped).
    Stopped,
    /// Switch Off: PdiStatusOperationEnabled clear.
    PowerOff,
    /// Quickstop: Operation enabled left or QsHaltBit set.
    QuickStop,
    /// Clear Error: PdiStatusFault clear.
    FaultCleared,
}

impl fmt::Display for Waiting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Waiting::Acknowledgement => f.write_str(
                "the acknowledgement (PdiStatusToggleCmd); is the PDI active (2290h bit 0)?",
            ),
            Waiting::Bit(bit) => write!(f, "{}", bit.name()),
            Waiting::Stopped => {
                f.write_str("standstill (PdiStatusQsHaltBit and PdiStatusTargetReached)")
            }
            Waiting::PowerOff => f.write_str("the power stage to switch off"),
            Waiting::QuickStop => f.write_str("the quick stop"),
            Waiting::FaultCleared => f.write_str("PdiStatusFault to clear"),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Command(Action),
    Halt,
    Resume,
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    tag: u64,
    kind: Kind,
    goal: Waiting,
    sent_at: Instant,
    acked_at: Option<Instant>,
    baseline_toggle: bool,
    baseline_halt: bool,
    goal_seen_clear: bool,
    goal_set_since: Option<Instant>,
    enabled_seen: bool,
    resent: bool,
}

impl Pending {
    /// A command just sent, judged against the `status` before it.
    fn sent(tag: u64, kind: Kind, goal: Waiting, status: Status, now: Instant) -> Pending {
        Pending {
            tag,
            kind,
            goal,
            sent_at: now,
            acked_at: None,
            baseline_toggle: status.is_set(StatusBit::ToggleCmd),
            baseline_halt: status.is_set(StatusBit::QsHaltBit),
            goal_seen_clear: false,
            goal_set_since: None,
            enabled_seen: false,
            resent: false,
        }
    }

    /// The drive refused the command after all: PdiStatusError, the code in ReturnValue.
    fn refused(&self, tx: TxImage) -> Progress {
        Progress::Failed {
            tag: self.tag,
            failure: Failure::Refused {
                code: tx.return_value as u32,
            },
        }
    }

    /// For a command waiting for a bit or standstill: whether this image shows the goal.
    fn goal_reached(&self, status: Status) -> bool {
        match self.goal {
            Waiting::Bit(bit) => status.is_set(bit),
            _ => status.is_set(StatusBit::QsHaltBit) && status.is_set(StatusBit::TargetReached),
        }
    }

    /// For a command waiting for a bit or standstill: the failure this image shows, if any.
    /// `foreground` is false for a move watched under a later command.
    fn motion_failed(&self, tx: TxImage, foreground: bool) -> Option<Progress> {
        let status = tx.status;
        let travel_like = matches!(self.kind, Kind::Resume)
            || matches!(self.kind, Kind::Command(a) if a.opcode().energises());
        if foreground && status.is_set(StatusBit::Error) {
            // The drive gave up on the command after accepting it (e.g. a homing
            // run that found no switch).
            return Some(self.refused(tx));
        }
        if status.is_set(StatusBit::Fault) && self.goal != Waiting::Stopped {
            return Some(Progress::Failed {
                tag: self.tag,
                failure: Failure::DriveFault {
                    error_code: tx.error_code,
                },
            });
        }
        if travel_like && self.enabled_seen && !status.is_set(StatusBit::OperationEnabled) {
            return Some(Progress::Failed {
                tag: self.tag,
                failure: Failure::PowerLost,
            });
        }
        None
    }
}

/// The travel command the halt bit belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Travel {
    pub action: Action,
    pub halted: bool,
}

/// The sans-IO PDI master. See the module documentation for its rules.
#[derive(Debug)]
pub struct PdiMaster {
    timing: Timing,
    last_sent: Option<RxImage>,
    /// Whether `last_sent` is known to be what the drive holds (adopted or sent by us).
    device_cmd_known: bool,
    last_tx: Option<TxImage>,
    pending: Option<Pending>,
    /// A move still running while a later OD access or NOP is judged.
    background: Option<Pending>,
    travel: Option<Travel>,
    progress: Vec<Progress>,
    /// PdiStatusToggleCmd in the last image, to see it flip.
    status_toggle: Option<bool>,
    /// Flips of PdiStatusToggleCmd our own commands may still cause (each new command
    /// byte sent, a halt or resume too in case the drive counts it as new), until the
    /// acknowledgement timeout after the last one sent: later flips are not ours.
    flips_expected: u32,
    expect_flips_until: Option<Instant>,
    /// Flips seen that no command of ours explains, since the last `take_foreign`.
    foreign: u32,
    /// When the flips were last reported by [`PdiMaster::foreign_report`].
    foreign_said: Option<Instant>,
    /// The image sent before `last_sent` (a bus that applies images late may still show
    /// it when read back).
    sent_before: Option<RxImage>,
    /// When the drive's RX image was last read back to compare with ours.
    read_back_at: Option<Instant>,
}

impl PdiMaster {
    pub fn new(timing: Timing) -> Self {
        Self {
            timing,
            last_sent: None,
            device_cmd_known: false,
            last_tx: None,
            pending: None,
            background: None,
            travel: None,
            progress: Vec::new(),
            status_toggle: None,
            flips_expected: 0,
            expect_flips_until: None,
            foreign: 0,
            foreign_said: None,
            sent_before: None,
            read_back_at: None,
        }
    }

    /// How many commands the drive took since the last call that this master did not
    /// send (PdiStatusToggleCmd flipped on its own): another master writes the PDI image,
    /// or a status frame was forged. Also reported to a running command as
    /// [`Failure::AnotherMaster`].
    pub fn take_foreign(&mut self) -> u32 {
        std::mem::take(&mut self.foreign)
    }

    /// Whether the drive's RX image (2291h) should be read back now and given to
    /// [`PdiMaster::on_read_back`]: every [`READ_BACK_RUNNING`] while a command of ours
    /// runs or a travel command is not halted, every [`READ_BACK_IDLE`] otherwise, once
    /// something was sent. Another master that writes its image every cycle right before
    /// it reads the status sees its own toggle echoed each time; only the image read
    /// between two of its writes shows it.
    pub fn read_back_due(&self, now: Instant) -> bool {
        if self.last_sent.is_none() || !self.device_cmd_known {
            return false;
        }
        let busy = self.pending.is_some() || self.background.is_some() || self.travel_running();
        let every = if busy {
            READ_BACK_RUNNING
        } else {
            READ_BACK_IDLE
        };
        self.read_back_at
            .is_none_or(|at| now.saturating_duration_since(at) >= every)
    }

    /// A read-back was asked for now (whether it comes or not, the next is due a period
    /// later).
    pub fn read_back_tried(&mut self, now: Instant) {
        self.read_back_at = Some(now);
    }

    /// The RX image the drive holds, read back before our next write: an image that is
    /// neither ours nor the one before it was written by somebody else (counted like a
    /// flip of the toggle, and fails the commands running).
    pub fn on_read_back(&mut self, rx: RxImage, now: Instant) {
        self.read_back_at = Some(now);
        let ours = [self.last_sent, self.sent_before];
        if ours.iter().flatten().any(|sent| *sent == rx) || self.last_sent.is_none() {
            return;
        }
        self.foreign += 1;
        self.fail_on_foreign();
    }

    /// The commands taken from elsewhere, to tell the user: at most every
    /// [`FOREIGN_REPORT_EVERY`] (another master writing cyclically flips the toggle in
    /// every cycle), the count since the last report.
    pub fn foreign_report(&mut self, now: Instant) -> Option<u32> {
        if self.foreign == 0
            || self
                .foreign_said
                .is_some_and(|said| now.saturating_duration_since(said) < FOREIGN_REPORT_EVERY)
        {
            return None;
        }
        self.foreign_said = Some(now);
        Some(self.take_foreign())
    }

    pub fn timing(&self) -> Timing {
        self.timing
    }

    pub fn set_timing(&mut self, timing: Timing) {
        self.timing = timing;
    }

    /// Start from the RX image the drive holds now (read from 2291h on connect), so that
    /// the first image the link writes changes nothing and nothing from an earlier session
    /// is replayed.
    pub fn adopt(&mut self, rx: RxImage) {
        self.last_sent = Some(rx);
        self.sent_before = None;
        self.device_cmd_known = true;
        self.status_toggle = None;
        self.flips_expected = 0;
        // A travel command the drive holds (e.g. from another master, or a script that
        // exited) can be halted and resumed from here.
        if let Ok(command) = rx.command()
            && command.opcode.is_travel()
        {
            self.travel = Some(Travel {
                action: Action::from_set_values(command.opcode, rx.values),
                halted: command.halt,
            });
        }
    }

    /// The image the link should write, or `None` while nothing has been commanded and
    /// the drive's own image is unknown (the link then only reads).
    pub fn outgoing(&self) -> Option<RxImage> {
        self.last_sent
    }

    pub fn last_tx(&self) -> Option<TxImage> {
        self.last_tx
    }

    /// The travel command the halt bit would act on, if any.
    pub fn travel(&self) -> Option<Travel> {
        self.travel
    }

    pub fn is_halted(&self) -> bool {
        self.travel.is_some_and(|t| t.halted)
    }

    /// Whether a command is still waiting for the drive to detect it.
    pub fn is_awaiting_ack(&self) -> bool {
        self.pending.is_some_and(|p| p.acked_at.is_none())
    }

    /// Whether a travel command runs without the halt bit (the motor may be moving).
    pub fn travel_running(&self) -> bool {
        self.travel.is_some_and(|t| !t.halted)
    }

    /// The tag of the command still running, if any.
    pub fn pending_tag(&self) -> Option<u64> {
        self.pending.map(|p| p.tag)
    }

    /// The tag of a move still watched under a later OD access, if any.
    pub fn background_tag(&self) -> Option<u64> {
        self.background.map(|p| p.tag)
    }

    /// Everything learned since the last call.
    pub fn drain_progress(&mut self) -> Vec<Progress> {
        std::mem::take(&mut self.progress)
    }

    /// Send a new command. Returns the image to write.
    pub fn start(&mut self, tag: u64, action: Action, now: Instant) -> Result<RxImage, Error> {
        let status = self.last_tx.ok_or(Error::NoStatusYet)?.status;
        let opcode = action.opcode();
        let toggle = match self.last_sent {
            Some(last) => {
                let last_toggle = last.cmd & Command::TOGGLE_BIT != 0;
                if last.cmd & Command::OPCODE_MASK == opcode.value() {
                    !last_toggle
                } else {
                    last_toggle
                }
            }
            None => false,
        };
        let image = RxImage::new(
            action.set_values(),
            Command {
                opcode,
                halt: false,
                toggle,
            },
        );
        self.make_way(Some(opcode));
        if opcode.is_travel() {
            self.travel = Some(Travel {
                action,
                halted: false,
            });
        } else if matches!(
            opcode,
            Opcode::SwitchOff
                | Opcode::Quickstop
                | Opcode::Homing
                | Opcode::HomeHere
                | Opcode::AutoSetup
        ) {
            // These end the travel command: a later halt has nothing to act on.
            self.travel = None;
        }
        let kind = Kind::Command(action);
        self.expect_flip(now);
        self.pending = Some(Pending::sent(tag, kind, goal_of(opcode), status, now));
        self.sent_before = self.last_sent.replace(image);
        Ok(image)
    }

    /// Set the halt bit on the travel command: the drive brakes to speed 0 and stays
    /// energised (spec 2.2.14).
    pub fn halt(&mut self, tag: u64, now: Instant) -> Result<RxImage, Error> {
        self.set_halt(tag, now, true)
    }

    /// Reset the halt bit: the drive continues to the old target with the old set values
    /// (spec 2.2.14). To take new values instead, `start` a new travel command; the master
    /// then resets halt and flips ToggleCmd together.
    pub fn resume(&mut self, tag: u64, now: Instant) -> Result<RxImage, Error> {
        self.set_halt(tag, now, false)
    }

    /// The travel command again, with the halt bit set or reset and ToggleCmd as it was.
    fn set_halt(&mut self, tag: u64, now: Instant, halt: bool) -> Result<RxImage, Error> {
        let status = self.last_tx.ok_or(Error::NoStatusYet)?.status;
        let travel = self.travel.ok_or(Error::NoTravel)?;
        if !halt && !travel.halted {
            return Err(Error::NotHalted);
        }
        let toggle = self
            .last_sent
            .is_some_and(|last| last.cmd & Command::TOGGLE_BIT != 0);
        let opcode = travel.action.opcode();
        let image = RxImage::new(
            travel.action.set_values(),
            Command {
                opcode,
                halt,
                toggle,
            },
        );
        self.make_way(None);
        // The halt bit alone is no new command (spec 2.2.14), but a drive that counts it as
        // one is not taken for another master.
        self.expect_flip(now);
        self.travel = Some(Travel {
            halted: halt,
            ..travel
        });
        let (kind, goal) = if halt {
            (Kind::Halt, Waiting::Stopped)
        } else {
            (Kind::Resume, goal_of(opcode))
        };
        self.pending = Some(Pending::sent(tag, kind, goal, status, now));
        self.sent_before = self.last_sent.replace(image);
        Ok(image)
    }

    /// Forget the commands in flight without a verdict (the link was lost). Returns their
    /// tags.
    pub fn abandon(&mut self) -> Vec<u64> {
        // The drive may have taken anything while the link was down: judge flips afresh.
        self.status_toggle = None;
        self.flips_expected = 0;
        [self.pending.take(), self.background.take()]
            .into_iter()
            .flatten()
            .map(|p| p.tag)
            .collect()
    }

    /// Judge one TX image from the drive.
    pub fn on_tx(&mut self, tx: TxImage, now: Instant) {
        self.last_tx = Some(tx);
        if self.foreign_flip(tx.status, now) {
            self.foreign += 1;
            self.fail_on_foreign();
        }
        if let Some(mut p) = self.background.take() {
            // A move still running under a later OD access: judge its completion only
            // (PdiStatusError now belongs to the later command).
            match self.judge(&mut p, tx, now, false) {
                Some(verdict) => self.progress.push(verdict),
                None => self.background = Some(p),
            }
        }
        let Some(mut p) = self.pending.take() else {
            return;
        };
        let status = tx.status;
        if p.acked_at.is_none() {
            let toggled = status.is_set(StatusBit::ToggleCmd) != p.baseline_toggle;
            let halt_edge = match p.kind {
                Kind::Halt => !p.baseline_halt && status.is_set(StatusBit::QsHaltBit),
                Kind::Resume => p.baseline_halt && !status.is_set(StatusBit::QsHaltBit),
                Kind::Command(_) => false,
            };
            if !toggled && !halt_edge {
                self.pending = Some(p);
                return;
            }
            if toggled && status.is_set(StatusBit::Error) {
                self.progress.push(p.refused(tx));
                return;
            }
            p.acked_at = Some(now);
            self.device_cmd_known = true;
            self.progress.push(Progress::Accepted { tag: p.tag });
        }
        match self.judge(&mut p, tx, now, true) {
            Some(verdict) => self.progress.push(verdict),
            None => self.pending = Some(p),
        }
    }

    /// Check the clocks: acknowledgement and completion timeouts.
    pub fn poll(&mut self, now: Instant) {
        if let Some(p) = self.background.take() {
            match self.overdue(&p, now) {
                Some(verdict) => self.progress.push(verdict),
                None => self.background = Some(p),
            }
        }
        let Some(mut p) = self.pending.take() else {
            return;
        };
        if p.acked_at.is_none() {
            let waited = now.saturating_duration_since(p.sent_at);
            if !self.device_cmd_known && !p.resent && waited >= self.timing.ack_timeout / 2 {
                // The drive may hold our exact byte from before we connected: flip
                // ToggleCmd once so it sees a new command.
                self.sent_before = self.last_sent;
                if let Some(last) = self.last_sent.as_mut() {
                    last.cmd ^= Command::TOGGLE_BIT;
                }
                self.expect_flip(now);
                p.resent = true;
                self.progress.push(Progress::Resent { tag: p.tag });
            }
        }
        match self.overdue(&p, now) {
            Some(verdict) => self.progress.push(verdict),
            None => self.pending = Some(p),
        }
    }

    /// Whether PdiStatusToggleCmd flipped in this status without a command of ours to
    /// explain it.
    fn foreign_flip(&mut self, status: Status, now: Instant) -> bool {
        let toggle = status.is_set(StatusBit::ToggleCmd);
        let before = self.status_toggle.replace(toggle);
        if before.is_none_or(|before| before == toggle) {
            return false;
        }
        if self.expect_flips_until.is_none_or(|until| now > until) {
            self.flips_expected = 0;
        }
        if self.flips_expected > 0 {
            self.flips_expected -= 1;
            return false;
        }
        true
    }

    /// A command of ours was sent: the drive may flip PdiStatusToggleCmd once more for it,
    /// within the acknowledgement timeout.
    fn expect_flip(&mut self, now: Instant) {
        self.flips_expected += 1;
        self.expect_flips_until = Some(now + self.timing.ack_timeout);
    }

    /// A command the drive took from elsewhere: the commands of ours still running can no
    /// longer be judged by the images (a done bit may be the other master's).
    fn fail_on_foreign(&mut self) {
        let failure = Failure::AnotherMaster {
            flips: self.foreign,
        };
        for p in [self.pending.take(), self.background.take()]
            .into_iter()
            .flatten()
        {
            self.progress.push(Progress::Failed {
                tag: p.tag,
                failure,
            });
        }
    }

    /// The verdict on a command that waited too long, if it did.
    fn overdue(&self, p: &Pending, now: Instant) -> Option<Progress> {
        match p.acked_at {
            None => {
                let waited = now.saturating_duration_since(p.sent_at);
                (waited >= self.timing.ack_timeout).then_some(Progress::TimedOut {
                    tag: p.tag,
                    waiting_for: Waiting::Acknowledgement,
                    after: waited,
                })
            }
            Some(acked_at) => {
                let waited = now.saturating_duration_since(acked_at);
                let limit = match p.goal {
                    Waiting::Bit(_) | Waiting::Stopped => self.timing.done_timeout,
                    _ => Some(self.timing.ack_timeout.max(self.timing.settle)),
                };
                if limit.is_none_or(|limit| waited < limit) {
                    return None;
                }
                Some(if p.goal == Waiting::FaultCleared {
                    Progress::Failed {
                        tag: p.tag,
                        failure: Failure::FaultPersists {
                            error_code: self.last_tx.unwrap_or_default().error_code,
                        },
                    }
                } else {
                    Progress::TimedOut {
                        tag: p.tag,
                        waiting_for: p.goal,
                        after: waited,
                    }
                })
            }
        }
    }

    /// Decide whether an acknowledged command is done or failed from one image.
    /// `foreground` is false for a move watched under a later command: PdiStatusError then
    /// belongs to that later command.
    fn judge(
        &self,
        p: &mut Pending,
        tx: TxImage,
        now: Instant,
        foreground: bool,
    ) -> Option<Progress> {
        let status = tx.status;
        let acked_at = p.acked_at?;
        let done = Progress::Done {
            tag: p.tag,
            return_value: tx.return_value,
        };
        match p.goal {
            Waiting::Acknowledgement => Some(done),
            Waiting::PowerOff => (!status.is_set(StatusBit::OperationEnabled)).then_some(done),
            Waiting::QuickStop => (!status.is_set(StatusBit::OperationEnabled)
                || status.is_set(StatusBit::QsHaltBit))
            .then_some(done),
            Waiting::FaultCleared => {
                if !status.is_set(StatusBit::Fault) {
                    Some(done)
                } else if now.saturating_duration_since(acked_at) >= self.timing.settle {
                    Some(Progress::Failed {
                        tag: p.tag,
                        failure: Failure::FaultPersists {
                            error_code: tx.error_code,
                        },
                    })
                } else {
                    None
                }
            }
            Waiting::Bit(_) | Waiting::Stopped => {
                if let Some(failed) = p.motion_failed(tx, foreground) {
                    return Some(failed);
                }
                if status.is_set(StatusBit::OperationEnabled) {
                    p.enabled_seen = true;
                }
                if !p.goal_reached(status) {
                    p.goal_seen_clear = true;
                    p.goal_set_since = None;
                    return None;
                }
                let since = *p.goal_set_since.get_or_insert(now);
                let settled = now.saturating_duration_since(since) >= self.timing.settle;
                // A watched move reports the actual value of its own mode, which the
                // ReturnValue no longer shows; report it only as done.
                (p.goal_seen_clear || settled).then_some(done)
            }
        }
    }

    /// Make way for a new command. A move that is acknowledged and still running stays
    /// watched when the new command is an OD access or NOP, which leave it running;
    /// anything else supersedes it.
    fn make_way(&mut self, next: Option<Opcode>) {
        let keeps_motion = matches!(next, Some(Opcode::OdRead | Opcode::OdWrite | Opcode::Nop));
        if let Some(p) = self.pending.take() {
            let watchable = p.acked_at.is_some()
                && matches!(p.goal, Waiting::Bit(_))
                && (matches!(p.kind, Kind::Resume)
                    || matches!(p.kind, Kind::Command(a) if a.opcode().energises()));
            if keeps_motion && watchable {
                if let Some(old) = self.background.replace(p) {
                    self.progress.push(Progress::Superseded {
                        tag: old.tag,
                        acknowledged: true,
                    });
                }
            } else {
                self.progress.push(Progress::Superseded {
                    tag: p.tag,
                    acknowledged: p.acked_at.is_some(),
                });
            }
        }
        if !keeps_motion && let Some(old) = self.background.take() {
            self.progress.push(Progress::Superseded {
                tag: old.tag,
                acknowledged: true,
            });
        }
    }

    /// The set values a travel command would be resumed with (for display).
    pub fn travel_values(&self) -> Option<SetValues> {
        self.travel.map(|t| t.action.set_values())
    }
}

fn goal_of(opcode: Opcode) -> Waiting {
    match opcode {
        Opcode::Nop | Opcode::OdRead | Opcode::OdWrite => Waiting::Acknowledgement,
        Opcode::SwitchOff => Waiting::PowerOff,
        Opcode::Quickstop => Waiting::QuickStop,
        Opcode::ClearError => Waiting::FaultCleared,
        Opcode::AutoSetup => Waiting::Bit(StatusBit::AutosetupDone),
        Opcode::HomeHere | Opcode::Homing => Waiting::Bit(StatusBit::HomingDone),
        Opcode::MoveAbsolute | Opcode::MoveRelative | Opcode::Velocity | Opcode::Torque => {
            Waiting::Bit(StatusBit::TargetReached)
        }
    }
}
