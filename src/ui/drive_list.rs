//! The list of drives at the head of the status panel: a row per drive (name, state, link,
//! position, motion, fault, project check), the selected one's name editable, "+ Add
//! drive" and the "Project" menu; so the plots and the dictionary lose no room to it.

use eframe::egui::containers::menu::{MenuButton, MenuConfig};
use eframe::egui::{self, Color32, PopupCloseBehavior, RichText, Ui};

use super::command::Command;
use super::drive_row::DriveRow;
use super::glance::tone_color;
use super::plots::drive_color;
use super::project_files::ProjectFiles;
use super::widgets::{AMBER, RED, name_widget, named_text_edit};
use super::window::DriveList;
use crate::link::LinkSpec;

/// Rows of the list shown before it scrolls.
const ROWS_SHOWN: f32 = 4.0;
/// Height of one row (two lines).
const ROW_HEIGHT: f32 = 38.0;
/// More drives than this and each takes one line (the details on hover, and whole in the
/// Machine tab): a 16-axis machine fits a laptop screen.
pub const COMPACT_ABOVE: usize = 4;
/// Compact rows shown before the list scrolls, and their height.
const COMPACT_SHOWN: f32 = 8.0;
const COMPACT_HEIGHT: f32 = 24.0;

/// What the list shows and offers: a row per drive, the one selected, the link the
/// connection bar describes (for "Another on the bar's bus"), and the project's menu.
pub struct ListView<'a> {
    pub rows: &'a [DriveRow],
    pub selected: usize,
    pub bar_link: Option<LinkSpec>,
    pub project: &'a ProjectFiles,
    pub any_connected: bool,
}

/// The list: a row per drive (the selected one's name editable), "+ Add drive" and the
/// project's menu.
pub fn drive_list_ui(
    ui: &mut Ui,
    view: &ListView<'_>,
    list: &mut DriveList,
    commands: &mut Vec<Command>,
) {
    let rows = view.rows;
    let selected = view.selected;
    ui.horizontal(|ui| {
        ui.strong(format!("Drives ({})", rows.len()));
        add_menu_ui(ui, view.bar_link.as_ref(), list, commands);
        project_menu_ui(ui, view.project, view.any_connected, commands);
    });
    project_line_ui(ui, view.project);
    if let Some(message) = &list.message {
        ui.colored_label(RED, message);
    }
    let several = rows.len() > 1;
    let compact = rows.len() > COMPACT_ABOVE;
    let height = if compact {
        COMPACT_SHOWN * COMPACT_HEIGHT
    } else {
        ROWS_SHOWN * ROW_HEIGHT
    };
    egui::ScrollArea::vertical()
        .id_salt("drive_list")
        .max_height(height)
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
                    let at = Row {
                        index: i,
                        chosen,
                        several,
                        compact,
                    };
                    row_ui(ui, list, row, at, commands);
                });
            }
        });
}

/// Where a row stands in the list.
#[derive(Clone, Copy)]
struct Row {
    index: usize,
    /// The drive shown.
    chosen: bool,
    /// More than one drive in the list.
    several: bool,
    /// One line per drive.
    compact: bool,
}

/// One drive: name (editable when selected) and state; link, position and motion under it
/// (on hover only, when the list is compact).
fn row_ui(ui: &mut Ui, list: &mut DriveList, row: &DriveRow, at: Row, commands: &mut Vec<Command>) {
    let Row {
        index,
        chosen,
        several,
        compact,
    } = at;
    ui.horizontal(|ui| {
        if several {
            // The drive's colour, as its lines have it when drives share the plots.
            let (swatch, _) = ui.allocate_exact_size(egui::vec2(4.0, 16.0), egui::Sense::hover());
            ui.painter()
                .rect_filled(swatch, 1.0, drive_color(row.color));
            plot_tick_ui(ui, row, index, chosen, commands);
        }
        if chosen {
            // Typed into a draft: a name half typed may be empty or taken for a moment.
            let mut name = list.name_draft.clone().unwrap_or_else(|| row.name.clone());
            let edit = named_text_edit(ui, &mut name, 110.0, "Drive name");
            if edit.changed() {
                commands.push(Command::Rename(index, name.clone()));
                list.name_draft = Some(name);
            }
            if !edit.has_focus() && list.name_draft.is_some() {
                list.name_draft = None;
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
                commands.push(Command::Select(index));
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
                    commands.push(Command::RemoveDrive(index));
                }
            }
            ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                let state = ui.add(
                    egui::Label::new(
                        RichText::new(&row.state)
                            .strong()
                            .color(tone_color(row.tone)),
                    )
                    .truncate(),
                );
                name_widget(
                    &state,
                    egui::accesskit::Role::Label,
                    &format!("{}: {}", row.name, row.state),
                );
                if compact {
                    let mut words = vec![row.details()];
                    words.extend(row.fault.clone());
                    words.extend(row.check.as_ref().map(|(c, _)| c.clone()));
                    state.on_hover_text(words.join("\n"));
                }
            });
        });
    });
    if compact {
        return;
    }
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
fn add_menu_ui(
    ui: &mut Ui,
    bar_link: Option<&LinkSpec>,
    list: &mut DriveList,
    commands: &mut Vec<Command>,
) {
    // Closed by its buttons or a click outside: a click into the connection string's box
    // must leave it open (egui's default closes a menu on any click inside it).
    let config = MenuConfig::new().close_behavior(PopupCloseBehavior::CloseOnClickOutside);
    MenuButton::new("+ Add drive").config(config).ui(ui, |ui| {
        ui.set_min_width(260.0);
        if ui
            .button("Simulated drive")
            .on_hover_text("A simulated drive of its own (sim://)")
            .clicked()
        {
            commands.push(Command::AddDriveOn(LinkSpec::Sim));
            ui.close();
        }
        if let Some(spec) = bar_link
            && ui
                .button(format!("Another on the bar's bus: {spec}"))
                .on_hover_text(BAR_LINK_HELP)
                .clicked()
        {
            commands.push(Command::AddDriveOn(spec.clone()));
            ui.close();
        }
        ui.separator();
        ui.label("Connection string:");
        ui.horizontal(|ui| {
            let edit = named_text_edit(
                ui,
                &mut list.add_link,
                190.0,
                "New drive's connection string",
            );
            let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Add").clicked() || enter) && !list.add_link.trim().is_empty() {
                commands.push(Command::AddDrive(list.add_link.trim().to_owned()));
                ui.close();
            }
        });
        ui.weak("e.g. modbus-tcp://192.168.2.100:502?unit=0, canopen+sim://?node=2");
    });
}

/// The "Project" menu beside the list's title: open, save, save as; the project's file
/// and the last action's outcome under the list.
fn project_menu_ui(
    ui: &mut Ui,
    project: &ProjectFiles,
    connected: bool,
    commands: &mut Vec<Command>,
) {
    let busy = project.is_asking();
    ui.menu_button("Project", |ui| {
        ui.set_min_width(220.0);
        let open = ui
            .add_enabled(!connected && !busy, egui::Button::new("Open project…"))
            .on_hover_text(
                "The drives, their options, watched objects and the plot layout of a project file",
            )
            .on_disabled_hover_text(
                "Disconnect every drive first: opening a project replaces the drives",
            );
        if open.clicked() {
            commands.push(Command::OpenProject);
            ui.close();
        }
        let save_to = project.path.clone();
        let save = ui
            .add_enabled(!busy, egui::Button::new("Save project"))
            .on_hover_text(match &save_to {
                Some(path) => format!("Write the drives to {}", path.display()),
                None => "Write the drives to a project file (asks where)".into(),
            });
        if save.clicked() {
            commands.push(Command::SaveProject);
            ui.close();
        }
        if ui
            .add_enabled(!busy, egui::Button::new("Save project as…"))
            .clicked()
        {
            commands.push(Command::SaveProjectAs);
            ui.close();
        }
    });
}

/// The project's file and the last open or save, under the list's title.
fn project_line_ui(ui: &mut Ui, project: &ProjectFiles) {
    match &project.message {
        Some(Ok(text)) => {
            ui.add(egui::Label::new(egui::RichText::new(text).small().weak()).wrap());
        }
        Some(Err(text)) => {
            ui.add(egui::Label::new(egui::RichText::new(text).small().color(RED)).wrap());
        }
        None => {}
    }
}

/// The box that draws a drive in the plots beside the drive shown (the shown one is always
/// drawn: its box is ticked and cannot be changed).
fn plot_tick_ui(
    ui: &mut Ui,
    row: &DriveRow,
    index: usize,
    chosen: bool,
    commands: &mut Vec<Command>,
) {
    let mut on = chosen || row.in_plots;
    let tick = ui
        .add_enabled(!chosen, egui::Checkbox::without_text(&mut on))
        .on_hover_text(format!(
            "Draw {}'s signals in the plots beside the drive shown",
            row.name
        ))
        .on_disabled_hover_text("The drive shown: always in the plots");
    name_widget(
        &tick,
        egui::accesskit::Role::CheckBox,
        &format!("Plot {} beside", row.name),
    );
    if tick.changed() {
        commands.push(Command::PlotBeside(index, on));
    }
}
