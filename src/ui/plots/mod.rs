//! The plot panel: stacked plots of the sampled signals on one time axis, the status bits
//! as digital lanes, command markers, a cursor read-out, pause, follow, zoom and pan; the
//! analog plots live in `traces`, the status-bit lanes in `lanes`, the trigger and the
//! exports in `capture`, the PNG in `picture`, recordings opened from files (and a frozen
//! capture) in `review`, the dialogs in `files`.

mod capture;
pub mod files;
mod lanes;
mod picture;
pub mod readout;
pub mod review;
mod traces;

use std::path::PathBuf;
use std::sync::Arc;

use eframe::egui::{self, Ui};
use serde::{Deserialize, Serialize};

use super::state::AppState;
use crate::od::Address;
use crate::od::backup::DeviceIdentity;
use crate::telemetry::{DEFAULT_HISTORY_ROWS, Scope, WatchedObject};

pub use capture::{Export, Job, TriggerForm};
pub use files::{Ask, FilePicker, NativePicker, ScriptedPicker};
pub use picture::PngResult;
pub use review::Review;

/// The unit of positions in the factory-default user units (6064h and its kin).
pub const FACTORY_POSITION_UNIT: &str = "0.1°";

/// How positions in the factory units are drawn: as the drive counts them, in degrees or
/// in revolutions of the motor shaft.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PositionUnit {
    #[default]
    Tenths,
    Degrees,
    Revolutions,
}

impl PositionUnit {
    pub const ALL: [PositionUnit; 3] = [
        PositionUnit::Tenths,
        PositionUnit::Degrees,
        PositionUnit::Revolutions,
    ];

    /// What a value in 0.1° is multiplied by.
    pub fn scale(self) -> f64 {
        match self {
            PositionUnit::Tenths => 1.0,
            PositionUnit::Degrees => 0.1,
            PositionUnit::Revolutions => 1.0 / 3600.0,
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            PositionUnit::Tenths => FACTORY_POSITION_UNIT,
            PositionUnit::Degrees => "°",
            PositionUnit::Revolutions => "rev",
        }
    }

    /// The scale and unit a signal in `unit` is drawn with: positions in the factory unit
    /// in this one, anything else as it is.
    pub fn drawn(self, unit: &str) -> (f64, String) {
        if unit == FACTORY_POSITION_UNIT {
            (self.scale(), self.unit().to_owned())
        } else {
            (1.0, unit.to_owned())
        }
    }
}

/// A position in the factory unit said in degrees and revolutions too: "3600 0.1° = 360.0°
/// = 1.000 rev"; any other value with its unit.
pub fn with_turns(value: f64, unit: &str) -> String {
    let number = crate::telemetry::format_number(value);
    if unit == FACTORY_POSITION_UNIT {
        format!(
            "{number} {unit} = {:.1}° = {:.3} rev",
            value * PositionUnit::Degrees.scale(),
            value * PositionUnit::Revolutions.scale()
        )
    } else {
        format!("{number} {unit}").trim_end().to_owned()
    }
}

/// What the plot panel remembers between runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlotSettings {
    /// Seconds shown while following the newest samples; 0 shows the whole history.
    pub window_s: f64,
    /// Samples kept per signal.
    pub history_rows: usize,
    /// The folder the save and open dialogs start in (the last one used).
    pub export_dir: String,
    pub trigger: TriggerForm,
    /// The ids of the signals drawn.
    pub shown: Vec<String>,
    /// How positions in the factory unit are drawn.
    pub position_unit: PositionUnit,
    /// Frames per second at most while the live plots move (new samples wake the window
    /// no more often).
    pub redraw_hz: f64,
}

impl Default for PlotSettings {
    fn default() -> Self {
        Self {
            window_s: 10.0,
            history_rows: DEFAULT_HISTORY_ROWS,
            export_dir: String::new(),
            trigger: TriggerForm::default(),
            shown: Vec::new(),
            position_unit: PositionUnit::default(),
            redraw_hz: crate::ui::pace::DEFAULT_REDRAW_HZ,
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
    /// Where the plots (every axis included) were drawn in the last frame.
    pub plots_rect: Option<egui::Rect>,
    /// The picture of the plots being taken.
    pub picture: picture::Picture,
    /// The files the export buttons wrote this session, and which button (the newest
    /// writer of each path).
    pub written: Vec<(PathBuf, Export)>,
    /// The file saved last, for "Open folder".
    pub saved: Option<PathBuf>,
    /// The open and save dialogs (the system's; a script's in tests).
    pub files: Arc<dyn FilePicker>,
    /// A dialog open now, and what its answer is for.
    pub asking: Option<(Job, files::Answer)>,
    /// A file that exists, waiting for the user's word before it is replaced.
    pub confirm: Option<(PathBuf, Job)>,
    /// A recording (or a frozen capture) on screen instead of the live history.
    pub review: Option<Review>,
    /// A recording being read from its file.
    pub loading: Option<review::Loading>,
    /// The two cursors (A, B) placed on the time axis: a click places A, a right click B.
    pub cursors: [Option<f64>; 2],
    /// The last frames' decimations, drawn again while the plots have not moved.
    pub decimations: crate::telemetry::ring::Decimations,
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
            picture: picture::Picture::default(),
            written: Vec::new(),
            saved: None,
            files: files::picker(),
            asking: None,
            confirm: None,
            review: None,
            loading: None,
            cursors: [None; 2],
            decimations: Default::default(),
        }
    }
}

impl PlotView {
    pub fn is_paused(&self) -> bool {
        self.paused_at.is_some()
    }
}

/// The history the plots draw: the recording under review, or the live one.
pub fn shown_scope(state: &AppState) -> &Scope {
    state
        .plot
        .review
        .as_ref()
        .map_or(&state.scope, |review| &review.base.scope)
}

/// The time span to draw: the newest `window_s` seconds (or the whole history) up to the
/// newest sample or the pause, while following; the whole recording under review (and
/// its overlay); what the user zoomed to otherwise.
pub fn time_range(state: &AppState) -> Option<(f64, f64)> {
    if let Some(review) = &state.plot.review {
        if !state.plot.follow
            && let Some(range) = state.plot.shown_range
        {
            return Some(range);
        }
        return review.span();
    }
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

/// Another drive's signals, drawn with the selected drive's on the same time axis: its
/// name (for the legend) and its history.
pub struct Beside<'a> {
    pub name: &'a str,
    pub scope: &'a Scope,
}

/// One frame of the plot panel alone, drawn through `ctx` without a window at 1600×1000
/// (layout, decimation, plot items and tessellation; no GPU): what the benches and
/// `drivedeck bench`'s plotting load measure. The number of clipped primitives.
pub fn headless_frame(ctx: &egui::Context, state: &mut AppState) -> usize {
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(1600.0, 1000.0),
        )),
        ..Default::default()
    };
    let output = ctx.run_ui(input, |ui| plots_ui(ui, state));
    ctx.tessellate(output.shapes, output.pixels_per_point).len()
}

pub fn plots_ui(ui: &mut Ui, state: &mut AppState) {
    drives_plots_ui(ui, state, "", &[]);
}

/// The plots of the selected drive (`own` its name), with the same signals of the drives
/// `beside` drawn in each plot: live, and over a triggered capture's span (a recording
/// opened from a file has a time base of its own and is drawn alone).
pub fn drives_plots_ui(ui: &mut Ui, state: &mut AppState, own: &str, beside: &[Beside<'_>]) {
    toolbar(ui, state);
    review::review_ui(ui, state);
    capture::capture_ui(ui, state, beside);
    readout::readout_ui(ui, state);
    let band = picture::title_band_ui(ui, state);
    let plots = traces::traces_ui(ui, state, own, beside);
    state.plot.plots_rect = plots;
    picture::taken(ui.ctx(), state, band, plots);
    // The answers of this frame's dialogs (a scripted one answers at once) and of those
    // that came in between.
    picture::poll(ui.ctx(), state);
    capture::poll(ui.ctx(), state);
    review::poll(state);
    capture::confirm_ui(ui.ctx(), state);
}

fn toolbar(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal_wrapped(|ui| {
        if state.plot.review.is_some() {
            ui.heading("Recording");
            review::open_buttons_ui(ui, state);
            signals_menu(ui, state);
            return;
        }
        ui.heading("Live plots");
        review::open_buttons_ui(ui, state);
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

/// Which signals are drawn (the button says how many; the menu stays open while
/// choosing, each signal in the colour of its trace), how positions are drawn, and the
/// objects added from the dictionary.
fn signals_menu(ui: &mut Ui, state: &mut AppState) {
    let scope = shown_scope(state);
    let drawn = scope.signals().iter().filter(|s| scope.is_drawn(s)).count();
    let title = format!("Signals ({drawn} of {})", scope.signals().len());
    let config = egui::containers::menu::MenuConfig::new()
        .close_behavior(egui::PopupCloseBehavior::CloseOnClickOutside);
    let (button, _) = egui::containers::menu::MenuButton::new(title)
        .config(config)
        .ui(ui, |ui| signals_menu_body(ui, state));
    crate::ui::widgets::name_widget(&button, egui::accesskit::Role::Button, "Signals");
}

fn signals_menu_body(ui: &mut Ui, state: &mut AppState) {
    {
        let reviewing = state.plot.review.is_some();
        let scope = match &mut state.plot.review {
            Some(review) => &mut review.base.scope,
            None => &mut state.scope,
        };
        let colors = traces::colors(scope.signals());
        let mut changed = false;
        let with_samples: Vec<bool> = scope
            .signals()
            .iter()
            .map(|s| scope.ring().latest(s.column).is_some())
            .collect();
        for ((signal, color), has) in scope.signals_mut().iter_mut().zip(colors).zip(with_samples) {
            let mut drawn = signal.shown || (signal.auto && has);
            let label = if signal.info.unit.is_empty() {
                signal.info.name.clone()
            } else {
                format!("{} [{}]", signal.info.name, signal.info.unit)
            };
            ui.horizontal(|ui| {
                let (rect, _) = ui.allocate_exact_size(egui::vec2(14.0, 4.0), egui::Sense::hover());
                ui.painter().rect_filled(rect, 1.0, color);
                if ui.checkbox(&mut drawn, label).changed() {
                    signal.shown = drawn;
                    signal.auto = false;
                    changed = true;
                }
            });
        }
        if changed && !reviewing {
            state.settings.plot.shown = state
                .scope
                .signals()
                .iter()
                .filter(|s| s.shown)
                .map(|s| s.info.id.clone())
                .collect();
        }
    }
    ui.separator();
    ui.horizontal(|ui| {
        ui.label("Positions in");
        for unit in PositionUnit::ALL {
            ui.selectable_value(&mut state.settings.plot.position_unit, unit, unit.unit());
        }
    })
    .response
    .on_hover_text(
        "Positions in the factory unit (0.1°) drawn as counted, in degrees or in revolutions",
    );
    if state.plot.review.is_some() {
        return;
    }
    {
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
        let plotted: Vec<Address> = state.plot.watched.iter().map(|(w, _)| w.address).collect();
        for address in plotted {
            ui.horizontal(|ui| {
                if ui
                    .button(format!("Remove {address}"))
                    .on_hover_text("Stop sampling it (its history is kept until cleared)")
                    .clicked()
                {
                    state.unwatch_object(&address.to_string());
                }
                let pinned = state.settings.watch.is_pinned(address);
                let pin = ui
                    .add_enabled(!pinned, egui::Button::new("Watch"))
                    .on_hover_text("Pin it to the watch panel too: its value in numbers")
                    .on_disabled_hover_text("in the watch panel already");
                crate::ui::widgets::name_widget(
                    &pin,
                    egui::accesskit::Role::Button,
                    &format!("Watch {address}"),
                );
                if pin.clicked() {
                    state.plot.message = Some(state.pin_to_watch(address));
                }
            });
        }
    }
}

/// The live plots' redraw rate: a box in frames per second.
fn redraw_ui(ui: &mut Ui, redraw_hz: &mut f64) {
    use crate::ui::pace::{REDRAW_HZ_MAX, REDRAW_HZ_MIN, redraw_hz as accepted};
    ui.horizontal(|ui| {
        ui.label("Redraw live plots at");
        *redraw_hz = accepted(*redraw_hz);
        let field = ui
            .add(
                egui::DragValue::new(redraw_hz)
                    .range(REDRAW_HZ_MIN..=REDRAW_HZ_MAX)
                    .speed(1.0)
                    .max_decimals(0)
                    .suffix(" Hz"),
            )
            .on_hover_text(
                "Frames per second at most while the plots follow new samples; fewer cost \
                 less CPU. Paused or moved plots redraw once a second.",
            );
        crate::ui::widgets::name_widget(&field, egui::accesskit::Role::SpinButton, "Redraw rate");
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
        ui.separator();
        redraw_ui(ui, &mut state.settings.plot.redraw_hz);
    });
}
