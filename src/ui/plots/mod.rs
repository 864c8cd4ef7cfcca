//! The plot panel: stacked plots of the sampled signals on one time axis, the status bits
//! as digital lanes, command markers, a cursor read-out, pause, follow, zoom and pan; the
//! trigger and the exports live in `capture`.

mod capture;
mod traces;

use std::sync::{Arc, Mutex};

use eframe::egui::{self, Rect, Ui};
use serde::{Deserialize, Serialize};

use super::state::AppState;
use crate::od::backup::DeviceIdentity;
use crate::telemetry::{DEFAULT_HISTORY_ROWS, Kind, WatchedObject};

pub use capture::{Export, TriggerForm};

/// Where the PNG writer puts its outcome for the next frame: the path and the message.
pub type PngResult = Arc<Mutex<Option<(std::path::PathBuf, Result<String, String>)>>>;

/// What the plot panel remembers between runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlotSettings {
    /// Seconds shown while following the newest samples; 0 shows the whole history.
    pub window_s: f64,
    /// Samples kept per signal.
    pub history_rows: usize,
    /// Where exports go (`.json` writes JSON, anything else CSV; PNG beside it).
    pub export_path: String,
    pub trigger: TriggerForm,
    /// The ids of the signals drawn.
    pub shown: Vec<String>,
}

impl Default for PlotSettings {
    fn default() -> Self {
        Self {
            window_s: 10.0,
            history_rows: DEFAULT_HISTORY_ROWS,
            export_path: "drivedeck-recording.csv".into(),
            trigger: TriggerForm::default(),
            shown: Vec::new(),
        }
    }
}

/// The plot panel's state in this run.
#[derive(Clone, Debug)]
pub struct PlotView {
    /// The plots are frozen at this time (recording goes on).
    pub paused_at: Option<f64>,
    /// The time axis follows the newest sample; zooming or panning turns it off.
    pub follow: bool,
    /// Where the pointer is on the time axis, over any plot.
    pub cursor: Option<f64>,
    /// A moment to mark (a timeline entry shown on the plots).
    pub highlight: Option<f64>,
    /// The time range drawn in the last frame.
    pub shown_range: Option<(f64, f64)>,
    /// The outcome of the last export or trigger action.
    pub message: Option<Result<String, String>>,
    /// The device identity, read on connect for the exports' header.
    pub identity: Option<DeviceIdentity>,
    /// The objects plotted besides the built-in signals, and the address being typed.
    pub watched: Vec<(WatchedObject, crate::od::DataType)>,
    pub watch_text: String,
    /// The history size being typed.
    pub rows_text: String,
    /// Where the plots were drawn (for the PNG export).
    pub plots_rect: Option<Rect>,
    /// What the PNG writer reported (it runs when the screenshot arrives), and where.
    pub png_result: PngResult,
    /// The files the export buttons wrote this session, and which button (the newest
    /// writer of each path).
    pub written: Vec<(std::path::PathBuf, Export)>,
}

impl Default for PlotView {
    fn default() -> Self {
        Self {
            paused_at: None,
            follow: true,
            cursor: None,
            shown_range: None,
            highlight: None,
            message: None,
            identity: None,
            watched: Vec::new(),
            watch_text: String::new(),
            rows_text: String::new(),
            plots_rect: None,
            png_result: Arc::default(),
            written: Vec::new(),
        }
    }
}

impl PlotView {
    pub fn is_paused(&self) -> bool {
        self.paused_at.is_some()
    }
}

/// The time span to draw: the newest `window_s` seconds (or the whole history) up to the
/// newest sample or the pause, while following; what the user zoomed to otherwise.
pub fn time_range(state: &AppState) -> Option<(f64, f64)> {
    let ring = state.scope.ring();
    let first = ring.first_time()?;
    let end = state.plot.paused_at.or_else(|| live_end(state))?;
    if !state.plot.follow
        && let Some(range) = state.plot.shown_range
    {
        return Some(range);
    }
    let window = state.settings.plot.window_s;
    let start = if window > 0.0 { end - window } else { first };
    Some((start.min(end - 0.001), end.max(start + 0.001)))
}

/// The newest moment on the samples' clock: the newest sample's time, or while the link
/// is lost, later by the wall-clock time since that sample came, so an outage grows in
/// view as it lasts.
pub fn live_end(state: &AppState) -> Option<f64> {
    let last = state.scope.ring().last_time()?;
    let lost = state.scope.open_gap().filter(|gap| gap.lost);
    Some(match lost {
        Some(gap) => {
            let age = state
                .sample_age(std::time::SystemTime::now())
                .unwrap_or(0.0);
            last.max(gap.from + age)
        }
        None => last,
    })
}

pub fn plots_ui(ui: &mut Ui, state: &mut AppState) {
    let png = state
        .plot
        .png_result
        .lock()
        .ok()
        .and_then(|mut result| result.take());
    if let Some((path, result)) = png {
        if result.is_ok() {
            capture::note_written(&mut state.plot, path, Export::Png);
        }
        state.plot.message = Some(result);
    }
    toolbar(ui, state);
    capture::capture_ui(ui, state);
    readout(ui, state);
    traces::traces_ui(ui, state);
}

fn toolbar(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        ui.heading("Live plots");
        let paused = state.plot.is_paused();
        if ui
            .add(egui::Button::selectable(
                paused,
                if paused { "Resume plot" } else { "Pause plot" },
            ))
            .on_hover_text(
                "Freeze the plots to look closely; sampling and recording go on underneath.",
            )
            .clicked()
        {
            if paused {
                state.plot.paused_at = None;
                state.plot.follow = true;
                state.plot.highlight = None;
            } else {
                state.plot.paused_at = state.scope.ring().last_time();
            }
        }
        let follow = state.plot.follow;
        if ui
            .add(egui::Button::selectable(follow, "Follow latest"))
            .on_hover_text(
                "Keep the newest samples in view. Dragging or zooming a plot stops following; \
                 double-click a plot to follow again.",
            )
            .clicked()
        {
            state.plot.follow = !follow;
            if !follow {
                state.plot.paused_at = None;
            }
        }
        ui.label("Window");
        let combo = egui::ComboBox::from_id_salt("plot_window")
            .selected_text(window_text(state.settings.plot.window_s))
            .show_ui(ui, |ui| {
                for w in [1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 0.0] {
                    ui.selectable_value(&mut state.settings.plot.window_s, w, window_text(w));
                }
            });
        crate::ui::widgets::name_widget(
            &combo.response,
            egui::accesskit::Role::ComboBox,
            "Plot window",
        );
        if ui
            .button("Clear plot")
            .on_hover_text("Forget the recorded history and markers")
            .clicked()
        {
            state.scope.clear();
            state.plot.paused_at = None;
            state.plot.follow = true;
        }
        signals_menu(ui, state);
        history_menu(ui, state);
    });
}

fn window_text(seconds: f64) -> String {
    if seconds <= 0.0 {
        "whole history".into()
    } else if seconds >= 60.0 {
        format!("{:.0} min", seconds / 60.0)
    } else {
        format!("{seconds:.0} s")
    }
}

/// Which signals are drawn, and the objects added from the dictionary.
fn signals_menu(ui: &mut Ui, state: &mut AppState) {
    ui.menu_button("Signals", |ui| {
        let mut changed = false;
        for signal in state.scope.signals_mut() {
            let label = if signal.info.unit.is_empty() {
                signal.info.name.clone()
            } else {
                format!("{} [{}]", signal.info.name, signal.info.unit)
            };
            if ui.checkbox(&mut signal.shown, label).changed() {
                signal.auto = false;
                changed = true;
            }
        }
        if changed {
            state.settings.plot.shown = state
                .scope
                .signals()
                .iter()
                .filter(|s| s.shown)
                .map(|s| s.info.id.clone())
                .collect();
        }
        ui.separator();
        ui.label("Plot an object of the dictionary (sampled every cycle):");
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut state.plot.watch_text)
                    .hint_text("e.g. 2031:00")
                    .desired_width(90.0),
            )
            .on_hover_text("Index and subindex in hex");
            if ui.button("Add").clicked() {
                let text = state.plot.watch_text.clone();
                state.watch_object(&text);
            }
        });
        let watched: Vec<String> = state
            .plot
            .watched
            .iter()
            .map(|(w, _)| w.address.to_string())
            .collect();
        for address in watched {
            if ui
                .button(format!("Remove {address}"))
                .on_hover_text("Stop sampling it (its history is kept until cleared)")
                .clicked()
            {
                state.unwatch_object(&address);
            }
        }
    });
}

fn history_menu(ui: &mut Ui, state: &mut AppState) {
    let ring = state.scope.ring();
    let rate = state.settings.poll_rate.max(1.0);
    let label = format!(
        "{} of {} samples ({:.0} s at {rate:.0} Hz, {:.0} MB)",
        ring.len(),
        ring.capacity(),
        ring.capacity() as f64 / rate,
        ring.memory_bytes() as f64 / 1e6
    );
    ui.menu_button("History", |ui| {
        ui.label(label);
        ui.horizontal(|ui| {
            ui.label("Samples per signal");
            if state.plot.rows_text.is_empty() {
                state.plot.rows_text = state.scope.capacity().to_string();
            }
            ui.add(egui::TextEdit::singleline(&mut state.plot.rows_text).desired_width(90.0));
            if ui.button("Apply").clicked() {
                match crate::number::parse_integer(&state.plot.rows_text, false)
                    .and_then(|v| usize::try_from(v).ok())
                    .filter(|v| (1_000..=50_000_000).contains(v))
                {
                    Some(rows) => {
                        state.scope.set_capacity(rows);
                        state.settings.plot.history_rows = rows;
                        state.plot.message =
                            Some(Ok(format!("history: {rows} samples per signal")));
                    }
                    None => {
                        state.plot.message = Some(Err(format!(
                            "'{}' is not a history size: 1000 to 50 000 000 samples",
                            state.plot.rows_text
                        )))
                    }
                }
            }
        });
        ui.weak("The default, 600 000, is 10 minutes at 1 kHz. The oldest samples go first.");
    });
}

/// The values under the cursor (or the newest ones) of every signal drawn.
fn readout(ui: &mut Ui, state: &AppState) {
    let ring = state.scope.ring();
    let at = state.plot.cursor.or(ring.last_time());
    let Some(at) = at else {
        ui.weak("no samples yet");
        return;
    };
    let Some(row) = ring.index_at_or_before(at) else {
        return;
    };
    ui.horizontal_wrapped(|ui| {
        let what = if state.plot.cursor.is_some() {
            "cursor"
        } else {
            "latest"
        };
        ui.monospace(format!("{what} t = {:.3} s", ring.time(row).unwrap_or(at)));
        for signal in state
            .scope
            .signals()
            .iter()
            .filter(|s| state.scope.is_drawn(s))
        {
            let Some(v) = value_near(ring, row, signal.column) else {
                continue;
            };
            let text = match signal.kind {
                Kind::Analog => format!(
                    "{} {}",
                    crate::telemetry::format_number(v),
                    signal.info.unit
                ),
                Kind::Bits => format!("{:04X}h", v as u32),
            };
            ui.monospace(format!("| {}: {}", signal.info.id, text.trim_end()));
        }
    });
}

/// The channel's value at `row`, or the nearest one before it within a few samples (a
/// signal read round robin is not in every row).
fn value_near(ring: &crate::telemetry::Ring, row: usize, column: usize) -> Option<f64> {
    (0..=32)
        .filter_map(|back| row.checked_sub(back))
        .filter_map(|i| ring.value(i, column))
        .find(|v| !v.is_nan())
}
