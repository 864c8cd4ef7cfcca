//! The Machine tab: every drive on one line (name, state, position, velocity, fault,
//! link), sortable by any column, a click on a name shows that drive, the box beside it
//! draws it in the plots. Sixteen drives fit a 1366×768 screen.

use eframe::egui::{self, RichText, Ui};

use super::command::Command;
use super::drive_row::DriveRow;
use super::glance::tone_color;
use super::machine_table::{Column, MachineSort};
use super::plots::drive_color;
use super::widgets::{RED, name_widget};

/// The id of the Machine tab.
pub const MACHINE: &str = "machine";

/// The overview of `rows` (`selected` the drive shown), sorted as `sort` says.
pub fn machine_ui(
    ui: &mut Ui,
    rows: &[DriveRow],
    selected: usize,
    sort: &mut MachineSort,
    commands: &mut Vec<Command>,
) {
    let order = sort.order(rows);
    egui::ScrollArea::both()
        .id_salt("machine_scroll")
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("machine")
                .num_columns(Column::ALL.len() + 1)
                .striped(true)
                .spacing([14.0, 4.0])
                .show(ui, |ui| {
                    ui.label("Plot");
                    for column in Column::ALL {
                        let arrow = match (sort.by == column, sort.descending) {
                            (true, false) => " ▲",
                            (true, true) => " ▼",
                            (false, _) => "",
                        };
                        let title = ui
                            .add(
                                egui::Button::new(
                                    RichText::new(format!("{}{arrow}", column.title())).strong(),
                                )
                                .frame(false),
                            )
                            .on_hover_text("Sort by this column; again to turn the order round");
                        name_widget(
                            &title,
                            egui::accesskit::Role::Button,
                            &format!("Sort by {}", column.title()),
                        );
                        if title.clicked() {
                            sort.click(column);
                        }
                    }
                    ui.end_row();
                    for index in order {
                        let Some(row) = rows.get(index) else {
                            continue;
                        };
                        let shown = index == selected;
                        let mut on = shown || row.in_plots;
                        let tick = ui
                            .add_enabled(!shown, egui::Checkbox::without_text(&mut on))
                            .on_hover_text("Draw this drive in the plots beside the one shown");
                        if tick.changed() {
                            commands.push(Command::PlotBeside(index, on));
                        }
                        ui.horizontal(|ui| {
                            let (swatch, _) =
                                ui.allocate_exact_size(egui::vec2(4.0, 14.0), egui::Sense::hover());
                            ui.painter()
                                .rect_filled(swatch, 1.0, drive_color(row.color));
                            let name = ui
                                .selectable_label(shown, &row.name)
                                .on_hover_text("Show this drive in the panels");
                            name_widget(
                                &name,
                                egui::accesskit::Role::Button,
                                &format!("Show {}", row.name),
                            );
                            if name.clicked() {
                                commands.push(Command::Select(index));
                            }
                        });
                        ui.colored_label(tone_color(row.tone), &row.state);
                        ui.monospace(row.position.as_deref().unwrap_or("–"));
                        ui.monospace(match row.velocity {
                            Some(v) => format!("{v:+.0} rpm"),
                            None => "–".to_owned(),
                        });
                        match &row.fault {
                            Some(fault) => ui.colored_label(RED, fault),
                            None => ui.weak("none"),
                        };
                        ui.weak(&row.link);
                        ui.end_row();
                    }
                });
        });
}
