//! The trigger (a status-bit edge or a threshold crossing, with pre- and post-trigger
//! time) and the exports: the triggered recording or the visible window to CSV or JSON
//! with the device's identity and units in the header, and the plots to PNG.

use std::path::{Path, PathBuf};

use eframe::egui::{self, Ui};
use serde::{Deserialize, Serialize};

use super::super::state::AppState;
use super::super::widgets::{choice_ui, message_ui};
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

pub fn capture_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        trigger_ui(ui, state);
    });
    ui.horizontal_wrapped(|ui| {
        export_ui(ui, state);
    });
    message_ui(ui, state.plot.message.as_ref());
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
        match state.settings.plot.trigger.trigger(&state.scope) {
            Ok(trigger) => {
                let text = state.scope.describe_trigger(&trigger);
                state.scope.arm(trigger);
                state.plot.message = Some(Ok(format!("armed: {text}")));
            }
            Err(e) => state.plot.message = Some(Err(e)),
        }
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

/// Where exports go, and the buttons that write them.
fn export_ui(ui: &mut Ui, state: &mut AppState) {
    ui.label("Export to");
    let path_box = ui
        .add(
            egui::TextEdit::singleline(&mut state.settings.plot.export_path)
                .desired_width(220.0)
                .hint_text("file.csv or file.json"),
        )
        .on_hover_text("A path ending in .json writes JSON, anything else CSV; PNG goes beside it");
    crate::ui::widgets::name_widget(&path_box, egui::accesskit::Role::TextInput, "Export path");
    let has_recording = state.scope.recording().is_some();
    if ui
        .add_enabled(has_recording, egui::Button::new("Save recording"))
        .on_hover_text("The triggered recording, every signal")
        .on_disabled_hover_text("Arm the trigger first: a recording comes when it fires")
        .clicked()
    {
        state.plot.message = Some(save_triggered(state));
    }
    if ui
        .button("Export visible")
        .on_hover_text("The time span in view, the signals shown")
        .clicked()
    {
        state.plot.message = Some(export_visible(state));
    }
    if ui
        .button("Save PNG")
        .on_hover_text("A picture of the plots, beside the export file")
        .clicked()
    {
        let png = Path::new(&state.settings.plot.export_path).with_extension("png");
        match target(&png.to_string_lossy())
            .and_then(|path| may_write(&state.plot, &path, Export::Png).map(|()| path))
        {
            Ok(path) => request_png(ui.ctx(), state, path),
            Err(e) => state.plot.message = Some(Err(e)),
        }
    }
}

/// What an export button writes; each remembers the files it wrote this session, so
/// another button does not write over them.
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

/// The export path as typed, made absolute so every message names the full path.
fn target(typed: &str) -> Result<PathBuf, String> {
    if typed.trim().is_empty() {
        return Err("type the file to export to in the box first".into());
    }
    std::path::absolute(typed).map_err(|e| format!("'{typed}' is not a usable path: {e}"))
}

/// Refuse to write over a file another export button wrote this session (Export visible
/// over the recording saved a moment ago, say). The same button writes its file anew.
fn may_write(plot: &super::PlotView, path: &Path, kind: Export) -> Result<(), String> {
    match plot.written.iter().find(|(p, _)| p == path) {
        Some((_, other)) if *other != kind && path.exists() => Err(format!(
            "{} holds {} ({} wrote it this session): {} does not write over it — choose another name",
            path.display(),
            other.what(),
            other.button(),
            kind.button()
        )),
        _ => Ok(()),
    }
}

/// Remember that `kind` wrote `path`.
pub fn note_written(plot: &mut super::PlotView, path: PathBuf, kind: Export) {
    plot.written.retain(|(p, _)| *p != path);
    plot.written.push((path, kind));
}

/// Write `recording` to the export path. A failed write names the full path and the
/// system's reason, and leaves the data where it was, to be saved elsewhere.
fn save(state: &mut AppState, recording: &Recording, kind: Export) -> Result<String, String> {
    if recording.is_empty() {
        return Err("nothing to export: no samples in that span".into());
    }
    let path = target(&state.settings.plot.export_path)?;
    may_write(&state.plot, &path, kind)?;
    let text = path
        .to_str()
        .map_or_else(|| state.settings.plot.export_path.clone(), str::to_owned);
    let message = crate::telemetry::save_recording(recording, &text)
        .map_err(|e| format!("{e}; {}", kind.retry()))?;
    note_written(&mut state.plot, path, kind);
    Ok(message)
}

/// The triggered recording to the export file; it stays in memory whatever happens.
fn save_triggered(state: &mut AppState) -> Result<String, String> {
    let mut recording = state
        .scope
        .recording()
        .cloned()
        .ok_or("no recording yet: arm the trigger, it records when it fires")?;
    recording.set_rates(state.settings.poll_rate);
    save(state, &recording, Export::Recording)
}

/// The visible time span of the shown signals to the export file.
pub fn export_visible(state: &mut AppState) -> Result<String, String> {
    let (from, to) = super::time_range(state).ok_or("nothing recorded yet")?;
    let mut meta = state.scope.meta.clone();
    meta.note = Some("the visible window of the plots".into());
    let mut recording = state.scope.export(from, to, meta, true);
    recording.set_rates(state.settings.poll_rate);
    save(state, &recording, Export::Visible)
}

/// Ask egui for a screenshot; the plots' part of it is written when it arrives.
fn request_png(ctx: &egui::Context, state: &mut AppState, path: PathBuf) {
    let rect = state.plot.plots_rect;
    let result = state.plot.png_result.clone();
    let repaint = ctx.clone();
    let pixels_per_point = ctx.pixels_per_point();
    ctx.send_viewport_cmd(egui::ViewportCommand::Screenshot(
        egui::ScreenshotCallback::new(move |image| {
            // Only the plots, clamped into the picture (`region` panics outside it).
            let whole = egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(image.size[0] as f32, image.size[1] as f32) / pixels_per_point,
            );
            let image = match rect.map(|r| r.intersect(whole.shrink(1.0))) {
                Some(r) if r.is_positive() => image.region(&r, Some(pixels_per_point)),
                _ => (*image).clone(),
            };
            let outcome = save_png(&image, &path);
            if let Ok(mut slot) = result.lock() {
                *slot = Some((path, outcome));
            }
            repaint.request_repaint();
        }),
    ));
    state.plot.message = Some(Ok("taking a picture of the plots…".into()));
}

/// The picture to `path`, a failure said with what to do.
fn save_png(image: &egui::ColorImage, path: &Path) -> Result<String, String> {
    write_png(image, &path.to_string_lossy()).map_err(|e| format!("{e}; {}", Export::Png.retry()))
}

/// An RGBA PNG of `image`.
pub fn write_png(image: &egui::ColorImage, path: &str) -> Result<String, String> {
    let [width, height] = image.size;
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let bytes: Vec<u8> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    encoder
        .write_header()
        .and_then(|mut writer| writer.write_image_data(&bytes))
        .map_err(|e| format!("cannot make the picture for {path}: {e}"))?;
    crate::file::write_whole(Path::new(path), &png_bytes)
        .map_err(|e| format!("cannot write {path}: {e}"))?;
    Ok(format!(
        "saved a {width}x{height} picture of the plots to {path}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_png_that_cannot_be_written_names_the_full_path_and_the_reason() {
        let image = egui::ColorImage::new([4, 3], vec![egui::Color32::RED; 12]);
        let path = target("no-such-dir-for-a-png/plots.png").expect("a path");
        assert!(path.is_absolute());
        let error = save_png(&image, &path).expect_err("no such directory");
        assert_eq!(
            error,
            format!(
                "cannot write {}: No such file or directory (os error 2); the plots are unchanged — choose another place",
                path.display()
            )
        );
        assert!(target("  ").is_err());
    }

    #[test]
    fn a_button_does_not_write_over_the_file_another_one_wrote() {
        let mut plot = super::super::PlotView::default();
        let path = std::env::temp_dir().join(format!("drivedeck-guard-{}.csv", std::process::id()));
        std::fs::write(&path, "recording").expect("temp file");
        note_written(&mut plot, path.clone(), Export::Recording);
        assert_eq!(may_write(&plot, &path, Export::Recording), Ok(()));
        let refused = may_write(&plot, &path, Export::Visible).expect_err("refused");
        assert!(
            refused
                .contains("holds the triggered recording (Save recording wrote it this session)"),
            "{refused}"
        );
        // Gone from the disk (deleted, moved): nothing to protect.
        let _ = std::fs::remove_file(&path);
        assert_eq!(may_write(&plot, &path, Export::Visible), Ok(()));
    }
}
