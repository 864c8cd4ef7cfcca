//! The ways to a recording and back: open one, overlay a second one, dismiss a frozen
//! capture or arm again, close a recording, move the overlay.

use eframe::egui::{self, Ui};

use super::exports::Job;
use super::exports_view::ask;
use super::review::close;
use super::trigger_view::arm;
use super::view::Plots;
use crate::ui::command::{Command, PlotCommand};
use crate::ui::widgets::AMBER;

/// The buttons that open a recording, and overlay one on the recording on screen.
pub fn open_buttons_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    if ui
        .button("Open recording…")
        .on_hover_text("Show a recording saved before (CSV or JSON), with or without a drive")
        .clicked()
    {
        ask(ui.ctx(), p, Job::Open { overlay: false });
    }
    if p.view.review.is_some()
        && ui
            .button("Overlay recording…")
            .on_hover_text("Draw a second recording over this one (before/after a change)")
            .clicked()
    {
        ask(ui.ctx(), p, Job::Open { overlay: true });
    }
}

/// What is on screen instead of the live plots, and the ways back: dismiss the capture
/// or arm again; close the recording; the overlay's alignment.
pub fn review_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    let Some(review) = &mut p.view.review else {
        return;
    };
    let mut close_it = false;
    let mut rearm = false;
    ui.horizontal_wrapped(|ui| {
        if review.capture {
            ui.colored_label(AMBER, egui::RichText::new("Frozen:").strong());
            ui.strong(format!(
                "{}; the live plots go on underneath",
                review.base.title
            ));
            close_it = ui
                .button("Dismiss")
                .on_hover_text("Back to the live plots (the capture stays for Save recording)")
                .clicked();
            rearm = ui
                .button("Re-arm")
                .on_hover_text("Back to the live plots, waiting for the trigger again")
                .clicked();
        } else {
            ui.strong(format!("Recording: {}", review.base.title));
            if let Some(started) = &review.base.scope.meta.started {
                ui.weak(format!("recorded {started}"));
            }
            close_it = ui.button("Close recording").clicked();
        }
    });
    let mut remove = false;
    let mut moved = None;
    if let Some(overlay) = &review.overlay {
        let title = overlay.title.clone();
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("Overlay (dashed): {title}, moved by"));
            let mut offset = review.offset_s;
            let drag = ui.add(
                egui::DragValue::new(&mut offset)
                    .speed(0.001)
                    .suffix(" s")
                    .max_decimals(4),
            );
            if drag.changed() {
                moved = Some(offset);
            }
            crate::ui::widgets::name_widget(
                &drag,
                egui::accesskit::Role::SpinButton,
                "Overlay offset",
            );
            let (offset, how) = review.aligned();
            if ui
                .button("Align")
                .on_hover_text(format!("Lay it on the recording {how}"))
                .clicked()
            {
                moved = Some(offset);
            }
            remove = ui.button("Remove overlay").clicked();
        });
    }
    if remove {
        review.overlay = None;
    }
    if let Some(seconds) = moved {
        p.commands
            .push(Command::Plot(PlotCommand::MoveOverlay(seconds)));
    }
    if rearm {
        arm(p);
    } else if close_it {
        close(p.view);
    }
}
