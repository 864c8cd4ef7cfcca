//! The reducer: every worker event applied to the window's state, one handler per event.

use super::*;

impl AppState {
    /// The reducer: one worker event into the state.
    pub fn apply(&mut self, event: Event) {
        match event {
            Event::Connecting(spec) => self.on_connecting(spec),
            Event::Connected(info) => self.on_connected(info),
            Event::LinkChanged(info) => self.on_link_changed(info),
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
            Event::Samples(samples) => self.on_samples(samples),
            Event::Health(health) => self.health = Some(health),
            Event::Frames(frames) => self.on_frames(frames),
            Event::SerialPorts(ports) => {
                self.serial_ports = Some(ports);
                self.serial_ports_asked = false;
            }
            Event::Interfaces(interfaces) => {
                self.interfaces = Some(interfaces);
                self.interfaces_asked = false;
            }
            Event::Scanned { result, .. } => self.on_scanned(result),
            Event::LinkOwnChanges(changes) => self.link_changes = changes,
            Event::Changed {
                address,
                dtype,
                before,
                after,
            } => {
                let change = crate::ui::changes::ChangeEntry {
                    address,
                    dtype,
                    before,
                    after,
                };
                crate::ui::changes::note_change(&mut self.changes, change);
            }
            Event::Notice(notice) => self.on_notice(notice),
            Event::Cancelled { id, dropped } => {
                self.browser.on_cancelled(id, dropped);
            }
        }
    }

    fn on_connecting(&mut self, spec: LinkSpec) {
        self.info(format!("connecting to {spec}"));
        self.connection = Connection::Connecting(spec);
    }

    /// The link describes itself anew (it learned something about the device).
    fn on_link_changed(&mut self, info: LinkInfo) {
        if self.is_connected() {
            self.connection = Connection::Connected(info);
        }
    }

    /// Traced frames into the frame log, the oldest going beyond [`FRAME_LIMIT`].
    fn on_frames(&mut self, frames: Vec<crate::link::TraceRecord>) {
        for frame in frames {
            if self.frames.len() >= FRAME_LIMIT {
                self.frames.pop_front();
            }
            self.frames.push_back(frame);
        }
    }

    fn on_scanned(
        &mut self,
        result: Result<Vec<crate::link::FoundDevice>, crate::link::LinkFailure>,
    ) {
        match &result {
            Ok(found) => self.info(format!("bus scan: {} device(s) found", found.len())),
            Err(e) => self.info(format!("bus scan failed: {e}")),
        }
        self.scan = Some(result);
    }

    /// A link up (the first, one brought back, or another): the session goes on, with
    /// one clock, its plot history, markers and timeline kept; identity, diagnosis and
    /// torque slope are read anew, and another drive than before is marked once its
    /// identity is known (`note_drive`).
    fn on_connected(&mut self, info: LinkInfo) {
        self.info(format!("connected: {}", info.description));
        let link = info.spec.to_string();
        let spec = info.spec.clone();
        self.browser.on_connected(&link);
        self.connection = Connection::Connected(info);
        self.link_lost = None;
        self.sampled_since_connect = false;
        self.connected_at = None;
        self.halt_engaged = false;
        self.torque_slope = None;
        self.injected.clear();
        // The exports name the device: read its identity again.
        self.plot.identity = None;
        self.identity_request = None;
        self.identity_reads.clear();
        self.describe_drive(None, &link);
        self.outbox.push(Self::identity_request());
        self.timeline.reconnected();
        // Changes belong to a drive: another link starts a new list (a reconnect
        // to the same one keeps the values from before the first write).
        if self.changes_link.as_ref() != Some(&spec) {
            self.changes.clear();
            self.changes_link = Some(spec);
        }
        self.diagnosis_request = None;
        self.diagnosis_again = false;
        self.outbox.push(Self::diagnosis_request());
        // Know the torque slope before anyone asks for torque.
        self.outbox.push(Request::ReadObject {
            address: TORQUE_SLOPE,
            dtype: Some(DataType::Unsigned32),
            path: ObjectPath::Auto,
        });
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
            crate::diagnostics::Severity::Warning,
            crate::diagnostics::Origin::Link,
            format!("connection to {spec} failed: {error}"),
        );
        let retry = retry_in
            .map(|d| format!("; retrying in {:.1} s", d.as_secs_f64()))
            .unwrap_or_default();
        self.info(format!("connection to {spec} failed: {error}{retry}"));
        self.check_against_project(Err(&error.to_string()));
        self.connection = Connection::Failed {
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
                crate::diagnostics::Severity::Fault,
                crate::diagnostics::Origin::Link,
                format!("link lost: {reason}"),
            );
        }
        match &reason {
            Some(reason) => self.info(format!("link lost: {reason}")),
            None => self.info("disconnected"),
        }
        self.connection = Connection::Disconnected;
        self.link_lost = reason;
        self.health = None;
        self.link_changes.clear();
        self.jog = None;
        self.halt_engaged = false;
        self.halt_request = None;
    }

    /// A request the worker would not send.
    fn on_rejected(&mut self, id: RequestId, request: String, reason: Rejection) {
        if self.slope_reads.contains(&id)
            || self.browser.on_rejected(id, &reason)
            || self.watch.on_rejected(id, &reason)
        {
            return;
        }
        if self.halt_request == Some(id) {
            self.halt_request = None;
            self.halt_engaged = false;
        }
        if let Rejection::Refused(why) = &reason {
            self.why = Some(format!("{request} refused: {why}"));
        }
        match self.entry(id) {
            Some(entry) => entry.outcome = Outcome::Failed(reason.to_string()),
            None => self.push_log(LogEntry {
                at: self.clock,
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
        if let Some(entry) = self.entry(id) {
            entry.image = Some(image);
            entry.outcome = Outcome::Sent;
        } else {
            self.push_log(LogEntry {
                at: self.clock,
                id: Some(id),
                what,
                image: Some(image),
                outcome: Outcome::Sent,
            });
        }
    }

    /// A command moved on: its log entry, the halt toggle and the timeline follow.
    fn on_progress(&mut self, id: RequestId, progress: CommandProgress) {
        if self.halt_request == Some(id) && progress.is_final() {
            self.halt_request = None;
            if !progress.is_success() {
                self.halt_engaged = false;
            }
        }
        // A command a newer one replaced ended as the user wanted: not a fault.
        let superseded = matches!(progress, CommandProgress::Superseded);
        if !progress.is_success()
            && !superseded
            && let Some(what) = self.entry(id).map(|e| e.what.clone())
        {
            let t = self.sample_time();
            self.timeline.add(
                t,
                crate::diagnostics::Severity::Warning,
                crate::diagnostics::Origin::Command,
                format!("{what}: {progress}"),
            );
            self.why = Some(format!("{what}: {progress}"));
        }
        if let Some(entry) = self.entry(id) {
            entry.outcome = match &progress {
                CommandProgress::Accepted => Outcome::Accepted,
                CommandProgress::Done { .. } => Outcome::Succeeded(progress.to_string()),
                CommandProgress::Superseded => Outcome::Superseded(progress.to_string()),
                _ => Outcome::Failed(progress.to_string()),
            };
        }
    }

    /// An object read came back: diagnosis, identity, the browser, the torque slope or the user.
    fn on_object_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: Result<Value, ObjectError>,
    ) {
        if self.diagnosis_request == Some(id) {
            self.diagnosis_read(address, result);
            return;
        }
        if self.identity_request == Some(id) {
            self.identity_reads.insert(address, result);
            if self.identity_reads.len() == crate::od::backup::IDENTITY.len() {
                let identity = crate::od::backup::DeviceIdentity::from_reads(&self.identity_reads);
                let link = self.scope.meta.link.clone().unwrap_or_default();
                self.describe_drive(Some(&identity), &link);
                self.note_drive(&identity);
                self.check_against_project(Ok(&identity));
                self.plot.identity = Some(identity);
                self.identity_request = None;
            }
            return;
        }
        if self.browser.on_read(id, address, &result, self.clock)
            || self.watch.on_read(id, address, &result, self.clock)
        {
            return;
        }
        if let Some(at) = self.slope_reads.iter().position(|r| *r == id) {
            self.slope_reads.remove(at);
            self.torque_slope = result
                .as_ref()
                .ok()
                .and_then(Value::as_i128)
                .and_then(|v| i64::try_from(v).ok());
            return;
        }
        if let Some(entry) = self.entry(id) {
            entry.outcome = match &result {
                Ok(value) => Outcome::Succeeded(format!("{address} = {value}")),
                Err(e) => Outcome::Failed(e.to_string()),
            };
        }
        if let Err(e) = &result {
            // The device's answer (Modbus exception, SDO abort, CIP status).
            self.object_failure(format!("read {address}: {e}"));
        }
        self.last_object = Some(ReadBack { address, result });
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
            self.torque_slope = value.as_i128().and_then(|v| i64::try_from(v).ok());
        }
        if self
            .browser
            .on_written(id, address, &result, &mut self.outbox)
        {
            return;
        }
        if let Some(entry) = self.entry(id) {
            entry.outcome = match &result {
                Ok(()) => Outcome::Succeeded(format!("{address} = {value} written")),
                Err(e) => Outcome::Failed(e.to_string()),
            };
        }
        if let Err(e) = &result {
            self.object_failure(format!("write {value} to {address}: {e}"));
        }
        self.last_object = Some(ReadBack {
            address,
            result: result.map(|()| value),
        });
    }

    /// Samples: timeline, scope and triggers, the latest state, the halt toggle.
    fn on_samples(&mut self, samples: Vec<Sample>) {
        let Some(first) = samples.first() else {
            return;
        };
        self.last_sample_at = Some(SystemTime::now());
        // The first sample on this link: where it starts on the one time axis.
        let fresh = !self.sampled_since_connect;
        if fresh {
            self.connected_at = Some(first.t);
        }
        self.sampled_since_connect = true;
        let gap = self.scope.open_gap().cloned();
        for sample in &samples {
            if self.timeline.observe(sample) {
                self.want_diagnosis();
            }
            self.scoped(sample);
        }
        if let Some(gap) = gap
            && self.scope.open_gap().is_none()
        {
            self.link_back(&gap, first.t);
        }
        self.take_latest(&samples, fresh);
        if let Some(last) = samples.last() {
            // A finished halt the drive no longer shows (a new command, a quick
            // stop, a fault) releases the toggle.
            if self.halt_engaged
                && self.halt_request.is_none()
                && !last.tx.status.is_set(StatusBit::QsHaltBit)
            {
                self.halt_engaged = false;
            }
        }
    }

    /// One sample into the plots' history and the trigger.
    fn scoped(&mut self, sample: &Sample) {
        match self.scope.push(sample) {
            Some(ScopeEvent::Fired(at)) => {
                self.info(format!("trigger fired at {at:.3} s"));
            }
            Some(ScopeEvent::Recorded) => {
                let text = self.scope.recording().map(|r| {
                    format!(
                        "triggered recording ready: {:.2} s, {} samples; Save recording writes it",
                        r.duration(),
                        r.len()
                    )
                });
                if let Some(text) = text {
                    self.plot.message = Some(Ok(text.clone()));
                    self.info(text);
                }
                crate::ui::plots::review::freeze_capture(&mut self.plot, &self.scope);
            }
            None => {}
        }
    }

    /// The newest value of every signal, merged over the samples before on this link (the
    /// first sample of a link starts afresh: another drive's values are not carried over).
    fn take_latest(&mut self, samples: &[Sample], fresh: bool) {
        for (i, sample) in samples.iter().enumerate() {
            self.latest = Some(match &self.latest {
                Some(older) if !(fresh && i == 0) && sample.t >= older.t => {
                    sample.merged_over(older)
                }
                _ => *sample,
            });
        }
    }

    /// Samples again after a gap (`at`: the first): how long the plots went without, on
    /// the timeline.
    fn link_back(&mut self, gap: &crate::telemetry::Gap, at: f64) {
        let what = if gap.lost {
            "link back"
        } else {
            "connected again"
        };
        self.timeline.add(
            Some(at),
            crate::diagnostics::Severity::Info,
            crate::diagnostics::Origin::Link,
            format!("{what} after {:.1} s without samples", at - gap.from),
        );
    }

    /// Something the link reported; EMCY and stopped jogs go on the timeline too.
    fn on_notice(&mut self, notice: Notice) {
        use crate::diagnostics::{Origin, Severity};
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
                self.why = Some(notice.text.clone());
            }
            NoticeKind::Info => {}
        }
        self.info(notice.text)
    }
}
