//! The drives of the window: each with its name, its own worker (and so its own link) and
//! its own `AppState`. The selected drive's state is `App::state`, which every panel
//! draws; the others wait here, parked, with their events applied every frame all the
//! same. Selecting swaps. The list itself sits at the head of the status panel, so the
//! plots and the dictionary lose no room to it.

use std::time::SystemTime;

use eframe::egui::{self, Color32, RichText, Ui};

use super::glance::{Tone, doing};
use super::state::{AppState, Connection, Settings};
use super::widgets::{AMBER, RED, name_widget, named_text_edit};
use super::{App, connection_form::ConnectionForm};
use crate::cia::PowerState;
use crate::link::{LinkSpec, SpecError};
use crate::pdi::Action;
use crate::signal::AT_REST_RPM;
use crate::worker::{self, LinkLossAction, Request, Worker};

/// Rows of the list shown before it scrolls.
const ROWS_SHOWN: f32 = 4.0;
/// Height of one row (two lines).
const ROW_HEIGHT: f32 = 38.0;

/// Why a drive could not be added.
#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    #[error("'{name}' is a name already given to another drive: each drive needs its own")]
    NameTaken { name: String },
    #[error("a drive needs a name")]
    NoName,
    #[error(transparent)]
    Spec(#[from] SpecError),
}

/// One drive: its name, its worker, and its state while another is selected.
pub struct Drive {
    pub name: String,
    /// The drive's state while it is not the selected one (`None` while it is: then its
    /// state is `App::state`).
    parked: Option<AppState>,
    channel: Channel,
}

/// A drive's way to its worker, and the worker settings last handed over.
pub(super) struct Channel {
    worker: Option<Worker>,
    poll_rate: f64,
    record_frames: bool,
    link_loss: Option<LinkLossAction>,
    lost_after: Option<u32>,
}

impl Channel {
    /// Start a worker for a drive with these settings; what went wrong goes in its log.
    fn spawn(state: &mut AppState, notify: worker::Notify, epoch: std::time::Instant) -> Channel {
        let config = worker::Config {
            poll_rate: state.settings.poll_rate,
            epoch: Some(epoch),
            ..worker::Config::default()
        };
        let worker = match Worker::spawn(config, notify) {
            Ok(worker) => Some(worker),
            Err(e) => {
                state.info(format!("the worker thread could not start: {e}"));
                None
            }
        };
        Channel {
            worker,
            poll_rate: state.settings.poll_rate,
            record_frames: false,
            link_loss: None,
            lost_after: None,
        }
    }

    /// Apply every event the worker has for this drive.
    fn pump(&self, state: &mut AppState) {
        if let Some(worker) = &self.worker {
            for event in worker.drain() {
                state.apply(event);
            }
        }
    }

    /// The worker settings changed in the window, as requests at the end of the outbox.
    fn sync_settings(&mut self, state: &mut AppState) {
        let settings = &state.settings;
        let mut wanted = Vec::new();
        if settings.record_frames != self.record_frames {
            self.record_frames = settings.record_frames;
            wanted.push(Request::SetTrace(self.record_frames));
        }
        if self.link_loss != Some(settings.on_link_loss) {
            self.link_loss = Some(settings.on_link_loss);
            wanted.push(Request::SetLinkLoss(settings.on_link_loss));
        }
        let lost_after = settings.lost_after.clamp(1, worker::MAX_LOST_AFTER);
        if self.lost_after != Some(lost_after) {
            self.lost_after = Some(lost_after);
            wanted.push(Request::SetLostAfter(lost_after));
        }
        if settings.poll_rate != self.poll_rate {
            self.poll_rate = settings.poll_rate;
            wanted.push(Request::SetPollRate(self.poll_rate));
        }
        state.outbox.extend(wanted);
    }

    /// Hand the requests of the outbox to the worker: only the urgent ones (stops, halt)
    /// when `urgent`, everything left otherwise. A full queue is reported, not waited for.
    fn send(&mut self, state: &mut AppState, urgent: bool) {
        let requests = if urgent {
            let (urgent, rest) = std::mem::take(&mut state.outbox)
                .into_iter()
                .partition(Request::is_urgent);
            state.outbox = rest;
            urgent
        } else {
            std::mem::take(&mut state.outbox)
        };
        for request in requests {
            match &self.worker {
                Some(worker) => match worker.send(request.clone()) {
                    Ok(id) => state.note_queued(id, &request),
                    Err(e) => state.note_unsent(&request, e.to_string()),
                },
                None => state.note_unsent(&request, "the worker is not running".into()),
            }
        }
    }
}

/// One drive, mutably: its name, its channel and its state (wherever that is kept now).
pub(super) struct DriveMut<'a> {
    pub name: &'a mut String,
    pub channel: &'a mut Channel,
    pub state: &'a mut AppState,
}

/// What a row of the list shows: name, link, CiA 402 state, fault, position, motion.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveRow {
    pub name: String,
    /// The connection string, and how the link stands when it is not up.
    pub link: String,
    /// The CiA 402 state (from 6041h, or PDI-Status), or NO LINK while not live.
    pub state: String,
    pub tone: Tone,
    /// The fault active, with its code and meaning.
    pub fault: Option<String>,
    pub position: Option<String>,
    /// "moving +300 rpm", "still", or nothing known.
    pub motion: String,
    pub connected: bool,
    /// The drive is not the device its project saw, or did not answer the check (`true`:
    /// an alarm), or the project has no identity for it yet (`false`: a caution).
    pub check: Option<(String, bool)>,
}

impl DriveRow {
    fn of(name: &str, state: &AppState, now: SystemTime) -> DriveRow {
        let link = match &state.connection {
            Connection::Connected(info) => info.spec.to_string(),
            Connection::Connecting(spec) => format!("{spec} (connecting)"),
            Connection::Failed {
                spec,
                retry_in: Some(_),
                ..
            } => format!("{spec} (link lost, retrying)"),
            Connection::Failed { spec, .. } => format!("{spec} (failed)"),
            Connection::Disconnected => {
                match (&state.link_lost, state.settings.connection.spec()) {
                    (Some(_), _) => "link lost".to_owned(),
                    (None, Ok(spec)) => format!("{spec} (not connected)"),
                    (None, Err(_)) => "not connected".to_owned(),
                }
            }
        };
        let live = state.is_live(now);
        let sample = state.latest;
        let power = sample
            .and_then(|s| s.statusword())
            .and_then(PowerState::from_statusword);
        let (headline, tone, fault) = match &sample {
            Some(s) => doing(s),
            None => (String::new(), Tone::Alarm, false),
        };
        let words = match (power, &sample) {
            (Some(power), _) => power.name().to_owned(),
            (None, Some(_)) => headline.to_lowercase(),
            (None, None) => "unknown".to_owned(),
        };
        // Lower case, unlike the state tile's headline: the list never repeats the
        // tile's words.
        let (state_text, tone) = if live {
            (words, tone)
        } else {
            let word = match &state.connection {
                Connection::Connected(_) if !state.sampled_since_connect => "waiting for data",
                Connection::Connected(_) => "no data",
                Connection::Connecting(_) if sample.is_none() => "connecting",
                _ => "no link",
            };
            (word.to_owned(), Tone::Alarm)
        };
        let unit = state.settings.plot.position_unit;
        let decimals = match unit {
            super::plots::PositionUnit::Tenths => 0,
            super::plots::PositionUnit::Degrees => 1,
            super::plots::PositionUnit::Revolutions => 3,
        };
        let position = sample
            .and_then(|s| s.position())
            .map(|p| format!("{:.*} {}", decimals, p * unit.scale(), unit.unit()));
        let motion = match sample.and_then(|s| s.velocity()) {
            Some(v) if v.abs() >= AT_REST_RPM => format!("moving {v:+.0} rpm"),
            Some(_) => "still".to_owned(),
            None => "speed unknown".to_owned(),
        };
        DriveRow {
            name: name.to_owned(),
            link,
            state: state_text,
            tone,
            fault: (fault && live).then(|| fault_words(sample)),
            position,
            motion,
            connected: state.is_connected(),
            check: state.project_warning(),
        }
    }

    /// The row's second line: link, position, motion.
    pub fn details(&self) -> String {
        let mut parts = vec![self.link.clone()];
        parts.extend(self.position.clone());
        parts.push(self.motion.clone());
        parts.join(" · ")
    }
}

/// The fault in a few words: "fault 2300h output current too large".
fn fault_words(sample: Option<crate::worker::Sample>) -> String {
    let code = crate::cia::ErrorCode(sample.map_or(0, |s| s.tx.error_code));
    if code.0 == 0 {
        "fault".to_owned()
    } else {
        format!("fault {:04X}h {}", code.0, code.meaning())
    }
}

/// The triggered capture a drive's plots show frozen: its trigger time and its span.
fn captured(state: &AppState) -> Option<(f64, (f64, f64))> {
    let review = state.plot.review.as_ref().filter(|r| r.capture)?;
    Some((review.base.trigger.unwrap_or(f64::NAN), review.span()?))
}

/// Another drive's trigger fired (`name`, at `at`): the selected drive's plots pause at
/// the end of that capture, the trigger marked, the other drives' signals drawn beside its
/// own; "Resume plot" follows again. A capture or recording of its own on screen is left
/// alone.
fn frozen_by(state: &mut AppState, name: &str, at: f64, (from, to): (f64, f64)) {
    if state.plot.review.is_some() {
        return;
    }
    state.plot.paused_at = Some(to);
    state.plot.follow = true;
    state.plot.highlight = Some(at);
    state.plot.message = Some(Ok(format!(
        "{name}'s trigger fired at {at:.3} s: the plots pause at the end of its capture ({from:.3} to {to:.3} s) with every drive's signals; Resume plot follows again"
    )));
}

/// Copy what belongs to the window, not to a drive, from one drive's settings to
/// another's: what the middle shows, the plots' and the dictionary's choices, the panels'
/// layout, where exports go. The rest (link, inputs, poll rate, link-loss policy, pinned
/// objects, jog speed) is each drive's own.
pub fn carry_window_settings(from: &Settings, to: &mut Settings) {
    to.central = from.central;
    to.plot = from.plot.clone();
    to.dictionary = from.dictionary.clone();
    to.commands_collapsed = from.commands_collapsed;
    to.show_log = from.show_log;
    to.watch.open = from.watch.open;
    to.frame_log_path = from.frame_log_path.clone();
    to.timeline_path = from.timeline_path.clone();
}

/// The drives other than the selected one, for the plots.
pub fn beside(drives: &[Drive], selected: usize) -> Vec<super::plots::Beside<'_>> {
    drives
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != selected)
        .filter_map(|(_, d)| {
            d.parked.as_ref().map(|state| super::plots::Beside {
                name: d.name.as_str(),
                scope: &state.scope,
            })
        })
        .collect()
}

impl Drive {
    /// A new drive, its worker started, connecting to `spec` when given.
    pub(super) fn start(
        name: String,
        mut state: AppState,
        notify: worker::Notify,
        epoch: std::time::Instant,
    ) -> (Drive, AppState) {
        let channel = Channel::spawn(&mut state, notify, epoch);
        (
            Drive {
                name,
                parked: None,
                channel,
            },
            state,
        )
    }
}

impl App {
    /// Every drive with its state, in the list's order.
    pub(super) fn each_drive(&mut self) -> Vec<DriveMut<'_>> {
        let selected = self.selected;
        let mut main = Some(&mut self.state);
        self.drives
            .iter_mut()
            .enumerate()
            .filter_map(|(i, drive)| {
                let Drive {
                    name,
                    parked,
                    channel,
                } = drive;
                let state = if i == selected {
                    main.take()
                } else {
                    parked.as_mut()
                };
                state.map(|state| DriveMut {
                    name,
                    channel,
                    state,
                })
            })
            .collect()
    }

    /// The state of the drive at `index` in the list.
    pub fn drive_state(&self, index: usize) -> Option<&AppState> {
        if index == self.selected {
            return Some(&self.state);
        }
        self.drives.get(index).and_then(|d| d.parked.as_ref())
    }

    /// The state of the drive at `index`, to change (tests, the project file).
    pub fn drive_state_mut(&mut self, index: usize) -> Option<&mut AppState> {
        if index == self.selected {
            return Some(&mut self.state);
        }
        self.drives.get_mut(index).and_then(|d| d.parked.as_mut())
    }

    /// Every drive's name and the link it is (or is to be) connected to.
    pub fn drives(&self) -> impl Iterator<Item = (&str, Option<LinkSpec>)> {
        self.drives.iter().enumerate().map(|(i, drive)| {
            let link = self
                .drive_state(i)
                .and_then(|state| match &state.connection {
                    Connection::Connected(info) => Some(info.spec.clone()),
                    Connection::Connecting(spec) | Connection::Failed { spec, .. } => {
                        Some(spec.clone())
                    }
                    Connection::Disconnected => state.settings.connection.spec().ok(),
                });
            (drive.name.as_str(), link)
        })
    }

    /// What the list's rows show at `now`.
    pub fn drive_rows(&self, now: SystemTime) -> Vec<DriveRow> {
        (0..self.drives.len())
            .filter_map(|i| {
                let state = self.drive_state(i)?;
                Some(DriveRow::of(&self.drives[i].name, state, now))
            })
            .collect()
    }

    /// Which drive the panels show.
    pub fn selected(&self) -> usize {
        self.selected
    }

    /// Add a drive by its connection string and connect to it; its index in the list.
    pub fn add_drive(&mut self, name: String, link: &str) -> Result<usize, DriveError> {
        let spec: LinkSpec = link.parse()?;
        self.add_drive_spec(name, spec)
    }

    /// Add a drive on `spec` and connect to it; its index in the list.
    pub fn add_drive_spec(&mut self, name: String, spec: LinkSpec) -> Result<usize, DriveError> {
        let name = name.trim().to_owned();
        if name.is_empty() {
            return Err(DriveError::NoName);
        }
        if self.drives.iter().any(|d| d.name == name) {
            return Err(DriveError::NameTaken { name });
        }
        let mut settings = self.state.settings.clone();
        settings.connection = ConnectionForm::from_spec(&spec, ConnectionForm::default());
        settings.watch.pins.clear();
        self.add_drive_with(name, spec, settings)
    }

    /// Add a drive on `spec` with its own `settings` (a project's drive) and connect it.
    pub(super) fn add_drive_with(
        &mut self,
        name: String,
        spec: LinkSpec,
        mut settings: Settings,
    ) -> Result<usize, DriveError> {
        let name = name.trim().to_owned();
        if name.is_empty() {
            return Err(DriveError::NoName);
        }
        if self.drives.iter().any(|d| d.name == name) {
            return Err(DriveError::NameTaken { name });
        }
        carry_window_settings(&self.state.settings, &mut settings);
        let mut state = AppState::new(settings);
        state.clock = self.state.clock;
        let (mut drive, mut state) = Drive::start(name, state, self.notify.clone(), self.started);
        state.request(Request::Connect(spec));
        drive.parked = Some(state);
        self.drives.push(drive);
        Ok(self.drives.len() - 1)
    }

    /// The next free name "Drive n".
    pub fn next_drive_name(&self) -> String {
        (1..)
            .map(|n| format!("Drive {n}"))
            .find(|name| self.drives.iter().all(|d| &d.name != name))
            .unwrap_or_default()
    }

    /// Point the panels at the drive at `index`. A jog held on the drive left is
    /// released (its button is no longer on screen).
    pub fn select(&mut self, index: usize) {
        if index == self.selected || index >= self.drives.len() {
            return;
        }
        if self.state.jog.take().is_some() {
            self.state.request(Request::JogStop);
        }
        let Some(mut next) = self.drives[index].parked.take() else {
            return;
        };
        carry_window_settings(&self.state.settings, &mut next.settings);
        self.name_draft = None;
        let previous = std::mem::replace(&mut self.state, next);
        self.drives[self.selected].parked = Some(previous);
        self.selected = index;
    }

    /// Rename the drive at `index`.
    pub fn rename(&mut self, index: usize, name: String) -> Result<(), DriveError> {
        let name = name.trim().to_owned();
        if name.is_empty() {
            return Err(DriveError::NoName);
        }
        if self
            .drives
            .iter()
            .enumerate()
            .any(|(i, d)| i != index && d.name == name)
        {
            return Err(DriveError::NameTaken { name });
        }
        if let Some(drive) = self.drives.get_mut(index) {
            drive.name = name;
        }
        Ok(())
    }

    /// Take the drive at `index` out of the list (its worker closes the link). The last
    /// drive stays, and a connected one must be disconnected first (leaving safely).
    pub fn remove_drive(&mut self, index: usize) -> Result<(), String> {
        if self.drives.len() <= 1 {
            return Err("the last drive stays in the list".into());
        }
        if self.drive_state(index).is_some_and(AppState::is_connected) {
            return Err("disconnect it first (the window asks what to leave behind)".into());
        }
        if index >= self.drives.len() {
            return Ok(());
        }
        if index == self.selected {
            let other = if index == 0 { 1 } else { index - 1 };
            self.select(other);
        }
        self.drives.remove(index);
        if self.selected > index {
            self.selected -= 1;
        }
        Ok(())
    }

    /// Whether any drive's link is up.
    pub fn any_connected(&self) -> bool {
        (0..self.drives.len()).any(|i| self.drive_state(i).is_some_and(AppState::is_connected))
    }

    /// Quickstop or switch off every connected drive, ahead of everything queued on each.
    pub fn stop_all(&mut self, action: Action) {
        for drive in self.each_drive() {
            if drive.state.is_connected() {
                drive.state.stop_now(action);
            }
        }
    }

    /// Apply every drive's waiting events. A trigger that fired on another drive than the
    /// selected one freezes the selected drive's plots on its capture's span too, so the
    /// capture shows every drive's signals (see `frozen_by`).
    pub(super) fn pump_drives(&mut self, clock: f64) {
        let selected = self.selected;
        let mut fired = None;
        for (i, drive) in self.each_drive().into_iter().enumerate() {
            drive.state.clock = clock;
            let was = captured(drive.state);
            drive.channel.pump(drive.state);
            if i != selected
                && was.is_none()
                && let Some((at, span)) = captured(drive.state)
            {
                fired = Some((drive.name.clone(), at, span));
            }
        }
        if let Some((name, at, span)) = fired {
            frozen_by(&mut self.state, &name, at, span);
        }
    }

    /// Every drive's requests to its worker: first every drive's urgent ones (a stop
    /// reaches all drives before anything else is sent), then the rest.
    pub(super) fn flush_drives(&mut self) {
        let mut drives = self.each_drive();
        for drive in drives.iter_mut() {
            drive.channel.send(drive.state, true);
        }
        for drive in drives.iter_mut() {
            drive.channel.sync_settings(drive.state);
            drive.channel.send(drive.state, false);
        }
    }
}

/// What the user asked of the list this frame.
enum Intent {
    Select(usize),
    Remove(usize),
    Add(String),
}

/// The list: a row per drive (the selected one's name editable), and "+ Add drive".
pub fn drive_list_ui(ui: &mut Ui, app: &mut App) {
    let rows = app.drive_rows(SystemTime::now());
    let selected = app.selected;
    let mut intent = None;
    ui.horizontal(|ui| {
        ui.strong(format!("Drives ({})", rows.len()));
        add_menu_ui(ui, app, &mut intent);
        super::project_window::project_menu_ui(ui, app);
    });
    super::project_window::project_line_ui(ui, app);
    if let Some(message) = &app.drive_message {
        ui.colored_label(RED, message);
    }
    let several = rows.len() > 1;
    egui::ScrollArea::vertical()
        .id_salt("drive_list")
        .max_height(ROWS_SHOWN * ROW_HEIGHT)
        .show(ui, |ui| {
            for (i, row) in rows.iter().enumerate() {
                let chosen = i == selected;
                let frame = egui::Frame::new()
                    .inner_margin(egui::Margin::symmetric(4, 1))
                    .corner_radius(3.0)
                    .fill(if chosen {
                        ui.visuals().selection.bg_fill.gamma_multiply(0.35)
                    } else {
                        Color32::TRANSPARENT
                    });
                frame.show(ui, |ui| {
                    row_ui(ui, app, i, row, chosen, several, &mut intent);
                });
            }
        });
    match intent {
        Some(Intent::Select(i)) => app.select(i),
        Some(Intent::Remove(i)) => app.drive_message = app.remove_drive(i).err(),
        Some(Intent::Add(link)) => {
            let name = app.next_drive_name();
            app.drive_message = app.add_drive(name, &link).err().map(|e| e.to_string());
            if app.drive_message.is_none() {
                app.add_link.clear();
            }
        }
        None => {}
    }
}

/// One drive: name (editable when selected) and state; link, position and motion under it.
fn row_ui(
    ui: &mut Ui,
    app: &mut App,
    index: usize,
    row: &DriveRow,
    chosen: bool,
    several: bool,
    intent: &mut Option<Intent>,
) {
    ui.horizontal(|ui| {
        if chosen {
            // Typed into a draft: a name half typed may be empty or taken for a moment.
            let mut name = app.name_draft.clone().unwrap_or_else(|| row.name.clone());
            let edit = named_text_edit(ui, &mut name, 110.0, "Drive name");
            if edit.changed() {
                app.drive_message = app
                    .rename(index, name.clone())
                    .err()
                    .map(|e| format!("{e}; the name stays '{}'", row.name));
                app.name_draft = Some(name);
            }
            if !edit.has_focus() && app.name_draft.is_some() {
                app.name_draft = None;
            }
            edit.on_hover_text("The drive's name, in the list and the plots' legend");
        } else {
            let pick = ui
                .add(
                    egui::Button::selectable(false, RichText::new(&row.name))
                        .min_size(egui::vec2(110.0, 0.0)),
                )
                .on_hover_text("Show this drive in the panels");
            if pick.clicked() {
                *intent = Some(Intent::Select(index));
            }
        }
        // Right to left: the remove button at the edge, the state in what is left (cut
        // short rather than widening the panel).
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            if several {
                let remove = ui
                    .add_enabled(!row.connected, egui::Button::new("×").small())
                    .on_hover_text(format!("Take {} out of the list", row.name))
                    .on_disabled_hover_text(
                        "Disconnect it first (the window asks what to leave behind)",
                    );
                name_widget(
                    &remove,
                    egui::accesskit::Role::Button,
                    &format!("Remove {}", row.name),
                );
                if remove.clicked() {
                    *intent = Some(Intent::Remove(index));
                }
            }
            ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                let state = ui.add(
                    egui::Label::new(RichText::new(&row.state).strong().color(row.tone.color()))
                        .truncate(),
                );
                name_widget(
                    &state,
                    egui::accesskit::Role::Label,
                    &format!("{}: {}", row.name, row.state),
                );
            });
        });
    });
    ui.horizontal(|ui| {
        ui.add_space(4.0);
        let details =
            ui.add(egui::Label::new(RichText::new(row.details()).small().weak()).truncate());
        if let Some(fault) = &row.fault {
            details.on_hover_text(fault);
        }
    });
    if let Some(fault) = &row.fault {
        ui.add(egui::Label::new(RichText::new(fault).small().color(RED)).truncate());
    }
    if let Some((check, alarm)) = &row.check {
        let color = if *alarm { RED } else { AMBER };
        ui.add(egui::Label::new(RichText::new(check).small().color(color)).truncate())
            .on_hover_text(check);
    }
}

/// What "Another on the bar's bus" does.
const BAR_LINK_HELP: &str = "The link the connection bar describes now, as a drive of its own (a bus scan's or a discovery's results have \"Add as drive\" too)";

/// "+ Add drive": a simulated one, one by connection string, or the connection bar's.
fn add_menu_ui(ui: &mut Ui, app: &mut App, intent: &mut Option<Intent>) {
    ui.menu_button("+ Add drive", |ui| {
        ui.set_min_width(260.0);
        if ui
            .button("Simulated drive")
            .on_hover_text("A simulated drive of its own (sim://)")
            .clicked()
        {
            *intent = Some(Intent::Add(LinkSpec::Sim.to_string()));
            ui.close();
        }
        if let Ok(spec) = app.state.settings.connection.spec()
            && ui
                .button(format!("Another on the bar's bus: {spec}"))
                .on_hover_text(BAR_LINK_HELP)
                .clicked()
        {
            *intent = Some(Intent::Add(spec.to_string()));
            ui.close();
        }
        ui.separator();
        ui.label("Connection string:");
        ui.horizontal(|ui| {
            let edit = named_text_edit(
                ui,
                &mut app.add_link,
                190.0,
                "New drive's connection string",
            );
            let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Add").clicked() || enter) && !app.add_link.trim().is_empty() {
                *intent = Some(Intent::Add(app.add_link.trim().to_owned()));
                ui.close();
            }
        });
        ui.weak("e.g. modbus-tcp://192.168.2.100:502?unit=0, canopen+sim://?node=2");
    });
}

/// The stop strip's Quickstop and Switch off for every drive; what was pressed.
pub fn stop_all_strip_ui(ui: &mut Ui, app: &App) -> Option<Action> {
    let names: Vec<&str> = app.drives.iter().map(|d| d.name.as_str()).collect();
    let enabled = app.any_connected();
    let offline = app.state.offline_reason().unwrap_or_default();
    super::connection::stop_buttons_ui(ui, enabled, &offline, &names)
}

impl AppState {
    /// A stop from the window, put ahead of everything waiting in the outbox.
    pub fn stop_now(&mut self, action: Action) {
        self.request(Request::Command(action));
        if let Some(stop) = self.outbox.pop() {
            self.outbox.insert(0, stop);
        }
    }
}
