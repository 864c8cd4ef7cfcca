//! The session of one command: a worker of its own, connected to the drive, and the
//! waiting for the events a command needs, with a caught signal ending the wait.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::context::Context;
use super::failure::{Failure, failed, interrupted, usage};
use super::interrupt;
use super::progress;
use crate::cia::PowerState;
use crate::link::LinkSpec;
use crate::od::backup::{DeviceIdentity, IDENTITY};
use crate::od::{Address, DataType, Value};
use crate::pdi::Action;
use crate::pdi::{Failure as PdiFailure, StatusBit, Timing};
use crate::project::{Drive, check};
use crate::worker::{
    self, CommandProgress, Event, LinkLossAction, ObjectError, ObjectPath, Request, Sample, Worker,
};

/// Objects read, each with its value or why it has none.
pub(super) type Reads = BTreeMap<Address, Result<Value, ObjectError>>;

/// Samples kept from the start of a session for a recording (the rest are the
/// recording's own business).
const EARLY_LIMIT: usize = 100_000;

/// The session of one command.
pub(super) struct Session {
    pub(super) worker: Worker,
    pub(super) latest: Option<Sample>,
    /// Every sample received while connecting, oldest first (a recording starts there).
    pub(super) early: Vec<Sample>,
    pub(super) keep_samples: bool,
    /// Whether the signals are caught: waiting then ends at a signal.
    pub(super) interruptible: bool,
    pub(super) warnings: Vec<String>,
    pub(super) notes: Vec<String>,
    /// Whether the frames are printed (`--trace`): then the link is closed before the
    /// command ends, so that the frames of closing are printed too.
    trace: bool,
    /// What an interrupted or timed-out command leaves the drive in (`--on-exit`): the
    /// same action the worker takes on a lost link, since both come from one policy.
    on_exit: LinkLossAction,
}

/// How long the end of a traced command waits for the link to close.
const CLOSE_WAIT: Duration = Duration::from_secs(2);

impl Drop for Session {
    fn drop(&mut self) {
        if !self.trace {
            // Dropping the worker closes the link on the worker's way out.
            return;
        }
        self.interruptible = false;
        if self.send(Request::Disconnect).is_err() {
            return;
        }
        let deadline = Instant::now() + CLOSE_WAIT;
        while let Ok(event) = self.next(deadline) {
            if matches!(event, Event::Disconnected { .. }) {
                break;
            }
        }
    }
}

impl Session {
    /// A session on `link`, with the run's policy and the device it expects (`context`).
    pub(super) fn open(
        link: &LinkSpec,
        timeout: Duration,
        trace: bool,
        context: &Context,
    ) -> Result<Session, Failure> {
        Session::open_at(link, timeout, trace, 200.0, false, context)
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
        context: &Context,
    ) -> Result<Session, Failure> {
        let policy = context.policy;
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
            // A connection that closes or resets is opened again within the --lost-after
            // budget, and the command goes on (the window reconnects on its own).
            reconnect_in_session: true,
            simulated_time: false,
            epoch: None,
        };
        // Signals are caught from before connecting: a Ctrl-C then ends the command through
        // the session, whose link closes on the way out (over CANopen that puts back the
        // PDO mapping the link set up). A signal while connecting ends it once connected.
        let caught = interrupt::install().is_ok();
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
            trace,
            on_exit: policy.on_exit,
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
        session.interruptible = caught;
        // A status before anything else: commands are judged against it.
        while session.latest.is_none() {
            session.next(deadline)?;
        }
        if let Some(drive) = &context.expected {
            session.check_device(drive, timeout);
        }
        Ok(session)
    }

    /// Once connected: the device against the identity the project stores for `drive`
    /// (the one of `--drive`). Another device (a replaced drive, a wrong address) is said
    /// on stderr, never passed over; it is not refused, since a replacement of the same
    /// product is a normal case (`project check --update` stores the new identity).
    fn check_device(&mut self, drive: &Drive, timeout: Duration) {
        let (reads, failure) = self.read_many(IDENTITY[..4].to_vec(), timeout, |_, _| {});
        let found = match failure {
            Some(f) => check::check(drive, Err(&f.message)),
            None => check::check(drive, Ok(&DeviceIdentity::from_reads(&reads))),
        };
        if !found.is_same() {
            eprintln!("warning: not the device the project saw: {found}");
        }
    }

    /// What an interrupted or timed-out command leaves the drive in (`--on-exit`, or the
    /// project drive's own option).
    pub(super) fn on_exit(&self) -> LinkLossAction {
        self.on_exit
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

    /// The samples kept since the last call (with `keep_samples`), oldest first; the
    /// session goes on keeping them.
    pub(super) fn drain_samples(&mut self) -> Vec<Sample> {
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

    pub(super) fn send(&self, request: Request) -> Result<u64, Failure> {
        self.worker
            .send(request)
            .map_err(|e| usage(format!("the worker refused the request: {e}")))
    }

    /// The next event before `deadline`, keeping the newest sample. A caught signal ends
    /// the waiting (once).
    pub(super) fn next(&mut self, deadline: Instant) -> Result<Event, Failure> {
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
            Event::Notice(notice) => self.notes.push(notice.text.clone()),
            Event::Frames(frames) => print_frames(frames),
            _ => {}
        }
        Ok(event)
    }

    /// The next event within `wait`, or `None`: unlike [`Session::next`], a lost link
    /// comes back as its event (a procedure's restart expects one). A caught signal ends
    /// the waiting (once).
    pub(super) fn poll(&mut self, wait: Duration) -> Result<Option<Event>, Failure> {
        if self.interruptible
            && let Some(signal) = interrupt::take()
        {
            return Err(interrupted(signal));
        }
        let event = match self.worker.recv_timeout(wait) {
            Ok(event) => event,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => return Ok(None),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(failed("the worker thread stopped"));
            }
        };
        match &event {
            Event::Samples(samples) => {
                for sample in samples {
                    self.latest = Some(match &self.latest {
                        Some(older) => sample.merged_over(older),
                        None => *sample,
                    });
                }
            }
            Event::Notice(notice) => self.notes.push(notice.text.clone()),
            Event::Frames(frames) => print_frames(frames),
            _ => {}
        }
        Ok(Some(event))
    }

    /// Send a PDI request and wait for acceptance, or completion with `wait`. A travel
    /// command waited for ends as soon as its target can no longer be reached (a limit
    /// switch, a halt from elsewhere: [`EndWatch`]); a move that seems to end by a fault
    /// or by leaving Operation enabled is judged only after the drive is read again
    /// ([`Session::judge_again`]).
    pub(super) fn command(
        &mut self,
        request: Request,
        wait: bool,
        timeout: Duration,
    ) -> Result<(String, Option<[u8; 8]>, CommandProgress), Failure> {
        let what = request.to_string();
        let mut watch = (wait && EndWatch::applies(&request)).then(EndWatch::default);
        let travel = EndWatch::applies(&request);
        let id = self.send(request)?;
        let deadline = Instant::now() + timeout + Duration::from_secs(1);
        let mut image = None;
        let mut accepted = false;
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
                Event::Samples(_) if accepted => {
                    if let (Some(watch), Some(sample)) = (watch.as_mut(), self.latest)
                        && let Some(end) = watch.check(&sample)
                    {
                        return Err(end.failure(&what, &sample));
                    }
                }
                Event::Progress {
                    id: i,
                    progress: CommandProgress::Failed(failure),
                } if i == id
                    && travel
                    && matches!(
                        failure,
                        PdiFailure::PowerLost | PdiFailure::DriveFault { .. }
                    ) =>
                {
                    return Err(self.judge_again(&what, failure, timeout));
                }
                Event::Progress { id: i, progress } if i == id => {
                    if matches!(progress, CommandProgress::Accepted) {
                        accepted = true;
                    }
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

    pub(super) fn read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Value, Failure> {
        self.try_read(address, dtype, path, timeout)?
            .map_err(|e| failed(format!("read {address}: {e}")))
    }

    /// An integer object read in the type the catalog gives it, as an i128; `None` when
    /// the drive refused it or did not answer (for listings that show what they got).
    pub(super) fn read_int(&mut self, index: u16, sub: u8, timeout: Duration) -> Option<i128> {
        let address = Address::new(index, sub);
        let dtype = crate::od::builtin().get(address).map(|e| e.dtype);
        self.try_read(address, dtype, ObjectPath::Auto, timeout)
            .ok()?
            .ok()?
            .as_i128()
    }

    /// Read an object, keeping a refusal (the device's or the worker's: `Ok(Err(text))`)
    /// apart from a broken link or a timeout (`Err`).
    pub(super) fn try_read(
        &mut self,
        address: Address,
        dtype: Option<DataType>,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<Result<Value, ObjectError>, Failure> {
        let request = Request::ReadObject {
            address,
            dtype,
            path,
        };
        self.await_object(request, timeout, |event| match event {
            Event::ObjectRead { id, result, .. } => Some((id, result)),
            _ => None,
        })
    }

    /// Send an object request and wait for its answer, which `answer` picks from the
    /// events with the request's id. The worker's rejection is a refusal (`Ok(Err(_))`);
    /// a broken link or a timeout is `Err`.
    fn await_object<T>(
        &mut self,
        request: Request,
        timeout: Duration,
        answer: impl Fn(Event) -> Option<(u64, Result<T, ObjectError>)>,
    ) -> Result<Result<T, ObjectError>, Failure> {
        let id = self.send(request)?;
        let deadline = Instant::now() + timeout;
        loop {
            match self.next(deadline)? {
                Event::Rejected { id: i, reason, .. } if i == id => {
                    return Ok(Err(ObjectError::NotSent(reason)));
                }
                event => {
                    if let Some((i, result)) = answer(event)
                        && i == id
                    {
                        return Ok(result);
                    }
                }
            }
        }
    }

    /// [`Session::read_many`] with a bar saying `what` on stderr, and its summary (how
    /// many, how fast) in `notes`.
    pub(super) fn read_many_shown(
        &mut self,
        objects: Vec<(Address, DataType)>,
        timeout: Duration,
        what: &'static str,
        notes: &mut Vec<String>,
    ) -> (Reads, Option<Failure>) {
        let started = Instant::now();
        let asked = objects.len();
        let (reads, failure) = self.read_many(objects, timeout, progress::bar(what));
        progress::done(asked, reads.len(), started.elapsed(), notes);
        (reads, failure)
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
    ) -> (Reads, Option<Failure>) {
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
    ) -> Result<Result<(), ObjectError>, Failure> {
        let request = Request::WriteObject {
            address,
            dtype,
            value,
            path: ObjectPath::Auto,
        };
        self.await_object(request, timeout, written)
    }

    /// Notices the worker gave (fallbacks, mapping changes), for the report.
    pub(super) fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    pub(super) fn write(
        &mut self,
        address: Address,
        dtype: DataType,
        value: Value,
        path: ObjectPath,
        timeout: Duration,
    ) -> Result<(), Failure> {
        let shown = value.to_string();
        let request = Request::WriteObject {
            address,
            dtype,
            value,
            path,
        };
        self.await_object(request, timeout, written)?
            .map_err(|e| failed(format!("write {shown} to {address}: {e}")))
    }

    /// Let a few more samples arrive, so a status printed after a command shows its effect.
    pub(super) fn refresh(&mut self) {
        let deadline = Instant::now() + Duration::from_millis(60);
        while self.next(deadline).is_ok() {}
    }
}

/// The outcome of a write, picked from the events for [`Session::await_object`].
fn written(event: Event) -> Option<(u64, Result<(), ObjectError>)> {
    match event {
        Event::ObjectWritten { id, result, .. } => Some((id, result)),
        _ => None,
    }
}

/// How long a travel command must stand still, short of its target, in a state that
/// cannot reach it (at a limit switch, halted), before a `--wait` gives up on it: a move
/// that starts at a limit switch, away from it, is still at rest for its first cycles.
const END_HOLD: f64 = 0.5;

/// How long PdiStatusFollowingError must stay set before a `--wait` gives up on the
/// travel command: the axis does not follow (blocked, overloaded). A drive reacts to it
/// only where 3700h says so; the factory's is no reaction, so it would push on until
/// `--timeout`. Longer than an acceleration's passing lag.
const FOLLOWING_HOLD: f64 = 2.0;

/// Watches the samples of a travel command waited for, for the end of it short of its
/// target: the motor at rest, PdiStatusTargetReached clear, and the drive at a limit
/// switch or halted (by someone else: the command did not ask for it), for [`END_HOLD`];
/// or PdiStatusFollowingError set, moving or not, for [`FOLLOWING_HOLD`].
#[derive(Default)]
pub(super) struct EndWatch {
    /// Sample time since which the end shows, and what it is.
    since: Option<(f64, End)>,
}

/// Why a travel command can no longer reach its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum End {
    LimitSwitch,
    Halted,
    /// The axis does not follow its command (PdiStatusFollowingError).
    NotFollowing,
}

/// A travel command's end short of its target, as seen in the samples.
pub(super) struct EndSeen {
    end: End,
    /// Whether the samples show the motor at rest (606Ch known); otherwise the drive may
    /// still be moving and is stopped by `--on-exit`.
    at_rest: bool,
}

impl EndWatch {
    /// Whether `request` is a travel command that waits for PdiStatusTargetReached (or
    /// the resume of one).
    pub(super) fn applies(request: &Request) -> bool {
        matches!(
            request,
            Request::Resume
                | Request::Command(
                    Action::MoveAbsolute { .. }
                        | Action::MoveRelative { .. }
                        | Action::Velocity { .. }
                        | Action::Torque { .. }
                )
        )
    }

    /// The end, once it has shown for [`END_HOLD`].
    pub(super) fn check(&mut self, sample: &Sample) -> Option<EndSeen> {
        let status = sample.tx.status;
        let moving = sample.at_rest() == Some(false);
        let end = if status.is_set(StatusBit::TargetReached) {
            None
        } else if status.is_set(StatusBit::FollowingError) {
            Some(End::NotFollowing)
        } else if moving {
            None
        } else if status.is_set(StatusBit::LimitReached) {
            Some(End::LimitSwitch)
        } else if status.is_set(StatusBit::QsHaltBit) && status.is_set(StatusBit::OperationEnabled)
        {
            Some(End::Halted)
        } else {
            None
        };
        let Some(end) = end else {
            self.since = None;
            return None;
        };
        let since = match self.since {
            Some((t, seen)) if seen == end => t,
            _ => {
                self.since = Some((sample.t, end));
                sample.t
            }
        };
        let hold = if end == End::NotFollowing {
            FOLLOWING_HOLD
        } else {
            END_HOLD
        };
        (sample.t - since >= hold).then_some(EndSeen {
            end,
            at_rest: sample.at_rest() == Some(true),
        })
    }
}

/// Where the drive stands, in words: "at position 36012" (6064h), or nothing known.
pub(super) fn position_words(sample: &Sample) -> String {
    match sample.position() {
        Some(p) => format!("at position {p:.0}"),
        None => "at a position this link does not report".to_owned(),
    }
}

impl EndSeen {
    /// The failure of the command `what` that ended so: what to do first, then why.
    fn failure(&self, what: &str, sample: &Sample) -> Failure {
        let at = position_words(sample);
        let message = match self.end {
            End::LimitSwitch => format!(
                "Move the axis off the limit switch (a move the other way) and check the target: the drive stopped {at} at a limit switch (PdiStatusLimitReached) before reaching it; {what}: target not reached"
            ),
            End::Halted => format!(
                "Find who halted the drive (another master or tool): it was halted (PdiStatusQsHaltBit) {at} before reaching its target, by a request not from this command; {what}: target not reached"
            ),
            End::NotFollowing => format!(
                "Check what blocks or loads the axis (a brake still closed, an end stop, a load too heavy for the current limit) and the gains: it does not follow its command, the drive signalled a following error (PdiStatusFollowingError) for {FOLLOWING_HOLD:.1} s {at}{}; the drive does not stop on it by itself unless its reaction 3700h says so (the factory's is no reaction); {what}: target not reached",
                match sample.following_error() {
                    Some(e) => format!(", {e:.0} behind (60F4h)"),
                    None => String::new(),
                }
            ),
        };
        Failure {
            // A drive that does not follow still pushes: stopped by `--on-exit`.
            stop: !self.at_rest || self.end == End::NotFollowing,
            ..failed(message)
        }
    }
}

impl Session {
    /// A travel command `what` seemed to end by `failure` (a fault, or the drive leaving
    /// Operation enabled) as the PDI status told it: before judging, read the drive again
    /// by another path (the statusword 6041h by the link's own object access where it has
    /// one) and a few more samples. The failure says what the drive was found in; it asks
    /// for the `--on-exit` stop (`stop`) unless the drive is found stopped for certain.
    pub(super) fn judge_again(
        &mut self,
        what: &str,
        failure: PdiFailure,
        timeout: Duration,
    ) -> Failure {
        let word = self.try_read(
            Address::new(0x6041, 0),
            Some(DataType::Unsigned16),
            ObjectPath::Auto,
            timeout.min(Duration::from_secs(2)),
        );
        self.refresh();
        let enabled = matches!(
            &word,
            Ok(Ok(v)) if v.as_i128().and_then(|w| u16::try_from(w).ok())
                .and_then(PowerState::from_statusword) == Some(PowerState::OperationEnabled)
        );
        if !enabled {
            // Out of Operation enabled the drive's own reaction brakes the motor: give it
            // the time to, so that "stands still" is seen rather than assumed.
            self.wait_at_rest(Instant::now() + SETTLE_WAIT);
        }
        let sample = self.latest;
        let at = sample
            .as_ref()
            .map(position_words)
            .unwrap_or_else(|| "at an unknown position".to_owned());
        let at_rest = sample.and_then(|s| s.at_rest()) == Some(true);
        let state = match &word {
            Ok(Ok(value)) => value
                .as_i128()
                .and_then(|w| u16::try_from(w).ok())
                .map(|w| (w, PowerState::from_statusword(w))),
            _ => None,
        };
        let (message, stopped) = match state {
            Some((word, Some(PowerState::OperationEnabled))) => (
                format!(
                    "Check the bus for a wrong status frame (a second master, noise, a forged or mis-decoded frame): the PDI status said {failure}, but the drive read again says Operation enabled (6041h = {word:04X}h) {at}, so the command did not end as the frame said; {what}: not finished"
                ),
                false,
            ),
            Some((word, Some(PowerState::Fault | PowerState::FaultReactionActive))) => (
                format!(
                    "{}: {what}: {failure}; the drive read again is in Fault (6041h = {word:04X}h), {}",
                    if matches!(failure, PdiFailure::DriveFault { error_code } if error_code == FIELDBUS_MONITORING)
                    {
                        "Clear the fault (`drivedeck clear-error`) once the link is sound: the drive's fieldbus monitoring tripped while its link was down"
                    } else {
                        "Remove the fault's cause, then clear it (`drivedeck clear-error`)"
                    },
                    stood(at_rest, &at)
                ),
                at_rest,
            ),
            Some((word, state)) => (
                format!(
                    "Find what took the drive out of Operation enabled (a quick stop, a switch-off by another master or tool, the enable input): {what}: {failure}; the drive read again is in {} (6041h = {word:04X}h), {}",
                    state.map_or_else(|| "no valid power state".to_owned(), |s| s.to_string()),
                    stood(at_rest, &at)
                ),
                at_rest,
            ),
            None => (
                format!(
                    "Check the drive at the machine: {what}: {failure}, and the statusword 6041h could not be read again to confirm it ({}), {}",
                    match word {
                        Ok(Err(e)) => e.to_string(),
                        Err(f) => f.message,
                        Ok(Ok(v)) => format!("not a statusword: {v}"),
                    },
                    stood(at_rest, &at)
                ),
                at_rest,
            ),
        };
        Failure {
            stop: !stopped,
            ..failed(message)
        }
    }
}

/// 603Fh when the drive's fieldbus monitoring tripped (the link was down too long).
const FIELDBUS_MONITORING: u16 = 0x8000;

/// How long a move that ended by a fault or a power loss is given to come to rest
/// (the drive's fault or quick stop reaction brakes it) before it is judged.
const SETTLE_WAIT: Duration = Duration::from_secs(3);

impl Session {
    /// Let samples arrive until the motor is seen at rest or `deadline` passes.
    fn wait_at_rest(&mut self, deadline: Instant) {
        while self.latest.and_then(|s| s.at_rest()) != Some(true) {
            if self.next(deadline).is_err() {
                return;
            }
        }
    }
}

/// Whether the drive was seen standing still, and where.
fn stood(at_rest: bool, at: &str) -> String {
    if at_rest {
        format!("standing still {at}")
    } else {
        format!("last seen {at}, not known to stand still")
    }
}

/// Frames of `--trace` on stderr, one a line: direction, raw, meaning.
pub(super) fn print_frames(frames: &[crate::link::TraceRecord]) {
    for f in frames {
        eprintln!(
            "{} {:<24} {}",
            if f.sent { "tx" } else { "rx" },
            f.raw,
            f.text
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Status, TxImage};
    use crate::signal::{Signal, Signals};

    fn sample(t: f64, bits: &[StatusBit], rpm: f64) -> Sample {
        let status = bits
            .iter()
            .fold(Status(0), |status, bit| status.with(*bit, true));
        Sample {
            t,
            tx: TxImage {
                status,
                ..TxImage::default()
            },
            signals: Signals::default()
                .with(Signal::Velocity, rpm)
                .with(Signal::Position, 36_000.0),
            ..Sample::default()
        }
    }

    /// What the watch says after `samples`, 10 ms apart from t = 0.
    fn watched(bits: &[StatusBit], rpm: f64, samples: usize) -> Option<End> {
        let mut watch = EndWatch::default();
        (0..samples)
            .filter_map(|i| watch.check(&sample(i as f64 * 0.01, bits, rpm)))
            .map(|seen| seen.end)
            .next()
    }

    const ENABLED: StatusBit = StatusBit::OperationEnabled;

    #[test]
    fn a_drive_standing_at_a_limit_switch_ends_the_wait_after_the_hold() {
        let bits = [ENABLED, StatusBit::LimitReached];
        assert_eq!(watched(&bits, 0.0, 40), None, "0.4 s is not yet the end");
        assert_eq!(watched(&bits, 0.0, 60), Some(End::LimitSwitch));
    }

    #[test]
    fn a_move_away_from_a_limit_switch_goes_on() {
        let bits = [ENABLED, StatusBit::LimitReached];
        assert_eq!(watched(&bits, 30.0, 200), None);
    }

    #[test]
    fn a_drive_halted_from_elsewhere_ends_the_wait() {
        let bits = [ENABLED, StatusBit::QsHaltBit];
        assert_eq!(watched(&bits, 0.0, 60), Some(End::Halted));
    }

    #[test]
    fn a_target_reached_or_a_motor_at_speed_is_no_end() {
        let reached = [ENABLED, StatusBit::LimitReached, StatusBit::TargetReached];
        assert_eq!(watched(&reached, 0.0, 200), None);
        assert_eq!(watched(&[ENABLED], 0.0, 200), None);
    }

    #[test]
    fn the_limit_message_leads_with_what_to_do_and_names_the_position() {
        let seen = EndSeen {
            end: End::LimitSwitch,
            at_rest: true,
        };
        let f = seen.failure(
            "move",
            &sample(1.0, &[ENABLED, StatusBit::LimitReached], 0.0),
        );
        assert!(
            f.message.starts_with("Move the axis off the limit switch"),
            "{}",
            f.message
        );
        assert!(f.message.contains("at position 36000"), "{}", f.message);
        assert!(!f.stop, "stood still: nothing to stop");
        let unknown = EndSeen {
            end: End::Halted,
            at_rest: false,
        };
        assert!(unknown.failure("move", &Sample::default()).stop);
    }
}
