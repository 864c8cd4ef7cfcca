//! One drive of the window, as plain data: its name and colour, its settings, its link as
//! last seen, its history (plots, timeline, frames, log, changes), the models of the
//! panels that are about it (commands, dictionary, watch, leaving), and its requests with
//! their owners. Worker events change it through [`Drive::apply`]; the user's intents reach
//! it through the window's commands. Every drive keeps its own; nothing is copied between
//! drives or swapped in and out of a slot.
//!
//! A model: no egui here.

mod events;
mod glance;
mod leave;
mod link;
mod log;
mod motion;
mod project;
mod reads;
mod requests;
#[cfg(test)]
mod tests;

use std::collections::VecDeque;

pub use events::FRAME_LIMIT;
pub use leave::{Leaving, STOP_TIMEOUT_S, Stage, StopChoice};
pub use link::{Connection, LinkState, Machine, STALE_AFTER, age_text, clock_text};
pub use log::{LOG_LIMIT, Log, LogEntry, Outcome};
pub use motion::{
    JOG_MAX_SPEED, JogHold, Motion, ReadBack, TORQUE_SLOPE, TorqueWarning, jog_speed,
};
pub use project::ProjectRecord;
pub use requests::{Owner, Requests};

use crate::diagnostics::Timeline;
use crate::link::{FoundDevice, LinkFailure, TraceRecord};
use crate::od::DataType;
use crate::telemetry::{Scope, WatchedObject};
use crate::ui::browser::Browser;
use crate::ui::changes::Changes;
use crate::ui::panel::Panels;
use crate::ui::settings::DriveSettings;
use crate::ui::watch::Watch;
use crate::worker::{Request, RequestId};

/// What a drive's event means for the whole window.
#[derive(Clone, Debug, PartialEq)]
pub enum News {
    /// A triggered recording is complete (what to say of it): the plots show it.
    Captured(String),
}

/// One drive of the window.
#[derive(Debug)]
pub struct Drive {
    pub name: String,
    /// Its colour in plots beside other drives, fixed when it was added.
    pub color: usize,
    /// Drawn in the plots beside the drive shown (the user ticked it in the list).
    pub in_plots: bool,
    pub settings: DriveSettings,
    pub link: LinkState,
    /// The plots' history, markers, trigger and recording.
    pub scope: Scope,
    /// Every fault and warning seen, in order.
    pub timeline: Timeline,
    /// Bus frames recorded (when `settings.record_frames`).
    pub frames: VecDeque<TraceRecord>,
    pub log: Log,
    /// The models of the panels registered in `ui::view` that keep their own (the
    /// Changes tab's, …).
    pub panels: Panels,
    pub motion: Motion,
    /// The object dictionary browser.
    pub browser: Browser,
    /// The watch panel's readings.
    pub watch: Watch,
    /// The objects plotted besides the built-in signals (sampled by the worker).
    pub plotted: Vec<(WatchedObject, DataType)>,
    /// Disconnecting (or closing) with the drive energised or objects changed.
    pub leaving: Option<Leaving>,
    /// The last bus scan's result.
    pub scan: Option<Result<Vec<FoundDevice>, LinkFailure>>,
    /// The project's record of this drive, and what comparing with it found.
    pub project: ProjectRecord,
    /// Seconds since the window opened, advanced by the window.
    pub clock: f64,
    requests: Requests,
    reads: reads::Reads,
}

impl Drive {
    /// A drive named `name` in colour `color`, with `settings`, its plots' history
    /// `history_rows` long (the signals `shown` drawn, or the automatic choice).
    pub fn new(
        name: String,
        color: usize,
        settings: DriveSettings,
        history_rows: usize,
        shown: &[String],
    ) -> Self {
        let mut scope = Scope::new(history_rows);
        if !shown.is_empty() {
            for signal in scope.signals_mut() {
                signal.shown = shown.contains(&signal.info.id);
                signal.auto = false;
            }
        }
        Self {
            name,
            color,
            in_plots: false,
            settings,
            link: LinkState::default(),
            scope,
            timeline: Timeline::default(),
            frames: VecDeque::new(),
            log: Log::default(),
            panels: Panels::default(),
            motion: Motion::default(),
            browser: Browser::new(),
            watch: Watch::default(),
            plotted: Vec::new(),
            leaving: None,
            scan: None,
            project: ProjectRecord::default(),
            clock: 0.0,
            requests: Requests::default(),
            reads: reads::Reads::default(),
        }
    }

    pub fn is_connected(&self) -> bool {
        self.link.is_connected()
    }

    pub fn link_info(&self) -> Option<&crate::link::LinkInfo> {
        self.link.info()
    }

    /// The newest known value of every signal.
    /// The PDI command last written to the drive from this window (its opcode, the halt
    /// and toggle bits aside): what PDI-ReturnValue holds follows it.
    pub fn last_opcode(&self) -> Option<crate::pdi::Opcode> {
        self.log
            .iter()
            .rev()
            .filter(|e| e.outcome != log::Outcome::Queued)
            .find_map(|e| e.image)
            .and_then(|image| image.command().ok())
            .map(|c| c.opcode)
    }

    pub fn latest(&self) -> Option<crate::worker::Sample> {
        self.link.latest
    }

    /// Whether a status bit is set in the newest sample.
    pub fn bit(&self, bit: crate::pdi::StatusBit) -> bool {
        self.link.bit(bit)
    }

    /// Why nothing can be sent to the drive now; `None` while connected.
    pub fn offline_reason(&self) -> Option<String> {
        self.link.offline_reason()
    }

    /// Whether what the panels show is the drive now (see [`LinkState::is_live`]).
    pub fn is_live(&self, now: std::time::SystemTime) -> bool {
        self.link.is_live(now, self.settings.poll_rate)
    }

    /// The status panel's headline while it does not show the drive live.
    pub fn stale_line(&self, now: std::time::SystemTime) -> Option<String> {
        self.link.stale_line(now, self.settings.poll_rate)
    }

    /// The samples' clock now (the newest sample's time).
    pub fn sample_time(&self) -> Option<f64> {
        self.scope.ring().last_time()
    }

    /// A note in the log, not tied to a request.
    pub fn info(&mut self, text: impl Into<String>) {
        self.log.info(self.clock, text);
    }

    /// Queue a request the window makes for its own reasons (settings of the link, the
    /// connection): not logged.
    pub fn ask(&mut self, request: Request) {
        self.requests.push(Owner::Window, request);
    }

    /// The requests waiting to be handed to the worker.
    pub fn waiting(&self) -> impl Iterator<Item = &Request> {
        self.requests.waiting().map(|(_, r)| r)
    }

    /// Who asked for request `id` (`None`: nobody the window still remembers).
    pub fn owner_of(&self, id: RequestId) -> Option<&Owner> {
        self.requests.owner(id)
    }

    /// What waits for the worker, with its owners: the urgent requests only (stops,
    /// halt) when `urgent`, all of it otherwise. The panels' own requests join first.
    pub fn take_requests(&mut self, urgent: bool) -> Vec<(Owner, Request)> {
        if !urgent {
            self.collect_panel_requests();
        }
        self.requests.take(urgent)
    }

    /// The worker took `request` as `id`, or could not (`Err` with why): its owner is
    /// told.
    pub fn handed(&mut self, owner: Owner, request: &Request, sent: Result<RequestId, String>) {
        self.handed_over(owner, request, sent);
    }

    /// The panels' requests joined to the drive's, each with its owner.
    fn collect_panel_requests(&mut self) {
        for (pending, request) in self.browser.take_asks() {
            self.requests.push(Owner::Browser(pending), request);
        }
        for (panel, tag, request) in self.panels.take_requests() {
            self.requests.push(Owner::Panel { panel, tag }, request);
        }
    }

    /// The watch panel is on screen: its next read, when one is due.
    pub fn refresh_watch(&mut self) {
        if !self.is_connected() || self.settings.watch.pins.is_empty() {
            return;
        }
        let catalog = self.browser.catalog();
        if let Some(request) = self.watch.due(&self.settings.watch, catalog, self.clock) {
            self.requests.push(Owner::Watch, request);
        }
    }

    /// Ask the worker for the serial ports (once until it answers).
    pub fn ask_serial_ports(&mut self) {
        if !self.link.machine.ports_asked {
            self.link.machine.ports_asked = true;
            self.ask(Request::ListSerialPorts);
        }
    }

    /// Ask the worker for the network interfaces (once until it answers).
    pub fn ask_interfaces(&mut self) {
        if !self.link.machine.interfaces_asked {
            self.link.machine.interfaces_asked = true;
            self.ask(Request::ListInterfaces);
        }
    }

    /// What the tool changed on the drive, with the values before (for undo): the
    /// Changes tab's model.
    pub fn changes(&self) -> Option<&Changes> {
        self.panels.find::<Changes>()
    }

    /// How many changes have an old value to write back.
    pub fn restorable(&self) -> usize {
        self.changes().map_or(0, Changes::restorable)
    }

    /// Write back every old value the tool changed, newest change first.
    pub fn restore_changes(&mut self) {
        let entries = self
            .changes()
            .map(|c| c.entries.as_slice())
            .unwrap_or_default();
        let requests = crate::ui::changes::restore_requests(entries);
        self.info(format!(
            "restoring {} changed object(s) in reverse order",
            requests.len()
        ));
        for request in requests {
            self.request(request);
        }
    }

    /// The objects plotted besides the built-in signals, to the scope and the worker.
    pub fn send_plotted(&mut self) {
        let objects: Vec<WatchedObject> = self.plotted.iter().map(|(w, _)| w.clone()).collect();
        self.scope.set_watched(&objects);
        let sampled = self
            .plotted
            .iter()
            .map(|(w, dtype)| (w.address, *dtype))
            .collect();
        self.ask(Request::Watch(sampled));
    }
}
