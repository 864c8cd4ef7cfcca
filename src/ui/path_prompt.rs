//! The window's own path field for an open or save no system dialog could show (no
//! desktop portal, no zenity): what was asked, why the system could not show it, the path
//! as a text box (the folder and proposed name filled in), and Save/Open or Cancel. The
//! answer goes where the dialog's would have (see `plots::files::PromptingPicker`).

use eframe::egui::{self, RichText};

use super::plots::files::Prompts;
use super::widgets::{AMBER, named_text_edit};

/// What the user did with the prompt shown.
enum Said {
    Pick,
    Cancel,
}

/// The oldest prompt waiting, as a modal window.
pub fn prompt_ui(ctx: &egui::Context, prompts: &Prompts) {
    let Ok(mut waiting) = prompts.lock() else {
        return;
    };
    let Some(prompt) = waiting.front_mut() else {
        return;
    };
    let verb = if prompt.ask.save { "Save" } else { "Open" };
    let mut said = None;
    egui::Modal::new(egui::Id::unique("path_prompt")).show(ctx, |ui| {
        ui.set_max_width(560.0);
        ui.heading(&prompt.ask.title);
        ui.add(
            egui::Label::new(
                RichText::new(format!(
                    "{}. Type the file's path instead.",
                    prompt.why.trim_end_matches('.')
                ))
                .color(AMBER),
            )
            .wrap(),
        );
        ui.add_space(4.0);
        let edit = named_text_edit(ui, &mut prompt.text, 520.0, "File path");
        if !edit.has_focus() && prompt.text.is_empty() {
            edit.request_focus();
        }
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            let typed = !prompt.text.trim().is_empty();
            if ui.add_enabled(typed, egui::Button::new(verb)).clicked() || (enter && typed) {
                said = Some(Said::Pick);
            }
            if ui.button("Cancel").clicked() || ui.input(|i| i.key_pressed(egui::Key::Escape)) {
                said = Some(Said::Cancel);
            }
        });
    });
    let Some(said) = said else {
        return;
    };
    let Some(prompt) = waiting.pop_front() else {
        return;
    };
    drop(waiting);
    match said {
        Said::Pick => {
            prompt.pick();
        }
        Said::Cancel => prompt.cancel(),
    }
}
