//! The window (eframe). `AppState` is plain data changed only by worker events
//! (`logic`); the panels draw it and collect the user's intents as requests (`ui`).

pub mod browser;
pub mod changes;
pub mod commands;
pub mod connection;
pub mod connection_form;
pub mod faults;
pub mod fonts;
pub mod glance;
pub mod jog;
pub mod leave;
pub mod log;
pub mod opened_project;
pub mod plots;
pub mod power_state;
pub mod scan;
pub mod state;
pub mod status;
pub mod watch;
pub mod widgets;

use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui::{self, Ui};

pub use state::{AppState, Settings};

use crate::worker::{self, Request, Worker};

/// Where eframe keeps the settings between runs.
pub const SETTINGS_KEY: &str = "drivedeck-settings";

/// The application: the state, and the worker that owns the link.
pub struct App {
    pub state: AppState,
    worker: Option<Worker>,
    started: Instant,
    last_poll_rate: f64,
    last_record_frames: bool,
    last_link_loss: Option<worker::LinkLossAction>,
    last_lost_after: Option<u32>,
    /// Leaving is done: let the window close.
    may_close: bool,
    /// The window's fonts are installed.
    fonts_set: bool,
}

impl App {
    /// Start the worker and connect to the link of the saved settings (the simulator by
    /// default). `notify` wakes the window when the worker has news.
    pub fn new(settings: Settings, notify: worker::Notify, connect: bool) -> Self {
        let mut state = AppState::new(settings);
        let config = worker::Config {
            poll_rate: state.settings.poll_rate,
            ..worker::Config::default()
        };
        let worker = match Worker::spawn(config, notify) {
            Ok(worker) => Some(worker),
            Err(e) => {
                state.info(format!("the worker thread could not start: {e}"));
                None
            }
        };
        let last_poll_rate = state.settings.poll_rate;
        let mut app = Self {
            state,
            worker,
            started: Instant::now(),
            last_poll_rate,
            last_record_frames: false,
            last_link_loss: None,
            last_lost_after: None,
            may_close: false,
            fonts_set: false,
        };
        if connect {
            match app.state.settings.connection.spec() {
                Ok(spec) => app.state.request(Request::Connect(spec)),
                Err(e) => app.state.info(format!("saved connection is invalid: {e}")),
            }
            app.flush_outbox();
        }
        app
    }

    /// Apply every waiting worker event.
    pub fn pump_events(&mut self) {
        self.state.clock = self.started.elapsed().as_secs_f64();
        if let Some(worker) = &self.worker {
            for event in worker.drain() {
                self.state.apply(event);
            }
        }
    }

    /// Hand the user's requests to the worker. The worker never blocks the window: a full
    /// queue is reported, not waited for.
    pub fn flush_outbox(&mut self) {
        if self.state.settings.record_frames != self.last_record_frames {
            self.last_record_frames = self.state.settings.record_frames;
            self.state
                .outbox
                .push(Request::SetTrace(self.last_record_frames));
        }
        if self.last_link_loss != Some(self.state.settings.on_link_loss) {
            self.last_link_loss = Some(self.state.settings.on_link_loss);
            self.state
                .outbox
                .push(Request::SetLinkLoss(self.state.settings.on_link_loss));
        }
        let lost_after = self
            .state
            .settings
            .lost_after
            .clamp(1, worker::MAX_LOST_AFTER);
        if self.last_lost_after != Some(lost_after) {
            self.last_lost_after = Some(lost_after);
            self.state.outbox.push(Request::SetLostAfter(lost_after));
        }
        if self.state.settings.poll_rate != self.last_poll_rate {
            self.last_poll_rate = self.state.settings.poll_rate;
            self.state
                .outbox
                .push(Request::SetPollRate(self.last_poll_rate));
        }
        let requests = std::mem::take(&mut self.state.outbox);
        for request in requests {
            match &self.worker {
                Some(worker) => match worker.send(request.clone()) {
                    Ok(id) => self.state.note_queued(id, &request),
                    Err(e) => self.state.note_unsent(&request, e.to_string()),
                },
                None => self
                    .state
                    .note_unsent(&request, "the worker is not running".into()),
            }
        }
    }

    /// Draw the whole window into `ui`.
    pub fn draw(&mut self, ui: &mut Ui) {
        let ctx = ui.ctx().clone();
        if !self.fonts_set {
            ctx.set_fonts(fonts::definitions());
            self.fonts_set = true;
        }
        connection::stop_keys(&ctx, &mut self.state);
        // Closing the window with the drive energised asks first.
        if ctx.input(|i| i.viewport().close_requested()) && !self.may_close {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            if self.state.leaving.is_none() {
                self.state.ask_to_leave(true);
            }
        }
        leave::leave_dialog(&ctx, &mut self.state);
        if self.state.leave_step() {
            self.may_close = true;
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        let state = &mut self.state;
        top_bar_ui(ui, state);
        log_panel_ui(ui, state);
        status_panel_ui(ui, state);
        commands_panel_ui(ui, state);
        egui::CentralPanel::default_margins().show(ui, |ui| central_ui(ui, state));
    }

    /// One frame without eframe (UI tests): events in, draw, requests out.
    pub fn frame(&mut self, ui: &mut Ui) {
        self.pump_events();
        self.draw(ui);
        self.flush_outbox();
    }
}

/// The connection bar, the stop strip at its right, and a bus scan's results under them.
fn top_bar_ui(ui: &mut Ui, state: &mut AppState) {
    egui::Panel::top("connection_bar").show(ui, |ui| {
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            ui.heading("drivedeck");
            ui.separator();
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                connection::stop_strip_ui(ui, state);
                ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                    connection::connection_ui(ui, state);
                });
            });
        });
        if state.scan.is_some() {
            ui.separator();
            scan::scan_results_ui(ui, state);
        }
        ui.add_space(4.0);
    });
}

/// The log at the bottom: resizable, its height kept with the window's memory between
/// runs; a sixth of the window's height the first time.
fn log_panel_ui(ui: &mut Ui, state: &mut AppState) {
    let height = ui.ctx().content_rect().height();
    egui::Panel::bottom("log")
        .resizable(true)
        .default_size((height / 6.0).clamp(90.0, 220.0))
        .min_size(60.0)
        .max_size((height * 0.6).max(120.0))
        .show(ui, |ui| log::log_ui(ui, state));
}

/// The status panel: the state tile as its fixed head, the details scrolling under it.
fn status_panel_ui(ui: &mut Ui, state: &mut AppState) {
    egui::Panel::left("status")
        .resizable(true)
        .default_size(290.0)
        .show(ui, |ui| {
            ui.add_space(4.0);
            glance::state_tile_ui(ui, state);
            ui.add_space(2.0);
            egui::ScrollArea::vertical()
                .id_salt("status_scroll")
                .show(ui, |ui| status::status_ui(ui, state));
        });
}

/// The command panel, or the narrow strip it collapses to (the choice is kept).
fn commands_panel_ui(ui: &mut Ui, state: &mut AppState) {
    let mut expanded = !state.settings.commands_collapsed;
    let strip = egui::Panel::right("commands_strip")
        .resizable(true)
        .exact_size(commands::STRIP_WIDTH);
    // A quarter of the window's width the first time, but no less than a command row
    // needs (button, label, box, unit): 390 px at 1366, 460 at 1920.
    let width = ui.ctx().content_rect().width();
    let full = egui::Panel::right("commands")
        .resizable(true)
        .default_size((width / 4.0).clamp(390.0, 460.0))
        .min_size(330.0);
    let asked = expanded;
    egui::Panel::show_switched(ui, &mut expanded, strip, full, |ui, shown| {
        if shown {
            egui::ScrollArea::vertical()
                .id_salt("commands_scroll")
                .show(ui, |ui| commands::commands_ui(ui, state));
        } else {
            commands::collapsed_strip_ui(ui, state);
        }
    });
    // Dragged open or shut: that is the choice now (a button set it in the contents).
    if expanded != asked {
        state.settings.commands_collapsed = !expanded;
    }
}

/// The middle: the plots or the object dictionary, in all the room the panels leave.
fn central_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        let central = &mut state.settings.central;
        ui.selectable_value(central, state::Central::Plots, "Plots");
        ui.selectable_value(central, state::Central::Dictionary, "Object dictionary");
        ui.separator();
        let watched = state.settings.watch.pins.len();
        ui.toggle_value(&mut state.settings.watch.open, format!("Watch ({watched})"))
            .on_hover_text("Objects pinned to be read live, beside the plots and the dictionary");
    });
    ui.separator();
    if state.settings.watch.open {
        egui::Panel::right("watch")
            .resizable(true)
            .default_size(270.0)
            .show(ui, |ui| watch::watch_ui(ui, state));
    }
    match state.settings.central {
        state::Central::Plots => plots::plots_ui(ui, state),
        state::Central::Dictionary => browser::browser_ui(ui, state),
    }
}

impl eframe::App for App {
    fn logic(&mut self, _ctx: &egui::Context, _frame: &mut eframe::Frame) {
        self.pump_events();
        self.flush_outbox();
    }

    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        self.draw(ui);
        self.flush_outbox();
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, SETTINGS_KEY, &self.state.settings);
    }

    fn auto_save_interval(&self) -> Duration {
        Duration::from_secs(10)
    }
}

/// Open the window, on `project` when one is given (see `opened_project`: the window
/// shows one of its drives, `connect_to`'s if it names one). Blocks until it is closed.
pub fn run_window(
    connect_to: Option<crate::link::LinkSpec>,
    project: Option<crate::project::Project>,
) -> Result<(), eframe::Error> {
    let options = eframe::NativeOptions {
        // The first time, the whole screen: eframe clamps the size to the monitor, and a
        // window manager maximises it. Later, the size and place it had (eframe keeps
        // them with the settings).
        viewport: egui::ViewportBuilder::default()
            .with_title("drivedeck")
            .with_inner_size([7680.0, 4320.0])
            .with_maximized(true)
            .with_min_inner_size([900.0, 560.0]),
        ..Default::default()
    };
    eframe::run_native(
        "drivedeck",
        options,
        Box::new(move |cc| {
            let mut settings: Settings = cc
                .storage
                .and_then(|s| eframe::get_value(s, SETTINGS_KEY))
                .unwrap_or_default();
            if let Some(project) = &project {
                let drive = connect_to.as_ref().and_then(|spec| {
                    project
                        .drives
                        .iter()
                        .find(|d| &d.link == spec)
                        .map(|d| d.name.as_str())
                });
                let notes;
                (settings, notes) = opened_project::settings_for_project(settings, project, drive);
                for note in notes {
                    eprintln!("note: {note}");
                }
            }
            if let Some(spec) = &connect_to {
                settings.connection = state::ConnectionForm::from_spec(spec, settings.connection);
            }
            let ctx = cc.egui_ctx.clone();
            let notify: worker::Notify =
                Arc::new(move || ctx.request_repaint_after(Duration::from_millis(5)));
            Ok(Box::new(App::new(settings, notify, true)))
        }),
    )
}
