//! The exports in view: the buttons that save the triggered recording, export the
//! visible window and take a PNG — each to the file picked in the save dialog, a file that
//! exists replaced only when the user says so.

use std::path::PathBuf;
use std::sync::Arc;

use eframe::egui::{self, Ui};

use super::exports::{Export, Job, note_written, others_over, save_others, triggered, visible};
use super::files::{Answer, Ask, Picked, Wake, default_name, take};
use super::model::PlotView;
use super::spectrum::SpectrumPanel;
use super::spectrum_view::spectrum_window_ui;
use super::view::Plots;

/// The buttons that save and export, each through the save dialog.
pub(super) fn export_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    // Other drives' signals are saved beside the selected drive's, over the same span,
    // while they are drawn with it (live or over a capture; not over a file's recording).
    let beside = if p.view.review.as_ref().is_none_or(|r| r.capture) {
        p.beside
    } else {
        &[]
    };
    let has_recording = p.drive.scope.recording().is_some();
    if ui
        .add_enabled(has_recording, egui::Button::new("Save recording…"))
        .on_hover_text(if beside.is_empty() {
            "The triggered recording, every signal, to CSV or JSON"
        } else {
            "The triggered recording, every signal, to CSV or JSON; every other drive's over the same span, each to a file of its own beside it"
        })
        .on_disabled_hover_text("Arm the trigger first: a recording comes when it fires")
        .clicked()
    {
        match triggered(p.drive) {
            Ok(recording) => {
                let others = others_over(&recording, beside, false);
                ask(ui.ctx(), p, Job::save(Export::Recording, recording).with(others));
            }
            Err(e) => p.view.message = Some(Err(e)),
        }
    }
    if ui
        .button("Export visible…")
        .on_hover_text(if beside.is_empty() {
            "The time span in view, the signals shown, to CSV or JSON"
        } else {
            "The time span in view, the signals shown, to CSV or JSON; every other drive's, each to a file of its own beside it"
        })
        .clicked()
    {
        match visible(p.view, p.drive, p.settings.window_s) {
            Ok(recording) => {
                let others = others_over(&recording, beside, true);
                ask(ui.ctx(), p, Job::save(Export::Visible, recording).with(others));
            }
            Err(e) => p.view.message = Some(Err(e)),
        }
    }
    if ui
        .button("Save PNG…")
        .on_hover_text(
            "A picture of the whole plot area with a title (the device, the date and the \
             time span), at the screen's resolution or up to twice it (Hi-res)",
        )
        .clicked()
    {
        super::picture::request(ui, p);
    }
    let twice = p.settings.picture_scale >= 2.0;
    let toggle = ui
        .add(egui::Button::selectable(twice, "Hi-res"))
        .on_hover_text(
            "Take the PNG at up to twice the screen's resolution: for a moment the plots are \
             drawn alone in the window, as large as it holds them (the message says the size)",
        );
    crate::ui::widgets::name_widget(
        &toggle,
        egui::accesskit::Role::Button,
        "PNG at up to twice the resolution",
    );
    if toggle.clicked() {
        p.settings.picture_scale = if twice { 1.0 } else { 2.0 };
    }
}

/// "Spectrum…" (beside Signals and History, where a small screen still has room) and the
/// spectrum's window while it is open.
pub(super) fn spectrum_ui(ui: &mut Ui, p: &mut Plots<'_>) {
    if ui
        .button("Spectrum…")
        .on_hover_text(
            "The amplitude spectrum of a signal over the time span in view (live or the \
             recording under review) and its strongest peaks: where a resonance rings",
        )
        .clicked()
    {
        match visible(p.view, p.drive, p.settings.window_s) {
            Ok(recording) => p.drive.panels.get::<SpectrumPanel>().open_on(recording),
            Err(e) => p.view.message = Some(Err(e)),
        }
    }
    spectrum_window_ui(ui, p.drive.panels.get::<SpectrumPanel>());
}

/// The device the files are of, for their proposed names: the recording on screen's, or
/// the drive's (1008h).
fn device_name(p: &Plots<'_>) -> Option<String> {
    let review = p.view.review.as_ref().filter(|r| !r.capture);
    match review {
        Some(review) => review.base.scope.meta.device_name.clone(),
        None => p
            .drive
            .link
            .identity
            .as_ref()
            .and_then(|i| i.name.clone())
            .or_else(|| p.drive.scope.meta.device_name.clone()),
    }
}

/// Ask the user where `job` goes (or what to open): the dialog runs by itself, `poll`
/// takes its answer.
pub fn ask(ctx: &egui::Context, p: &mut Plots<'_>, job: Job) {
    if p.view.asking.is_some() {
        p.view.message = Some(Err("a file dialog is open already: finish it first".into()));
        return;
    }
    let (title, what, ext, filters) = job.dialog();
    let dir = &p.settings.export_dir;
    let ask = Ask {
        save: !matches!(job, Job::Open { .. }),
        title: title.into(),
        directory: (!dir.is_empty()).then(|| PathBuf::from(dir)),
        name: if ext.is_empty() {
            String::new()
        } else {
            default_name(
                device_name(p).as_deref(),
                std::time::SystemTime::now(),
                what,
                ext,
            )
        },
        filters,
    };
    let answer = Answer::default();
    p.view.files.clone().pick(ask, answer.clone(), wake(ctx));
    p.view.asking = Some((job, answer));
}

/// A wake-up for the window from a thread (a dialog's answer, a file read).
pub fn wake(ctx: &egui::Context) -> Wake {
    let ctx = ctx.clone();
    Arc::new(move || ctx.request_repaint())
}

/// The dialog's answer, once there: a file to write (a file that exists waits for the
/// user's word), a recording to open, or nothing (cancelled).
pub fn poll(ctx: &egui::Context, p: &mut Plots<'_>) {
    let Some(picked) = p.view.asking.as_ref().and_then(|(_, a)| take(a)) else {
        return;
    };
    let Some((job, _)) = p.view.asking.take() else {
        return;
    };
    let path = match picked {
        Picked::File(path) => path,
        Picked::Cancelled => {
            p.view.message = Some(Ok(match job {
                Job::Open { .. } => "no recording opened".into(),
                _ => "cancelled: nothing written".into(),
            }));
            return;
        }
        Picked::NoDialog(why) => {
            p.view.message = Some(Err(format!("{why}; nothing was written or opened")));
            return;
        }
    };
    let path = std::path::absolute(&path).unwrap_or(path);
    if let Some(dir) = path.parent() {
        p.settings.export_dir = dir.to_string_lossy().into_owned();
    }
    match job {
        Job::Open { overlay } => super::review::load(p.view, wake(ctx), path, overlay),
        job if job
            .paths(&path)
            .iter()
            .any(|p| std::fs::symlink_metadata(p).is_ok()) =>
        {
            p.view.confirm = Some((path, job))
        }
        job => write(p.view, path, &job),
    }
}

/// Write `job` to `path`; a failed write names the full path and the system's reason,
/// and leaves the data where it was, to be saved elsewhere.
fn write(view: &mut PlotView, path: PathBuf, job: &Job) {
    let Some(kind) = job.export() else {
        return;
    };
    let text = path.to_string_lossy().into_owned();
    let outcome = match job {
        Job::Save {
            recording, others, ..
        } => crate::telemetry::save_recording(recording, &text)
            .map(|said| save_others(said, &path, others)),
        Job::Png(image) => super::picture::write_png(image, &text),
        Job::Open { .. } => return,
    }
    .map_err(|e| format!("{e}; {}", kind.retry()));
    if outcome.is_ok() {
        note_written(view, path.clone(), kind);
        view.saved = Some(path);
    }
    view.message = Some(outcome);
}

/// The question before a file is replaced: what it is (and which button wrote it this
/// session), Replace, another name, or nothing.
pub fn confirm_ui(ctx: &egui::Context, p: &mut Plots<'_>) {
    let Some((path, job)) = &p.view.confirm else {
        return;
    };
    let holds = p
        .view
        .written
        .iter()
        .find(|(p, _)| p == path)
        .map(|(_, other)| {
            format!(
                " It holds {} ({} wrote it this session).",
                other.what(),
                other.button()
            )
        })
        .unwrap_or_default();
    let existing: Vec<String> = job
        .paths(path)
        .into_iter()
        .filter(|p| std::fs::symlink_metadata(p).is_ok())
        .map(|p| p.display().to_string())
        .collect();
    let text = match existing.as_slice() {
        [one] => format!("{one} exists already.{holds}"),
        many => format!("These exist already: {}.{holds}", many.join(", ")),
    };
    let what = job.export().map_or("it", Export::what);
    let mut choice = None;
    let modal = egui::Modal::new(egui::Id::unique("plots_replace_file")).show(ctx, |ui| {
        ui.set_max_width(520.0);
        ui.heading("Replace the file?");
        ui.label(text);
        ui.label(format!(
            "Replacing it writes {what} in its place; the old file is gone."
        ));
        ui.horizontal(|ui| {
            if ui.button("Replace").clicked() {
                choice = Some(Confirm::Replace);
            }
            if ui.button("Choose another name…").clicked() {
                choice = Some(Confirm::Elsewhere);
            }
            if ui.button("Cancel").clicked() {
                choice = Some(Confirm::Cancel);
            }
        });
    });
    if modal.should_close() && choice.is_none() {
        choice = Some(Confirm::Cancel);
    }
    let Some(choice) = choice else {
        return;
    };
    let Some((path, job)) = p.view.confirm.take() else {
        return;
    };
    match choice {
        Confirm::Replace => write(p.view, path, &job),
        Confirm::Elsewhere => ask(ctx, p, job),
        Confirm::Cancel => {
            p.view.message = Some(Ok(format!(
                "nothing written: {} kept as it was",
                path.display()
            )))
        }
    }
}

enum Confirm {
    Replace,
    Elsewhere,
    Cancel,
}
