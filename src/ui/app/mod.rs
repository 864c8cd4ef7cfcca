//! The window as a whole: its own state ([`Window`]), the drives (each a [`Drive`] model
//! and the channel to its worker), which one the panels show, and the frame: the workers'
//! events applied (`events`), the panels drawn, the user's commands applied (`commands`),
//! the requests handed to the workers.

mod commands;
mod drives;
mod events;
mod project;

use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui::{self, Ui};

pub use drives::DriveError;

use super::channel::{Channel, WorkerClock};
use super::command::Command;
use super::drive::Drive;
use super::input::InputQueue;
use super::plots::{Beside, PlotView};
use super::project_files::ProjectFiles;
use super::settings::{Settings, WindowSettings};
use super::window::Window;
use super::{pace, timings, view};
use crate::worker;

/// Where eframe keeps the settings between runs.
pub const SETTINGS_KEY: &str = "drivedeck-settings";

/// A drive of the window and the channel to its worker.
struct Slot {
    drive: Drive,
    channel: Channel,
}

/// The application: the window's state, the drives in the list's order, each with its
/// worker (which owns its link), and which one the panels show.
pub struct App {
    window: Window,
    drives: Vec<Slot>,
    selected: usize,
    /// The user's intents of this frame, applied once it is drawn.
    commands: Vec<Command>,
    /// Wakes the window when a worker has news.
    notify: worker::Notify,
    /// The window's start: time zero of every drive's samples (one time axis for all).
    started: Instant,
    /// How the workers keep time (simulated in tests of the simulated drive).
    clock: WorkerClock,
    /// The project file the drives were opened from or saved to.
    project: ProjectFiles,
    /// The window is to close once every drive has been left.
    closing: bool,
    /// Leaving is done: let the window close.
    may_close: bool,
    /// The window's fonts are installed.
    fonts_set: bool,
    /// The start, timed (`DRIVEDECK_TIMINGS`).
    timings: Option<timings::Timings>,
    /// How often the workers' news may wake the window.
    pace: Arc<pace::Pace>,
    /// Frames per second on stderr (`DRIVEDECK_FRAME_STATS`).
    stats: Option<pace::FrameStats>,
    /// Input held back so that no frame mixes typing with a change of focus.
    input: InputQueue,
    /// No settings were saved before: the first frame fits the layout to the screen.
    first_start: bool,
}

impl App {
    /// Start the worker of the first drive and connect it to the link of the saved
    /// settings (the simulator by default). `notify` wakes the window when a worker has
    /// news.
    pub fn new(settings: Settings, notify: worker::Notify, connect: bool) -> Self {
        Self::with_clock(settings, notify, connect, WorkerClock::default())
    }

    /// [`App::new`] with the workers on `clock`.
    pub fn with_clock(
        settings: Settings,
        notify: worker::Notify,
        connect: bool,
        clock: WorkerClock,
    ) -> Self {
        let (window, drive) = settings.split();
        let mut app = Self {
            window: Window::new(window),
            drives: Vec::new(),
            selected: 0,
            commands: Vec::new(),
            notify,
            started: Instant::now(),
            clock,
            project: ProjectFiles::default(),
            closing: false,
            may_close: false,
            fonts_set: false,
            timings: None,
            pace: Arc::new(pace::Pace::default()),
            stats: pace::FrameStats::from_env(),
            input: InputQueue::default(),
            first_start: false,
        };
        let first = app.start_drive("Drive 1".into(), drive);
        if connect {
            let drive = &mut app.drives[first].drive;
            match drive.settings.connection.spec() {
                Ok(spec) => drive.ask(worker::Request::Connect(spec)),
                Err(e) => drive.info(format!("saved connection is invalid: {e}")),
            }
            app.flush_outbox();
        }
        app
    }

    /// The pace the workers' wake-up call (`notify`) keeps: the window sets its rate
    /// and tells it when each frame begins.
    pub fn set_pace(&mut self, pace: Arc<pace::Pace>) {
        self.pace = pace;
    }

    pub fn pace(&self) -> &Arc<pace::Pace> {
        &self.pace
    }

    /// The window is open: its fonts are in, the start is timed when asked, and the
    /// workers' news wakes it at `pace`.
    /// The window opens for the first time (no settings saved): its first frame folds
    /// the command panel on a narrow screen, so the plots get the room.
    pub fn first_start(&mut self) {
        self.first_start = true;
    }

    /// On the first start, a screen narrower than [`NARROW`] points starts with the
    /// command panel folded (to the strip; one click brings it back): at 1024×600 the
    /// panel's 390 points would leave the plots a third of the width.
    fn fit_first_start(&mut self, ctx: &egui::Context) {
        if std::mem::take(&mut self.first_start) && ctx.content_rect().width() < NARROW {
            self.window.settings.commands_collapsed = true;
        }
    }

    pub(super) fn started_in_window(
        &mut self,
        timings: Option<timings::Timings>,
        pace: Arc<pace::Pace>,
    ) {
        self.fonts_set = true;
        self.timings = timings;
        if let Some(timings) = &mut self.timings {
            timings.connect_asked();
        }
        self.set_pace(pace);
    }

    /// The window's own state.
    pub fn window(&self) -> &Window {
        &self.window
    }

    /// The window's own state, to change (tests; the panels change it through commands).
    pub fn window_mut(&mut self) -> &mut Window {
        &mut self.window
    }

    /// The window-wide settings.
    pub fn settings(&self) -> &WindowSettings {
        &self.window.settings
    }

    /// The plots' view (one for the window).
    pub fn plot(&self) -> &PlotView {
        &self.window.plot
    }

    /// The span the plots show now.
    pub fn time_range(&self) -> Option<(f64, f64)> {
        super::plots::time_range(
            &self.window.plot,
            self.shown(),
            self.window.settings.plot.window_s,
        )
    }

    /// Where the plots were drawn in the last frame.
    pub fn plots_rect(&self) -> Option<egui::Rect> {
        self.window
            .plot
            .plots_area()
            .map(|[l, t, r, b]| egui::Rect::from_min_max(egui::pos2(l, t), egui::pos2(r, b)))
    }

    /// The drive the panels show.
    pub fn shown(&self) -> &Drive {
        &self.drives[self.selected].drive
    }

    /// The drive the panels show, to change.
    pub fn shown_mut(&mut self) -> &mut Drive {
        &mut self.drives[self.selected].drive
    }

    /// The drive at `index` in the list.
    pub fn drive(&self, index: usize) -> Option<&Drive> {
        self.drives.get(index).map(|s| &s.drive)
    }

    /// The drive at `index`, to change (tests, scripts).
    pub fn drive_mut(&mut self, index: usize) -> Option<&mut Drive> {
        self.drives.get_mut(index).map(|s| &mut s.drive)
    }

    /// How many drives the list has.
    pub fn drive_count(&self) -> usize {
        self.drives.len()
    }

    /// Which drive the panels show.
    pub fn selected(&self) -> usize {
        self.selected
    }

    /// The plots stand still: paused, a recording under review, or moved away from the
    /// newest samples; new samples change nothing in them.
    pub fn plots_still(&self) -> bool {
        self.window.settings.central == view::PLOTS
            && self
                .window
                .plot
                .stands_still(self.shown().scope.ring().last_time())
    }

    /// Apply every waiting worker event, of every drive. A frame begins: the news from
    /// here on asks for the next one at the redraw rate's pace.
    pub fn pump_events(&mut self) {
        self.pace.frame_began(
            Instant::now(),
            pace::redraw_hz(self.window.settings.plot.redraw_hz),
            self.plots_still(),
        );
        if let Some(stats) = &mut self.stats {
            stats.frame();
        }
        let clock = self.started.elapsed().as_secs_f64();
        self.pump_drives(clock);
    }

    /// Hand the user's requests to the workers. A worker never blocks the window: a full
    /// queue is reported, not waited for. First every drive's urgent ones (a stop reaches
    /// all drives before anything else is sent), then the rest.
    pub fn flush_outbox(&mut self) {
        for slot in &mut self.drives {
            slot.channel.send(&mut slot.drive, true);
        }
        for slot in &mut self.drives {
            slot.channel.sync_settings(&mut slot.drive);
            slot.channel.send(&mut slot.drive, false);
        }
    }

    /// Draw the whole window into `ui`, then apply what the user asked.
    pub fn draw(&mut self, ui: &mut Ui) {
        let ctx = ui.ctx().clone();
        if !self.fonts_set {
            ctx.set_fonts(super::fonts::definitions());
            super::fonts::style(&ctx);
            self.fonts_set = true;
        }
        if let Some(stop) = super::connection::stop_keys(&ctx, self.any_connected()) {
            self.commands.push(Command::StopAll(stop));
        }
        if ctx.input_mut(|i| i.consume_key(egui::Modifiers::NONE, egui::Key::F1)) {
            self.commands.push(Command::OpenGuide);
        }
        // Closing the window with a drive energised asks first.
        if ctx.input(|i| i.viewport().close_requested()) && !self.may_close {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            if !self.closing {
                self.start_closing();
            }
        }
        self.leave_steps(&ctx);
        self.project_steps(&ctx);
        self.fit_first_start(&ctx);
        let rows = self.drive_rows(std::time::SystemTime::now());
        let any_connected = self.any_connected();
        let selected_index = self.selected;
        let Some((selected, others)) = split_shown(&mut self.drives, selected_index) else {
            return;
        };
        // The drives the user ticked, not every drive: sixteen lines a plot read as none.
        let beside: Vec<Beside<'_>> = others
            .iter()
            .filter(|d| d.in_plots)
            .map(|d| Beside {
                name: d.name.as_str(),
                scope: &d.scope,
                color: d.color,
            })
            .collect();
        let mut frame = view::Frame {
            drive: selected,
            window: &mut self.window,
            beside: &beside,
            rows: &rows,
            selected: selected_index,
            project: &self.project,
            any_connected,
            commands: &mut self.commands,
        };
        let focused = ctx.memory(|m| m.focused());
        view::window_ui(ui, &mut frame);
        super::widgets::select_all_on_tab(&ctx, focused);
        drop(beside);
        self.apply_commands();
    }

    /// One frame without eframe (UI tests): events in, draw, requests out.
    pub fn frame(&mut self, ui: &mut Ui) {
        self.pump_events();
        self.draw(ui);
        self.flush_outbox();
    }

    /// The settings kept between runs: the window's choices and the first drive's link
    /// and inputs, as they are now.
    pub fn settings_to_keep(&self) -> Settings {
        let drive = self
            .drives
            .first()
            .map(|s| s.drive.settings.clone())
            .unwrap_or_default();
        Settings::join(self.window.settings.clone(), drive)
    }
}

/// The drive shown, to change, and every other drive, to read (`None` only if the list
/// broke its rule of always holding the selected drive).
fn split_shown(drives: &mut [Slot], selected: usize) -> Option<(&mut Drive, Vec<&Drive>)> {
    let mut shown = None;
    let mut others = Vec::new();
    for (i, slot) in drives.iter_mut().enumerate() {
        if i == selected {
            shown = Some(&mut slot.drive);
        } else {
            others.push(&slot.drive);
        }
    }
    Some((shown?, others))
}

/// Narrower than this (points), the first start folds the command panel.
pub const NARROW: f32 = 1200.0;

impl App {
    /// This frame's share of the input events (`incoming` after those held before): no
    /// frame mixes typing with a change of focus (see [`InputQueue`]).
    pub fn take_input_frame(&mut self, incoming: Vec<egui::Event>) -> Vec<egui::Event> {
        self.input.take_frame(incoming)
    }

    /// Input is held for the next frame.
    pub fn input_pending(&self) -> bool {
        self.input.pending()
    }
}

impl eframe::App for App {
    fn raw_input_hook(&mut self, ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        raw_input.events = self.take_input_frame(std::mem::take(&mut raw_input.events));
        if self.input_pending() {
            ctx.request_repaint();
        }
    }

    fn logic(&mut self, _ctx: &egui::Context, _frame: &mut eframe::Frame) {
        self.pump_events();
        self.flush_outbox();
    }

    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        self.draw(ui);
        self.flush_outbox();
        let status = self.shown().link.sampled_since_connect;
        if let Some(timings) = &mut self.timings
            && timings.frame_drawn(status)
            && !self.closing
        {
            self.start_closing();
            ui.ctx().request_repaint();
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, SETTINGS_KEY, &self.settings_to_keep());
    }

    fn auto_save_interval(&self) -> Duration {
        Duration::from_secs(10)
    }
}
