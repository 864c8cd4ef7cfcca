//! The Procedure tab: a procedure file loaded and checked, run on the drive shown with its
//! steps' verdicts and figures as they come, the operator's questions with Yes and No,
//! Abort (and Esc), and where the record went.

use eframe::egui::{self, RichText, Ui};

use super::model::ProcedurePanel;
use crate::procedure::Verdict;
use crate::procedure::runner::{DriveSetup, Prompt};
use crate::ui::drive::Drive;
use crate::ui::widgets::{AMBER, GREEN, RED, message_ui, named_text_edit};

/// The id of the Procedure tab.
pub const PROCEDURE: &str = "procedure";

enum Intent {
    Load,
    Start,
    Answer(bool),
    Abort(&'static str),
    OpenRecord(std::path::PathBuf),
}

/// What the project and the connection say of the drive, for a run.
fn setup_of(drive: &Drive) -> (DriveSetup, String) {
    let spec = drive.settings.connection.spec().ok();
    let link = spec
        .as_ref()
        .map_or_else(|| "?".to_owned(), ToString::to_string);
    let saved = drive.project.drive.as_ref();
    let setup = DriveSetup {
        name: drive.name.clone(),
        link: link.clone(),
        expected: saved.and_then(|d| d.identity.clone()),
        baseline: saved.and_then(|d| d.backup.clone()),
        backups: Default::default(),
        // The built-in simulated drive has no switch to press: its inputs are forced.
        rehearsal: spec == Some(crate::link::LinkSpec::Sim),
        // The drive's own rule for a lost link is what an aborted run leaves it in.
        on_abort: drive.settings.on_link_loss,
    };
    (setup, format!("{} on {link} (window)", drive.name))
}

fn verdict_color(ui: &Ui, v: Verdict) -> egui::Color32 {
    match v {
        Verdict::Passed => GREEN,
        Verdict::Failed => RED,
        Verdict::Aborted => AMBER,
        Verdict::Skipped => ui.visuals().weak_text_color(),
    }
}

pub fn procedure_ui(ui: &mut Ui, drive: &mut Drive) {
    let (setup, machine) = setup_of(drive);
    let panel = drive.panels.get::<ProcedurePanel>();
    let mut intents = vec![];
    if panel.is_running() && ui.input(|i| i.key_pressed(egui::Key::Escape)) {
        intents.push(Intent::Abort("Esc pressed (quick stop)"));
    }
    ui.horizontal(|ui| {
        ui.label("Procedure");
        let typed = named_text_edit(ui, &mut panel.path, 300.0, "Procedure file");
        let enter = typed.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if ui
            .add_enabled(!panel.is_running(), egui::Button::new("Load"))
            .on_hover_text("Read and check the file: a bad one is refused with its line")
            .clicked()
            || enter
        {
            intents.push(Intent::Load);
        }
    });
    ui.horizontal_wrapped(|ui| {
        ui.label("Record");
        named_text_edit(ui, &mut panel.record_path, 220.0, "Record file");
        ui.label("Operator");
        named_text_edit(ui, &mut panel.operator, 120.0, "Operator");
    });
    ui.horizontal_wrapped(|ui| {
        let can_run = panel.procedure.is_some() && panel.is_connected() && !panel.is_running();
        let run = ui
            .add_enabled(
                can_run,
                egui::Button::new(RichText::new(format!("Run on {}", setup.name)).strong()),
            )
            .on_disabled_hover_text(if panel.procedure.is_none() {
                "load a procedure first"
            } else if !panel.is_connected() {
                "not connected"
            } else {
                "a run is under way"
            });
        if run.clicked() {
            intents.push(Intent::Start);
        }
        if ui
            .add_enabled(panel.is_running(), egui::Button::new("Abort"))
            .on_hover_text(
                "Halt the drive and end the run; the record says it was aborted (Esc too)",
            )
            .clicked()
        {
            intents.push(Intent::Abort("aborted by the operator"));
        }
        if let Some(page) = panel.written.clone().filter(|_| !panel.is_running())
            && ui
                .button("Open record")
                .on_hover_text(format!("{} in the browser", page.display()))
                .clicked()
        {
            intents.push(Intent::OpenRecord(page));
        }
        if let Some(progress) = panel.run().and_then(|r| r.progress()) {
            ui.spinner();
            ui.weak(progress);
        }
        if setup.rehearsal {
            ui.weak("simulated drive: a rehearsal (inputs forced, identity not compared)");
        }
    });
    message_ui(ui, panel.message.as_ref());
    match panel.prompt().cloned() {
        Some(Prompt::Question(q)) => {
            ui.horizontal_wrapped(|ui| {
                ui.label(RichText::new(q).strong().color(AMBER));
                if ui.button("Yes").clicked() {
                    intents.push(Intent::Answer(true));
                }
                if ui.button("No").clicked() {
                    intents.push(Intent::Answer(false));
                }
            });
        }
        Some(Prompt::Action(text)) => {
            ui.label(RichText::new(text).strong().color(AMBER));
        }
        None => {}
    }
    ui.separator();
    egui::ScrollArea::vertical()
        .id_salt("procedure_steps")
        .auto_shrink([false, false])
        .show(ui, |ui| steps_ui(ui, panel));
    for intent in intents {
        match intent {
            Intent::Load => panel.load(),
            Intent::Start => panel.start(setup.clone(), machine.clone()),
            Intent::Answer(yes) => panel.answer(yes),
            Intent::OpenRecord(page) => {
                if let Err(why) = crate::ui::plots::files::open_with_system(&page) {
                    panel.message = Some(Err(format!("the record could not be opened: {why}")));
                }
            }
            Intent::Abort(why) => panel.abort(why),
        }
    }
}

fn steps_ui(ui: &mut Ui, panel: &ProcedurePanel) {
    let Some(procedure) = panel.procedure.as_ref() else {
        ui.add(
            egui::Label::new(
                RichText::new(
                    "Load a procedure file (TOML): ordered steps with limits. The guide's page \
                     \"Procedures and records\" describes the file (docs/guide/ in the source, \
                     /usr/share/doc/drivedeck/guide/ where the package is installed); an \
                     example is in assets/procedures/ (/usr/share/doc/drivedeck/examples/).",
                )
                .weak(),
            )
            .wrap(),
        );
        return;
    };
    ui.strong(&procedure.name);
    if !procedure.description.is_empty() {
        ui.weak(&procedure.description);
    }
    let done = panel.run().map(|r| r.steps.as_slice()).unwrap_or_default();
    // Long titles and notes wrap inside the tab rather than widen it.
    let title_width = 240.0;
    let details_width = (ui.available_width() - title_width - 130.0).max(200.0);
    let wrapped = |ui: &mut Ui, text: &str, width: f32| {
        ui.scope(|ui| {
            ui.set_max_width(width);
            ui.add(egui::Label::new(text).wrap());
        });
    };
    let current = panel.run().and_then(|r| r.current());
    egui::Grid::new("procedure_grid")
        .striped(true)
        .num_columns(4)
        .show(ui, |ui| {
            ui.strong("#");
            ui.strong("Step");
            ui.strong("Verdict");
            ui.strong("Measured, limit, note");
            ui.end_row();
            for (i, step) in procedure.steps.iter().enumerate() {
                ui.label(format!("{}", i + 1));
                wrapped(ui, &step.title, title_width);
                match done.get(i) {
                    Some(record) => {
                        ui.label(
                            RichText::new(record.verdict.word())
                                .strong()
                                .color(verdict_color(ui, record.verdict)),
                        );
                        let mut lines: Vec<String> = record
                            .figures
                            .iter()
                            .map(|f| match &f.limit {
                                Some(l) => format!("{} {} (limit {l})", f.name, f.shown()),
                                None => format!("{} {}", f.name, f.shown()),
                            })
                            .collect();
                        lines.push(record.note.clone());
                        wrapped(ui, &lines.join("\n"), details_width);
                    }
                    None if current == Some(i) && panel.is_running() => {
                        ui.label(RichText::new("under way").color(AMBER));
                        ui.label("");
                    }
                    None => {
                        ui.weak("waiting");
                        ui.label("");
                    }
                }
                ui.end_row();
            }
        });
}
