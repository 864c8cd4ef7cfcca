//! One drive's run of a procedure, without I/O: it asks for worker requests (each with a
//! tag), is handed their replies, every worker event and the time, and steps through the
//! procedure — reading, writing, commanding, asking the operator — to a [`DriveRecord`].
//! The window's Procedure tab and `drivedeck commission` drive the same runner; only how
//! requests travel and how the operator answers differ.
//!
//! One request is under way at a time. The clock (`tick`) is the driver's, in seconds;
//! the test steps measure on the samples' own clock.

mod judge;
mod moves;
mod objects;
mod reboot;
mod waits;

pub use judge::judge;
use judge::{input_figure, nanoj_figure, thin};
use objects::{differs_from_baseline, differs_from_factory, identity_rows};

use std::collections::BTreeMap;
use std::sync::Arc;

use super::file::{Condition, Kind, Limits, OnFailure, Procedure};
use super::record::{self, Difference, DriveRecord, Figure, Plot, StepRecord, Verdict};
use crate::diagnostics::Timeline;
use crate::od::backup::{self, Backup, DeviceIdentity, IDENTITY, STORE_ALL};
use crate::od::{Address, DataType, Value, builtin};
use crate::pdi::{Action, Opcode};
use crate::signal::{Sample, Signal};
use crate::telemetry::test_run::{Plan, StepReport};
use crate::telemetry::test_sequence::{Next, Sequence};
use crate::worker::{CommandProgress, Event, LinkLossAction, ObjectPath, Request};

/// "boot" to 2800h:01 restarts the firmware.
const BOOT: u64 = 0x746F_6F62;
/// How often an input or the NanoJ program is read while waited for, seconds.
const POLL_S: f64 = 0.1;
/// After a restart the link may never notice it was gone: the objects are read again
/// after this long all the same.
const REBOOT_QUIET_S: f64 = 2.5;
/// A test step may take its plan's time and this much more before it counts as stuck.
const TEST_SLACK_S: f64 = 30.0;

/// What a drive's run is told about the drive beside the procedure.
#[derive(Clone, Debug, Default)]
pub struct DriveSetup {
    pub name: String,
    /// The link, in words, for the record.
    pub link: String,
    /// The identity the project stored (None: no project, or none stored).
    pub expected: Option<DeviceIdentity>,
    /// The project's backup of the drive: its baseline.
    pub baseline: Option<Backup>,
    /// The backup each apply-backup step writes, by step index (resolved and loaded
    /// before anything runs).
    pub backups: BTreeMap<usize, Backup>,
    /// A simulated drive stands in for the project's.
    pub rehearsal: bool,
    /// What an aborted run leaves the drive in (the on-exit rule: `--on-exit`, or the
    /// project drive's link-loss policy): halt by default.
    pub on_abort: LinkLossAction,
}

/// What the operator is asked now.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Prompt {
    /// A yes/no question: [`DriveRun::answer`].
    Question(String),
    /// Something to do at the machine (press a switch); the run sees it happen.
    Action(String),
}

/// Where the step under way stands.
#[derive(Debug)]
enum Phase {
    /// Between steps.
    Ready,
    Identity {
        reads: BTreeMap<Address, Result<Value, String>>,
    },
    BackupRead {
        reads: BTreeMap<Address, Result<Value, String>>,
        expected: usize,
    },
    BackupWrite {
        plan: Vec<backup::Step>,
        at: usize,
        failures: Vec<String>,
        left_out: Vec<String>,
    },
    Command {
        deadline: f64,
    },
    Asking,
    Test {
        sequence: Box<Sequence>,
        limits: Limits,
        deadline: f64,
        /// Where a limit switch was reached during the test, if one was (position).
        limit_at: Option<f64>,
    },
    /// Rehearsal: 3240h:03 and :04 read before an input is forced.
    ForceRead {
        words: [Option<u32>; 2],
    },
    InputWait {
        deadline: f64,
        next_poll: f64,
        /// 3240h:03 and :04 to put back (rehearsal).
        restore: Option<[u32; 2]>,
        seen: Option<bool>,
    },
    Unforce {
        restore: [u32; 2],
        verdict: (Verdict, String, Vec<Figure>),
        sub: u8,
    },
    NanojStart,
    NanojWait {
        deadline: f64,
        next_poll: f64,
        running: bool,
        last: Option<i64>,
    },
    Store,
    RebootRead {
        verify: Vec<(Address, DataType)>,
        reads: BTreeMap<Address, Result<Value, String>>,
    },
    RebootSent {
        expected: BTreeMap<Address, Value>,
        verify: Vec<(Address, DataType)>,
        sent_at: f64,
        deadline: f64,
        lost: bool,
        back: bool,
    },
    RebootVerify {
        expected: BTreeMap<Address, Value>,
        verify: Vec<(Address, DataType)>,
        reads: BTreeMap<Address, Result<Value, String>>,
        back_after: f64,
        deadline: f64,
    },
    /// The settings read at the end, for the comparisons.
    Final {
        reads: BTreeMap<Address, Result<Value, String>>,
        expected: usize,
    },
    Done,
}

/// One drive's run.
#[derive(Debug)]
pub struct DriveRun {
    procedure: Arc<Procedure>,
    setup: DriveSetup,
    pub steps: Vec<StepRecord>,
    /// The step under way (== steps.len() once every step ended).
    at: usize,
    phase: Phase,
    now: f64,
    started: Option<f64>,
    step_started: f64,
    requests: Vec<(u64, Request)>,
    next_tag: u64,
    /// The request under way.
    waiting: Option<u64>,
    connected: bool,
    prompt: Option<Prompt>,
    timeline: Timeline,
    identity: Option<DeviceIdentity>,
    /// What this run wrote (for the restart's check).
    written: BTreeMap<Address, (DataType, Value)>,
    /// A step that stops the run failed, or the run was aborted: the rest is skipped.
    stopping: Option<(Verdict, String)>,
    latest: Option<Sample>,
    record: Option<DriveRecord>,
}

fn text_of(result: &Result<Value, crate::worker::ObjectError>) -> Result<Value, String> {
    result.clone().map_err(|e| e.to_string())
}

fn int(value: &Value) -> Option<i64> {
    value.as_i128().and_then(|v| i64::try_from(v).ok())
}

/// A read request for these objects.
fn read_many(objects: Vec<(Address, DataType)>) -> Request {
    Request::ReadMany {
        objects,
        path: ObjectPath::Auto,
    }
}

fn write(address: Address, dtype: DataType, value: Value) -> Request {
    Request::WriteObject {
        address,
        dtype,
        value,
        path: ObjectPath::Auto,
    }
}

fn catalog_type(address: Address) -> DataType {
    builtin()
        .get(address)
        .map_or(DataType::Unsigned32, |e| e.dtype)
}

impl DriveRun {
    pub fn new(procedure: Arc<Procedure>, setup: DriveSetup) -> DriveRun {
        DriveRun {
            procedure,
            setup,
            steps: Vec::new(),
            at: 0,
            phase: Phase::Ready,
            now: 0.0,
            started: None,
            step_started: 0.0,
            requests: Vec::new(),
            next_tag: 1,
            waiting: None,
            connected: false,
            prompt: None,
            timeline: Timeline::default(),
            identity: None,
            written: BTreeMap::new(),
            stopping: None,
            latest: None,
            record: None,
        }
    }

    pub fn name(&self) -> &str {
        &self.setup.name
    }

    pub fn procedure(&self) -> &Procedure {
        &self.procedure
    }

    /// The question or action the operator is asked now.
    pub fn prompt(&self) -> Option<&Prompt> {
        self.prompt.as_ref()
    }

    /// The step under way (its index), if any.
    pub fn current(&self) -> Option<usize> {
        (self.at < self.procedure.steps.len() && self.record.is_none()).then_some(self.at)
    }

    /// Where the step under way stands, in words.
    pub fn progress(&self) -> Option<String> {
        Some(match &self.phase {
            Phase::Test { sequence, .. } => sequence.progress(),
            Phase::Final { .. } => "reading the settings for the record".into(),
            Phase::RebootSent { .. } => "waiting for the drive to come back".into(),
            Phase::InputWait { .. } | Phase::NanojWait { .. } => "waiting".into(),
            Phase::Done | Phase::Ready => return None,
            _ => "under way".into(),
        })
    }

    /// The record, once the run is over.
    pub fn record(&self) -> Option<&DriveRecord> {
        self.record.as_ref()
    }

    pub fn is_over(&self) -> bool {
        self.record.is_some()
    }

    /// Whether a restart is under way (a lost link is then expected).
    pub fn expects_restart(&self) -> bool {
        matches!(self.phase, Phase::RebootSent { .. })
    }

    /// The requests to send now, each with its tag.
    pub fn take_requests(&mut self) -> Vec<(u64, Request)> {
        std::mem::take(&mut self.requests)
    }

    fn send(&mut self, request: Request) {
        let tag = self.next_tag;
        self.next_tag += 1;
        self.waiting = Some(tag);
        self.requests.push((tag, request));
    }

    /// The link is up: for a driver whose connection was made before the runner saw its
    /// `Connected` (a session opened, or opened again after a restart).
    pub fn link_up(&mut self) {
        self.connected = true;
        if let Phase::RebootSent { lost, back, .. } = &mut self.phase {
            *lost = true;
            *back = true;
        }
    }

    /// Every worker event of the drive, in order.
    pub fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => {
                self.connected = true;
                if let Phase::RebootSent { lost, back, .. } = &mut self.phase
                    && *lost
                {
                    *back = true;
                }
            }
            Event::Disconnected { reason } => {
                self.connected = false;
                if let Phase::RebootSent { lost, .. } = &mut self.phase {
                    *lost = true;
                } else if self.record.is_none() && self.started.is_some() {
                    let why = reason
                        .clone()
                        .unwrap_or_else(|| "the drive was disconnected".into());
                    self.abort(&format!("the link was lost: {why}"));
                }
            }
            Event::ConnectFailed { .. } => {
                if let Phase::RebootSent { lost, .. } = &mut self.phase {
                    *lost = true;
                }
            }
            Event::Samples(samples) => self.on_samples(samples),
            // A stop from elsewhere (the window's Esc, a Quickstop button, another
            // script): the run never sends one itself, so it ends here, said so.
            Event::Sent { image, .. } if self.started.is_some() && self.record.is_none() => {
                let stop = match image.command().map(|c| c.opcode) {
                    Ok(Opcode::Quickstop) => Some("a quick stop was sent (Esc)"),
                    Ok(Opcode::SwitchOff) => Some("the power stage was switched off (Shift+Esc)"),
                    _ => None,
                };
                if let Some(why) = stop {
                    self.abort(why);
                }
            }
            _ => {}
        }
    }

    fn on_samples(&mut self, samples: &[Sample]) {
        for sample in samples {
            self.timeline.observe(sample);
        }
        if let Some(last) = samples.last() {
            self.latest = Some(*last);
        }
        if let Phase::Test {
            sequence, limit_at, ..
        } = &mut self.phase
        {
            if limit_at.is_none()
                && let Some(hit) = samples
                    .iter()
                    .find(|s| s.tx.status.is_set(crate::pdi::StatusBit::LimitReached))
            {
                *limit_at = Some(hit.signals.get(Signal::Position).unwrap_or(f64::NAN));
            }
            let next = sequence.on_samples(samples);
            self.follow(next);
        }
    }

    /// A reply to the request with `tag`; `true` when the request is over.
    pub fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        if self.waiting != Some(tag) {
            // A halt sent on abort, a write not waited for, or a reply after the step
            // moved on.
            return match event {
                Event::Progress { progress, .. } => progress.is_final(),
                Event::Sent { .. } => false,
                _ => true,
            };
        }
        let over = match event {
            Event::Rejected { reason, .. } => {
                self.waiting = None;
                self.refused(format!("not sent: {reason}"));
                return true;
            }
            Event::Cancelled { .. } => {
                self.waiting = None;
                return true;
            }
            Event::ObjectRead {
                address, result, ..
            } => self.on_read(*address, text_of(result)),
            Event::ObjectWritten { result, .. } => {
                self.on_written(result.clone().map_err(|e| e.to_string()));
                true
            }
            Event::Progress { progress, .. } if progress.is_final() => {
                self.on_command_over(progress);
                true
            }
            _ => false,
        };
        if over && self.waiting == Some(tag) {
            self.waiting = None;
        }
        over
    }

    /// The driver's clock (seconds): starts the run, ends waits that ran out, polls.
    pub fn tick(&mut self, now: f64) {
        self.now = now;
        if self.started.is_none() {
            if !self.connected {
                return;
            }
            self.started = Some(now);
            self.begin_step();
        }
        if self.waiting.is_some() {
            // A deadline still ends a wait whose request never comes back.
            self.check_deadlines();
            return;
        }
        self.check_deadlines();
        let nanoj_object = self.nanoj_object();
        match &mut self.phase {
            Phase::InputWait { next_poll, .. } if now >= *next_poll => {
                *next_poll = now + POLL_S;
                self.send(Request::ReadObject {
                    address: Address::new(0x60FD, 0),
                    dtype: Some(DataType::Unsigned32),
                    path: ObjectPath::Auto,
                });
            }
            Phase::NanojWait {
                next_poll, running, ..
            } if now >= *next_poll => {
                *next_poll = now + POLL_S;
                let objects = if *running {
                    vec![(nanoj_object, catalog_type(nanoj_object))]
                } else {
                    vec![
                        (Address::new(0x2301, 0), DataType::Unsigned32),
                        (Address::new(0x2302, 0), DataType::Unsigned32),
                    ]
                };
                self.send(read_many(objects));
            }
            Phase::RebootSent {
                lost,
                back,
                sent_at,
                ..
            } if self.connected && (*back || (!*lost && now - *sent_at >= REBOOT_QUIET_S)) => {
                let back_after = now - *sent_at;
                let Phase::RebootSent {
                    expected,
                    verify,
                    deadline,
                    ..
                } = std::mem::replace(&mut self.phase, Phase::Ready)
                else {
                    return;
                };
                self.phase = Phase::RebootVerify {
                    expected,
                    verify: verify.clone(),
                    reads: BTreeMap::new(),
                    back_after,
                    deadline,
                };
                self.send(read_many(verify));
            }
            _ => {}
        }
    }

    fn check_deadlines(&mut self) {
        let now = self.now;
        let late = match &self.phase {
            Phase::Command { deadline }
            | Phase::Test { deadline, .. }
            | Phase::InputWait { deadline, .. }
            | Phase::NanojWait { deadline, .. }
            | Phase::RebootSent { deadline, .. }
            | Phase::RebootVerify { deadline, .. } => now > *deadline,
            _ => false,
        };
        if !late {
            return;
        }
        self.waiting = None;
        match std::mem::replace(&mut self.phase, Phase::Ready) {
            Phase::Command { .. } => {
                self.requests.push((0, Request::Halt));
                self.end_step(
                    Verdict::Failed,
                    "no end in time (the drive was halted)".into(),
                    vec![],
                );
            }
            Phase::Test { sequence, .. } => {
                self.requests.push((0, Request::Halt));
                self.end_step(
                    Verdict::Failed,
                    format!(
                        "the test did not end in time after {} step(s) (the drive was halted)",
                        sequence.steps.len()
                    ),
                    vec![],
                );
            }
            Phase::InputWait { restore, seen, .. } => {
                let step = self.step_kind();
                let (name, expect, within) = match step {
                    Some(Kind::Input {
                        name,
                        expect,
                        within,
                        ..
                    }) => (name, expect, within),
                    _ => (String::new(), true, std::time::Duration::ZERO),
                };
                let verdict = (
                    Verdict::Failed,
                    format!(
                        "the {name} did not become {} within {:.0} s",
                        if expect { "active" } else { "inactive" },
                        within.as_secs_f64()
                    ),
                    vec![input_figure(&name, seen, expect)],
                );
                self.after_input(restore, verdict);
            }
            Phase::NanojWait { running, last, .. } => {
                let (object, condition) = self.nanoj_expectation();
                let note = if running {
                    format!(
                        "the program runs, but {object} did not become {} in time",
                        condition.text()
                    )
                } else {
                    "the program did not report running in time (2301h)".to_owned()
                };
                let figures = vec![nanoj_figure(object, condition, last)];
                self.end_step(Verdict::Failed, note, figures);
            }
            Phase::RebootSent { .. } | Phase::RebootVerify { .. } => {
                self.end_step(
                    Verdict::Failed,
                    "the drive did not answer again in time after the restart".into(),
                    vec![],
                );
            }
            other => self.phase = other,
        }
    }

    fn step_kind(&self) -> Option<Kind> {
        self.procedure.steps.get(self.at).map(|s| s.kind.clone())
    }

    /// The operator's answer to the question asked.
    pub fn answer(&mut self, yes: bool) {
        if !matches!(self.phase, Phase::Asking) {
            return;
        }
        self.prompt = None;
        let Some(Kind::Question { expect, .. }) = self.step_kind() else {
            return;
        };
        let said = if yes { "yes" } else { "no" };
        let wanted = if expect { "yes" } else { "no" };
        let figure = Figure {
            name: "answer".into(),
            value: Some(if yes { 1.0 } else { 0.0 }),
            unit: said.into(),
            limit: Some(format!("= {wanted}")),
            passed: Some(yes == expect),
        };
        if yes == expect {
            self.end_step(
                Verdict::Passed,
                format!("the operator answered {said}"),
                vec![figure],
            );
        } else {
            self.end_step(
                Verdict::Failed,
                format!("the operator answered {said}; {wanted} passes"),
                vec![figure],
            );
        }
    }

    /// No answer can be had (the answers file ran out): the question fails, named.
    pub fn no_answer(&mut self, why: &str) {
        if matches!(self.phase, Phase::Asking) {
            self.prompt = None;
            self.end_step(Verdict::Failed, format!("no answer: {why}"), vec![]);
        }
    }

    /// Abort the run (Esc, Ctrl-C, a lost link): the drive is left as the on-exit rule
    /// says (halted by default), the step under way is aborted and the rest skipped, the
    /// record says why.
    pub fn abort(&mut self, why: &str) {
        if self.record.is_some() {
            return;
        }
        if self.connected {
            match self.setup.on_abort {
                LinkLossAction::Halt => self.requests.push((0, Request::Halt)),
                LinkLossAction::SwitchOff => {
                    self.requests.push((0, Request::Command(Action::SwitchOff)))
                }
                LinkLossAction::Nothing => {}
            }
        }
        self.prompt = None;
        self.waiting = None;
        let reason = format!("aborted: {why}");
        if self.at < self.procedure.steps.len() && !matches!(self.phase, Phase::Final { .. }) {
            self.phase = Phase::Ready;
            self.stopping = Some((Verdict::Skipped, reason.clone()));
            self.end_step(Verdict::Aborted, reason, vec![]);
        } else {
            self.stopping = Some((Verdict::Skipped, reason));
            self.finish();
        }
    }

    /// Start step `self.at`, or skip it, or end the run.
    fn begin_step(&mut self) {
        self.step_started = self.now;
        let Some(step) = self.procedure.steps.get(self.at).cloned() else {
            return self.begin_final();
        };
        if let Some((verdict, why)) = self.stopping.clone() {
            return self.end_step(verdict, why, vec![]);
        }
        let now = self.now;
        match step.kind {
            Kind::Identity => {
                self.phase = Phase::Identity {
                    reads: BTreeMap::new(),
                };
                self.send(read_many(IDENTITY.to_vec()));
            }
            Kind::ApplyBackup { .. } => {
                let Some(backup) = self.setup.backups.get(&self.at) else {
                    return self.end_step(
                        Verdict::Failed,
                        "no backup for this drive (the project has none)".into(),
                        vec![],
                    );
                };
                let objects = backup.objects_to_read(builtin());
                self.phase = Phase::BackupRead {
                    reads: BTreeMap::new(),
                    expected: objects.len(),
                };
                if objects.is_empty() {
                    return self.end_step(
                        Verdict::Passed,
                        "the backup holds no setting".into(),
                        vec![],
                    );
                }
                self.send(read_many(objects));
            }
            Kind::AutoSetup { timeout } => {
                self.phase = Phase::Command {
                    deadline: now + timeout.as_secs_f64(),
                };
                self.send(Request::Command(Action::AutoSetup));
            }
            Kind::Question { text, .. } => {
                self.phase = Phase::Asking;
                self.prompt = Some(Prompt::Question(text));
            }
            Kind::Test { plan, limits } => self.begin_test(plan, limits),
            Kind::Input { bit, prompt, .. } => {
                if self.setup.rehearsal {
                    self.phase = Phase::ForceRead {
                        words: [None, None],
                    };
                    self.send(read_many(vec![
                        (Address::new(0x3240, 3), DataType::Unsigned32),
                        (Address::new(0x3240, 4), DataType::Unsigned32),
                    ]));
                } else {
                    self.prompt = Some(Prompt::Action(prompt));
                    self.phase = Phase::InputWait {
                        deadline: now + self.input_within(),
                        next_poll: now,
                        restore: None,
                        seen: None,
                    };
                }
                let _ = bit;
            }
            Kind::Nanoj { .. } => {
                self.phase = Phase::NanojStart;
                self.send(write(
                    Address::new(0x2300, 0),
                    DataType::Unsigned32,
                    Value::Uint(1),
                ));
            }
            Kind::Store => {
                self.phase = Phase::Store;
                self.send(write(
                    STORE_ALL.0,
                    DataType::Unsigned32,
                    Value::Uint(u64::from(STORE_ALL.1)),
                ));
            }
            Kind::Reboot { verify, .. } => {
                let verify: Vec<(Address, DataType)> = if verify.is_empty() {
                    self.written
                        .iter()
                        .filter(|(a, _)| !matches!(a.index, 0x1010 | 0x1011 | 0x2300 | 0x2800))
                        .map(|(a, (t, _))| (*a, *t))
                        .collect()
                } else {
                    verify.iter().map(|a| (*a, catalog_type(*a))).collect()
                };
                if verify.is_empty() {
                    // Nothing to compare: the restart alone, checked by the drive's return.
                    self.phase = Phase::RebootRead {
                        verify: vec![],
                        reads: BTreeMap::new(),
                    };
                    return self.send_boot(BTreeMap::new(), vec![]);
                }
                self.phase = Phase::RebootRead {
                    verify: verify.clone(),
                    reads: BTreeMap::new(),
                };
                self.send(read_many(verify));
            }
        }
    }

    /// A reply's read; `true` when the request is over.
    fn on_read(&mut self, address: Address, result: Result<Value, String>) -> bool {
        let kind = self.step_kind();
        let (object, condition) = self.nanoj_expectation();
        let now = self.now;
        let step_started = self.step_started;
        match &mut self.phase {
            Phase::Identity { reads } => {
                reads.insert(address, result);
                if reads.len() < IDENTITY.len() {
                    return false;
                }
                let reads = std::mem::take(reads);
                self.identity_read(&reads);
                true
            }
            Phase::BackupRead { reads, expected } => {
                reads.insert(address, result);
                if reads.len() < *expected {
                    return false;
                }
                let reads = std::mem::take(reads);
                self.backup_read(&reads);
                true
            }
            Phase::ForceRead { words } => {
                let value = result.ok().as_ref().and_then(int).map(|v| v as u32);
                match address.sub {
                    3 => words[0] = value,
                    _ => words[1] = value,
                }
                if address.sub == 4 {
                    let words = *words;
                    self.force_input(words);
                    return true;
                }
                false
            }
            Phase::InputWait { restore, seen, .. } => {
                let Some(Kind::Input {
                    bit, expect, name, ..
                }) = kind
                else {
                    return true;
                };
                let value = result.ok().as_ref().and_then(int);
                let level = value.map(|v| v & (1 << bit) != 0);
                *seen = level;
                if level == Some(expect) {
                    let restore = *restore;
                    let verdict = (
                        Verdict::Passed,
                        format!(
                            "the {name} became {} after {:.1} s",
                            if expect { "active" } else { "inactive" },
                            now - step_started
                        ),
                        vec![input_figure(&name, level, expect)],
                    );
                    self.after_input(restore, verdict);
                }
                true
            }
            Phase::NanojWait { running, last, .. } => {
                let value = result.ok().as_ref().and_then(int);
                if *running && address != object {
                    return true;
                }
                if !*running {
                    match (address.index, value) {
                        (0x2301, Some(1)) => *running = true,
                        (0x2301, Some(0)) | (0x2301, None) => {}
                        (0x2301, Some(_)) => {
                            // Stopped with an error: 2302h follows in this read.
                        }
                        (0x2302, Some(code)) if code != 0 => {
                            let text = crate::od::nanoj::error_text(code as u32);
                            self.end_step(
                                Verdict::Failed,
                                format!("the program stopped with error {code:X}h: {text}"),
                                vec![],
                            );
                            return true;
                        }
                        _ => {}
                    }
                    return address.index == 0x2302;
                }
                *last = value;
                if value.is_some_and(|v| condition.holds(v)) {
                    let figures = vec![nanoj_figure(object, condition, value)];
                    self.end_step(
                        Verdict::Passed,
                        format!(
                            "the program runs and {object} is {}",
                            value.unwrap_or_default()
                        ),
                        figures,
                    );
                }
                true
            }
            Phase::RebootRead { verify, reads } => {
                reads.insert(address, result);
                if reads.len() < verify.len() {
                    return false;
                }
                let expected: BTreeMap<Address, Value> = reads
                    .iter()
                    .filter_map(|(a, r)| r.as_ref().ok().map(|v| (*a, v.clone())))
                    .collect();
                let verify = verify.clone();
                self.send_boot(expected, verify);
                true
            }
            Phase::RebootVerify { verify, reads, .. } => {
                reads.insert(address, result);
                if reads.len() < verify.len() {
                    return false;
                }
                self.reboot_verified();
                true
            }
            Phase::Final { reads, expected } => {
                reads.insert(address, result);
                if reads.len() < *expected {
                    return false;
                }
                self.finish();
                true
            }
            _ => true,
        }
    }

    /// Step `self.at` ended: recorded; a stopping failure skips the rest; the next begins.
    fn end_step(&mut self, verdict: Verdict, note: String, figures: Vec<Figure>) {
        let Some(step) = self.procedure.steps.get(self.at) else {
            return;
        };
        let t0 = self.started.unwrap_or(self.now);
        self.steps.push(StepRecord {
            number: self.at + 1,
            kind: step.kind.name().into(),
            title: step.title.clone(),
            verdict,
            note,
            figures,
            started_s: self.step_started - t0,
            duration_s: self.now - self.step_started,
            plot: None,
        });
        if verdict == Verdict::Failed
            && step.on_failure == OnFailure::Stop
            && self.stopping.is_none()
        {
            self.stopping = Some((
                Verdict::Skipped,
                format!("step {} failed and stops the run", self.at + 1),
            ));
        }
        self.phase = Phase::Ready;
        self.prompt = None;
        self.at += 1;
        self.begin_step();
    }

    /// After the last step: the settings read for the comparisons.
    fn begin_final(&mut self) {
        if !self.connected
            || self
                .stopping
                .as_ref()
                .is_some_and(|(_, why)| why.starts_with("aborted"))
        {
            return self.finish();
        }
        let objects = backup::objects_to_read(builtin());
        self.phase = Phase::Final {
            reads: BTreeMap::new(),
            expected: objects.len(),
        };
        self.send(read_many(objects));
    }

    fn finish(&mut self) {
        let reads = match std::mem::replace(&mut self.phase, Phase::Done) {
            Phase::Final { reads, .. } => reads,
            _ => BTreeMap::new(),
        };
        let from_factory = differs_from_factory(&reads);
        let from_baseline = self
            .setup
            .baseline
            .as_ref()
            .filter(|_| !reads.is_empty())
            .map(|b| differs_from_baseline(b, &reads));
        let identity = self
            .identity
            .as_ref()
            .map(identity_rows)
            .unwrap_or_default();
        let timeline = self
            .timeline
            .entries()
            .map(|e| record::Event {
                wall: e.wall.clone(),
                severity: e.severity.name().into(),
                text: e.text.clone(),
            })
            .collect();
        self.prompt = None;
        self.record = Some(DriveRecord {
            name: self.setup.name.clone(),
            link: self.setup.link.clone(),
            identity,
            verdict: record::overall(self.steps.iter().map(|s| &s.verdict)),
            steps: self.steps.clone(),
            differs_from_factory: from_factory,
            differs_from_baseline: from_baseline,
            timeline,
        });
    }
}
