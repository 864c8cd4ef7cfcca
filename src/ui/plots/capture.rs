//! The trigger (a status-bit edge or a threshold crossing, with pre- and post-trigger
//! time) and the exports: the triggered recording or the visible window to CSV or JSON
//! with the device's identity and units in the header, and the plots to PNG — each to
//! the file picked in the save dialog, a file that exists replaced only when the user
//! says so.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use eframe::egui::{self, Ui};
use serde::{Deserialize, Serialize};

use super::super::state::AppState;
use super::super::widgets::{choice_ui, message_ui};
use super::files::{Answer, Ask, Picked, default_name, open_folder, take};
use crate::telemetry::{
    Builtin, CaptureState, Condition, Edge, Kind, Recording, Trigger, bit_name,
};

/// The trigger as typed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TriggerForm {
    pub threshold: bool,
    /// The signal's id.
    pub signal: String,
    pub bit: u8,
    pub level: String,
    pub edge: Edge,
    pub pre_s: String,
    pub post_s: String,
}

impl Default for TriggerForm {
    fn default() -> Self {
        Self {
            threshold: false,
            signal: Builtin::PdiStatus.id().into(),
            bit: crate::pdi::StatusBit::TargetReached.bit(),
            level: "1000".into(),
            edge: Edge::Rising,
            pre_s: "1".into(),
            post_s: "2".into(),
        }
    }
}

fn edge_text(edge: Edge) -> &'static str {
    match edge {
        Edge::Rising => "rises",
        Edge::Falling => "falls",
        Edge::Either => "changes",
    }
}

impl TriggerForm {
    /// The trigger it describes, or why not.
    pub fn trigger(&self, scope: &crate::telemetry::Scope) -> Result<Trigger, String> {
        let signal = scope
            .signal(&self.signal)
            .ok_or_else(|| format!("no signal '{}' to trigger on", self.signal))?;
        let seconds = |text: &str, what: &str| {
            text.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && (0.0..=3600.0).contains(v))
                .ok_or_else(|| format!("{what} '{text}' is not a time of 0 to 3600 s"))
        };
        let pre_s = seconds(&self.pre_s, "pre-trigger")?;
        let post_s = seconds(&self.post_s, "post-trigger")?;
        let condition = if self.threshold {
            let level = self
                .level
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("level '{}' is not a number", self.level))?;
            Condition::Threshold {
                channel: signal.column,
                level,
                edge: self.edge,
            }
        } else {
            if signal.kind != Kind::Bits {
                return Err(format!(
                    "{} has no bits: pick PDI-Status or the digital inputs, or a threshold",
                    signal.info.name
                ));
            }
            Condition::Bit {
                channel: signal.column,
                bit: self.bit.min(31),
                edge: self.edge,
            }
        };
        Ok(Trigger {
            condition,
            pre_s,
            post_s,
        })
    }
}

pub fn capture_ui(ui: &mut Ui, state: &mut AppState, beside: &[super::Beside<'_>]) {
    // The trigger and the files on one wrapped line: every row of controls comes off
    // the plots' height, which is what a 1366x768 screen has least of.
    ui.horizontal_wrapped(|ui| {
        if state.plot.review.as_ref().is_none_or(|r| r.capture) {
            trigger_ui(ui, state);
            ui.separator();
        }
        export_ui(ui, state, beside);
    });
    ui.horizontal_wrapped(|ui| {
        message_ui(ui, state.plot.message.as_ref());
        let saved = state.plot.saved.clone();
        let said = matches!(&state.plot.message, Some(Ok(text)) if saved.as_ref().is_some_and(|p| text.contains(&*p.to_string_lossy())));
        if let Some(path) = saved.filter(|_| said)
            && ui
                .button("Open folder")
                .on_hover_text("Show the file in the file manager")
                .clicked()
            && let Err(e) = open_folder(&path)
        {
            state.plot.message = Some(Err(e));
        }
    });
}

/// Arm the trigger as typed (a capture frozen on screen goes: the plots run live again,
/// waiting for the next one).
pub fn arm(state: &mut AppState) {
    match state.settings.plot.trigger.trigger(&state.scope) {
        Ok(trigger) => {
            let text = state.scope.describe_trigger(&trigger);
            state.scope.arm(trigger);
            if state.plot.review.as_ref().is_some_and(|r| r.capture) {
                super::review::close(&mut state.plot);
            }
            state.plot.message = Some(Ok(format!("armed: {text}")));
        }
        Err(e) => state.plot.message = Some(Err(e)),
    }
}

/// A signal the trigger may watch: its id, its name, and which built-in it is.
type Candidate = (String, String, Option<Builtin>);

/// The trigger row: the condition, the time around it, Arm or Disarm, and where it stands.
fn trigger_ui(ui: &mut Ui, state: &mut AppState) {
    ui.label("Trigger");
    let form = &mut state.settings.plot.trigger;
    choice_ui(
        ui,
        "trigger_kind",
        "Trigger kind",
        &mut form.threshold,
        &[false, true],
        |threshold| if threshold { "threshold" } else { "status bit" },
        None,
    );
    let wanted = if form.threshold {
        Kind::Analog
    } else {
        Kind::Bits
    };
    let candidates: Vec<Candidate> = state
        .scope
        .signals()
        .iter()
        .filter(|s| s.kind == wanted)
        .map(|s| (s.info.id.clone(), s.info.name.clone(), s.builtin()))
        .collect();
    let builtin = trigger_signal_ui(ui, form, &candidates);
    if form.threshold {
        ui.add(
            egui::TextEdit::singleline(&mut form.level)
                .desired_width(60.0)
                .hint_text("level"),
        )
        .on_hover_text("The level the signal crosses, in its unit");
    } else {
        trigger_bit_ui(ui, form, builtin);
    }
    let edges = [Edge::Rising, Edge::Falling, Edge::Either];
    choice_ui(
        ui,
        "trigger_edge",
        "Trigger edge",
        &mut form.edge,
        &edges,
        edge_text,
        None,
    );
    ui.label("pre [s]");
    ui.add(egui::TextEdit::singleline(&mut form.pre_s).desired_width(36.0))
        .on_hover_text("History kept from before the trigger");
    ui.label("post [s]");
    ui.add(egui::TextEdit::singleline(&mut form.post_s).desired_width(36.0))
        .on_hover_text("Recorded after the trigger");
    arm_ui(ui, state);
}

/// The signal to watch, among `candidates` (the first when the one picked is not among
/// them); which built-in signal it is.
fn trigger_signal_ui(
    ui: &mut Ui,
    form: &mut TriggerForm,
    candidates: &[Candidate],
) -> Option<Builtin> {
    if !candidates.iter().any(|(id, _, _)| *id == form.signal)
        && let Some((id, _, _)) = candidates.first()
    {
        form.signal = id.clone();
    }
    let selected = candidates
        .iter()
        .find(|(id, _, _)| *id == form.signal)
        .map_or_else(String::new, |(_, name, _)| name.clone());
    let combo = egui::ComboBox::from_id_salt("trigger_signal")
        .selected_text(selected)
        .show_ui(ui, |ui| {
            for (id, name, _) in candidates {
                ui.selectable_value(&mut form.signal, id.clone(), name);
            }
        });
    crate::ui::widgets::name_widget(
        &combo.response,
        egui::accesskit::Role::ComboBox,
        "Trigger signal",
    );
    candidates
        .iter()
        .find(|(id, _, _)| *id == form.signal)
        .and_then(|(_, _, b)| *b)
}

/// The bit to watch: PDI-Status's named bits, or any of 32.
fn trigger_bit_ui(ui: &mut Ui, form: &mut TriggerForm, builtin: Option<Builtin>) {
    let bits: Vec<u8> = match builtin {
        Some(Builtin::PdiStatus) => crate::pdi::StatusBit::ALL
            .into_iter()
            .map(|b| b.bit())
            .collect(),
        _ => (0..32).collect(),
    };
    let combo = egui::ComboBox::from_id_salt("trigger_bit")
        .selected_text(bit_name(builtin, form.bit))
        .show_ui(ui, |ui| {
            for bit in bits {
                ui.selectable_value(&mut form.bit, bit, bit_name(builtin, bit));
            }
        });
    crate::ui::widgets::name_widget(
        &combo.response,
        egui::accesskit::Role::ComboBox,
        "Trigger bit",
    );
}

/// Arm the trigger as typed, or disarm it; what the capture is doing.
fn arm_ui(ui: &mut Ui, state: &mut AppState) {
    let capture = state.scope.capture_state();
    let armed = matches!(capture, CaptureState::Armed | CaptureState::Fired { .. });
    if armed {
        if ui.button("Disarm").clicked() {
            state.scope.disarm();
            state.plot.message = Some(Ok("trigger disarmed".into()));
        }
    } else if ui
        .button("Arm")
        .on_hover_text("Wait for the condition, then record the time around it")
        .clicked()
    {
        arm(state);
    }
    match capture {
        CaptureState::Idle => ui.weak("not armed"),
        CaptureState::Armed => ui.strong("armed, waiting"),
        CaptureState::Fired { at } => ui.strong(format!("fired at {at:.3} s, recording")),
        CaptureState::Complete { from, at, to } => {
            ui.label(format!("recorded {:.2} s around {at:.3} s", to - from))
        }
    };
}

/// The buttons that save and export, each through the save dialog.
fn export_ui(ui: &mut Ui, state: &mut AppState, beside: &[super::Beside<'_>]) {
    // Other drives' signals are saved beside the selected drive's, over the same span,
    // while they are drawn with it (live or over a capture; not over a file's recording).
    let beside = if state.plot.review.as_ref().is_none_or(|r| r.capture) {
        beside
    } else {
        &[]
    };
    let has_recording = state.scope.recording().is_some();
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
        match triggered(state) {
            Ok(recording) => {
                let others = others_over(&recording, beside, false);
                ask(ui.ctx(), state, Job::save(Export::Recording, recording).with(others));
            }
            Err(e) => state.plot.message = Some(Err(e)),
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
        match visible(state) {
            Ok(recording) => {
                let others = others_over(&recording, beside, true);
                ask(ui.ctx(), state, Job::save(Export::Visible, recording).with(others));
            }
            Err(e) => state.plot.message = Some(Err(e)),
        }
    }
    if ui
        .button("Save PNG…")
        .on_hover_text(
            "A picture of the whole plot area at the screen's resolution, with a title: \
             the device, the date and the time span",
        )
        .clicked()
    {
        super::picture::request(ui.ctx(), state);
    }
}

/// A dialog's title, the file's part of the proposed name, its extension, and the kinds
/// of file listed (description, extensions).
type Dialog = (
    &'static str,
    &'static str,
    &'static str,
    Vec<(String, Vec<String>)>,
);

/// What a file dialog's answer is for.
#[derive(Clone, Debug)]
pub enum Job {
    /// Write this recording (the triggered one, or the visible window).
    Save {
        kind: Export,
        recording: Arc<Recording>,
        /// The other drives' signals over the same span: each drive's name and its
        /// recording, written beside the file chosen (see [`beside_path`]).
        others: Vec<(String, Arc<Recording>)>,
    },
    /// Write this picture of the plots.
    Png(Arc<egui::ColorImage>),
    /// Open a recording, on its own or over the one on screen.
    Open { overlay: bool },
}

impl Job {
    fn save(kind: Export, recording: Recording) -> Job {
        Job::Save {
            kind,
            recording: Arc::new(recording),
            others: Vec::new(),
        }
    }

    /// This save with the other drives' recordings to write beside it.
    fn with(self, more: Vec<(String, Recording)>) -> Job {
        match self {
            Job::Save {
                kind,
                recording,
                mut others,
            } => {
                others.extend(more.into_iter().map(|(n, r)| (n, Arc::new(r))));
                Job::Save {
                    kind,
                    recording,
                    others,
                }
            }
            job => job,
        }
    }

    /// Every file this job writes at `path`: the chosen one first, then one per other
    /// drive beside it.
    pub fn paths(&self, path: &Path) -> Vec<PathBuf> {
        let mut paths = vec![path.to_path_buf()];
        if let Job::Save { others, .. } = self {
            paths.extend(others.iter().map(|(name, _)| beside_path(path, name)));
        }
        paths
    }

    fn export(&self) -> Option<Export> {
        match self {
            Job::Save { kind, .. } => Some(*kind),
            Job::Png(_) => Some(Export::Png),
            Job::Open { .. } => None,
        }
    }

    /// The dialog's title, the file's part of the proposed name, its extension and the
    /// kinds of file listed.
    fn dialog(&self) -> Dialog {
        let recordings = || {
            vec![
                ("CSV recording".to_owned(), vec!["csv".to_owned()]),
                ("JSON recording".to_owned(), vec!["json".to_owned()]),
            ]
        };
        let any = || {
            (
                "Recording (CSV or JSON)".to_owned(),
                vec!["csv".to_owned(), "json".to_owned()],
            )
        };
        match self {
            Job::Save {
                kind: Export::Visible,
                ..
            } => ("Export the visible window", "visible", "csv", recordings()),
            Job::Save { .. } => (
                "Save the triggered recording",
                "capture",
                "csv",
                recordings(),
            ),
            Job::Png(_) => (
                "Save a picture of the plots",
                "plots",
                "png",
                vec![("PNG picture".to_owned(), vec!["png".to_owned()])],
            ),
            Job::Open { overlay: false } => ("Open a recording", "", "", vec![any()]),
            Job::Open { overlay: true } => ("Overlay a recording", "", "", vec![any()]),
        }
    }
}

/// The device the files are of, for their proposed names: the recording on screen's, or
/// the drive's (1008h).
fn device_name(state: &AppState) -> Option<String> {
    let review = state.plot.review.as_ref().filter(|r| !r.capture);
    match review {
        Some(review) => review.base.scope.meta.device_name.clone(),
        None => state
            .plot
            .identity
            .as_ref()
            .and_then(|i| i.name.clone())
            .or_else(|| state.scope.meta.device_name.clone()),
    }
}

/// Ask the user where `job` goes (or what to open): the dialog runs by itself, `poll`
/// takes its answer.
pub fn ask(ctx: &egui::Context, state: &mut AppState, job: Job) {
    if state.plot.asking.is_some() {
        state.plot.message = Some(Err("a file dialog is open already: finish it first".into()));
        return;
    }
    let (title, what, ext, filters) = job.dialog();
    let dir = &state.settings.plot.export_dir;
    let ask = Ask {
        save: !matches!(job, Job::Open { .. }),
        title: title.into(),
        directory: (!dir.is_empty()).then(|| PathBuf::from(dir)),
        name: if ext.is_empty() {
            String::new()
        } else {
            default_name(
                device_name(state).as_deref(),
                std::time::SystemTime::now(),
                what,
                ext,
            )
        },
        filters,
    };
    let answer = Answer::default();
    state
        .plot
        .files
        .clone()
        .pick(ask, answer.clone(), ctx.clone());
    state.plot.asking = Some((job, answer));
}

/// The dialog's answer, once there: a file to write (a file that exists waits for the
/// user's word), a recording to open, or nothing (cancelled).
pub fn poll(ctx: &egui::Context, state: &mut AppState) {
    let Some(picked) = state.plot.asking.as_ref().and_then(|(_, a)| take(a)) else {
        return;
    };
    let Some((job, _)) = state.plot.asking.take() else {
        return;
    };
    let path = match picked {
        Picked::File(path) => path,
        Picked::Cancelled => {
            state.plot.message = Some(Ok(match job {
                Job::Open { .. } => "no recording opened".into(),
                _ => "cancelled: nothing written".into(),
            }));
            return;
        }
        Picked::NoDialog(why) => {
            state.plot.message = Some(Err(format!("{why}; nothing was written or opened")));
            return;
        }
    };
    let path = std::path::absolute(&path).unwrap_or(path);
    if let Some(dir) = path.parent() {
        state.settings.plot.export_dir = dir.to_string_lossy().into_owned();
    }
    match job {
        Job::Open { overlay } => super::review::load(ctx, state, path, overlay),
        job if job
            .paths(&path)
            .iter()
            .any(|p| std::fs::symlink_metadata(p).is_ok()) =>
        {
            state.plot.confirm = Some((path, job))
        }
        job => write(state, path, &job),
    }
}

/// Write `job` to `path`; a failed write names the full path and the system's reason,
/// and leaves the data where it was, to be saved elsewhere.
fn write(state: &mut AppState, path: PathBuf, job: &Job) {
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
        note_written(&mut state.plot, path.clone(), kind);
        state.plot.saved = Some(path);
    }
    state.plot.message = Some(outcome);
}

/// The question before a file is replaced: what it is (and which button wrote it this
/// session), Replace, another name, or nothing.
pub fn confirm_ui(ctx: &egui::Context, state: &mut AppState) {
    let Some((path, job)) = &state.plot.confirm else {
        return;
    };
    let holds = state
        .plot
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
    let Some((path, job)) = state.plot.confirm.take() else {
        return;
    };
    match choice {
        Confirm::Replace => write(state, path, &job),
        Confirm::Elsewhere => ask(ctx, state, job),
        Confirm::Cancel => {
            state.plot.message = Some(Ok(format!(
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

/// What an export button writes; each remembers the files it wrote this session, so
/// the question before replacing one says what it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Export {
    Recording,
    Visible,
    Png,
}

impl Export {
    pub fn button(self) -> &'static str {
        match self {
            Export::Recording => "Save recording",
            Export::Visible => "Export visible",
            Export::Png => "Save PNG",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Export::Recording => "the triggered recording",
            Export::Visible => "an export of the visible window",
            Export::Png => "the picture of the plots",
        }
    }

    /// What to do after a failed write; nothing was lost.
    fn retry(self) -> &'static str {
        match self {
            Export::Recording => "the recording is still here — choose another place",
            Export::Visible => "the samples are still in the plots — choose another place",
            Export::Png => "the plots are unchanged — choose another place",
        }
    }
}

/// Remember that `kind` wrote `path`.
pub fn note_written(plot: &mut super::PlotView, path: PathBuf, kind: Export) {
    plot.written.retain(|(p, _)| *p != path);
    plot.written.push((path, kind));
}

/// The triggered recording, with the rates in its header; it stays in memory whatever
/// happens to the file.
fn triggered(state: &AppState) -> Result<Recording, String> {
    let mut recording = state
        .scope
        .recording()
        .cloned()
        .ok_or("no recording yet: arm the trigger, it records when it fires")?;
    recording.set_rates(state.settings.poll_rate);
    Ok(recording)
}

/// The other drives' signals over `recording`'s span (only the shown ones when
/// `shown_only`), each with its drive's name; a drive with no sample in the span is left
/// out (its file would be empty), and said so in the saved message by its absence.
fn others_over(
    recording: &Recording,
    beside: &[super::Beside<'_>],
    shown_only: bool,
) -> Vec<(String, Recording)> {
    let (Some(&from), Some(&to)) = (recording.times.first(), recording.times.last()) else {
        return Vec::new();
    };
    beside
        .iter()
        .map(|other| {
            let mut meta = other.scope.meta.clone();
            meta.note = Some(format!(
                "drive \"{}\", over the same span as the file beside it{}",
                other.name,
                meta.note
                    .take()
                    .map(|n| format!("; {n}"))
                    .unwrap_or_default()
            ));
            (
                other.name.to_owned(),
                other.scope.export(from, to, meta, shown_only),
            )
        })
        .filter(|(_, r)| !r.is_empty())
        .collect()
}

/// Where another drive's recording goes beside `path`: the drive's name (letters, digits,
/// `-` and `_`; the rest `_`) added to the file's stem — `…_capture.csv` beside
/// `…_capture_Y_axis.csv`.
pub fn beside_path(path: &Path, drive: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name: String = drive
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let file = match path.extension() {
        Some(ext) => format!("{stem}_{name}.{}", ext.to_string_lossy()),
        None => format!("{stem}_{name}"),
    };
    path.with_file_name(file)
}

/// Write the other drives' recordings beside `path`, and say what was written after
/// `said` (the selected drive's file); a file that cannot be written is said, and the
/// others are still written.
fn save_others(said: String, path: &Path, others: &[(String, Arc<Recording>)]) -> String {
    let mut parts = vec![said];
    for (name, recording) in others {
        let at = beside_path(path, name);
        let text = at.to_string_lossy().into_owned();
        match crate::telemetry::save_recording(recording, &text) {
            Ok(_) => parts.push(format!("{name}'s signals to {text}")),
            Err(e) => parts.push(format!("{name}'s signals NOT saved: {e}")),
        }
    }
    parts.join("; ")
}

/// The visible time span of the shown signals (of the recording on screen, or live).
pub fn visible(state: &AppState) -> Result<Recording, String> {
    let (from, to) = super::time_range(state).ok_or("nothing recorded yet")?;
    let scope = super::shown_scope(state);
    let mut meta = scope.meta.clone();
    let note = "the visible window of the plots";
    meta.note = Some(match (&state.plot.review, meta.note.take()) {
        (Some(_), Some(before)) => format!("{note}; {before}"),
        _ => note.into(),
    });
    let mut recording = scope.export(from, to, meta, true);
    if state.plot.review.is_none() {
        recording.set_rates(state.settings.poll_rate);
    }
    if recording.is_empty() {
        return Err("nothing to export: no samples in that span".into());
    }
    Ok(recording)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_drive_s_file_is_named_after_it_beside_the_one_chosen() {
        let path = Path::new("/data/PD4_2026-12-03_0612_capture.csv");
        assert_eq!(
            beside_path(path, "Y axis"),
            Path::new("/data/PD4_2026-12-03_0612_capture_Y_axis.csv")
        );
        assert_eq!(
            beside_path(Path::new("run.json"), "Z/../../etc"),
            Path::new("run_Z_______etc.json")
        );
        assert_eq!(beside_path(Path::new("bare"), "A"), Path::new("bare_A"));
    }

    #[test]
    fn every_job_proposes_its_own_name_so_the_buttons_never_share_a_file() {
        let recording = || Recording {
            meta: crate::telemetry::Metadata::default(),
            channels: Vec::new(),
            times: Vec::new(),
            columns: Vec::new(),
            markers: Vec::new(),
        };
        let image = Arc::new(egui::ColorImage::new([1, 1], vec![egui::Color32::RED]));
        let names: Vec<(&str, &str)> = [
            Job::save(Export::Recording, recording()),
            Job::save(Export::Visible, recording()),
            Job::Png(image),
        ]
        .iter()
        .map(|job| {
            let (_, what, ext, _) = job.dialog();
            (what, ext)
        })
        .collect();
        assert_eq!(
            names,
            [("capture", "csv"), ("visible", "csv"), ("plots", "png")]
        );
    }
}
