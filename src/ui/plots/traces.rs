//! The stacked plots: one per analog signal (or per group of signals sharing one, drawn
//! by `analog`), then the digital lanes (drawn by `lanes`), in a scroll area with the time
//! axis's labels under it, all on one time axis (the plot view's span; `navigate` turns a
//! drag or the wheel into a new one), each drawn from the history's min/max decimation at
//! one point group per pixel column, so the whole history draws without dropping a peak.
//! The y axes always fit what is in view (zoom and pan move the time axis only, no trace
//! is clipped); a recording overlaid is drawn dashed over the one it is compared with.

use std::cell::RefCell;

use eframe::egui::{self, Color32, Ui};
use egui_plot::{Line, LineStyle, Plot, PlotBounds, PlotUi, Span, Text, VLine};

use super::analog::{Axes, analog_plot_ui, blank_y_axes};
use super::groups::plot_groups;

use super::exports::Beside;
use super::lanes::{lane_labels_ui, lanes, lanes_plot_ui, shown_lanes};
use super::model::{DrawnPlot, LineExtent, PositionUnit, live_end, shown_scope, time_range};
use super::navigate;
use super::view::Plots;
use crate::telemetry::ring::Decimations;
use crate::telemetry::{Builtin, CaptureState, Condition, Kind, Ring, Scope, SignalDef};
use crate::ui::command::Command;
use crate::ui::command::PlotCommand;
use crate::ui::widgets::{AMBER, BLUE, GREEN, RED};

/// Height of one digital lane, in points: at most, and at least (the lanes take up to
/// 40 % of the panel between the two).
const LANE_HEIGHT: f32 = 26.0;
const LANE_HEIGHT_MIN: f32 = 16.0;
/// Width of every plot's y axis, so the time axes line up.
pub(super) const Y_AXIS_WIDTH: f32 = 56.0;
/// The lowest an analog plot gets: three labelled values on its y axis and a line of
/// legend fit (when the plots do not all fit at this height, they scroll).
pub const PLOT_HEIGHT_MIN: f32 = 80.0;
/// The height of the time axis's labels under the plots.
const TIME_AXIS_HEIGHT: f32 = 38.0;
/// The least height of the plots' scroll area.
const SCROLL_HEIGHT_MIN: f32 = 24.0;
/// What the lanes' plot takes beyond its lanes (its margins), in points.
const LANES_FRAME: f32 = 20.0;
/// The space egui leaves between two plots, in points.
const PLOT_SPACING: f32 = 4.0;
/// Marker labels drawn per plot at most (all markers get their line).
const MARKER_LABELS: usize = 24;

const PURPLE: Color32 = Color32::from_rgb(150, 110, 210);
const TEAL: Color32 = Color32::from_rgb(60, 190, 190);
const PINK: Color32 = Color32::from_rgb(230, 110, 170);
const LIME: Color32 = Color32::from_rgb(170, 210, 60);
const ORANGE: Color32 = Color32::from_rgb(240, 120, 40);
const SKY: Color32 = Color32::from_rgb(140, 200, 250);
const SAND: Color32 = Color32::from_rgb(210, 180, 130);
const GREY: Color32 = Color32::from_gray(150);
const WHITE: Color32 = Color32::from_gray(225);
/// The shade of a stretch without samples.
const GAP_FILL: Color32 = Color32::from_rgba_premultiplied(60, 40, 40, 60);
/// The colours for traces that are no built-in signal, in order.
pub(super) const PALETTE: [Color32; 9] = [PURPLE, TEAL, PINK, LIME, ORANGE, SKY, SAND, GREEN, BLUE];
/// Another drive's line in a plot: its legend name, its points, its gaps, its colour.
pub(super) type DriveLine<'b> = (String, Vec<[f64; 2]>, &'b [Band], Color32);

/// The drives' lines when several are drawn on one plot: each drive's line in the colour
/// it was given when it was added, the shown drive's too, so a colour stays with its drive
/// whichever is selected (alone, the shown drive's lines take the signals' colours).
pub const DRIVE_COLORS: [Color32; 16] = [
    ORANGE,
    PINK,
    SKY,
    LIME,
    SAND,
    TEAL,
    PURPLE,
    WHITE,
    // A machine of sixteen axes: each its own colour still.
    Color32::from_rgb(235, 205, 60),  // gold
    Color32::from_rgb(250, 130, 115), // coral
    Color32::from_rgb(150, 230, 180), // mint
    Color32::from_rgb(190, 170, 250), // lavender
    Color32::from_rgb(195, 95, 55),   // rust
    Color32::from_rgb(160, 160, 70),  // olive
    Color32::from_rgb(110, 145, 190), // steel
    Color32::from_rgb(210, 120, 150), // rose
];

/// The colour of the drive given colour index `index` when it was added.
pub fn drive_color(index: usize) -> Color32 {
    DRIVE_COLORS[index % DRIVE_COLORS.len()]
}
/// The cursors' colours (A, B).
const CURSOR_COLORS: [Color32; 2] = [
    Color32::from_rgb(250, 230, 80),
    Color32::from_rgb(90, 230, 230),
];

/// A colour per signal, none used twice while the palette lasts: the built-in signals
/// keep theirs (position blue, velocity green, …), the others take the next free one.
pub fn colors(signals: &[SignalDef]) -> Vec<Color32> {
    let fixed = |signal: &SignalDef| match signal.builtin() {
        Some(Builtin::Position) => Some(BLUE),
        Some(Builtin::Velocity) => Some(GREEN),
        Some(Builtin::Torque) => Some(AMBER),
        Some(Builtin::FollowingError) => Some(RED),
        Some(Builtin::AnalogInput) => Some(PURPLE),
        Some(Builtin::ReturnValue) => Some(TEAL),
        _ => None,
    };
    let mut used: Vec<Color32> = signals.iter().filter_map(fixed).collect();
    let mut spare = PALETTE
        .iter()
        .copied()
        .filter(|c| !used.contains(c))
        .collect::<Vec<_>>()
        .into_iter();
    signals
        .iter()
        .enumerate()
        .map(|(i, signal)| {
            fixed(signal).unwrap_or_else(|| {
                let color = spare.next().unwrap_or(PALETTE[i % PALETTE.len()]);
                used.push(color);
                color
            })
        })
        .collect()
}

/// A stretch without samples in view (a lost link, a disconnect): shaded, labelled, and
/// no line drawn across it.
pub(super) struct Band {
    pub(super) from: f64,
    pub(super) to: f64,
    pub(super) label: String,
}

/// What the plots report back for the next frame.
#[derive(Default)]
struct Interaction {
    /// The span a drag, the wheel or a right drag over a plot asked for.
    asked: Option<(f64, f64)>,
    follow_again: bool,
    /// A click placed cursor A (0) or B (1) here.
    placed: Option<(usize, f64)>,
    /// The right edge of the plots drawn.
    right: f32,
    /// The plots drawn, top to bottom.
    drawn: Vec<DrawnPlot>,
}

/// What every plot of one frame shares: the time span, the pointer's line across them, and
/// the marks drawn across all plots.
pub(super) struct View<'a> {
    pub(super) ring: &'a Ring,
    /// The recording drawn over this one, and the seconds its times are moved by.
    pub(super) overlay: Option<(&'a Scope, f64)>,
    pub(super) position_unit: PositionUnit,
    cursors: [Option<f64>; 2],
    pub(super) from: f64,
    pub(super) to: f64,
    /// The plots that draw the pointer's time as a line where it is over one of them.
    pub(super) group: egui::Id,
    pub(super) markers: Vec<(f64, &'a str)>,
    /// The gaps in view, oldest first.
    pub(super) bands: Vec<Band>,
    highlight: Option<f64>,
    trigger_at: Option<f64>,
    /// The threshold trigger's signal column and level.
    pub(super) threshold: Option<(usize, f64)>,
    /// The selected drive's name and colour, when other drives are drawn beside it.
    pub(super) own: Option<(&'a str, Color32)>,
    /// The other drives whose signals are drawn on the same time axis, and their gaps.
    pub(super) beside: Vec<(&'a Beside<'a>, Vec<Band>)>,
    /// The last frames' decimations, reused where the plots have not moved.
    pub(super) decimations: RefCell<Decimations>,
}

impl<'a> View<'a> {
    fn new(p: &'a Plots<'a>, from: f64, to: f64, decimations: Decimations) -> Self {
        let (plot, drive, beside) = (&*p.view, &*p.drive, p.beside);
        let scope = shown_scope(plot, drive);
        let markers = scope
            .markers()
            .filter(|m| m.t >= from && m.t <= to)
            .map(|m| (m.t, m.text.as_str()))
            .collect();
        let review = plot.review.as_ref();
        let trigger_at = match review {
            Some(review) => review.base.trigger,
            None => match drive.scope.capture_state() {
                CaptureState::Fired { at } | CaptureState::Complete { at, .. } => Some(at),
                _ => None,
            },
        };
        // The threshold's column is of the live history (a capture has the same ones).
        let threshold = drive
            .scope
            .trigger()
            .and_then(|t| match t.condition {
                Condition::Threshold { channel, level, .. } => Some((channel, level)),
                Condition::Bit { .. } => None,
            })
            .filter(|_| review.is_none_or(|r| r.capture));
        View {
            ring: scope.ring(),
            overlay: review.and_then(|r| r.overlay.as_ref().map(|o| (&o.scope, r.offset_s))),
            position_unit: p.settings.position_unit,
            cursors: plot.cursors,
            from,
            to,
            group: egui::Id::unique("plots_pointer_line"),
            markers,
            bands: bands(p, from, to),
            highlight: plot.highlight,
            trigger_at,
            threshold,
            own: (!beside.is_empty() && review.is_none_or(|r| r.capture))
                .then(|| (drive.name.as_str(), drive_color(drive.color))),
            // A recording opened from a file has a time base of its own: nothing beside.
            beside: if review.is_none_or(|r| r.capture) {
                beside
                    .iter()
                    .map(|b| (b, scope_bands(b.scope, from, to)))
                    .collect()
            } else {
                Vec::new()
            },
            decimations: RefCell::new(decimations),
        }
    }

    /// [`Ring::decimate`] of `ring` (reused from the last frame when it still holds),
    /// thinned to what a line shows of each pixel column.
    pub(super) fn points(
        &self,
        ring: &Ring,
        column: usize,
        from: f64,
        to: f64,
        columns: usize,
    ) -> Vec<[f64; 2]> {
        self.decimations
            .borrow_mut()
            .points_with(ring, column, from, to, columns, |points| {
                extremes_per_column(points, from, to, columns)
            })
    }
}

/// Per pixel column, only its lowest and highest point, in time order: a line through a
/// column's first, lowest, highest and last samples covers the same pixels as one through
/// its lowest and highest (the first and last lie between them), at half the points to
/// draw. Points outside `from..=to` (the neighbours that carry the line to the edges) are
/// kept. A line with no more than two points per column is left as it is.
fn extremes_per_column(points: Vec<[f64; 2]>, from: f64, to: f64, columns: usize) -> Vec<[f64; 2]> {
    let width = to - from;
    if points.len() <= 2 * columns + 2 || width.is_nan() || width <= 0.0 {
        return points;
    }
    let scale = columns as f64 / width;
    // The column of a time: -1 before the span, `columns` at its end and after.
    let column = |t: f64| {
        let x = (t - from) * scale;
        if x < 0.0 {
            -1
        } else {
            (x as i64).min(columns as i64)
        }
    };
    let mut out = Vec::with_capacity(2 * columns + 2);
    let mut i = 0;
    while i < points.len() {
        let k = column(points[i][0]);
        let (mut low, mut high, mut j) = (i, i, i + 1);
        while j < points.len() && column(points[j][0]) == k {
            if points[j][1] < points[low][1] {
                low = j;
            }
            if points[j][1] > points[high][1] {
                high = j;
            }
            j += 1;
        }
        out.push(points[low.min(high)]);
        if low != high {
            out.push(points[low.max(high)]);
        }
        i = j;
    }
    out
}

/// Another drive's gaps between `from` and `to` (one still open reaches to its newest
/// sample): its lines are not drawn across them.
fn scope_bands(scope: &Scope, from: f64, to: f64) -> Vec<Band> {
    let last = scope.ring().last_time().unwrap_or(to);
    scope
        .gaps()
        .map(|gap| Band {
            from: gap.from,
            to: gap.to.unwrap_or(last),
            label: String::new(),
        })
        .filter(|band| band.to > band.from && band.to >= from && band.from <= to)
        .collect()
}

/// The gaps between `from` and `to`; one still open reaches to now (while the link is
/// lost, the plots run on to show it grow).
fn bands(p: &Plots<'_>, from: f64, to: f64) -> Vec<Band> {
    if p.view.review.is_some() {
        return Vec::new();
    }
    let now = live_end(p.drive).unwrap_or(to);
    p.drive
        .scope
        .gaps()
        .map(|gap| Band {
            from: gap.from,
            to: gap.to.unwrap_or(now),
            label: gap.label(now),
        })
        .filter(|band| band.to > band.from && band.to >= from && band.from <= to)
        .collect()
}

/// `points` (in time order) in runs that no band cuts: no line is drawn across a
/// stretch without samples.
fn split_at_bands<'p>(points: &'p [[f64; 2]], bands: &[Band]) -> Vec<&'p [[f64; 2]]> {
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..points.len() {
        let (a, b) = (points[i - 1][0], points[i][0]);
        if bands.iter().any(|band| a <= band.from && b >= band.to) {
            runs.push(&points[start..i]);
            start = i;
        }
    }
    if start < points.len() {
        runs.push(&points[start..]);
    }
    runs
}

/// The plots; where they were drawn (every axis included), for the picture. Stacked in a
/// scroll area: each keeps a height where its labels and a line of legend fit, and when
/// they do not all fit the area scrolls (its bar, or the wheel over the y axes' labels;
/// the wheel over a plot's data moves the time axis). The time axis's labels sit under the
/// scroll area, always in view.
pub fn traces_ui(ui: &mut Ui, p: &mut Plots<'_>) -> Option<egui::Rect> {
    let Some((from, to)) = time_range(p.view, p.drive, p.settings.window_s) else {
        ui.add_space(8.0);
        ui.weak(
            "Waiting for samples: connect to a drive (or the simulated one), or open a \
             recording.",
        );
        return None;
    };
    let mut decimations = std::mem::take(&mut p.view.decimations);
    let scope = shown_scope(p.view, p.drive);
    let colors = colors(scope.signals());
    let analog: Vec<(&SignalDef, Color32)> = scope
        .signals()
        .iter()
        .zip(colors)
        .filter(|(s, _)| scope.is_drawn(s) && s.kind == Kind::Analog)
        .collect();
    let ids: Vec<&str> = analog.iter().map(|(s, _)| s.info.id.as_str()).collect();
    let groups = plot_groups(&ids, &p.settings.together);
    let candidates = lanes(scope, from, to, &mut decimations);
    let lanes_seen: Vec<(String, String)> = candidates.iter().map(|l| l.key_and_name()).collect();
    let lanes = shown_lanes(candidates, &p.settings.hidden_lanes);
    let room = ui.available_height() - TIME_AXIS_HEIGHT - PLOT_SPACING;
    let (plot_height, lanes_height) = heights(room, groups.len(), lanes.len());
    let axes = Axes::for_sizes(groups.iter().map(Vec::len));
    let overlay_name = p
        .view
        .review
        .as_ref()
        .and_then(|r| r.overlay.as_ref())
        .map(|o| o.title.clone());
    let view = View::new(p, from, to, decimations);
    let mut interaction = Interaction::default();
    let top = ui.cursor().min;

    let scrolled = egui::ScrollArea::vertical()
        .id_salt("plots_scroll")
        .auto_shrink([false, true])
        // However little room the window leaves (a zoomed-in window, a small screen),
        // the time axis under the area stays in view: the area shrinks, its plots scroll.
        .max_height(room.max(SCROLL_HEIGHT_MIN))
        .show(ui, |ui| {
            for (n, group) in groups.iter().enumerate() {
                let signals: Vec<(&SignalDef, Color32)> =
                    group.iter().map(|&k| analog[k]).collect();
                let response = analog_plot_ui(
                    ui,
                    &view,
                    &signals,
                    plot_height,
                    n == 0,
                    axes,
                    overlay_name.as_deref(),
                );
                let (decimated, lines) = &response.inner;
                let id = lines.first().map_or("", |(id, _)| id.as_str());
                interaction.absorb(ui, &response, id, (from, to), *decimated, lines.clone());
            }
            if !lanes.is_empty() {
                let response = lanes_plot_ui(ui, &view, &lanes, lanes_height, axes);
                let (decimated, labels) = &response.inner;
                interaction.absorb(ui, &response, "lanes", (from, to), *decimated, Vec::new());
                lane_labels_ui(ui, labels, &response.transform);
            }
        });
    // As wide as the plots in the scroll area (its bar may take room at the right).
    let width = scrolled.inner_rect.width();
    let need = scrolled.content_size.y + TIME_AXIS_HEIGHT + PLOT_SPACING;
    let response = ui
        .allocate_ui(egui::vec2(width, TIME_AXIS_HEIGHT), |ui| {
            ui.set_width(width);
            time_axis_ui(ui, &view, axes)
        })
        .inner;
    interaction.absorb(ui, &response, "time", (from, to), (from, to), Vec::new());

    let bottom = ui.cursor().min;
    let plots = egui::Rect::from_min_max(
        top,
        // The plots' right axes are outside their frames: the scroll area's width holds
        // them (the picture is cut to this).
        egui::pos2(
            interaction.right.max(top.x + width).max(top.x + 1.0),
            bottom.y,
        ),
    );
    let mut decimations = view.decimations.into_inner();
    decimations.end_frame();
    p.view.decimations = decimations;
    p.view.lanes_seen = lanes_seen;
    p.view.drawn_at.need = need;
    remember_view(ui.ctx(), p, interaction, (from, to));
    Some(plots)
}

/// The time axis's labels under the plots' scroll area, on their span: always in view,
/// however many plots there are and whatever the zoom of the window. A drag or the wheel
/// over it moves the time axis as over a plot.
fn time_axis_ui(ui: &mut Ui, view: &View<'_>, axes: Axes) -> egui_plot::PlotResponse<()> {
    navigate::fixed(Plot::new("plot_time_axis"))
        .height(TIME_AXIS_HEIGHT)
        .show_grid([false, false])
        .show_background(false)
        .custom_y_axes(blank_y_axes(axes))
        .custom_x_axes(time_axis())
        .x_grid_spacer(time_steps)
        .show(ui, |plot_ui| {
            plot_ui.set_plot_bounds(PlotBounds::from_min_max([view.from, 0.0], [view.to, 1.0]));
        })
}

/// The height of each analog plot and of the lanes' plot: the lanes take what they need
/// (up to 40 % while analog plots share the panel), the analog plots share the rest; when
/// that leaves the analog plots too little the lanes give way, down to their least height;
/// none lower than its minimum (then the plots scroll).
fn heights(available: f32, analog: usize, lanes: usize) -> (f32, f32) {
    // Between plots egui puts its item spacing; below them a little air.
    let spacing = PLOT_SPACING * (analog + usize::from(lanes > 0)) as f32 + 4.0;
    let room = (available - spacing).max(0.0);
    let lanes_height = if lanes == 0 {
        0.0
    } else {
        let share = if analog == 0 { 1.0 } else { 0.4 };
        let lane =
            ((room * share - LANES_FRAME) / lanes as f32).clamp(LANE_HEIGHT_MIN, LANE_HEIGHT);
        let least = lanes as f32 * LANE_HEIGHT_MIN + LANES_FRAME;
        let left = room - analog as f32 * PLOT_HEIGHT_MIN;
        (lanes as f32 * lane + LANES_FRAME).min(left.max(least))
    };
    let plot_height = if analog == 0 {
        0.0
    } else {
        ((room - lanes_height) / analog as f32).max(PLOT_HEIGHT_MIN)
    };
    (plot_height, lanes_height)
}

/// A signal's line, broken where a band (a stretch without samples) cuts it; the points
/// handed over as they are when nothing cuts them.
pub(super) fn draw_runs(
    plot_ui: &mut PlotUi,
    name: &str,
    color: Color32,
    points: Vec<[f64; 2]>,
    bands: &[Band],
) {
    let runs = split_at_bands(&points, bands);
    if runs.len() == 1 {
        plot_ui.line(Line::new(name, points).color(color).width(1.5));
        return;
    }
    for run in runs {
        plot_ui.line(Line::new(name, run.to_vec()).color(color).width(1.5));
    }
}

/// Values times `scale` (positions in degrees or revolutions), times moved by `offset`.
pub(super) fn scale_values(points: &mut [[f64; 2]], scale: f64, offset: f64) {
    if scale != 1.0 || offset != 0.0 {
        for p in points {
            p[0] += offset;
            p[1] *= scale;
        }
    }
}

/// The trigger's moment and level, and the moment marked from the timeline.
pub(super) fn draw_moments(plot_ui: &mut PlotUi, view: &View<'_>, level: Option<f64>) {
    if let Some(at) = view.trigger_at {
        // Unnamed: a name would put it in every plot's legend.
        plot_ui.add(VLine::new("", at).color(RED).width(1.5).allow_hover(false));
    }
    for (k, at) in view.cursors.iter().enumerate() {
        if let Some(at) = at {
            plot_ui.add(
                VLine::new("", *at)
                    .color(CURSOR_COLORS[k])
                    .width(1.5)
                    .allow_hover(false),
            );
        }
    }
    if let Some(at) = view.highlight {
        plot_ui.add(
            VLine::new("", at)
                .color(AMBER)
                .width(2.0)
                .allow_hover(false),
        );
    }
    if let Some(level) = level {
        plot_ui.add(
            egui_plot::HLine::new("trigger level", level)
                .color(RED)
                .style(LineStyle::dashed_loose()),
        );
    }
}

/// What the next frame needs of this one: where the plots were (the read-out's pointer),
/// the cursor placed, the span shown; a double click (follow again) and a pan or zoom
/// (show that span) are the user's commands.
fn remember_view(
    ctx: &egui::Context,
    p: &mut Plots<'_>,
    interaction: Interaction,
    (from, to): (f64, f64),
) {
    let view = &mut *p.view;
    if let Some((k, at)) = interaction.placed
        && let Some(cursor) = view.cursors.get_mut(k)
    {
        *cursor = Some(at);
    }
    view.shown_range = Some((from, to));
    view.drawn = interaction.drawn;
    if interaction.follow_again {
        p.commands.push(Command::Plot(PlotCommand::FollowAgain));
    } else if let Some((from, to)) = interaction.asked {
        p.commands
            .push(Command::Plot(PlotCommand::ShowSpan { from, to }));
        // The span asked for is drawn in the next frame, also when no input comes to
        // wake it (the last step of a drag, the wheel's last bit).
        ctx.request_repaint();
    }
}

/// The time axis: a label every 1, 2 or 5 × 10ⁿ s, about one per 90 points whatever the
/// zoom (egui_plot's decades show one label per 10 s on a 10 s window, none when zoomed
/// in between two), each with the decimals its step needs.
pub(super) fn time_axis<'a>() -> Vec<egui_plot::AxisHints<'a>> {
    vec![
        egui_plot::AxisHints::new_x()
            .label(egui::RichText::new("time [s]").small())
            .label_spacing(40.0..=60.0)
            .formatter(|mark, _| time_label(mark.value, mark.step_size)),
    ]
}

/// A time at `step`'s precision: "12 s" steps give "12", "0.05 s" steps "12.35" (the
/// y axes' rule, `groups::value_label`).
fn time_label(value: f64, step: f64) -> String {
    super::groups::value_label(value, step)
}

/// The time axis's marks: labelled ones at 1, 2 or 5 × 10ⁿ s about 90 points apart, and
/// finer unlabelled ones between.
pub(super) fn time_steps(input: egui_plot::GridInput) -> Vec<egui_plot::GridMark> {
    let (min, max) = input.bounds;
    let span = max - min;
    if !span.is_finite() || span <= 0.0 || input.base_step_size <= 0.0 {
        return Vec::new();
    }
    // base_step_size is the time of egui_plot's smallest grid spacing (8 points).
    let step = super::groups::nice_step(input.base_step_size / 8.0 * 90.0);
    steps_between(min, max, &[(step, 200), (step / 5.0, 1000)])
}

/// Marks every `size` between `min` and `max`, for each (size, most marks) that fits.
fn steps_between(min: f64, max: f64, sizes: &[(f64, i64)]) -> Vec<egui_plot::GridMark> {
    let mut marks = Vec::new();
    for &(size, limit) in sizes {
        let first = (min / size).ceil() as i64;
        let last = (max / size).floor() as i64;
        if last - first > limit {
            continue;
        }
        marks.extend((first..=last).map(|k| egui_plot::GridMark {
            value: k as f64 * size,
            step_size: size,
        }));
    }
    marks
}

impl Interaction {
    /// One plot drawn on `span` (its points decimated for `decimated`): where it was, a
    /// cursor placed by a click, a double click, the span a pan or zoom over it asks for.
    /// Times under the pointer come from the transform the plot was drawn with (egui_plot's
    /// `pointer_coordinate` is the last frame's).
    fn absorb<R>(
        &mut self,
        ui: &Ui,
        plot: &egui_plot::PlotResponse<R>,
        id: &str,
        span: (f64, f64),
        decimated: (f64, f64),
        lines: Vec<(String, Option<LineExtent>)>,
    ) {
        let (response, transform) = (&plot.response, &plot.transform);
        self.right = self.right.max(response.rect.right());
        let (frame, bounds) = (transform.frame(), transform.bounds());
        let visible = frame.intersect(ui.clip_rect());
        self.drawn.push(DrawnPlot {
            id: id.to_owned(),
            frame: [frame.min.x, frame.min.y, frame.max.x, frame.max.y],
            visible: [visible.min.x, visible.min.y, visible.max.x, visible.max.y],
            axis: (bounds.min()[0], bounds.max()[0]),
            decimated,
            line: lines.first().and_then(|(_, line)| *line),
            lines,
        });
        let time_at = |pos: egui::Pos2| transform.value_from_position(pos).x;
        if let Some(pos) = response.interact_pointer_pos() {
            if response.clicked() {
                self.placed = Some((0, time_at(pos)));
            } else if response.secondary_clicked() {
                self.placed = Some((1, time_at(pos)));
            }
        }
        if response.double_clicked() {
            self.follow_again = true;
        } else if self.asked.is_none() {
            self.asked = navigate::asked(ui, response, transform, span);
        }
    }
}

/// Every stretch without samples shaded, with its edges; labelled ("no link 12.3 s") on
/// the top plot.
pub(super) fn draw_bands(plot_ui: &mut PlotUi, bands: &[Band], labels: bool) {
    let top = plot_ui.plot_bounds().max()[1];
    for band in bands {
        plot_ui.add(
            Span::new("", band.from..=band.to)
                .fill(GAP_FILL)
                .border(egui::Stroke::new(1.0, AMBER))
                .border_style(LineStyle::dashed_loose()),
        );
        if labels {
            plot_ui.text(
                Text::new(
                    "",
                    egui_plot::PlotPoint::new((band.from + band.to) / 2.0, top),
                    &band.label,
                )
                .anchor(egui::Align2::CENTER_TOP)
                .color(AMBER)
                .allow_hover(false),
            );
        }
    }
}

/// A dashed line for every command sent, labelled (the newest few) on the top plot.
pub(super) fn draw_markers(plot_ui: &mut PlotUi, markers: &[(f64, &str)], labels: bool) {
    for (t, _) in markers {
        plot_ui.add(
            VLine::new("", *t)
                .color(GREY)
                .style(LineStyle::dashed_dense())
                .allow_hover(false),
        );
    }
    if labels {
        let top = plot_ui.plot_bounds().max()[1];
        for (t, text) in markers.iter().rev().take(MARKER_LABELS) {
            // The command's name; its values are in the log and the exported file.
            let name = text.split(':').next().unwrap_or(text);
            plot_ui.text(
                Text::new("", egui_plot::PlotPoint::new(*t, top), name)
                    .anchor(egui::Align2::LEFT_TOP)
                    .color(GREY)
                    .allow_hover(false),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_drives_have_sixteen_colours() {
        let mut seen: Vec<Color32> = (0..16).map(drive_color).collect();
        seen.sort_by_key(|c| c.to_array());
        seen.dedup();
        assert_eq!(seen.len(), 16);
        assert_eq!(
            drive_color(16),
            drive_color(0),
            "then they come round again"
        );
    }

    #[test]
    fn time_labels_keep_the_decimals_their_step_needs_at_every_zoom() {
        assert_eq!(time_label(12.0, 2.0), "12");
        assert_eq!(time_label(12.35, 0.05), "12.35");
        assert_eq!(time_label(12.3456, 0.0002), "12.3456");
        assert_eq!(time_label(-0.0, 0.5), "0.0");
        assert_eq!(super::super::groups::nice_step(0.37), 0.5);
        assert_eq!(super::super::groups::nice_step(3.0), 5.0);
        // A 2 ms window 1000 points wide: a label every 0.2 ms, each one different.
        let marks = time_steps(egui_plot::GridInput {
            bounds: (100.0, 100.002),
            base_step_size: 0.002 / 1000.0 * 8.0,
        });
        let labelled: Vec<String> = marks
            .iter()
            .filter(|m| m.step_size > 1e-4)
            .map(|m| time_label(m.value, m.step_size))
            .collect();
        assert!(labelled.len() >= 5, "{labelled:?}");
        let mut unique = labelled.clone();
        unique.dedup();
        assert_eq!(unique, labelled);
    }

    #[test]
    fn every_trace_has_a_colour_of_its_own() {
        let mut scope = Scope::new(10);
        let objects: Vec<crate::telemetry::WatchedObject> = [0x2031u16, 0x6065, 0x6073, 0x6075]
            .into_iter()
            .map(|index| crate::telemetry::WatchedObject {
                address: crate::od::Address::new(index, 0),
                name: format!("{index:04X}"),
                unit: String::new(),
            })
            .collect();
        scope.set_watched(&objects);
        let colors = colors(scope.signals());
        let analog: Vec<Color32> = scope
            .signals()
            .iter()
            .zip(&colors)
            .filter(|(s, _)| s.kind == Kind::Analog)
            .map(|(_, c)| *c)
            .collect();
        for (i, c) in analog.iter().enumerate() {
            assert!(
                !analog[..i].contains(c),
                "colour {i} used twice: {analog:?}"
            );
        }
    }

    #[test]
    fn the_plots_and_lanes_fit_the_height_there_is_or_keep_their_minimum() {
        for (available, analog, lanes) in [
            (320.0, 5, 3),
            (320.0, 3, 6),
            (700.0, 3, 5),
            (400.0, 0, 11),
            (250.0, 4, 4),
            (900.0, 4, 6),
        ] {
            let (plot, lane_plot) = heights(available, analog, lanes);
            let used = plot * analog as f32 + lane_plot + PLOT_SPACING * (analog + 1) as f32;
            // Every plot at its minimum at least; all of them within the height there is
            // unless that is less than their minimums (then the plots scroll).
            assert!(plot >= PLOT_HEIGHT_MIN || analog == 0);
            if lanes > 0 {
                assert!((lane_plot - LANES_FRAME) / lanes as f32 >= LANE_HEIGHT_MIN);
            }
            let least = PLOT_HEIGHT_MIN * analog as f32
                + lanes as f32 * LANE_HEIGHT_MIN
                + LANES_FRAME
                + PLOT_SPACING * (analog + 1) as f32
                + 4.0;
            if least <= available {
                assert!(
                    used <= available,
                    "{available} {analog} {lanes}: {plot} {lane_plot}"
                );
            }
        }
        // Room to spare: lanes at their full height, the analog plots share the rest.
        let (plot, lanes) = heights(900.0, 3, 5);
        assert_eq!(lanes, 5.0 * LANE_HEIGHT + LANES_FRAME);
        assert!(plot > 150.0, "{plot}");
    }

    #[test]
    fn a_column_keeps_its_lowest_and_highest_point_in_time_order() {
        // Two columns of 1 s between 0 and 2, four points each, and the neighbours.
        let points = vec![
            [-0.5, 7.0],
            [0.1, 1.0],
            [0.2, 9.0],
            [0.3, -3.0],
            [0.4, 2.0],
            [1.1, 5.0],
            [1.2, 4.0],
            [1.3, 6.0],
            [1.4, 5.5],
            [2.5, 0.0],
        ];
        let thinned = extremes_per_column(points.clone(), 0.0, 2.0, 2);
        assert_eq!(
            thinned,
            [
                [-0.5, 7.0],
                [0.2, 9.0],
                [0.3, -3.0],
                [1.2, 4.0],
                [1.3, 6.0],
                [2.5, 0.0]
            ]
        );
        // Few points per column: as they are.
        assert_eq!(extremes_per_column(points.clone(), 0.0, 2.0, 4), points);
    }

    #[test]
    fn no_line_is_drawn_across_a_gap() {
        let points = [
            [0.0, 1.0],
            [0.9, 2.0],
            [13.2, 3.0],
            [13.3, 4.0],
            [20.0, 5.0],
        ];
        let bands = [Band {
            from: 0.9,
            to: 13.2,
            label: String::new(),
        }];
        let runs = split_at_bands(&points, &bands);
        assert_eq!(runs, [&points[..2], &points[2..]]);
        assert_eq!(split_at_bands(&points, &[]), [&points[..]]);
        assert!(split_at_bands(&[], &bands).is_empty());
    }
}
