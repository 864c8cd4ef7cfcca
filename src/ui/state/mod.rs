//! `AppState`: everything the window shows, as plain data. The worker's events change it
//! through `apply`; panels read it and put the user's intents into `outbox`.

use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, SystemTime};

use serde::{Deserialize, Serialize};

use crate::injection::Injection;
use crate::link::{LinkFailure, LinkInfo, LinkSpec, Notice, NoticeKind};
use crate::od::backup::DeviceIdentity;
use crate::od::{Address, DataType, Value};
use crate::pdi::{Action, Opcode, RxImage, StatusBit};
use crate::telemetry::{Scope, ScopeEvent};
use crate::worker::{
    CommandProgress, Event, Health, ObjectError, ObjectPath, Rejection, Request, RequestId, Sample,
};

/// Log entries kept in the window.
pub const LOG_LIMIT: usize = 2000;
/// Bus frames kept in the window (the export writes what is kept).
pub const FRAME_LIMIT: usize = 20_000;

pub use super::connection_form::{Bus, ConnectionForm, FormError};

mod events;
#[cfg(test)]
mod tests;

/// What persists between runs: the connection bar, every input box, plot settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    pub connection: ConnectionForm,
    /// The text of every command's input boxes, by opcode name.
    pub inputs: BTreeMap<String, Vec<String>>,
    pub poll_rate: f64,
    /// Torque slope suggested when 6087h is 0, ‰/s.
    pub torque_slope: String,
    pub show_log: bool,
    /// Record every bus frame in the frame log.
    pub record_frames: bool,
    /// The "any object" row: address and value as typed.
    pub object_address: String,
    pub object_value: String,
    /// Where "Export" writes the frame log (candump format for CAN).
    pub frame_log_path: String,
    /// What the middle of the window shows.
    pub central: Central,
    /// The plot panel's choices.
    pub plot: super::plots::PlotSettings,
    /// The object dictionary's choices.
    pub dictionary: super::browser::DictionarySettings,
    /// The jog speed as typed, rpm.
    pub jog_speed: String,
    /// Where the fault timeline's export goes.
    pub timeline_path: String,
    /// What the worker does when the link fails during a move.
    pub on_link_loss: crate::worker::LinkLossAction,
    /// Exchanges that must fail in a row before the link counts as lost.
    pub lost_after: u32,
    /// The watch panel: pinned objects, their formats, the refresh rate.
    pub watch: super::watch::WatchSettings,
    /// The command panel folded to a narrow strip (more room for the plots).
    pub commands_collapsed: bool,
}

/// The middle of the window: the plots or the object dictionary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Central {
    #[default]
    Plots,
    Dictionary,
}

impl Default for Settings {
    fn default() -> Self {
        let mut inputs = BTreeMap::new();
        let mut put = |op: Opcode, values: &[&str]| {
            inputs.insert(
                op.name().to_owned(),
                values.iter().map(|v| (*v).to_owned()).collect(),
            );
        };
        put(Opcode::MoveAbsolute, &["2000", "200"]);
        put(Opcode::MoveRelative, &["3600", "200"]);
        put(Opcode::Velocity, &["300"]);
        put(Opcode::Torque, &["500", "100"]);
        put(Opcode::Homing, &["19"]);
        put(Opcode::HomeHere, &["0"]);
        put(Opcode::OdRead, &["1018", "01"]);
        put(Opcode::OdWrite, &["203B", "01", "1000"]);
        Self {
            connection: ConnectionForm::default(),
            inputs,
            poll_rate: 100.0,
            torque_slope: "1000".into(),
            show_log: true,
            record_frames: false,
            object_address: "1008".into(),
            object_value: String::new(),
            frame_log_path: "drivedeck-frames.log".into(),
            central: Central::Plots,
            plot: super::plots::PlotSettings::default(),
            dictionary: super::browser::DictionarySettings::default(),
            jog_speed: "100".into(),
            timeline_path: "drivedeck-faults.csv".into(),
            on_link_loss: crate::worker::LinkLossAction::Halt,
            lost_after: crate::worker::LOST_AFTER,
            watch: super::watch::WatchSettings::default(),
            commands_collapsed: false,
        }
    }
}

/// The link as the window sees it.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Connection {
    #[default]
    Disconnected,
    Connecting(LinkSpec),
    Connected(LinkInfo),
    Failed {
        spec: LinkSpec,
        error: LinkFailure,
        retry_in: Option<Duration>,
    },
}

/// One line of the command log.
#[derive(Clone, Debug, PartialEq)]
pub struct LogEntry {
    /// Seconds since the window opened.
    pub at: f64,
    pub id: Option<RequestId>,
    pub what: String,
    /// The RX image as written, once sent.
    pub image: Option<RxImage>,
    pub outcome: Outcome,
}

/// Where a logged request stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Queued,
    Sent,
    Accepted,
    Succeeded(String),
    Failed(String),
    /// A newer command took its place (a relative move followed by the next): not a
    /// fault, the drive did what it was told last.
    Superseded(String),
    /// Done, but not quite as asked (a halt the drive shows while the motor still
    /// brakes): drawn amber.
    Caution(String),
    /// Not tied to a request (connection changes, notices).
    Info,
}

impl Outcome {
    pub fn is_open(&self) -> bool {
        matches!(self, Outcome::Queued | Outcome::Sent | Outcome::Accepted)
    }
}

/// A value read from the drive for the window (the torque slope, the OD-Read box).
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

/// Everything the window shows.
#[derive(Clone, Debug)]
pub struct AppState {
    pub settings: Settings,
    pub connection: Connection,
    /// The newest known value of every signal (merged over recent samples). Kept when
    /// the link goes: the status panel shows it dimmed, as last seen.
    pub latest: Option<Sample>,
    /// When the reducer took the last `Samples` event (wall clock): "last seen at".
    pub last_sample_at: Option<SystemTime>,
    /// A sample came on the link connected now; until then `latest` is from before.
    pub sampled_since_connect: bool,
    /// The time of the first sample on the link connected now (the samples' clock goes
    /// on across connections).
    pub connected_at: Option<f64>,
    /// The drive of the last connection whose identity was read, and its link: another
    /// one is marked on the plots and the timeline (see `note_drive`).
    drive: Option<(LinkSpec, DeviceIdentity)>,
    /// The project's record of this drive (its identity to compare on connecting, its
    /// backup kept when the project is saved again); `None` outside a project.
    pub project_drive: Option<crate::project::Drive>,
    /// What comparing the drive with the project's record found, once it did.
    pub project_check: Option<crate::project::check::DriveCheck>,
    /// Why the link went, when it was lost rather than closed (cleared on connecting
    /// again and on the user's disconnect).
    pub link_lost: Option<String>,
    pub health: Option<Health>,
    /// The plots' history, markers, trigger and recording.
    pub scope: Scope,
    /// The plot panel's view (pause, follow, cursor, exports).
    pub plot: super::plots::PlotView,
    pub log: VecDeque<LogEntry>,
    /// Requests for the worker, taken by the app after each frame.
    pub outbox: Vec<Request>,
    /// Whether the user holds the halt toggle on.
    pub halt_engaged: bool,
    /// Why the drive last stopped or refused, in one line for the state tile (a quick
    /// stop sent, a command refused); cleared by the next command.
    pub why: Option<String>,
    /// 6087h as last read (None = unknown).
    pub torque_slope: Option<i64>,
    pub torque_warning: Option<TorqueWarning>,
    /// The last OD-Read/OD-Write result of the command panel.
    pub last_object: Option<ReadBack>,
    /// Faults injected into the simulated drive.
    pub injected: Vec<Injection>,
    /// Seconds since the window opened, advanced by the app.
    pub clock: f64,
    /// Serial ports found by the last scan (for Modbus RTU and slcan).
    pub serial_ports: Option<Vec<String>>,
    /// Bus frames recorded (when `settings.record_frames`).
    pub frames: VecDeque<crate::link::TraceRecord>,
    /// Which log the bottom panel shows.
    pub bottom: Bottom,
    /// Every fault and warning seen, in order.
    pub timeline: crate::diagnostics::Timeline,
    /// What the tool changed on the drive, with the values before (for undo), and the
    /// link they belong to.
    pub changes: Vec<super::changes::ChangeEntry>,
    /// What the link itself changed on the device (a PDO mapping) and its fate.
    pub link_changes: Vec<String>,
    changes_link: Option<LinkSpec>,
    /// The IPv4 interfaces, for EtherNet/IP discovery (found once, on first use).
    pub interfaces: Option<Vec<crate::link::NetworkInterface>>,
    /// Whether the lists of serial ports and interfaces were asked of the worker and not
    /// answered yet.
    serial_ports_asked: bool,
    interfaces_asked: bool,
    /// The object dictionary browser.
    pub browser: super::browser::Browser,
    /// The watch panel's readings.
    pub watch: super::watch::Watch,
    /// The last bus scan's result.
    pub scan: Option<Result<Vec<crate::link::FoundDevice>, LinkFailure>>,
    /// Devices of a scan or discovery to add as drives of their own (the app takes them).
    pub wanted_drives: Vec<LinkSpec>,
    /// Reads of 6087h the window asked for itself (not logged).
    slope_reads: Vec<RequestId>,
    /// The halt request still running.
    halt_request: Option<RequestId>,
    /// A jog button (or arrow key) held.
    pub jog: Option<super::jog::JogHold>,
    /// A stop ended the jog: nothing jogs again until the button is released.
    pub jog_blocked: bool,
    /// Disconnecting (or closing) with the drive energised or objects changed.
    pub leaving: Option<super::leave::Leaving>,
    /// The identity read for the exports' header, and its request.
    identity_request: Option<RequestId>,
    identity_reads: BTreeMap<Address, Result<Value, ObjectError>>,
    /// The read of 1001h and 1003h for the timeline, its results, and whether another
    /// fault came while it ran (read again after).
    diagnosis_request: Option<RequestId>,
    diagnosis_reads: BTreeMap<Address, Result<Value, ObjectError>>,
    diagnosis_again: bool,
}

/// What the bottom panel shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Bottom {
    #[default]
    Commands,
    Frames,
    Faults,
    Changes,
}

/// 1001h, 1003h:00 and the first eight 1003h entries: read on connecting and on each new
/// fault or warning, for the timeline.
fn diagnosis_objects() -> Vec<(Address, DataType)> {
    let mut objects = vec![
        (Address::new(0x1001, 0), DataType::Unsigned8),
        (Address::new(0x1003, 0), DataType::Unsigned8),
    ];
    objects.extend((1..=8).map(|sub| (Address::new(0x1003, sub), DataType::Unsigned32)));
    objects
}

impl AppState {
    pub fn new(settings: Settings) -> Self {
        let mut scope = Scope::new(settings.plot.history_rows);
        if !settings.plot.shown.is_empty() {
            for signal in scope.signals_mut() {
                signal.shown = settings.plot.shown.contains(&signal.info.id);
                signal.auto = false;
            }
        }
        Self {
            settings,
            connection: Connection::Disconnected,
            latest: None,
            last_sample_at: None,
            sampled_since_connect: false,
            connected_at: None,
            drive: None,
            project_drive: None,
            project_check: None,
            link_lost: None,
            health: None,
            scope,
            plot: super::plots::PlotView::default(),
            log: VecDeque::new(),
            outbox: Vec::new(),
            halt_engaged: false,
            why: None,
            torque_slope: None,
            torque_warning: None,
            last_object: None,
            injected: Vec::new(),
            clock: 0.0,
            serial_ports: None,
            scan: None,
            wanted_drives: Vec::new(),
            browser: super::browser::Browser::new(),
            watch: super::watch::Watch::default(),
            interfaces: None,
            serial_ports_asked: false,
            interfaces_asked: false,
            frames: VecDeque::new(),
            bottom: Bottom::Commands,
            timeline: crate::diagnostics::Timeline::default(),
            changes: Vec::new(),
            link_changes: Vec::new(),
            changes_link: None,
            slope_reads: Vec::new(),
            halt_request: None,
            jog: None,
            jog_blocked: false,
            leaving: None,
            identity_request: None,
            identity_reads: BTreeMap::new(),
            diagnosis_request: None,
            diagnosis_reads: BTreeMap::new(),
            diagnosis_again: false,
        }
    }

    fn diagnosis_request() -> Request {
        Request::ReadMany {
            objects: diagnosis_objects(),
            path: ObjectPath::Auto,
        }
    }

    /// Read 1001h and 1003h for the timeline (again after the running read, if one runs).
    fn want_diagnosis(&mut self) {
        if self.diagnosis_request.is_some() || self.outbox.contains(&Self::diagnosis_request()) {
            self.diagnosis_again = true;
        } else {
            self.outbox.push(Self::diagnosis_request());
        }
    }

    /// The samples' clock now (the newest sample's time).
    fn sample_time(&self) -> Option<f64> {
        self.scope.ring().last_time()
    }

    fn diagnosis_read(&mut self, address: Address, result: Result<Value, ObjectError>) {
        self.diagnosis_reads.insert(address, result);
        if self.diagnosis_reads.len() < diagnosis_objects().len() {
            return;
        }
        let reads = std::mem::take(&mut self.diagnosis_reads);
        self.diagnosis_request = None;
        let t = self.sample_time();
        let uint = |address: Address| match reads.get(&address) {
            Some(Ok(value)) => value.as_i128().and_then(|v| u32::try_from(v).ok()),
            _ => None,
        };
        if let Some(register) = uint(Address::new(0x1001, 0)) {
            self.timeline.error_register(t, register as u8);
        }
        let count = uint(Address::new(0x1003, 0)).unwrap_or(0).min(8) as u8;
        let entries: Vec<(u8, u32)> = (1..=count)
            .filter_map(|sub| uint(Address::new(0x1003, sub)).map(|raw| (sub, raw)))
            .collect();
        self.timeline.error_history(t, &entries);
        if std::mem::take(&mut self.diagnosis_again) {
            self.want_diagnosis();
        }
    }

    /// The exports' header: the drive (where its identity is known) and the link; the
    /// session's start stays that of its first connection (t = 0 of the samples' clock).
    fn describe_drive(&mut self, identity: Option<&DeviceIdentity>, link: &str) {
        let started = self.scope.meta.started.take();
        self.scope.meta = crate::telemetry::metadata(identity, link, self.settings.poll_rate);
        if started.is_some() {
            self.scope.meta.started = started;
        }
    }

    /// The drive connected now, its identity read. Another link or another identity (1018h)
    /// than the drive before in this session is another drive: the history stays, and a
    /// marker on the plots and an entry on the timeline say from when the samples are of
    /// this one.
    fn note_drive(&mut self, identity: &DeviceIdentity) {
        let Some(spec) = self.link_info().map(|info| info.spec.clone()) else {
            return;
        };
        let Some((link, was)) = self.drive.replace((spec.clone(), identity.clone())) else {
            return;
        };
        if link == spec && same_device(&was, identity) {
            return;
        }
        let text = format!("another drive: {} on {spec}", device_text(identity));
        let t = self.connected_at.or(self.sample_time());
        if let Some(t) = t {
            self.scope.new_drive(t, text.clone());
        }
        self.timeline.add(
            t,
            crate::diagnostics::Severity::Info,
            crate::diagnostics::Origin::Link,
            format!(
                "{text}; before: {} on {link} (its history stays)",
                device_text(&was)
            ),
        );
        self.info(text);
    }

    /// An object access the device refused, on the timeline.
    fn object_failure(&mut self, text: String) {
        let t = self.sample_time();
        self.timeline.add(
            t,
            crate::diagnostics::Severity::Warning,
            crate::diagnostics::Origin::Command,
            text,
        );
    }

    /// Show the moment `t` on the plots: the window around it, marked.
    pub fn show_on_plot(&mut self, t: f64) {
        self.settings.central = Central::Plots;
        let half = if self.settings.plot.window_s > 0.0 {
            self.settings.plot.window_s / 2.0
        } else {
            5.0
        };
        let last = self.scope.ring().last_time().unwrap_or(t);
        self.plot.paused_at = Some((t + half).min(last));
        self.plot.follow = true;
        self.plot.highlight = Some(t);
    }

    /// Plot an object of the dictionary (typed as an address): checked against the
    /// browser's catalog, then sampled by the worker every cycle.
    pub fn watch_object(&mut self, text: &str) {
        match crate::telemetry::watchable(self.browser.catalog(), text) {
            Ok((object, dtype)) => {
                if self
                    .plot
                    .watched
                    .iter()
                    .any(|(w, _)| w.address == object.address)
                {
                    self.plot.message = Some(Err(format!("{} is plotted already", object.address)));
                    return;
                }
                if self.plot.watched.len() >= crate::worker::MAX_WATCHED {
                    self.plot.message = Some(Err(format!(
                        "at most {} objects can be plotted besides the built-in signals",
                        crate::worker::MAX_WATCHED
                    )));
                    return;
                }
                self.plot.message =
                    Some(Ok(format!("plotting {} {}", object.address, object.name)));
                self.plot.watched.push((object, dtype));
                self.send_watch();
            }
            Err(e) => self.plot.message = Some(Err(e)),
        }
    }

    /// Pin an object to the watch panel (from the dictionary or the plots) and open the
    /// panel; the words say what happened, for the panel the request came from.
    pub fn pin_to_watch(&mut self, address: Address) -> Result<String, String> {
        let catalog = self.browser.catalog();
        let name = catalog
            .get(address)
            .map(|e| e.name.clone())
            .unwrap_or_default();
        self.settings
            .watch
            .pin(address, catalog)
            .map(|()| format!("watching {address} {name}: see the watch panel"))
            .map_err(|e| e.to_string())
    }

    /// Stop plotting an object (`address` as `Address` displays it).
    pub fn unwatch_object(&mut self, address: &str) {
        self.plot
            .watched
            .retain(|(w, _)| w.address.to_string() != address);
        self.send_watch();
    }

    fn send_watch(&mut self) {
        let objects: Vec<crate::telemetry::WatchedObject> =
            self.plot.watched.iter().map(|(w, _)| w.clone()).collect();
        self.scope.set_watched(&objects);
        self.outbox.push(Request::Watch(
            self.plot
                .watched
                .iter()
                .map(|(w, dtype)| (w.address, *dtype))
                .collect(),
        ));
    }

    fn identity_request() -> Request {
        Request::ReadMany {
            objects: crate::od::backup::IDENTITY.to_vec(),
            path: ObjectPath::Auto,
        }
    }

    pub fn is_connected(&self) -> bool {
        matches!(self.connection, Connection::Connected(_))
    }

    pub fn link_info(&self) -> Option<&LinkInfo> {
        match &self.connection {
            Connection::Connected(info) => Some(info),
            _ => None,
        }
    }

    /// Why nothing can be sent to the drive now, in words for a disabled button's tooltip
    /// and the panels; `None` while connected.
    pub fn offline_reason(&self) -> Option<String> {
        let lost = self.link_lost.as_deref();
        match (&self.connection, lost) {
            (Connection::Connected(_), _) => None,
            (Connection::Connecting(_), None) => Some("connecting…".into()),
            (Connection::Connecting(_), Some(reason)) => {
                Some(format!("reconnecting…: the link was lost ({reason})"))
            }
            (Connection::Disconnected, None) => Some("not connected".into()),
            (Connection::Disconnected, Some(reason)) => {
                Some(format!("not connected: the link was lost ({reason})"))
            }
            (
                Connection::Failed {
                    error, retry_in, ..
                },
                lost,
            ) => {
                // What happens next first, the link's (often long) error text after it.
                let retry = match retry_in {
                    Some(d) => format!(", retrying in {:.1} s", d.as_secs_f64()),
                    None => String::new(),
                };
                Some(match lost {
                    // Right after the loss the worker reports the same error again.
                    Some(reason) if *reason == error.text => {
                        format!("not connected: the link was lost{retry} ({reason})")
                    }
                    Some(reason) => format!(
                        "not connected: the link was lost{retry} ({reason}; reconnecting failed: {error})"
                    ),
                    None => format!("not connected: connecting failed{retry} ({error})"),
                })
            }
        }
    }

    /// Whether what the status panel shows is the drive now: connected, a sample taken on
    /// this link, and the last one no older than `STALE_AFTER` (or three cycles at a slow
    /// poll rate) at `now`.
    pub fn is_live(&self, now: SystemTime) -> bool {
        self.is_connected() && self.sampled_since_connect && !self.is_silent(now)
    }

    /// Connected, but no samples came for longer than they should.
    fn is_silent(&self, now: SystemTime) -> bool {
        let limit = STALE_AFTER.max(3.0 / self.settings.poll_rate.max(0.1));
        self.sample_age(now).is_some_and(|age| age > limit)
    }

    /// Seconds since the last sample came, at `now`.
    pub fn sample_age(&self, now: SystemTime) -> Option<f64> {
        self.last_sample_at
            .map(|at| now.duration_since(at).map_or(0.0, |d| d.as_secs_f64()))
    }

    /// The status panel's headline while it does not show the drive live: "NO LINK — last
    /// seen at 14:02:11 UTC (3.2 s ago)"; `None` while live.
    pub fn stale_line(&self, now: SystemTime) -> Option<String> {
        if self.is_live(now) {
            return None;
        }
        let seen = match (self.last_sample_at, self.sample_age(now)) {
            (Some(at), Some(age)) => {
                format!("last seen at {} ({})", clock_text(at), age_text(age))
            }
            _ => "never connected".to_owned(),
        };
        Some(match &self.connection {
            Connection::Connected(_) if !self.sampled_since_connect => {
                if self.latest.is_some() {
                    format!("WAITING FOR DATA — connected; {seen}")
                } else {
                    "WAITING FOR DATA — connected, no sample yet".to_owned()
                }
            }
            Connection::Connected(_) => format!("NO DATA — the drive stopped answering; {seen}"),
            _ => format!("NO LINK — {seen}"),
        })
    }

    /// Whether a halt the window sent is still queued or running.
    pub fn halt_pending(&self) -> bool {
        self.halt_request.is_some()
    }

    /// Whether a status bit is set in the newest sample.
    pub fn bit(&self, bit: StatusBit) -> bool {
        self.latest.is_some_and(|s| s.tx.status.is_set(bit))
    }

    /// Queue a request for the worker.
    pub fn request(&mut self, request: Request) {
        match &request {
            Request::Command(action)
                if (action.opcode().is_travel()
                    || matches!(action, Action::Quickstop | Action::SwitchOff)) =>
            {
                self.halt_engaged = false;
                if matches!(action, Action::Quickstop | Action::SwitchOff) {
                    // A stop ends the jog; holding on does not start it again.
                    if self.jog.take().is_some() {
                        self.jog_blocked = true;
                    }
                }
            }
            Request::Jog { .. } => self.halt_engaged = false,
            Request::Halt => self.halt_engaged = true,
            Request::Resume => self.halt_engaged = false,
            _ => {}
        }
        self.note_why(&request);
        self.outbox.push(request);
    }

    /// A stop sent from the window is the reason for what follows; any other command
    /// makes the last reason old news.
    fn note_why(&mut self, request: &Request) {
        let at = clock_text(SystemTime::now());
        match request {
            Request::Command(Action::Quickstop) => {
                self.why = Some(format!("Quickstop sent from this window at {at}"));
            }
            Request::Command(Action::SwitchOff) => {
                self.why = Some(format!("Switch off sent from this window at {at}"));
            }
            Request::Command(_) | Request::Halt | Request::Resume | Request::Jog { .. } => {
                self.why = None;
            }
            _ => {}
        }
    }

    /// Ask the worker for the serial ports (once until it answers).
    pub fn ask_serial_ports(&mut self) {
        if !self.serial_ports_asked {
            self.serial_ports_asked = true;
            self.outbox.push(Request::ListSerialPorts);
        }
    }

    /// Ask the worker for the network interfaces (once until it answers).
    pub fn ask_interfaces(&mut self) {
        if !self.interfaces_asked {
            self.interfaces_asked = true;
            self.outbox.push(Request::ListInterfaces);
        }
    }

    /// Record that the app handed a request to the worker.
    pub fn note_queued(&mut self, id: RequestId, request: &Request) {
        if self.identity_request.is_none()
            && self.plot.identity.is_none()
            && *request == Self::identity_request()
        {
            self.identity_request = Some(id);
            return;
        }
        if self.diagnosis_request.is_none() && *request == Self::diagnosis_request() {
            self.diagnosis_request = Some(id);
            self.diagnosis_reads.clear();
            return;
        }
        if matches!(request, Request::Watch(_) | Request::JogKeepAlive) {
            return;
        }
        if self.browser.note_queued(id, request) || self.watch.note_queued(id, request) {
            return;
        }
        if matches!(request, Request::ReadObject { address, .. } if *address == TORQUE_SLOPE)
            && !self.slope_reads.contains(&id)
        {
            self.slope_reads.push(id);
            return;
        }
        if matches!(
            request,
            Request::SetPollRate(_)
                | Request::SetLinkLoss(_)
                | Request::SetLostAfter(_)
                | Request::ListSerialPorts
                | Request::ListInterfaces
                | Request::Connect(_)
                | Request::Disconnect
                | Request::Inject { .. }
        ) {
            // These report through their own events (connecting, connected, notices).
            return;
        }
        if matches!(request, Request::Halt) {
            self.halt_request = Some(id);
        }
        self.push_log(LogEntry {
            at: self.clock,
            id: Some(id),
            what: request.to_string(),
            image: None,
            outcome: Outcome::Queued,
        });
    }

    /// The worker could not take a request.
    pub fn note_unsent(&mut self, request: &Request, reason: String) {
        if self.browser.note_unsent(request, &reason) || self.watch.note_unsent(request, &reason) {
            return;
        }
        self.push_log(LogEntry {
            at: self.clock,
            id: None,
            what: request.to_string(),
            image: None,
            outcome: Outcome::Failed(reason),
        });
    }

    pub fn info(&mut self, text: impl Into<String>) {
        self.push_log(LogEntry {
            at: self.clock,
            id: None,
            what: text.into(),
            image: None,
            outcome: Outcome::Info,
        });
    }

    pub(crate) fn push_log(&mut self, entry: LogEntry) {
        if self.log.len() >= LOG_LIMIT {
            self.log.pop_front();
        }
        self.log.push_back(entry);
    }

    fn entry(&mut self, id: RequestId) -> Option<&mut LogEntry> {
        self.log.iter_mut().rev().find(|e| e.id == Some(id))
    }
}

/// With the link up, samples older than this make the status panel stale (a drive that
/// stopped answering before the link times out).
pub const STALE_AFTER: f64 = 1.0;

/// A wall-clock time as `14:02:11 UTC`: the clock the fault timeline writes (no time
/// zone database, so UTC, said so).
pub fn clock_text(at: SystemTime) -> String {
    let text = crate::telemetry::utc_text(at);
    // `2026-12-01T18:48:28Z`: the time of day is characters 11 to 19.
    match text.get(11..19) {
        Some(time) => format!("{time} UTC"),
        None => text,
    }
}

/// How long ago, for the stale status: "3.2 s ago", "4 min 10 s ago".
pub fn age_text(seconds: f64) -> String {
    if seconds < 60.0 {
        format!("{seconds:.1} s ago")
    } else if seconds < 3600.0 {
        let whole = seconds as u64;
        format!("{} min {} s ago", whole / 60, whole % 60)
    } else {
        let whole = seconds as u64;
        format!("{} h {} min ago", whole / 3600, whole / 60 % 60)
    }
}

/// Whether two identities are of the same device: vendor, product, revision and serial
/// number (1018h) alike.
fn same_device(a: &DeviceIdentity, b: &DeviceIdentity) -> bool {
    (a.vendor, a.product, a.revision, a.serial) == (b.vendor, b.product, b.revision, b.serial)
}

/// A device in a few words: its name (1008h) and serial number.
fn device_text(identity: &DeviceIdentity) -> String {
    let name = identity.name.as_deref().unwrap_or("a device");
    match identity.serial {
        Some(serial) => format!("{name} serial {serial:08X}h"),
        None => name.to_owned(),
    }
}

/// 6087h, Torque Slope: read on connect, so a torque command with slope 0 can be warned
/// about before it is sent.
pub const TORQUE_SLOPE: Address = Address::new(0x6087, 0);
