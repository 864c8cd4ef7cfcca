//! The reducer: every worker event applied to a drive's model, one handler per event. A
//! reply to a request goes to the request's owner, found by its id (see `requests`).
//!
//! A model: no egui here.

use std::time::{Duration, SystemTime};

use super::log::{LogEntry, Outcome};
use super::motion::{ReadBack, TORQUE_SLOPE};
use super::requests::Owner;
use super::{Connection, Drive, News};
use crate::diagnostics::{Origin, Severity};
use crate::link::{FoundDevice, LinkFailure, LinkInfo, LinkSpec, Notice, NoticeKind, TraceRecord};
use crate::od::{Address, Value};
use crate::pdi::{RxImage, StatusBit};
use crate::telemetry::{Gap, ScopeEvent, link_mark};
use crate::ui::browser::Pending;
use crate::worker::{CommandProgress, Event, ObjectError, Rejection, Request, RequestId, Sample};

/// Bus frames kept per drive (the export writes what is kept).
pub const FRAME_LIMIT: usize = 20_000;

impl Drive {
    /// The reducer: one worker event into the drive's model; what the window must know
    /// of it (a capture to show), if anything.
    pub fn apply(&mut self, event: Event) -> Option<News> {
        if self.reply_to_panel(&event) {
            return None;
        }
        self.panels.on_event(&event);
        match event {
            Event::Connecting(spec) => self.on_connecting(spec),
            Event::Connected(info) => self.on_connected(info),
            Event::LinkChanged(info) => {
                if self.link.is_connected() {
                    self.link.connection = Connection::Connected(info);
                }
            }
            Event::ConnectFailed {
                spec,
                error,
                retry_in,
            } => self.on_connect_failed(spec, error, retry_in),
            Event::Disconnected { reason } => self.on_disconnected(reason),
            Event::Rejected {
                id,
                request,
                reason,
            } => self.on_rejected(id, request, reason),
            Event::Sent { id, t, what, image } => self.on_sent(id, t, what, image),
            Event::Progress { id, progress } => self.on_progress(id, progress),
            Event::ObjectRead {
                id,
                address,
                result,
            } => self.on_object_read(id, address, result),
            Event::ObjectWritten {
                id,
                address,
                value,
                result,
            } => self.on_object_written(id, address, value, result),
            Event::Samples(samples) => return self.on_samples(samples),
            Event::Health(health) => self.link.health = Some(health),
            Event::Frames(frames) => self.on_frames(frames),
            Event::SerialPorts(ports) => {
                self.link.machine.serial_ports = Some(ports);
                self.link.machine.ports_asked = false;
            }
            Event::Interfaces(interfaces) => {
                self.link.machine.interfaces = Some(interfaces);
                self.link.machine.interfaces_asked = false;
            }
            Event::Scanned { id, result } => {
                self.requests.done(id);
                self.on_scanned(result);
            }
            Event::LinkOwnChanges(changes) => self.link.own_changes = changes,
            // The Changes tab's model takes it (`Drive::panels`).
            Event::Changed { .. } => {}
            Event::Notice(notice) => self.on_notice(notice),
            Event::Cancelled { id, dropped } => {
                if let Some(Owner::Browser(pending)) = self.requests.owner_mut(id)
                    && self.browser.on_cancelled(id, pending, dropped)
                {
                    self.requests.done(id);
                }
            }
        }
        None
    }

    fn on_connecting(&mut self, spec: LinkSpec) {
        self.info(format!("connecting to {spec}"));
        self.link.connection = Connection::Connecting(spec);
    }

    /// A link up (the first, one brought back, or another): the session goes on, with
    /// one clock, its plot history, markers and timeline kept; identity, diagnosis and
    /// torque slope are read anew, and another drive than before is marked once its
    /// identity is known.
    fn on_connected(&mut self, info: LinkInfo) {
        self.info(format!("connected: {}", info.description));
        let link = info.spec.to_string();
        self.browser.on_connected(&link);
        // Answers still coming for the browser over the link before are not its now.
        for owner in self.requests.owners_mut() {
            if let Owner::Browser(pending) = owner {
                *pending = Pending::Stale;
            }
        }
        let state = &mut self.link;
        state.connection = Connection::Connected(info);
        state.lost = None;
        state.sampled_since_connect = false;
        state.connected_at = None;
        state.injected.clear();
        // The exports name the device: read its identity again.
        state.identity = None;
        self.motion.halt_engaged = false;
        self.motion.torque_slope = None;
        // Why the drive stood on the link before is history now (the log and the fault
        // timeline keep it): the tile tells of this link's drive only.
        self.motion.why = None;
        self.describe_drive(None, &link);
        self.timeline.reconnected();
        self.read_on_connecting();
    }

    /// A connection attempt failed; the worker may retry.
    fn on_connect_failed(
        &mut self,
        spec: LinkSpec,
        error: LinkFailure,
        retry_in: Option<Duration>,
    ) {
        self.timeline.add(
            None,
            Severity::Warning,
            Origin::Link,
            format!("connection to {spec} failed: {error}"),
        );
        let retry = retry_in
            .map(|d| format!("; retrying in {:.1} s", d.as_secs_f64()))
            .unwrap_or_default();
        self.info(format!("connection to {spec} failed: {error}{retry}"));
        self.check_against_project(Err(&error.to_string()));
        self.link.connection = Connection::Failed {
            spec,
            error,
            retry_in,
        };
    }

    /// The link closed: by the user (no reason) or lost (the reason goes on the timeline).
    fn on_disconnected(&mut self, reason: Option<String>) {
        // The plots go on on the same clock: a gap until the next sample.
        match &reason {
            Some(reason) => self.scope.link_down(true, format!("link lost: {reason}")),
            None => self.scope.link_down(false, "disconnected"),
        }
        if let Some(reason) = &reason {
            let t = self.sample_time();
            self.timeline.add(
                t,
                Severity::Fault,
                Origin::Link,
                format!("link lost: {reason}"),
            );
        }
        match &reason {
            Some(reason) => self.info(format!("link lost: {reason}")),
            None => self.info("disconnected"),
        }
        let state = &mut self.link;
        state.connection = Connection::Disconnected;
        state.lost = reason;
        state.health = None;
        state.own_changes.clear();
        self.motion.jog = None;
        self.motion.halt_engaged = false;
        self.motion.halt_request = None;
    }

    /// A request the worker would not send, told to whoever asked.
    fn on_rejected(&mut self, id: RequestId, request: String, reason: Rejection) {
        match self.requests.owner_mut(id) {
            Some(Owner::Browser(pending)) => {
                if self.browser.on_rejected(id, pending, &reason) {
                    self.requests.done(id);
                }
                return;
            }
            Some(Owner::Watch) => {
                self.watch.on_rejected(id, &reason);
                return;
            }
            Some(owner @ (Owner::Identity | Owner::Diagnosis | Owner::TorqueSlope)) => {
                let owner = owner.clone();
                self.read_refused(id, &owner);
                return;
            }
            // A panel's replies went to it before (`reply_to_panel`).
            Some(Owner::User | Owner::Window | Owner::Panel { .. }) | None => {}
        }
        if self.motion.halt_request == Some(id) {
            self.motion.halt_request = None;
            self.motion.halt_engaged = false;
        }
        if let Rejection::Refused(why) = &reason {
            self.motion.why = Some(format!("{request} refused: {why}"));
        }
        let at = self.clock;
        match self.log.entry(id) {
            Some(entry) => entry.outcome = Outcome::Failed(reason.to_string()),
            None => self.log.push(LogEntry {
                at,
                id: Some(id),
                what: request,
                image: None,
                outcome: Outcome::Failed(reason.to_string()),
            }),
        }
    }

    /// A PDI command went out: marked on the plots and logged with its image.
    fn on_sent(&mut self, id: RequestId, t: f64, what: String, image: RxImage) {
        self.scope.mark(t, what.clone());
        let at = self.clock;
        if let Some(entry) = self.log.entry(id) {
            entry.image = Some(image);
            entry.outcome = Outcome::Sent;
        } else {
            self.log.push(LogEntry {
                at,
                id: Some(id),
                what,
                image: Some(image),
                outcome: Outcome::Sent,
            });
        }
    }

    /// A command moved on: its log entry, the halt toggle and the timeline follow.
    fn on_progress(&mut self, id: RequestId, progress: CommandProgress) {
        if self.motion.halt_request == Some(id) && progress.is_final() {
            self.motion.halt_request = None;
            if !progress.is_success() {
                self.motion.halt_engaged = false;
            }
        }
        // A command a newer one replaced ended as the user wanted: not a fault.
        let superseded = matches!(progress, CommandProgress::Superseded);
        if !progress.is_success()
            && !superseded
            && let Some(what) = self.log.entry(id).map(|e| e.what.clone())
        {
            let t = self.sample_time();
            self.timeline.add(
                t,
                Severity::Warning,
                Origin::Command,
                format!("{what}: {progress}"),
            );
            // A link lost mid-move: its words lead with what the technician must do.
            self.motion.why = Some(match &progress {
                CommandProgress::LinkLost { reason } => {
                    format!("{reason} ({what}: the link was lost before it finished)")
                }
                _ => format!("{what}: {progress}"),
            });
        }
        if let Some(entry) = self.log.entry(id) {
            entry.outcome = match &progress {
                CommandProgress::Accepted => Outcome::Accepted,
                CommandProgress::Done { .. } => Outcome::Succeeded(progress.to_string()),
                CommandProgress::Superseded => Outcome::Superseded(progress.to_string()),
                _ => Outcome::Failed(progress.to_string()),
            };
        }
    }

    /// An object read came back: to the diagnosis, the identity, the browser, the watch
    /// panel, the torque slope or the user, whoever asked.
    fn on_object_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: Result<Value, ObjectError>,
    ) {
        let clock = self.clock;
        match self.requests.owner_mut(id) {
            Some(Owner::Diagnosis) => return self.diagnosis_read(id, address, result),
            Some(Owner::Identity) => return self.identity_read(id, address, result),
            Some(Owner::TorqueSlope) => return self.slope_read(id, result),
            Some(Owner::Watch) => {
                if self.watch.on_read(id, address, &result, clock) {
                    self.requests.done(id);
                }
                return;
            }
            Some(Owner::Browser(pending)) => {
                if self.browser.on_read(id, pending, address, &result, clock) {
                    self.requests.done(id);
                }
                return;
            }
            // A panel's replies went to it before (`reply_to_panel`).
            Some(Owner::User | Owner::Window | Owner::Panel { .. }) | None => {}
        }
        if let Some(entry) = self.log.entry(id) {
            entry.outcome = match &result {
                Ok(value) => Outcome::Succeeded(format!("{address} = {value}")),
                Err(e) => Outcome::Failed(e.to_string()),
            };
        }
        if let Err(e) = &result {
            // The device's answer (Modbus exception, SDO abort, CIP status).
            self.object_failure(format!("read {address}: {e}"));
        }
        self.motion.last_object = Some(ReadBack { address, result });
    }

    /// An object write came back.
    fn on_object_written(
        &mut self,
        id: RequestId,
        address: Address,
        value: Value,
        result: Result<(), ObjectError>,
    ) {
        if address == TORQUE_SLOPE && result.is_ok() {
            self.motion.torque_slope = value.as_i128().and_then(|v| i64::try_from(v).ok());
        }
        if let Some(Owner::Browser(pending)) = self.requests.owner_mut(id) {
            let pending = std::mem::replace(pending, Pending::Stale);
            self.requests.done(id);
            self.browser.on_written(pending, address, &result);
            return;
        }
        if let Some(entry) = self.log.entry(id) {
            entry.outcome = match &result {
                Ok(()) => Outcome::Succeeded(format!("{address} = {value} written")),
                Err(e) => Outcome::Failed(e.to_string()),
            };
        }
        if let Err(e) = &result {
            self.object_failure(format!("write {value} to {address}: {e}"));
        }
        self.motion.last_object = Some(ReadBack {
            address,
            result: result.map(|()| value),
        });
    }

    /// Samples: timeline, scope and triggers, the latest state, the halt toggle.
    fn on_samples(&mut self, samples: Vec<Sample>) -> Option<News> {
        let first = samples.first()?;
        self.link.last_sample_at = Some(SystemTime::now());
        // The first sample on this link: where it starts on the one time axis.
        let fresh = !self.link.sampled_since_connect;
        if fresh {
            self.link.connected_at = Some(first.t);
        }
        self.link.sampled_since_connect = true;
        let first_t = first.t;
        let gap = self.scope.open_gap().cloned();
        let mut news = None;
        for sample in &samples {
            if self.timeline.observe(sample) {
                self.want_diagnosis();
            }
            news = self.scoped(sample).or(news);
        }
        if let Some(gap) = gap
            && self.scope.open_gap().is_none()
        {
            self.link_back(&gap, first_t);
        }
        self.take_latest(&samples, fresh);
        if let Some(last) = samples.last() {
            // A finished halt the drive no longer shows (a new command, a quick
            // stop, a fault) releases the toggle.
            if self.motion.halt_engaged
                && self.motion.halt_request.is_none()
                && !last.tx.status.is_set(StatusBit::QsHaltBit)
            {
                self.motion.halt_engaged = false;
            }
        }
        news
    }

    /// One sample into the plots' history and the trigger.
    fn scoped(&mut self, sample: &Sample) -> Option<News> {
        match self.scope.push(sample)? {
            ScopeEvent::Fired(at) => {
                self.info(format!("trigger fired at {at:.3} s"));
                None
            }
            ScopeEvent::Recorded => {
                let text = self.scope.recording().map(|r| {
                    format!(
                        "triggered recording ready: {:.2} s, {} samples; Save recording writes it",
                        r.duration(),
                        r.len()
                    )
                })?;
                self.info(text.clone());
                Some(News::Captured(text))
            }
        }
    }

    /// The newest value of every signal, merged over the samples before on this link (the
    /// first sample of a link starts afresh: another drive's values are not carried over).
    fn take_latest(&mut self, samples: &[Sample], fresh: bool) {
        for (i, sample) in samples.iter().enumerate() {
            self.link.latest = Some(match &self.link.latest {
                Some(older) if !(fresh && i == 0) && sample.t >= older.t => {
                    sample.merged_over(older)
                }
                _ => *sample,
            });
        }
    }

    /// Samples again after a gap (`at`: the first): how long the plots went without, on
    /// the timeline.
    fn link_back(&mut self, gap: &Gap, at: f64) {
        let what = if gap.lost {
            "link back"
        } else {
            "connected again"
        };
        self.timeline.add(
            Some(at),
            Severity::Info,
            Origin::Link,
            format!("{what} after {:.1} s without samples", at - gap.from),
        );
    }

    /// Traced frames into the frame log, the oldest going beyond [`FRAME_LIMIT`].
    fn on_frames(&mut self, frames: Vec<TraceRecord>) {
        for frame in frames {
            if self.frames.len() >= FRAME_LIMIT {
                self.frames.pop_front();
            }
            self.frames.push_back(frame);
        }
    }

    fn on_scanned(&mut self, result: Result<Vec<FoundDevice>, LinkFailure>) {
        match &result {
            Ok(found) => self.info(format!("bus scan: {} device(s) found", found.len())),
            Err(e) => self.info(format!("bus scan failed: {e}")),
        }
        self.scan = Some(result);
    }

    /// Something the link reported; EMCY and stopped jogs go on the timeline too.
    fn on_notice(&mut self, notice: Notice) {
        let t = self.sample_time();
        match notice.kind {
            NoticeKind::Emcy { error_code, .. } => {
                let severity = if error_code == 0 {
                    Severity::Info
                } else {
                    Severity::Fault
                };
                self.timeline
                    .add(t, severity, Origin::Emcy, notice.text.clone());
            }
            NoticeKind::MotorStopped => {
                self.timeline
                    .add(t, Severity::Warning, Origin::Link, notice.text.clone());
                self.motion.why = Some(notice.text.clone());
            }
            NoticeKind::Info => {
                // An outage the link got over, its end, a reply sent again: a marker on
                // the plots at the newest sample, and so in the exported files.
                if let (Some(text), Some(t)) = (link_mark(&notice.text), t) {
                    self.scope.mark(t, text);
                }
            }
        }
        self.info(notice.text)
    }

    /// An object access the device refused, on the timeline.
    fn object_failure(&mut self, text: String) {
        let t = self.sample_time();
        self.timeline
            .add(t, Severity::Warning, Origin::Command, text);
    }

    /// A reply to a request of a panel the drive keeps the model of, handed to it; `true`
    /// when the event was such a reply.
    fn reply_to_panel(&mut self, event: &Event) -> bool {
        let id = match event {
            Event::Scanned { .. } => return false,
            other => match other.reply_id() {
                Some(id) => id,
                None => return false,
            },
        };
        let Some(Owner::Panel { panel, tag }) = self.requests.owner(id).cloned() else {
            return false;
        };
        if self.panels.on_reply(panel, tag, event) {
            self.requests.done(id);
        }
        true
    }

    /// The worker took a request as `id` (or could not: `Err` with why).
    pub(super) fn handed_over(
        &mut self,
        owner: Owner,
        request: &Request,
        sent: Result<RequestId, String>,
    ) {
        let id = match sent {
            Ok(id) => id,
            Err(reason) => return self.unsent(owner, request, reason),
        };
        match &owner {
            Owner::Identity | Owner::Diagnosis => self.read_sent(id, &owner),
            Owner::Browser(pending) => self.browser.sent(id, pending),
            Owner::Watch => self.watch.sent(id, request),
            Owner::User => {
                if matches!(request, Request::Halt) {
                    self.motion.halt_request = Some(id);
                }
                let at = self.clock;
                self.log.push(LogEntry {
                    at,
                    id: Some(id),
                    what: request.to_string(),
                    image: None,
                    outcome: Outcome::Queued,
                });
            }
            Owner::TorqueSlope | Owner::Window | Owner::Panel { .. } => {}
        }
        // Only requests with replies need their owner kept.
        if expects_replies(request) {
            self.requests.sent(id, owner);
        }
    }

    /// The worker could not take a request: its owner is told.
    fn unsent(&mut self, owner: Owner, request: &Request, reason: String) {
        match owner {
            Owner::Browser(pending) => self.browser.unsent(pending, request, &reason),
            Owner::Watch => self.watch.unsent(&reason),
            Owner::Identity | Owner::Diagnosis | Owner::TorqueSlope => {}
            Owner::Panel { panel, tag } => {
                let refused = Event::Rejected {
                    id: 0,
                    request: request.to_string(),
                    reason: Rejection::Refused(reason),
                };
                self.panels.on_reply(panel, tag, &refused);
            }
            Owner::User | Owner::Window => {
                let at = self.clock;
                self.log.push(LogEntry {
                    at,
                    id: None,
                    what: request.to_string(),
                    image: None,
                    outcome: Outcome::Failed(reason),
                });
            }
        }
    }
}

/// Whether the worker answers a request with events that carry its id.
fn expects_replies(request: &Request) -> bool {
    !matches!(
        request,
        Request::Connect(_)
            | Request::Disconnect
            | Request::JogKeepAlive
            | Request::Inject { .. }
            | Request::SetPollRate(_)
            | Request::SetLinkLoss(_)
            | Request::SetLostAfter(_)
            | Request::SetTrace(_)
            | Request::Watch(_)
            | Request::Cancel(_)
            | Request::ListSerialPorts
            | Request::ListInterfaces
    )
}
