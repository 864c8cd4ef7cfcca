//! The row under the plots: the trigger (`trigger_view`) and the files (`exports_view`)
//! on one wrapped line, and the message of the last of them.

use eframe::egui::Ui;

use super::exports_view::export_ui;
use super::files::open_folder;
use super::trigger_view::trigger_ui;
use super::view::Plots;
use crate::ui::widgets::message_ui;

pub fn capture_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    // The trigger and the files on one wrapped line: every row of controls comes off
    // the plots' height, which is what a 1366x768 screen has least of.
    ui.horizontal_wrapped(|ui| {
        if p.view.review.as_ref().is_none_or(|r| r.capture) {
            trigger_ui(ui, p);
            ui.separator();
        }
        export_ui(ui, p);
    });
    ui.horizontal_wrapped(|ui| {
        message_ui(ui, p.view.message.as_ref());
        let saved = p.view.saved.clone();
        let said = matches!(&p.view.message, Some(Ok(text)) if saved.as_ref().is_some_and(|p| text.contains(&*p.to_string_lossy())));
        if let Some(path) = saved.filter(|_| said)
            && ui
                .button("Open folder")
                .on_hover_text("Show the file in the file manager")
                .clicked()
            && let Err(e) = open_folder(&path)
        {
            p.view.message = Some(Err(e));
        }
    });
}
