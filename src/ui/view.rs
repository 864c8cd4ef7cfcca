//! The window's layout: the connection bar with the stop strip on top, the log at the
//! bottom, the list of drives and the status on the left, the commands on the right, and
//! the panels in the middle, each drawn from the models and pushing the user's intents as
//! commands. The panels of the middle and the tabs of the log are registered in
//! [`CENTRAL`] and [`BOTTOM`]: a new one is a line there.

use eframe::egui::{self, Ui};

use super::changes::Changes;
use super::command::Command;
use super::drive::Drive;
use super::drive_row::DriveRow;
use super::panel::{PanelModel, Panels};
use super::plots::{Beside, Plots};
use super::project_files::ProjectFiles;
use super::window::Window;
use super::{
    browser, changes, commands, connection, drive_list, faults, gains, glance, io_panel, log,
    machine, nanoj, plots, procedure, scan, status, test_run, watch,
};

/// What one frame of the window draws from, and where the user's intents go.
pub struct Frame<'a> {
    /// The drive the panels show.
    pub drive: &'a mut Drive,
    pub window: &'a mut Window,
    /// The other drives, drawn beside the shown one in the plots.
    pub beside: &'a [Beside<'a>],
    /// The list's rows, every drive's, and which is shown.
    pub rows: &'a [DriveRow],
    pub selected: usize,
    pub project: &'a ProjectFiles,
    pub any_connected: bool,
    pub commands: &'a mut Vec<Command>,
}

/// A panel of the window: its id (kept in the window's settings while shown), its tab's
/// title for the drive shown, its view, the model it keeps per drive (made in every
/// drive the window starts; `None`: what it shows is the drive's own) and how the log's
/// Clear empties it.
pub struct Panel {
    pub id: &'static str,
    pub title: fn(&Drive) -> String,
    pub ui: fn(&mut Ui, &mut Frame<'_>),
    pub model: Option<fn(&mut Panels)>,
    pub clear: Option<fn(&mut Drive)>,
}

/// Make the model `M` in a drive's panels (a [`Panel`]'s `model`).
pub fn model<M: PanelModel + Default>(panels: &mut Panels) {
    panels.get::<M>();
}

/// Every registered panel's model, made in a new drive's `panels`.
pub fn make_models(panels: &mut Panels) {
    for panel in CENTRAL.iter().chain(BOTTOM) {
        if let Some(make) = panel.model {
            make(panels);
        }
    }
}

pub use super::settings::{DICTIONARY, PLOTS};

/// The panels of the middle of the window, in their tabs' order.
pub const CENTRAL: &[Panel] = &[
    Panel {
        id: PLOTS,
        title: |_| "Plots".into(),
        ui: plots_panel_ui,
        model: None,
        clear: None,
    },
    Panel {
        id: DICTIONARY,
        title: |_| "Object dictionary".into(),
        ui: |ui, f| browser::browser_ui(ui, f.drive, &mut f.window.settings.dictionary, f.commands),
        model: None,
        clear: None,
    },
    // The controller's gains and the limits that shape a response, editable.
    Panel {
        id: gains::GAINS,
        title: |_| "Gains".into(),
        ui: |ui, f| gains::gains_ui(ui, f.drive, &mut f.window.settings.central),
        model: Some(model::<gains::GainsPanel>),
        clear: None,
    },
    // Test moves and velocity steps with figures, runs compared and overlaid.
    Panel {
        id: test_run::TEST,
        title: |_| "Test".into(),
        ui: |ui, f| test_run::test_ui(ui, f.drive),
        model: Some(model::<test_run::TestRuns>),
        clear: None,
    },
    // The drive's NanoJ program.
    Panel {
        id: nanoj::NANOJ,
        title: |_| "NanoJ".into(),
        ui: |ui, f| nanoj::nanoj_ui(ui, f.drive, f.commands),
        model: Some(model::<nanoj::NanojPanel>),
        clear: None,
    },
    // The digital inputs and outputs and the analog input.
    Panel {
        id: io_panel::IO,
        title: |_| "I/O".into(),
        ui: |ui, f| io_panel::io_ui(ui, f.drive, f.commands),
        model: Some(model::<io_panel::IoPanel>),
        clear: None,
    },
    // A commissioning procedure run on the drive, its record written.
    Panel {
        id: procedure::PROCEDURE,
        title: |_| "Procedure".into(),
        ui: |ui, f| procedure::procedure_ui(ui, f.drive),
        model: Some(model::<procedure::ProcedurePanel>),
        clear: None,
    },
    // Every drive on one line: the machine at a glance.
    Panel {
        id: machine::MACHINE,
        title: |_| "Machine".into(),
        ui: |ui, f| machine::machine_ui(ui, f.rows, f.selected, &mut f.window.machine, f.commands),
        model: None,
        clear: None,
    },
];

/// The tabs of the log at the bottom, in their order.
pub const BOTTOM: &[Panel] = &[
    Panel {
        id: log::COMMANDS,
        title: |_| "Commands".into(),
        ui: |ui, f| log::commands_ui(ui, f.drive),
        model: None,
        clear: Some(|d| d.log.clear()),
    },
    Panel {
        id: log::FRAMES,
        title: |_| "Bus frames".into(),
        ui: |ui, f| log::frames_ui(ui, f.drive, &mut f.window.settings.frame_log_path),
        model: None,
        clear: Some(|d| d.frames.clear()),
    },
    Panel {
        id: faults::FAULTS,
        title: |d| counted("Faults", d.timeline.len()),
        ui: |ui, f| {
            faults::faults_ui(
                ui,
                f.drive,
                &mut f.window.settings.timeline_path,
                f.commands,
            )
        },
        model: None,
        clear: Some(|d| d.timeline.clear()),
    },
    // The recipe's example: a model file, a view file, and this entry.
    Panel {
        id: changes::CHANGES,
        title: |d| counted("Changes", d.changes().map_or(0, Changes::len)),
        ui: |ui, f| changes::changes_ui(ui, f.drive, f.commands),
        model: Some(model::<Changes>),
        clear: Some(|d| d.panels.get::<Changes>().clear()),
    },
];

/// A tab's title with how many entries it holds, when it holds any.
fn counted(name: &str, count: usize) -> String {
    if count == 0 {
        name.to_owned()
    } else {
        format!("{name} ({count})")
    }
}

/// The registered panel with this id, else the first.
fn panel<'p>(panels: &'p [Panel], id: &str) -> Option<&'p Panel> {
    panels
        .iter()
        .find(|p| p.id == id)
        .or_else(|| panels.first())
}

/// The whole window.
pub fn window_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    if plots::fills_window(ui.ctx(), &f.window.plot) {
        // A picture of the plots at twice the resolution, for a frame or two: the plots
        // alone (a panel drawn as well would come out over them). The jog keys still work.
        super::jog::jog_input(ui.ctx(), f.drive, 0, f.commands);
        // No margin of its own: the plots get every point the window's zoom was raised for.
        let fill = egui::Frame::NONE.fill(ui.visuals().panel_fill);
        egui::CentralPanel::default_margins()
            .frame(fill)
            .show(ui, |ui| plots_panel_ui(ui, f));
        return;
    }
    top_bar_ui(ui, f);
    log_panel_ui(ui, f);
    status_panel_ui(ui, f);
    super::path_prompt::prompt_ui(ui.ctx(), &f.window.prompts);
    let jog = commands_panel_ui(ui, f);
    // The jog keys work with the command panel folded too.
    super::jog::jog_input(ui.ctx(), f.drive, jog, f.commands);
    egui::CentralPanel::default_margins().show(ui, |ui| central_ui(ui, f));
}

/// The connection bar, the stop strip at its right, and a bus scan's results under them.
fn top_bar_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    egui::Panel::top("connection_bar").show(ui, |ui| {
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            ui.heading("drivedeck");
            if ui
                .small_button("?")
                .on_hover_text("The user guide, in the browser (F1)")
                .clicked()
            {
                f.commands.push(Command::OpenGuide);
            }
            ui.separator();
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                let names: Vec<&str> = f.rows.iter().map(|r| r.name.as_str()).collect();
                let offline = f.drive.offline_reason().unwrap_or_default();
                if let Some(stop) =
                    connection::stop_buttons_ui(ui, f.any_connected, &offline, &names)
                {
                    f.commands.push(Command::StopAll(stop));
                }
                ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                    connection::connection_ui(ui, f.drive, f.commands);
                });
            });
        });
        if f.drive.scan.is_some() {
            ui.separator();
            scan::scan_results_ui(ui, f.drive, f.commands);
        }
        ui.add_space(4.0);
    });
}

/// The log at the bottom: resizable, its height kept with the window's memory between
/// runs; a sixth of the window's height the first time. Its tabs are [`BOTTOM`]'s.
fn log_panel_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    let height = ui.ctx().content_rect().height();
    egui::Panel::bottom("log")
        .resizable(true)
        .default_size((height / 6.0).clamp(90.0, 220.0))
        .min_size(60.0)
        .max_size((height * 0.6).max(120.0))
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.heading("Log");
                for tab in BOTTOM {
                    let title = (tab.title)(f.drive);
                    ui.selectable_value(&mut f.window.bottom, tab.id, title);
                }
                if ui.small_button("Clear").clicked() {
                    f.commands.push(Command::ClearLog(f.window.bottom));
                }
            });
            if let Some(tab) = panel(BOTTOM, f.window.bottom) {
                (tab.ui)(ui, f);
            }
        });
}

/// The status panel: the list of drives and the shown one's state tile as its fixed head,
/// the details scrolling under it.
fn status_panel_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    egui::Panel::left("status")
        .resizable(true)
        .default_size(290.0)
        .show(ui, |ui| {
            ui.add_space(4.0);
            let list = drive_list::ListView {
                rows: f.rows,
                selected: f.selected,
                bar_link: f.drive.settings.connection.spec().ok(),
                project: f.project,
                any_connected: f.any_connected,
            };
            drive_list::drive_list_ui(ui, &list, &mut f.window.list, f.commands);
            ui.separator();
            glance::state_tile_ui(ui, f.drive, f.commands);
            ui.add_space(2.0);
            egui::ScrollArea::vertical()
                .id_salt("status_scroll")
                .show(ui, |ui| status::status_ui(ui, f.drive, f.commands));
        });
}

/// The command panel, or the narrow strip it collapses to (the choice is kept); which jog
/// button is held in it.
fn commands_panel_ui(ui: &mut Ui, f: &mut Frame<'_>) -> i32 {
    let collapsed = &mut f.window.settings.commands_collapsed;
    let mut expanded = !*collapsed;
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
    let drive = &mut *f.drive;
    let commands = &mut *f.commands;
    let mut jog = 0;
    egui::Panel::show_switched(ui, &mut expanded, strip, full, |ui, shown| {
        if shown {
            // The bar always shows: a panel cut off at the bottom says there is more.
            egui::ScrollArea::vertical()
                .id_salt("commands_scroll")
                .scroll_bar_visibility(egui::scroll_area::ScrollBarVisibility::AlwaysVisible)
                .show(ui, |ui| {
                    jog = commands::commands_ui(ui, drive, collapsed, commands);
                });
        } else {
            commands::collapsed_strip_ui(ui, collapsed);
        }
    });
    // Dragged open or shut: that is the choice now (a button set it in the contents).
    if expanded != asked {
        *collapsed = !expanded;
    }
    jog
}

/// The middle: the panel picked in its tabs ([`CENTRAL`]), in all the room the others
/// leave, and the watch panel beside it when shown.
fn central_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    // The tabs scroll sideways where the middle is narrow (the command panel open on a
    // small screen) instead of widening it: a wider middle would push the panels' own
    // buttons under the command panel, out of reach.
    egui::ScrollArea::horizontal()
        .id_salt("central_tabs")
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                for panel in CENTRAL {
                    let title = (panel.title)(f.drive);
                    ui.selectable_value(&mut f.window.settings.central, panel.id.to_owned(), title);
                }
                ui.separator();
                let watched = f.drive.settings.watch.pins.len();
                ui.toggle_value(
                    &mut f.window.settings.watch_open,
                    format!("Watch ({watched})"),
                )
                .on_hover_text(
                    "Objects pinned to be read live, beside the plots and the dictionary",
                );
            });
        });
    ui.separator();
    if f.window.settings.watch_open {
        egui::Panel::right("watch")
            .resizable(true)
            .default_size(270.0)
            .show(ui, |ui| watch::watch_ui(ui, f.drive));
    }
    let central = f.window.settings.central.clone();
    if let Some(panel) = panel(CENTRAL, &central) {
        (panel.ui)(ui, f);
    }
}

/// The plots of the drive shown, the other drives beside it.
fn plots_panel_ui(ui: &mut Ui, f: &mut Frame<'_>) {
    let window = &mut *f.window;
    let mut p = Plots {
        view: &mut window.plot,
        settings: &mut window.settings.plot,
        drive: &mut *f.drive,
        beside: f.beside,
        commands: &mut *f.commands,
    };
    plots::plots_ui(ui, &mut p);
}
