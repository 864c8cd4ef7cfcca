//! The fault timeline in the bottom panel: every fault and warning in order with its
//! meaning, exportable to CSV; "Show" puts the plots at that moment.

use eframe::egui::{self, RichText, Ui};

use super::command::Command;
use super::drive::Drive;
use super::plots::PlotCommand;
use super::widgets::{AMBER, GREEN, RED, labelled_text_edit_ui, log_grid_ui};
use crate::diagnostics::{Entry as TimelineEntry, Severity};

/// The id of the log's tab of faults.
pub const FAULTS: &str = "faults";

pub fn faults_ui(ui: &mut Ui, drive: &mut Drive, file: &mut String, commands: &mut Vec<Command>) {
    ui.horizontal(|ui| {
        labelled_text_edit_ui(ui, "Export to", file, 200.0, "Timeline file");
        if ui
            .button("Export timeline")
            .on_hover_text("Every entry as CSV: time, wall clock, severity, origin, text")
            .clicked()
        {
            let path = file.clone();
            let message = match crate::file::write_whole(
                std::path::Path::new(&path),
                drive.timeline.to_csv(),
            ) {
                Ok(()) => format!("saved {} entries to {path}", drive.timeline.len()),
                Err(e) => format!("cannot write {path}: {e}"),
            };
            drive.info(message);
        }
        ui.weak("PDI-Status edges, 603Fh, 1001h, 1003h, EMCY, failed commands, link drops");
    });
    let mut show = None;
    log_grid_ui(ui, "timeline_grid", 5, |ui| {
        if drive.timeline.is_empty() {
            ui.weak("no faults or warnings seen");
            ui.end_row();
        }
        for (i, entry) in drive.timeline.entries().enumerate() {
            if let Some(t) = entry_time_ui(ui, i, entry) {
                show = Some(t);
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
    if let Some(t) = show {
        commands.push(Command::Plot(PlotCommand::ShowMoment(t)));
    }
}

/// The entry's time on the plots' axis, as a button that shows that moment there: the
/// time when it is clicked.
fn entry_time_ui(ui: &mut Ui, i: usize, entry: &TimelineEntry) -> Option<f64> {
    let Some(t) = entry.t else {
        ui.weak("");
        return None;
    };
    let button = ui
        .small_button(format!("{t:9.3}"))
        .on_hover_text("Show this moment on the plots");
    crate::ui::widgets::name_widget(
        &button,
        egui::accesskit::Role::Button,
        &format!("Show entry {}", i + 1),
    );
    button.clicked().then_some(t)
}
