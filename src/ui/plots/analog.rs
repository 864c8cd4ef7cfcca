//! One analog plot: a signal, or several sharing the plot as a scope's channels (see
//! `groups`), each in its colour and, when several, on a y axis of its own with its own
//! round values; the same signals of the drives beside and of an overlaid recording drawn
//! in it; a compact legend that names no more lines than fit the plot's height.

use std::cell::Cell;
use std::rc::Rc;

use eframe::egui::{self, Color32, Ui};
use egui_plot::{AxisHints, HPlacement, Legend, Line, LineStyle, Plot, PlotBounds};

use super::groups::{self, Scale};
use super::model::LineExtent;
use super::navigate;
use super::traces::{
    DriveLine, View, Y_AXIS_WIDTH, draw_bands, draw_markers, draw_moments, draw_runs, drive_color,
    scale_values, time_axis, time_steps,
};
use crate::telemetry::{Kind, SignalDef};

/// The width of a y axis beyond the first (a second signal's, on the right), in points.
pub(super) const MORE_Y_AXIS_WIDTH: f32 = 48.0;
/// Grid steps of air above and below the signals of a shared plot: the labels at its
/// lowest and highest grid line stay inside it.
const SHARED_MARGIN: f64 = 0.45;

/// How many y axes every plot has on each side (left, right): as many as the plot with
/// the most signals needs, so that every plot's data area, and its time axis, line up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Axes {
    pub(super) left: usize,
    pub(super) right: usize,
}

impl Axes {
    /// The axes for plots of `sizes` signals: the first signal's on the left, the second's
    /// on the right, the third's on the left again, …
    pub(super) fn for_sizes(sizes: impl Iterator<Item = usize>) -> Axes {
        let most = sizes.max().unwrap_or(1).max(1);
        Axes {
            left: most.div_ceil(2),
            right: most / 2,
        }
    }
}

/// A plot's legend entries, no more than fit: later lines go unnamed (each signal is in
/// the Signals menu in its colour, each drive in the drive list in its own).
pub(super) struct Names {
    left: usize,
}

impl Names {
    /// As many entries as `height` points of plot hold in egui_plot's legend (its padding,
    /// frame and rows of small text).
    pub(super) fn fitting(ui: &Ui, height: f32) -> Names {
        let row = ui.text_style_height(&egui::TextStyle::Small);
        let spacing = ui.spacing().item_spacing.y;
        // 4 points of padding each side, a frame of 4 points' margin and a stroke.
        let room = height - 2.0 * 4.0 - 2.0 * 5.0;
        let rows = ((room + spacing) / (row + spacing)).floor().max(0.0);
        Names {
            left: rows as usize,
        }
    }

    /// `name` while rows are left, unnamed (out of the legend) after.
    fn take(&mut self, name: String) -> String {
        if self.left == 0 {
            return String::new();
        }
        self.left -= 1;
        name
    }
}

/// The legend, top left (the newest samples come in on the right), small and see-through
/// so that on a low plot the traces under it still show.
fn legend() -> Legend {
    Legend::default()
        .position(egui_plot::Corner::LeftTop)
        .text_style(egui::TextStyle::Small)
        .background_alpha(0.45)
}

/// A signal drawn in a plot: its id, and its line's extent in its true values.
pub(super) type SignalLine = (String, Option<LineExtent>);

/// One signal of a plot and what is drawn of it.
struct Channel<'s> {
    signal: &'s SignalDef,
    color: Color32,
    /// What drawn values are multiplied by (positions in degrees or revolutions).
    scale: f64,
    label: String,
}

/// One plot of `signals` (one, or several sharing it), on the shared time axis; the first
/// plot labels the markers and names the overlaid recording. What it answers: the span its
/// points were decimated for and each signal's id and line (in its true values).
pub(super) fn analog_plot_ui(
    ui: &mut Ui,
    view: &View<'_>,
    signals: &[(&SignalDef, Color32)],
    height: f32,
    first: bool,
    axes: Axes,
    overlay_name: Option<&str>,
) -> egui_plot::PlotResponse<((f64, f64), Vec<SignalLine>)> {
    let channels: Vec<Channel<'_>> = signals
        .iter()
        .map(|(signal, color)| {
            let (scale, unit) = view.position_unit.drawn(&signal.info.unit);
            let label = if unit.is_empty() {
                signal.info.name.clone()
            } else {
                format!("{} [{unit}]", signal.info.name)
            };
            // With other drives drawn beside it, each line says whose it is.
            let (label, color) = match view.own {
                Some((own, theirs)) if signals.len() == 1 => (format!("{own}: {label}"), theirs),
                Some((own, _)) => (format!("{own}: {label}"), *color),
                None => (label, *color),
            };
            Channel {
                signal,
                color,
                scale,
                label,
            }
        })
        .collect();
    let shared = channels.len() > 1;
    // Each signal's scale in a shared plot, set while its points are drawn; its axis's
    // labels (drawn after) read it.
    let cells: Vec<Rc<Cell<Option<Scale>>>> =
        channels.iter().map(|_| Rc::new(Cell::new(None))).collect();
    let y_axes = y_axes(&channels, &cells, axes);
    // The grid lines: at each whole step of the first signal's scale.
    let grid: Rc<Cell<Option<Scale>>> = Rc::new(Cell::new(None));
    let spacer = {
        let grid = grid.clone();
        move |input: egui_plot::GridInput| grid_marks(input, grid.get())
    };
    let mut names = Names::fitting(ui, height);
    let id = channels
        .first()
        .map_or("", |c| c.signal.info.id.as_str())
        .to_owned();
    // The time axis shows the view's span (a pan or zoom asks for another, see
    // `navigate`); the value axis always fits what is in view. The time labels are under
    // the plots, outside their scroll area.
    navigate::fixed(Plot::new(("plot", id.as_str())))
        .height(height)
        .link_cursor(view.group, [true, false])
        .legend(legend())
        .custom_y_axes(y_axes)
        .y_grid_spacer(spacer)
        .custom_x_axes(time_axis())
        .x_grid_spacer(time_steps)
        .show_axes([false, true])
        .show(ui, |plot_ui| {
            let (from, to) = (view.from, view.to);
            // This frame's width (the transform is the last frame's).
            let columns = plot_ui.response().rect.width().max(1.0) as usize;
            let lines: Vec<Lines<'_>> = channels
                .iter()
                .map(|c| c.lines(view, columns, &mut names))
                .collect();
            let overlay_named = overlay_name
                .filter(|_| first && lines.iter().any(|l| !l.overlay.is_empty()))
                .map(|name| names.take(format!("{name} (dashed)")));
            let extents: Vec<SignalLine> = channels
                .iter()
                .zip(&lines)
                .map(|(c, l)| {
                    let own = LineExtent::of(&l.own, (from, to)).map(|e| LineExtent {
                        // True values: the unit's scale undone.
                        low: e.low / c.scale,
                        high: e.high / c.scale,
                        ..e
                    });
                    (c.signal.info.id.clone(), own)
                })
                .collect();
            let mut lines = lines;
            // Each signal on round values of its own filling the plot, with a little air
            // above and below so that the labels of the lowest and highest grid lines stay
            // inside it (clear of the neighbouring plots' labels).
            let ranges: Vec<(f64, f64)> = lines.iter().map(|l| l.range(from, to)).collect();
            let (scales, steps) = groups::scales(&ranges);
            let top = f64::from(steps) + SHARED_MARGIN;
            if shared {
                for ((l, scale), cell) in lines.iter_mut().zip(&scales).zip(&cells) {
                    l.normalise(*scale);
                    cell.set(Some(*scale));
                }
                grid.set(Some(Scale {
                    origin: 0.0,
                    step: 1.0,
                }));
                plot_ui
                    .set_plot_bounds(PlotBounds::from_min_max([from, -SHARED_MARGIN], [to, top]));
            } else if let Some(&scale) = scales.first() {
                grid.set(Some(scale));
                plot_ui.set_plot_bounds(PlotBounds::from_min_max(
                    [from, scale.value_at(-SHARED_MARGIN)],
                    [to, scale.value_at(top)],
                ));
            }
            let level = lines.iter().find_map(|l| l.level);
            draw_bands(plot_ui, &view.bands, first);
            draw_markers(plot_ui, &view.markers, first);
            draw_moments(plot_ui, view, level);
            let mut overlay_named = overlay_named;
            for (c, l) in channels.iter().zip(lines) {
                draw_runs(plot_ui, &l.name, c.color, l.own, &view.bands);
                for (name, theirs, bands, color) in l.drives {
                    draw_runs(plot_ui, &name, color, theirs, bands);
                }
                if !l.overlay.is_empty() {
                    // The overlaid recording's line, dashed, named once (its file).
                    plot_ui.line(
                        Line::new(overlay_named.take().unwrap_or_default(), l.overlay)
                            .color(c.color.gamma_multiply(0.75))
                            .style(LineStyle::dashed_loose())
                            .width(1.5),
                    );
                }
            }
            ((from, to), extents)
        })
}

/// What one signal draws in a plot: its line, the overlaid recording's, the drives'
/// beside, the trigger level on it.
struct Lines<'b> {
    name: String,
    own: Vec<[f64; 2]>,
    overlay: Vec<[f64; 2]>,
    drives: Vec<DriveLine<'b>>,
    level: Option<f64>,
}

impl Channel<'_> {
    fn lines<'b>(&self, view: &'b View<'_>, columns: usize, names: &mut Names) -> Lines<'b> {
        let (from, to) = (view.from, view.to);
        let (signal, scale) = (self.signal, self.scale);
        let mut own = view.points(view.ring, signal.column, from, to, columns);
        scale_values(&mut own, scale, 0.0);
        // The same signal in the overlaid recording, if it has it.
        let overlay = view
            .overlay
            .and_then(|(scope, offset)| {
                let theirs = scope
                    .signal(&signal.info.id)
                    .filter(|s| s.kind == Kind::Analog)?;
                let mut points = view.points(
                    scope.ring(),
                    theirs.column,
                    from - offset,
                    to - offset,
                    columns,
                );
                scale_values(&mut points, scale, offset);
                Some(points)
            })
            .unwrap_or_default();
        let name = names.take(self.label.clone());
        // The same signal of the other drives, on the same time axis.
        let drives = view
            .beside
            .iter()
            .filter_map(|(b, bands)| {
                let theirs = b.scope.signal(&signal.info.id)?;
                let mut points = view.points(b.scope.ring(), theirs.column, from, to, columns);
                scale_values(&mut points, scale, 0.0);
                Some((
                    names.take(format!("{}: {}", b.name, signal.info.name)),
                    points,
                    bands.as_slice(),
                    drive_color(b.color),
                ))
            })
            .collect();
        let level = view
            .threshold
            .filter(|(c, _)| *c == signal.column)
            .map(|(_, l)| l * scale);
        Lines {
            name,
            own,
            overlay,
            drives,
            level,
        }
    }
}

impl Lines<'_> {
    fn all(&self) -> impl Iterator<Item = &[[f64; 2]]> {
        [self.own.as_slice(), self.overlay.as_slice()]
            .into_iter()
            .chain(self.drives.iter().map(|d| d.1.as_slice()))
    }

    /// The lowest and highest value drawn inside `from..=to` (the trigger level too).
    fn range(&self, from: f64, to: f64) -> (f64, f64) {
        let (low, high) = self
            .all()
            .flat_map(|points| points.iter())
            .filter(|p| p[0] >= from && p[0] <= to)
            .fold((f64::NAN, f64::NAN), |(lo, hi), p| {
                (lo.min(p[1]), hi.max(p[1]))
            });
        match self.level {
            Some(level) => (low.min(level), high.max(level)),
            None => (low, high),
        }
    }

    /// Every value drawn at its height on the shared plot's grid.
    fn normalise(&mut self, scale: Scale) {
        let drives = self.drives.iter_mut().map(|d| &mut d.1);
        for points in [&mut self.own, &mut self.overlay].into_iter().chain(drives) {
            for p in points.iter_mut() {
                p[1] = scale.to_drawn(p[1]);
            }
        }
        self.level = self.level.map(|l| scale.to_drawn(l));
    }
}

/// The plot's y axes: one per signal when several share it (each labelling the grid
/// lines with its own values, in its colour), and blank ones up to `axes` so that every
/// plot's data area lines up with the others'.
fn y_axes<'a>(
    channels: &[Channel<'_>],
    cells: &[Rc<Cell<Option<Scale>>>],
    axes: Axes,
) -> Vec<AxisHints<'a>> {
    let mut left = Vec::new();
    let mut right = Vec::new();
    for (k, (channel, cell)) in channels.iter().zip(cells).enumerate() {
        let side = if k % 2 == 0 { &mut left } else { &mut right };
        let hints = AxisHints::new_y()
            .label_spacing(10.0..=16.0)
            .min_thickness(axis_width(side.len()))
            .placement(if k % 2 == 0 {
                HPlacement::Left
            } else {
                HPlacement::Right
            });
        side.push(if channels.len() == 1 {
            // Alone: the values as egui_plot gives them, three or four on a low plot.
            hints
        } else {
            let cell = cell.clone();
            hints
                .tick_label_color(channel.color)
                .formatter(move |mark, _| {
                    cell.get().map_or_else(String::new, |scale| {
                        groups::value_label(scale.value_at(mark.value), scale.step)
                    })
                })
        });
    }
    pad(left, right, axes)
}

/// A plot's y axes with no labels (the lanes', the time axis's): as wide as the others',
/// so that its data area lines up with theirs.
pub(super) fn blank_y_axes<'a>(axes: Axes) -> Vec<AxisHints<'a>> {
    pad(Vec::new(), Vec::new(), axes)
}

/// `left` and `right` filled up with blank axes to `axes`, left ones first.
fn pad<'a>(
    mut left: Vec<AxisHints<'a>>,
    mut right: Vec<AxisHints<'a>>,
    axes: Axes,
) -> Vec<AxisHints<'a>> {
    let blank = |k: usize, placement: HPlacement| {
        AxisHints::new_y()
            .min_thickness(axis_width(k))
            .placement(placement)
            .formatter(|_, _| String::new())
    };
    while left.len() < axes.left.max(1) {
        left.push(blank(left.len(), HPlacement::Left));
    }
    while right.len() < axes.right {
        right.push(blank(right.len(), HPlacement::Right));
    }
    left.into_iter().chain(right).collect()
}

/// The width of the `k`th y axis on a side.
fn axis_width(k: usize) -> f32 {
    if k == 0 {
        Y_AXIS_WIDTH
    } else {
        MORE_Y_AXIS_WIDTH
    }
}

/// A line at every whole step of `scale` inside the plot's bounds (one set of round
/// values per signal); none before the first frame has set it.
fn grid_marks(input: egui_plot::GridInput, scale: Option<Scale>) -> Vec<egui_plot::GridMark> {
    let (min, max) = input.bounds;
    let Some(scale) = scale.filter(|s| s.step > 0.0 && s.step.is_finite()) else {
        return Vec::new();
    };
    let (first, last) = (scale.to_drawn(min).ceil(), scale.to_drawn(max).floor());
    if !(first.is_finite() && last.is_finite()) || last - first > 1000.0 {
        return Vec::new();
    }
    (first as i64..=last as i64)
        .map(|k| egui_plot::GridMark {
            value: scale.value_at(k as f64),
            step_size: scale.step,
        })
        .collect()
}
