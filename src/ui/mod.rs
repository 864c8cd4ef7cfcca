//! The window (eframe). `AppState` is plain data changed only by worker events
//! (`logic`); the panels draw it and collect the user's intents as requests (`ui`).

pub mod browser;
pub mod changes;
pub mod commands;
pub mod connection;
pub mod connection_form;
pub mod drives;
pub mod faults;
pub mod fonts;
pub mod glance;
pub mod jog;
pub mod leave;
pub mod log;
pub mod pace;
pub mod plots;
pub mod power_state;
pub mod project_window;
pub mod scan;
pub mod state;
pub mod status;
pub mod timings;
pub mod watch;
pub mod widgets;

use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui::{self, Ui};

pub use state::{AppState, Settings};

use crate::worker::{self, Request};

/// Where eframe keeps the settings between runs.
pub const SETTINGS_KEY: &str = "drivedeck-settings";

/// The application: the drives, each with its worker (which owns its link) and its state;
/// `state` is the selected drive's, which the panels show.
pub struct App {
    /// The selected drive's state.
    pub state: AppState,
    /// Every drive in the list's order; the selected one's state is `state`.
    drives: Vec<drives::Drive>,
    selected: usize,
    /// Wakes the window when a worker has news.
    notify: worker::Notify,
    /// The window's start: time zero of every drive's samples (one time axis for all).
    started: Instant,
    /// The "+ Add drive" menu's connection string, and what went wrong with the list.
    add_link: String,
    drive_message: Option<String>,
    /// The selected drive's name as being typed.
    name_draft: Option<String>,
    /// The window is to close once every drive has been left.
    closing: bool,
    /// Leaving is done: let the window close.
    may_close: bool,
    /// The window's fonts are installed.
    fonts_set: bool,
    /// The project file the drives were opened from or saved to.
    project: project_window::ProjectFiles,
    /// The start, timed (`DRIVEDECK_TIMINGS`).
    timings: Option<timings::Timings>,
    /// How often the workers' news may wake the window.
    pace: Arc<pace::Pace>,
    /// Frames per second on stderr (`DRIVEDECK_FRAME_STATS`).
    stats: Option<pace::FrameStats>,
}

impl App {
    /// Start the worker of the first drive and connect it to the link of the saved
    /// settings (the simulator by default). `notify` wakes the window when a worker has
    /// news.
    pub fn new(settings: Settings, notify: worker::Notify, connect: bool) -> Self {
        let started = Instant::now();
        let (drive, state) = drives::Drive::start(
            "Drive 1".into(),
            AppState::new(settings),
            notify.clone(),
            started,
        );
        let mut app = Self {
            state,
            drives: vec![drive],
            selected: 0,
            notify,
            started,
            add_link: String::new(),
            drive_message: None,
            name_draft: None,
            closing: false,
            may_close: false,
            fonts_set: false,
            project: project_window::ProjectFiles::default(),
            timings: None,
            pace: Arc::new(pace::Pace::default()),
            stats: pace::FrameStats::from_env(),
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

    /// The pace the workers' wake-up call (`notify`) keeps: the window sets its rate
    /// and tells it when each frame begins.
    pub fn set_pace(&mut self, pace: Arc<pace::Pace>) {
        self.pace = pace;
    }

    pub fn pace(&self) -> &Arc<pace::Pace> {
        &self.pace
    }

    /// The plots stand still: paused, a recording under review, or moved away from the
    /// newest samples; new samples change nothing in them.
    pub fn plots_still(&self) -> bool {
        let state = &self.state;
        if state.settings.central != state::Central::Plots {
            return false;
        }
        let plot = &state.plot;
        if plot.is_paused() || plot.review.is_some() {
            return true;
        }
        let newest = state.scope.ring().last_time();
        !plot.follow
            && plot
                .shown_range
                .zip(newest)
                .is_some_and(|((_, to), newest)| to < newest)
    }

    /// Apply every waiting worker event, of every drive. A frame begins: the news from
    /// here on asks for the next one at the redraw rate's pace.
    pub fn pump_events(&mut self) {
        self.pace.frame_began(
            Instant::now(),
            pace::redraw_hz(self.state.settings.plot.redraw_hz),
            self.plots_still(),
        );
        if let Some(stats) = &mut self.stats {
            stats.frame();
        }
        let clock = self.started.elapsed().as_secs_f64();
        self.pump_drives(clock);
    }

    /// Hand the user's requests to the workers. A worker never blocks the window: a full
    /// queue is reported, not waited for.
    pub fn flush_outbox(&mut self) {
        for spec in std::mem::take(&mut self.state.wanted_drives) {
            let name = self.next_drive_name();
            self.drive_message = self.add_drive_spec(name, spec).err().map(|e| e.to_string());
        }
        self.flush_drives();
    }

    /// Closing the window: ask once for every drive that needs it, or go.
    fn start_closing(&mut self) {
        self.closing = true;
        let mut drives = self.each_drive();
        let asking = drives
            .iter()
            .any(|d| d.state.leaving.is_none() && d.state.needs_leave_question());
        for drive in drives.iter_mut() {
            if drive.state.leaving.is_none() && (!asking || drive.state.needs_leave_question()) {
                drive.state.ask_to_leave(true);
            }
        }
    }

    /// The leave question, and every drive's step of leaving; the window closes once all
    /// drives are left.
    fn leave_steps(&mut self, ctx: &egui::Context) {
        let answered = {
            let mut named: Vec<leave::Named<'_>> = self
                .each_drive()
                .into_iter()
                .map(|d| leave::Named {
                    name: d.name.as_str(),
                    state: d.state,
                })
                .collect();
            leave::leave_dialog(ctx, &mut named)
        };
        match answered {
            Some(leave::Answered::Cancelled) if self.closing => self.closing = false,
            Some(leave::Answered::Going) if self.closing => {
                // The drives that needed no question go too.
                for drive in self.each_drive() {
                    if drive.state.leaving.is_none() {
                        drive.state.ask_to_leave(true);
                    }
                }
            }
            _ => {}
        }
        let mut done = true;
        for drive in self.each_drive() {
            drive.state.leave_step();
            done &= drive.state.leaving.is_none();
        }
        if self.closing && done {
            self.may_close = true;
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    /// Draw the whole window into `ui`.
    pub fn draw(&mut self, ui: &mut Ui) {
        let ctx = ui.ctx().clone();
        if !self.fonts_set {
            ctx.set_fonts(fonts::definitions());
            self.fonts_set = true;
        }
        if let Some(stop) = connection::stop_keys(&ctx, self.any_connected()) {
            self.stop_all(stop);
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
        top_bar_ui(ui, self);
        log_panel_ui(ui, &mut self.state);
        status_panel_ui(ui, self);
        let beside = drives::beside(&self.drives, self.selected);
        let own = self
            .drives
            .get(self.selected)
            .map_or("", |d| d.name.as_str());
        let state = &mut self.state;
        commands_panel_ui(ui, state);
        egui::CentralPanel::default_margins().show(ui, |ui| central_ui(ui, state, own, &beside));
    }

    /// One frame without eframe (UI tests): events in, draw, requests out.
    pub fn frame(&mut self, ui: &mut Ui) {
        self.pump_events();
        self.draw(ui);
        self.flush_outbox();
    }

    /// The settings kept between runs: the first drive's link and inputs, the window's
    /// layout and choices as they are now.
    pub fn settings_to_keep(&self) -> Settings {
        let mut settings = self
            .drive_state(0)
            .map(|s| s.settings.clone())
            .unwrap_or_else(|| self.state.settings.clone());
        drives::carry_window_settings(&self.state.settings, &mut settings);
        settings
    }
}

/// The connection bar, the stop strip at its right, and a bus scan's results under them.
fn top_bar_ui(ui: &mut Ui, app: &mut App) {
    egui::Panel::top("connection_bar").show(ui, |ui| {
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            ui.heading("drivedeck");
            ui.separator();
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                if let Some(stop) = drives::stop_all_strip_ui(ui, app) {
                    app.stop_all(stop);
                }
                ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                    connection::connection_ui(ui, &mut app.state);
                });
            });
        });
        let state = &mut app.state;
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

/// The status panel: the list of drives and the selected one's state tile as its fixed
/// head, the details scrolling under it.
fn status_panel_ui(ui: &mut Ui, app: &mut App) {
    egui::Panel::left("status")
        .resizable(true)
        .default_size(290.0)
        .show(ui, |ui| {
            ui.add_space(4.0);
            drives::drive_list_ui(ui, app);
            ui.separator();
            let state = &mut app.state;
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
fn central_ui(ui: &mut Ui, state: &mut AppState, own: &str, beside: &[plots::Beside<'_>]) {
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
        state::Central::Plots => plots::drives_plots_ui(ui, state, own, beside),
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
        let status = self.state.sampled_since_connect;
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

/// What the window opens on: a project (its file, and the drive to show first), or a
/// link (`--link`), or what was open last time.
pub enum Opening {
    /// The last project when one was opened before and still opens, else the link of the
    /// saved settings (the simulator the first time: the two-drive demo).
    Last,
    /// This link, as one drive.
    Link(crate::link::LinkSpec),
    /// This project, with the drive named shown first.
    Project {
        project: crate::project::Project,
        path: std::path::PathBuf,
        show: Option<String>,
    },
}

/// Open the window. Blocks until it is closed.
pub fn run_window(opening: Opening) -> Result<(), eframe::Error> {
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
            // The workers' news wakes the window at the redraw rate, not at every burst.
            let pace = pace::Pace::new(cc.egui_ctx.clone());
            let notify: worker::Notify = pace.notify();
            let (opening, note) = match opening {
                Opening::Last => last_project(),
                other => (other, None),
            };
            let mut app = match opening {
                Opening::Project {
                    project,
                    path,
                    show,
                } => App::with_project(settings, notify, &project, Some(path), show.as_deref()),
                Opening::Link(spec) => {
                    settings.connection =
                        state::ConnectionForm::from_spec(&spec, settings.connection);
                    App::new(settings, notify, true)
                }
                Opening::Last => {
                    let demo = settings.connection.bus == state::Bus::Sim;
                    let mut app = App::new(settings, notify, true);
                    if demo {
                        // The demo: two simulated drives, so the list shows what it is for.
                        let named = app.rename(0, "X axis".into());
                        let added = app.add_drive("Y axis".into(), "sim://");
                        if let Err(e) = named.and(added.map(|_| ())) {
                            app.state.info(format!("the demo's second drive: {e}"));
                        }
                    }
                    app
                }
            };
            if let Some(note) = note {
                app.state.info(note);
            }
            // Installed before the first frame, so that it is not laid out twice.
            cc.egui_ctx.set_fonts(fonts::definitions());
            app.fonts_set = true;
            app.timings = timings::Timings::from_env();
            if let Some(timings) = &mut app.timings {
                timings.connect_asked();
            }
            app.set_pace(pace);
            Ok(Box::new(app))
        }),
    )
}

/// The last project opened, when there is one and it still opens; else what to say.
fn last_project() -> (Opening, Option<String>) {
    last_project_from(crate::project::recent::settings_dir().as_deref())
}

/// [`last_project`] with the settings folder `dir`.
fn last_project_from(dir: Option<&std::path::Path>) -> (Opening, Option<String>) {
    let Some(path) = dir.and_then(crate::project::recent::last_project_in) else {
        return (Opening::Last, None);
    };
    match crate::project::open(&path) {
        Ok(project) => (
            Opening::Project {
                project,
                path,
                show: None,
            },
            None,
        ),
        Err(e) => (
            Opening::Last,
            Some(format!(
                "the last project, {}, did not reopen: {e}",
                path.display()
            )),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_project_reopens_and_one_that_no_longer_opens_is_said() {
        let dir = tempfile::tempdir().expect("a folder");
        assert!(matches!(
            last_project_from(Some(dir.path())),
            (Opening::Last, None)
        ));
        assert!(matches!(last_project_from(None), (Opening::Last, None)));
        let file = dir.path().join("machine.json");
        let drive = crate::project::Drive::new("X axis", crate::link::LinkSpec::Sim);
        let project = crate::project::Project::new(vec![drive]).expect("a project");
        crate::project::save(&project, &file).expect("saved");
        crate::project::recent::remember_in(dir.path(), &file).expect("remembered");
        match last_project_from(Some(dir.path())) {
            (
                Opening::Project {
                    project: opened, ..
                },
                None,
            ) => assert_eq!(opened, project),
            _ => panic!("the last project did not reopen"),
        }
        std::fs::write(&file, "{ not a project").expect("spoilt");
        match last_project_from(Some(dir.path())) {
            (Opening::Last, Some(note)) => {
                assert!(
                    note.contains("did not reopen") && note.contains("machine.json"),
                    "{note}"
                )
            }
            _ => panic!("a spoilt last project must be said"),
        }
    }
}
