//! The fault timeline in the bottom panel: every fault and warning in order with its
//! meaning, exportable to CSV; "Show" puts the plots at that moment.

use eframe::egui::{self, RichText, Ui};

use super::state::AppState;
use super::widgets::{AMBER, GREEN, RED, named_text_edit};
use crate::diagnostics::Severity;

pub fn faults_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.label("Export to");
        named_text_edit(
            ui,
            &mut state.settings.timeline_path,
            200.0,
            "Timeline file",
        );
        if ui
            .button("Export timeline")
            .on_hover_text("Every entry as CSV: time, wall clock, severity, origin, text")
            .clicked()
        {
            let path = state.settings.timeline_path.clone();
            let message = match crate::file::write_whole(
                std::path::Path::new(&path),
                state.timeline.to_csv(),
            ) {
                Ok(()) => format!("saved {} entries to {path}", state.timeline.len()),
                Err(e) => format!("cannot write {path}: {e}"),
            };
            state.info(message);
        }
        ui.weak("PDI-Status edges, 603Fh, 1001h, 1003h, EMCY, failed commands, link drops");
    });
    let mut show = None;
    egui::ScrollArea::vertical()
        .stick_to_bottom(true)
        .auto_shrink([false, false])
        .show(ui, |ui| {
            egui::Grid::new("timeline_grid")
                .num_columns(5)
                .striped(true)
                .spacing([10.0, 2.0])
                .show(ui, |ui| {
                    if state.timeline.is_empty() {
                        ui.weak("no faults or warnings seen");
                        ui.end_row();
                    }
                    for (i, entry) in state.timeline.entries().enumerate() {
                        match entry.t {
                            Some(t) => {
                                let button = ui
                                    .small_button(format!("{t:9.3}"))
                                    .on_hover_text("Show this moment on the plots");
                                crate::ui::widgets::name_widget(
                                    &button,
                                    egui::accesskit::Role::Button,
                                    &format!("Show entry {}", i + 1),
                                );
                                if button.clicked() {
                                    show = Some(t);
                                }
                            }
                            None => {
                                ui.weak("");
                            }
                        }
                        ui.weak(&entry.wall);
                        let color = match entry.severity {
                            Severity::Fault => RED,
                            Severity::Warning => AMBER,
                            Severity::Info => GREEN,
                        };
                        ui.colored_label(color, RichText::new(entry.severity.name()).strong());
                        ui.monospace(entry.origin.name());
                        ui.label(&entry.text);
                        ui.end_row();
                    }
                });
        });
    if let Some(t) = show {
        state.show_on_plot(t);
    }
}
