//! One action against one drive: connect through the worker, do it, report, exit.

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::interrupt::{self, Signal};
use super::report::{self, Report};
use super::{Command, DiscoverArgs, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_USAGE, Via};
use crate::link::LinkSpec;
use crate::od::{self, Address, DataType, Value};
use crate::pdi::{Action, Opcode, StatusBit, Timing};
use crate::worker::{
    self, CommandProgress, Event, LinkLossAction, ObjectPath, Request, Sample, Worker,
};

/// What the command line does at the edges: what an interrupted or timed-out move, or a
/// lost link, leaves the drive in, and how many failed exchanges in a row lose the link.
/// Set once from the flags (`--on-exit`, `--lost-after`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Policy {
    pub on_exit: LinkLossAction,
    pub lost_after: u32,
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            on_exit: LinkLossAction::Halt,
            lost_after: worker::LOST_AFTER,
        }
    }
}

static POLICY: std::sync::OnceLock<Policy> = std::sync::OnceLock::new();

/// Set the policy from the command line's flags (once; later calls change nothing).
pub fn set_policy(policy: Policy) {
    let _ = POLICY.set(policy);
}

fn policy() -> Policy {
    POLICY.get().copied().unwrap_or_default()
}

/// What an interrupted command leaves the drive in (`--on-exit`).
pub(super) fn on_exit() -> LinkLossAction {
    policy().on_exit
}

/// Why a one-shot command did not succeed: the message and the exit code.
pub(super) struct Failure {
    pub(super) code: u8,
    pub(super) message: String,
    /// The signal that ended it, if one did.
    pub(super) signal: Option<Signal>,
    /// The command it ended may still run on the drive (a signal, a --wait that timed
    /// out): stop the drive by the `--on-exit` policy before exiting.
    pub(super) stop: bool,
}

impl Failure {
    /// This failure with more said after its message.
    fn and(mut self, more: impl std::fmt::Display) -> Failure {
        self.message = format!("{}; {more}", self.message);
        self
    }
}

fn interrupted(signal: Signal) -> Failure {
    Failure {
        code: EXIT_INTERRUPTED,
        message: format!("interrupted by {signal}"),
        signal: Some(signal),
        stop: true,
    }
}

pub(super) fn usage(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_USAGE,
        message: message.into(),
        signal: None,
        stop: false,
    }
}

pub(super) fn failed(message: impl Into<String>) -> Failure {
    Failure {
        code: EXIT_FAILED,
        message: message.into(),
        signal: None,
        stop: false,
    }
}

/// Samples kept from the start of a session for a recording (the rest are the
/// recording's own business).
const EARLY_LIMIT: usize = 100_000;

pub fn run(
    link: &LinkSpec,
    command: &Command,
    json: bool,
    timeout: Duration,
    trace: bool,
) -> ExitCode {
    match execute(link, command, timeout, trace) {
        Ok(report) => {
            report::print(&report, json);
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

/// The session of one command.
pub(super) struct Session {
    worker: Worker,
    latest: Option<Sample>,
    /// Every sample received while connecting, oldest first (a recording starts there).
    early: Vec<Sample>,
    keep_samples: bool,
    /// Whether the signals are caught: waiting then ends at a signal.
    interruptible: bool,
    warnings: Vec<String>,
    notes: Vec<String>,
}

impl Session {
    pub(super) fn open(
        link: &LinkSpec,
        timeout: Duration,
        trace: bool,
    ) -> Result<Session, Failure> {
        Session::open_at(link, timeout, trace, 200.0, false)
    }

    /// A session whose worker polls (and samples) `poll_rate` times a second; with
    /// `keep_samples`, every sample from the first on is kept for
    /// [`Session::take_early_samples`] (a recording starts at t = 0).
    pub(super) fn open_at(
        link: &LinkSpec,
        timeout: Duration,
        trace: bool,
        poll_rate: f64,
        keep_samples: bool,
    ) -> Result<Session, Failure> {
        let policy = policy();
        let config = worker::Config {
            poll_rate,
            timing: Timing {
                ack_timeout: timeout.min(Duration::from_secs(5)),
                done_timeout: Some(timeout),
                ..Timing::default()
            },
            reconnect: false,
            trace,
            on_link_loss: policy.on_exit,
            lost_after: policy.lost_after,
        };
        let worker = Worker::spawn(config, Arc::new(|| {}))
            .map_err(|e| usage(format!("cannot start the worker thread: {e}")))?;
        let mut session = Session {
            worker,
            latest: None,
            early: vec![],
            keep_samples,
            interruptible: false,
            warnings: vec![],
            notes: vec![],
        };
        session.send(Request::Connect(link.clone()))?;
        let deadline = Instant::now() + timeout;
        loop {
            match session.next(deadline)? {
                Event::Connected(_) => break,
                Event::ConnectFailed { error, .. } => {
                    return Err(usage(format!("cannot connect to {link}: {error}")));
                }
                _ => {}
            }
        }
        // A status before anything else: commands are judged against it.
        while session.latest.is_none() {
            session.next(deadline)?;
        }
        Ok(session)
    }

    /// From now on, a signal (Ctrl-C, SIGTERM, SIGHUP) ends the waiting with an
    /// `interrupted` failure instead of ending the process, so that the command can stop
    /// the drive and keep its data first. `Err` when the signals cannot be caught.
    pub(super) fn catch_signals(&mut self) -> Result<(), String> {
        interrupt::install()?;
        self.interruptible = true;
        Ok(())
    }

    /// The samples received while connecting (and since, until taken), oldest first.
    pub(super) fn take_early_samples(&mut self) -> Vec<Sample> {
        self.keep_samples = false;
        std::mem::take(&mut self.early)
    }

    /// Hand the worker a request without waiting for its outcome.
    pub(super) fn send_request(&self, request: Request) -> Result<u64, Failure> {
        self.send(request)
    }

    /// The next event (samples included) before `deadline`.
    pub(super) fn next_event(&mut self, deadline: Instant) -> Result<Event, Failure> {
        self.next(deadline)
    }

    fn send(&self, request: Request) -> Result<u64, Failure> {
        self.worker
            .send(request)
            .map_err(|e| usage(format!("the worker refused the request: {e}")))
    }

    /// The next event before `deadline`, keeping the newest sample. A caught signal ends
    /// the waiting (once).
    fn next(&mut self, deadline: Instant) -> Result<Event, Failure> {
        /// How often a wait looks for a caught signal.
        const SIGNAL_POLL: Duration = Duration::from_millis(50);
        let event = loop {
            if self.interruptible
                && let Some(signal) = interrupt::take()
            {
                return Err(interrupted(signal));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(failed(
                    "no answer from the drive in time (raise --timeout?)",
                ));
            }
            match self.worker.recv_timeout(left.min(SIGNAL_POLL)) {
                Ok(event) => break event,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(failed("the worker thread stopped"));
                }
            }
        };
        match &event {
            Event::Samples(samples) => {
                for sample in samples {
                    if self.keep_samples && self.early.len() < EARLY_LIMIT {
                        self.early.push(*sample);
                    }
                    self.latest = Some(match &self.latest {
                        Some(older) => sample.merged_over(older),
                        None => *sample,
                    });
                }
            }
            Event::Disconnected {
                reason: Some(reason),
            } => {
                return Err(failed(format!("the link was lost: {reason}")));
            }
            Event::Notice(text) => self.notes.push(text.clone()),
            Event::Frames(frames) => {
                for f in frames {
                    eprintln!(
                        "{} {:<24} {}",
                        if f.sent { "tx" } else { "rx" },
                        f.raw,
                        f.text
                    );
                }
            }
            _ => {}
        }
        Ok(event)
    }

    /// Send a PDI request and wait for acceptance, or completion with `wait`.
    fn command(
        &mut self,
        request: Request,
        wait: bool,
        timeout: Duration,
    ) -> Result<(String, Option<[u8; 8]>, CommandProgress), Failure> {
        let what = request.to_string();
        let id = self.send(request)?;
        let deadline = Instant::now() + timeout + Duration::from_secs(1);
        let mut image = None;
        loop {
            let event = match self.next(deadline) {
                Ok(event) => event,
                Err(f) if f.signal.is_some() => return Err(f),
                // Waited out: the command may still run.
                Err(f) => {
                    return Err(Failure {
                        stop: true,
                        ..failed(format!("{what}: {}", f.message))
                    });
                }
            };
            match event {
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return Err(failed(format!("{what}: {reason}")));
                }
                Event::Sent {
                    id: i, image: sent, ..
                } if i == id => image = Some(sent.to_bytes()),
                Event::Progress { id: i, progress } if i == id => {
                    if let CommandProgress::TimedOut { .. } = progress {
                        // The drive may still be at it: stopped on the way out.
                        return Err(Failure {
                            stop: true,
                            ..failed(format!("{what}: {progress}"))
                        });
                    }
                    if !progress.is_success() {
                        return Err(failed(format!("{what}: {progress}")));
                    }
                    if progress.is_final() || !wait {
                        return Ok((what, image, progress));
                    }
                }
                _ => {}
            }
        }
    }

    /// Stop the drive on the way out by `action` (the `--on-exit` policy), and say
    /// honestly what came of it: acknowledged and stopped, still braking, or not reached.
    /// Signals are not caught from here on: a second Ctrl-C ends the process at once.
    pub(super) fn stop_drive(&mut self, action: LinkLossAction, wait: Duration) -> String {
        self.interruptible = false;
        let (mut what, request) = match action {
            LinkLossAction::Nothing => {
                return format!(
                    "the drive is left as it is (--on-exit leave): {}",
                    self.motion_now()
                );
            }
            LinkLossAction::Halt => ("halt", Request::Halt),
            LinkLossAction::SwitchOff => ("switch-off", Request::Command(Action::SwitchOff)),
        };
        let mut id = match self.send(request) {
            Ok(id) => id,
            Err(f) => {
                return format!(
                    "no {what} could be sent ({}): the drive may still be moving; stop it at the machine",
                    f.message
                );
            }
        };
        let mut instead = String::new();
        let mut acknowledged = false;
        let deadline = Instant::now() + wait;
        loop {
            let event = match self.next(deadline) {
                Ok(event) => event,
                Err(f) if acknowledged => {
                    return format!(
                        "{instead}{what} sent and acknowledged, but not finished within {:.1} s ({}): {}",
                        wait.as_secs_f64(),
                        f.message,
                        self.motion_now()
                    );
                }
                Err(f) => {
                    return format!(
                        "{instead}{what} sent, but the drive did not acknowledge it ({}): it may still be moving; stop it at the machine",
                        f.message
                    );
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
    fn motion_now(&self) -> String {
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
            Some(v) if v.abs() < 1.0 => format!("it stands still ({power}{halted})"),
            Some(v) => format!("it still turns at {v:.0} rpm ({power}{halted})"),
            None => format!("{power}{halted}"),
        }
    }

    fn read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Value, Failure> {
        self.try_read(address, dtype, path, timeout)?
            .map_err(|e| failed(format!("read {address}: {e}")))
    }

    /// Read an object, keeping a refusal (the device's or the worker's: `Ok(Err(text))`)
    /// apart from a broken link or a timeout (`Err`).
    pub(super) fn try_read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Result<Value, String>, Failure> {
        let id = self.send(Request::ReadObject {
            address,
            dtype,
            path,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectRead { id: i, result, .. } if i == id => return Ok(result),
                Event::Rejected { id: i, reason, .. } if i == id => return Ok(Err(reason)),
                _ => {}
            }
        }
    }

    /// Read many objects in one queued request, in order; `progress(done, total)` after
    /// each. A refusal stays with its object. A broken link or a stalled read (no answer
    /// within `timeout` of the previous one) ends the reading: the objects read until then
    /// come back with the failure.
    pub(super) fn read_many(
        &mut self,
        objects: Vec<(Address, DataType)>,
        timeout: Duration,
        mut progress: impl FnMut(usize, usize),
    ) -> (BTreeMap<Address, Result<Value, String>>, Option<Failure>) {
        let total = objects.len();
        let mut reads = BTreeMap::new();
        if total == 0 {
            return (reads, None);
        }
        let id = match self.send(Request::ReadMany {
            objects,
            path: ObjectPath::Auto,
        }) {
            Ok(id) => id,
            Err(f) => return (reads, Some(f)),
        };
        let mut deadline = Instant::now() + timeout;
        // Answers counted, not addresses: a list that names an object twice gets two.
        let mut answered = 0;
        while answered < total {
            match self.next(deadline) {
                Ok(Event::ObjectRead {
                    id: i,
                    address,
                    result,
                }) if i == id => {
                    reads.insert(address, result);
                    answered += 1;
                    progress(answered, total);
                    deadline = Instant::now() + timeout;
                }
                Ok(Event::Rejected { id: i, reason, .. }) if i == id => {
                    return (
                        reads,
                        Some(failed(format!("reading {total} objects: {reason}"))),
                    );
                }
                Ok(_) => {}
                Err(f) => {
                    let _ = self.send(Request::Cancel(id));
                    return (reads, Some(f));
                }
            }
        }
        (reads, None)
    }

    /// Write an object, keeping a refusal (`Ok(Err(text))`) apart from a broken link or a
    /// timeout (`Err`).
    pub(super) fn try_write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        timeout: Duration,
    ) -> Result<Result<(), String>, Failure> {
        let id = self.send(Request::WriteObject {
            address,
            dtype,
            value,
            path: ObjectPath::Auto,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectWritten { id: i, result, .. } if i == id => return Ok(result),
                Event::Rejected { id: i, reason, .. } if i == id => return Ok(Err(reason)),
                _ => {}
            }
        }
    }

    /// Notices the worker gave (fallbacks, mapping changes), for the report.
    pub(super) fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    fn write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<(), Failure> {
        let shown = value.to_string();
        let id = self.send(Request::WriteObject {
            address,
            dtype,
            value,
            path,
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::ObjectWritten { id: i, result, .. } if i == id => {
                    return result.map_err(|e| failed(format!("write {shown} to {address}: {e}")));
                }
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return Err(failed(format!("write {shown} to {address}: {reason}")));
                }
                _ => {}
            }
        }
    }

    /// Let a few more samples arrive, so a status printed after a command shows its effect.
    fn refresh(&mut self) {
        let deadline = Instant::now() + Duration::from_millis(60);
        while self.next(deadline).is_ok() {}
    }
}

fn path(via: Via) -> ObjectPath {
    match via {
        Via::Auto => ObjectPath::Auto,
        Via::Pdi => ObjectPath::Pdi,
        Via::Native => ObjectPath::Native,
    }
}

fn action(opcode: Opcode, inputs: &[i64]) -> Result<Action, Failure> {
    Action::from_inputs(opcode, inputs).map_err(|e| usage(e.to_string()))
}

fn execute(
    link: &LinkSpec,
    command: &Command,
    timeout: Duration,
    trace: bool,
) -> Result<Report, Failure> {
    // Check the inputs before connecting: a typo never touches the drive.
    let planned: Option<(Request, bool)> = match command {
        Command::MoveAbs(a) => Some((
            Request::Command(action(Opcode::MoveAbsolute, &[a.position, a.speed])?),
            a.wait,
        )),
        Command::MoveRel(a) => Some((
            Request::Command(action(Opcode::MoveRelative, &[a.position, a.speed])?),
            a.wait,
        )),
        Command::Velocity(a) => Some((
            Request::Command(action(Opcode::Velocity, &[a.speed])?),
            a.wait,
        )),
        Command::Torque(a) => Some((
            Request::Command(action(Opcode::Torque, &[a.torque, a.max_speed])?),
            a.wait,
        )),
        Command::Halt(w) => Some((Request::Halt, w.wait)),
        Command::Resume(w) => Some((Request::Resume, w.wait)),
        Command::Quickstop => Some((Request::Command(Action::Quickstop), true)),
        Command::SwitchOff => Some((Request::Command(Action::SwitchOff), true)),
        Command::ClearError => Some((Request::Command(Action::ClearError), true)),
        Command::Home(a) => Some((
            Request::Command(action(Opcode::Homing, &[a.method])?),
            a.wait,
        )),
        Command::HomeHere(a) => Some((
            Request::Command(action(Opcode::HomeHere, &[a.position])?),
            true,
        )),
        Command::AutoSetup(w) => Some((Request::Command(Action::AutoSetup), w.wait)),
        Command::Status
        | Command::Read(_)
        | Command::Write(_)
        | Command::Scan
        | Command::Discover(_)
        | Command::Sim(_)
        | Command::Bench(_)
        | Command::Record(_)
        | Command::Od(_) => None,
    };
    let write_value = match command {
        Command::Write(w) => {
            let dtype = w
                .dtype
                .or_else(|| od::builtin().get(w.address).map(|e| e.dtype))
                .ok_or_else(|| {
                    usage(format!(
                        "{} is not in the catalog: give its type with --type (e.g. --type u32)",
                        w.address
                    ))
                })?;
            let value =
                Value::parse(dtype, &w.value).map_err(|e| usage(format!("{}: {e}", w.address)))?;
            if let Some(entry) = od::builtin().get(w.address) {
                if !entry.access.writable() {
                    return Err(usage(format!(
                        "{} {} is read-only",
                        w.address,
                        entry.full_name()
                    )));
                }
                entry
                    .check(&value)
                    .map_err(|e| usage(format!("{}: {e}", w.address)))?;
            }
            Some((dtype, value))
        }
        _ => None,
    };

    if let Command::Scan = command {
        return scan(link, timeout);
    }
    refuse_still_moves(command)?;
    let mut session = Session::open(link, timeout, trace)?;
    if let Some((request, _)) = &planned {
        check_ramps(&mut session, request, timeout)?;
    }
    let mut report = match (command, planned) {
        (Command::Status, _) => {
            session.refresh();
            Report::Status(report::status(link, session.latest))
        }
        (Command::Read(r), _) => {
            let dtype = r
                .dtype
                .or_else(|| od::builtin().get(r.address).map(|e| e.dtype));
            let value = session.read(r.address, dtype, path(r.via), timeout)?;
            Report::Object(report::object(r.address, dtype, &value, false))
        }
        (Command::Write(w), _) => {
            let (dtype, value) = write_value.ok_or_else(|| usage("no value"))?;
            session.write(w.address, dtype, value.clone(), path(w.via), timeout)?;
            Report::Object(report::object(w.address, Some(dtype), &value, true))
        }
        (Command::Torque(t), Some((request, wait))) => {
            if let Some(slope) = t.slope {
                session.write(
                    Address::new(0x6087, 0),
                    DataType::Unsigned32,
                    Value::Uint(u64::from(slope)),
                    ObjectPath::Auto,
                    timeout,
                )?;
            } else {
                match session.read(Address::new(0x6087, 0), Some(DataType::Unsigned32), ObjectPath::Auto, timeout) {
                    Ok(v) if v.as_i128() == Some(0) => session.warnings.push(
                        "torque slope 6087h is 0 (the factory value): the torque will not build up and the motor will not move; give --slope N (‰/s)".into(),
                    ),
                    Ok(_) => {}
                    Err(e) => session.warnings.push(format!("could not check the torque slope: {}", e.message)),
                }
            }
            motion(&mut session, request, wait, timeout)?
        }
        (command, Some((request, wait))) if moves(command) => {
            motion(&mut session, request, wait, timeout)?
        }
        (_, Some((request, wait))) => {
            let (what, image, progress) = session.command(request, wait, timeout)?;
            Report::Command(report::command(what, image, &progress))
        }
        (_, None) => return Err(usage("nothing to do")),
    };
    report.set_warnings(std::mem::take(&mut session.warnings));
    report.set_notes(std::mem::take(&mut session.notes));
    Ok(report)
}

/// Commands that start motion or wait on it: an interrupt, or a --wait that times out,
/// stops the drive by the `--on-exit` policy on the way out.
fn moves(command: &Command) -> bool {
    matches!(
        command,
        Command::MoveAbs(_)
            | Command::MoveRel(_)
            | Command::Velocity(_)
            | Command::Torque(_)
            | Command::Home(_)
            | Command::AutoSetup(_)
            | Command::Resume(_)
    )
}

/// Run a command that moves the motor: signals are caught while it runs, and whatever
/// ends it early (a signal, a --wait timed out) stops the drive first, saying how that
/// went. The exit code of an interrupt is 130.
fn motion(
    session: &mut Session,
    request: Request,
    wait: bool,
    timeout: Duration,
) -> Result<Report, Failure> {
    if let Err(e) = session.catch_signals() {
        session.warnings.push(format!(
            "{e}: Ctrl-C will end drivedeck without stopping the drive"
        ));
    }
    match session.command(request, wait, timeout) {
        Ok((what, image, progress)) => Ok(Report::Command(report::command(what, image, &progress))),
        Err(f) if f.stop => {
            let done = session.stop_drive(policy().on_exit, timeout.min(STOP_WAIT));
            Err(f.and(done))
        }
        Err(f) => Err(f),
    }
}

/// How long the way out waits for a stop to finish (the drive brakes on its ramp).
const STOP_WAIT: Duration = Duration::from_secs(10);

/// A move that cannot move, refused before anything is sent: a max speed of 0.
fn refuse_still_moves(command: &Command) -> Result<(), Failure> {
    match command {
        Command::MoveAbs(a) | Command::MoveRel(a) if a.speed == 0 => Err(usage(format!(
            "{}: a max speed of 0 rpm never moves the motor; nothing was sent (give --speed N, rpm)",
            if matches!(command, Command::MoveAbs(_)) {
                "move-abs"
            } else {
                "move-rel"
            }
        ))),
        _ => Ok(()),
    }
}

/// 6083h profile acceleration and 6084h profile deceleration: a profile move or velocity
/// with either at 0 never starts, or once started never brakes (not even for a halt).
const RAMPS: [(Address, &str); 2] = [
    (Address::new(0x6083, 0), "profile acceleration 6083h"),
    (Address::new(0x6084, 0), "profile deceleration 6084h"),
];

/// Refuse a profile move or velocity, before anything is sent, when the drive's ramps
/// are 0. A ramp that cannot be read is a warning only.
fn check_ramps(session: &mut Session, request: &Request, timeout: Duration) -> Result<(), Failure> {
    let what = match request {
        Request::Command(Action::MoveAbsolute { .. }) => "move-abs",
        Request::Command(Action::MoveRelative { .. }) => "move-rel",
        Request::Command(Action::Velocity { speed }) if *speed != 0 => "velocity",
        _ => return Ok(()),
    };
    for (address, name) in RAMPS {
        match session.try_read(
            address,
            Some(DataType::Unsigned32),
            ObjectPath::Auto,
            timeout,
        )? {
            Ok(value) if value.as_i128() == Some(0) => {
                return Err(failed(format!(
                    "{what} refused, nothing was sent: the {name} is 0 on the drive, so the motor would {} (set it first, e.g. `drivedeck write {:04X} 1000`)",
                    if address.index == 0x6083 {
                        "never start"
                    } else {
                        "never brake, not even for a halt"
                    },
                    address.index
                )));
            }
            Ok(_) => {}
            Err(e) => session
                .warnings
                .push(format!("could not check the {name}: {e}")),
        }
    }
    Ok(())
}

/// `drivedeck discover`: EtherNet/IP adapters by ListIdentity.
pub fn discover(args: &DiscoverArgs, json: bool) -> ExitCode {
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(runtime) => runtime,
        Err(e) => {
            eprintln!("drivedeck discover: cannot start the runtime: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    let discovery = crate::link::enip::discovery::Discovery {
        port: args.port,
        interface: args.interface.clone(),
        unicast: args.host.iter().cloned().collect(),
        wait: Duration::from_secs_f64(args.wait.clamp(0.1, 60.0)),
        ..Default::default()
    };
    match runtime.block_on(crate::link::enip::discovery::discover(&discovery)) {
        Ok(devices) => {
            let place = match (&args.interface, &args.host) {
                (Some(i), _) => format!("EtherNet/IP on {i}"),
                (None, Some(h)) => format!("EtherNet/IP on every interface and at {h}"),
                (None, None) => "EtherNet/IP on every interface".to_owned(),
            };
            let mut scan = report::scan(&LinkSpec::Sim, devices);
            scan.bus = place;
            report::print(&Report::Scan(scan), json);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("drivedeck discover: {e}");
            ExitCode::from(EXIT_USAGE)
        }
    }
}

/// A bus scan through the worker, without connecting to a node.
fn scan(link: &LinkSpec, timeout: Duration) -> Result<Report, Failure> {
    let worker = Worker::spawn(
        worker::Config {
            reconnect: false,
            ..worker::Config::default()
        },
        Arc::new(|| {}),
    )
    .map_err(|e| usage(format!("cannot start the worker thread: {e}")))?;
    let id = worker
        .send(Request::Scan(link.clone()))
        .map_err(|e| usage(e.to_string()))?;
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match worker.recv_timeout(left) {
            Ok(Event::Scanned { id: i, result }) if i == id => {
                return result
                    .map(|devices| Report::Scan(report::scan(link, devices)))
                    .map_err(usage);
            }
            Ok(_) => {}
            Err(_) => return Err(failed("the scan did not finish in time")),
        }
    }
}
