//! Leaving a drive safely, the question: on Disconnect (or closing the window) with the
//! power stage on or objects changed, the window asks what to leave behind — halt (the
//! default), switch off, or leave it on — and offers to restore what the tool changed
//! first; once for every drive that needs it. What follows the answer (stop, restore,
//! disconnect) is the drive's (`ui::drive`'s leaving).

use eframe::egui::{self, RichText, Ui};

use super::drive::{Drive, StopChoice, age_text};
use super::glance::motion_words;
use super::widgets::{AMBER, RED};

/// What the motor does, for the question: "The power stage is on: the motor is moving
/// at 300 rpm."; `None` while the power stage is off.
pub fn motor_sentence(drive: &Drive) -> Option<String> {
    if !drive.power_stage_on() {
        return None;
    }
    let motion = drive.latest().map(|s| motion_words(&s)).unwrap_or_default();
    let now = std::time::SystemTime::now();
    Some(
        match drive.link.sample_age(now).filter(|_| !drive.is_live(now)) {
            Some(age) => format!(
                "The power stage was on ({}): the motor was {motion}.",
                age_text(age)
            ),
            None => format!("The power stage is on: the motor is {motion}."),
        },
    )
}

/// The user's answer to the question.
enum Answer {
    Stop(StopChoice),
    Cancel,
}

/// How the question ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answered {
    /// A stop was chosen: every drive asked is on its way out.
    Going,
    Cancelled,
}

/// The question, while it is asked, once for every drive that waits for it (closing the
/// window with several drives energised asks once for all of them).
pub fn leave_dialog(ctx: &egui::Context, drives: &mut [&mut Drive]) -> Option<Answered> {
    let several = drives.len() > 1;
    let asked: Vec<usize> = (0..drives.len())
        .filter(|&i| drives[i].is_asked_to_leave())
        .collect();
    let first = drives.get(*asked.first()?)?;
    let leaving = first.leaving?;
    let mut restore = leaving.restore;
    let answer = {
        let shown: Vec<&Drive> = asked.iter().map(|&i| &*drives[i]).collect();
        egui::Modal::new(egui::Id::unique("leave_dialog"))
            .show(ctx, |ui: &mut Ui| {
                leave_question_ui(ui, &shown, several, leaving.close_window, &mut restore)
            })
            .inner
    };
    for &i in &asked {
        let drive = &mut *drives[i];
        if let Some(l) = drive.leaving.as_mut() {
            l.restore = restore;
        }
        match answer {
            Some(Answer::Cancel) => drive.leaving = None,
            Some(Answer::Stop(stop)) => drive.confirm_leave(stop, restore),
            None => {}
        }
    }
    match answer {
        Some(Answer::Cancel) => Some(Answered::Cancelled),
        Some(Answer::Stop(_)) => Some(Answered::Going),
        None => None,
    }
}

/// The dialog's content: what each motor asked about does, restore or not, and the three
/// ways to go. With `several` drives in the window, each sentence names its drive.
fn leave_question_ui(
    ui: &mut Ui,
    drives: &[&Drive],
    several: bool,
    close_window: bool,
    restore: &mut bool,
) -> Option<Answer> {
    let mut answer = None;
    ui.set_max_width(460.0);
    let heading = match (close_window, drives) {
        (true, _) => "Close drivedeck".to_owned(),
        (false, [drive]) if several => format!("Disconnect {}", drive.name),
        (false, _) => "Disconnect".to_owned(),
    };
    ui.heading(heading);
    let mut energised = false;
    for drive in drives {
        if let Some(sentence) = motor_sentence(drive) {
            energised = true;
            ui.colored_label(
                AMBER,
                if several {
                    format!("{}: {sentence}", drive.name)
                } else {
                    sentence
                },
            );
        }
    }
    for drive in drives {
        for held in drive.panels.holding() {
            let line = format!("{held}: it is given back to the drive first, whatever you choose.");
            ui.colored_label(
                AMBER,
                if several {
                    format!("{}: {line}", drive.name)
                } else {
                    line
                },
            );
        }
    }
    if energised {
        ui.label("What should stay behind?");
    }
    let restorable: usize = drives.iter().map(|d| d.restorable()).sum();
    let with_changes = drives.iter().filter(|d| d.restorable() > 0).count();
    if restorable > 0 {
        let on = if with_changes > 1 {
            format!(" on {with_changes} drives")
        } else {
            String::new()
        };
        ui.checkbox(
            restore,
            format!("First restore what I changed ({restorable} objects{on}, newest first)"),
        );
    }
    let each = if drives.len() > 1 { " each" } else { "" };
    ui.add_space(6.0);
    ui.horizontal(|ui| {
        let halt = ui.button(RichText::new(format!("Halt{each}, then disconnect")).strong());
        ui.weak("Enter presses this button");
        // Enter takes the default.
        if halt.clicked() || ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            answer = Some(Answer::Stop(StopChoice::Halt));
        }
    });
    if ui
        .button(RichText::new(format!("Switch off{each}, then disconnect")).color(RED))
        .on_hover_text("Power stage off: the motor coasts and holds no torque")
        .clicked()
    {
        answer = Some(Answer::Stop(StopChoice::SwitchOff));
    }
    if ui
        .button("Leave it as it is, disconnect")
        .on_hover_text("The drive keeps doing what it does")
        .clicked()
    {
        answer = Some(Answer::Stop(StopChoice::LeaveOn));
    }
    ui.separator();
    if ui.button("Cancel").clicked() {
        answer = Some(Answer::Cancel);
    }
    answer
}
