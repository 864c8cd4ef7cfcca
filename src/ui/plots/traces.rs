//! The stacked plots: one per analog signal, then the digital lanes, all on one linked
//! time axis, each drawn from the history's min/max decimation at one point group per
//! pixel column, so the whole history draws without dropping a peak.

use eframe::egui::{self, Color32, Ui};
use egui_plot::{Legend, Line, LineStyle, Plot, PlotBounds, PlotUi, Span, Text, VLine};

use super::super::state::AppState;
use super::super::widgets::{AMBER, BLUE, GREEN, RED};
use super::time_range;
use crate::telemetry::{
    BitSpan, Builtin, CaptureState, Condition, Kind, Ring, SignalDef, bit_name,
};

/// Height of one digital lane, in points: at most, and at least (the lanes take up to
/// 40 % of the panel between the two).
const LANE_HEIGHT: f32 = 16.0;
const LANE_HEIGHT_MIN: f32 = 9.0;
/// Width of every plot's y axis, so the time axes line up.
const Y_AXIS_WIDTH: f32 = 56.0;
/// The lowest an analog plot gets.
const PLOT_HEIGHT_MIN: f32 = 40.0;
/// Marker labels drawn per plot at most (all markers get their line).
const MARKER_LABELS: usize = 24;

const PURPLE: Color32 = Color32::from_rgb(150, 110, 210);
const TEAL: Color32 = Color32::from_rgb(60, 190, 190);
const GREY: Color32 = Color32::from_gray(150);
/// The shade of a stretch without samples.
const GAP_FILL: Color32 = Color32::from_rgba_premultiplied(60, 40, 40, 60);

fn color_of(signal: &SignalDef, index: usize) -> Color32 {
    match signal.builtin() {
        Some(Builtin::Position) => BLUE,
        Some(Builtin::Velocity) => GREEN,
        Some(Builtin::Torque) => AMBER,
        Some(Builtin::FollowingError) => RED,
        Some(Builtin::AnalogInput) => PURPLE,
        Some(Builtin::ReturnValue) => TEAL,
        _ => [PURPLE, TEAL, AMBER, GREEN, BLUE, RED][index % 6],
    }
}

/// A lane to draw: which bit of which bit signal.
struct Lane {
    column: usize,
    bit: u8,
    name: String,
}

/// A stretch without samples in view (a lost link, a disconnect): shaded, labelled, and
/// no line drawn across it.
struct Band {
    from: f64,
    to: f64,
    label: String,
}

/// What the plots report back for the next frame.
#[derive(Default)]
struct Interaction {
    cursor: Option<f64>,
    range: Option<(f64, f64)>,
    user_moved: bool,
    follow_again: bool,
}

/// What every plot of one frame shares: the time span, whether it follows the newest
/// sample, the linked axis, and the marks drawn across all plots.
struct View<'a> {
    ring: &'a Ring,
    from: f64,
    to: f64,
    follow: bool,
    group: egui::Id,
    markers: Vec<(f64, &'a str)>,
    /// The gaps in view, oldest first.
    bands: Vec<Band>,
    highlight: Option<f64>,
    trigger_at: Option<f64>,
    /// The threshold trigger's signal column and level.
    threshold: Option<(usize, f64)>,
}

impl<'a> View<'a> {
    fn new(state: &'a AppState, from: f64, to: f64) -> Self {
        let markers = state
            .scope
            .markers()
            .filter(|m| m.t >= from && m.t <= to)
            .map(|m| (m.t, m.text.as_str()))
            .collect();
        let trigger_at = match state.scope.capture_state() {
            CaptureState::Fired { at } | CaptureState::Complete { at, .. } => Some(at),
            _ => None,
        };
        let threshold = state.scope.trigger().and_then(|t| match t.condition {
            Condition::Threshold { channel, level, .. } => Some((channel, level)),
            Condition::Bit { .. } => None,
        });
        View {
            ring: state.scope.ring(),
            from,
            to,
            follow: state.plot.follow,
            group: egui::Id::unique("plots_time_axis"),
            markers,
            bands: bands(state, from, to),
            highlight: state.plot.highlight,
            trigger_at,
            threshold,
        }
    }
}

/// The gaps between `from` and `to`; one still open reaches to now (while the link is
/// lost, the plots run on to show it grow).
fn bands(state: &AppState, from: f64, to: f64) -> Vec<Band> {
    let now = super::live_end(state).unwrap_or(to);
    state
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

/// Where the pointer is on the time axis, and the span the plot showed.
type Seen = (Option<f64>, (f64, f64));

pub fn traces_ui(ui: &mut Ui, state: &mut AppState) {
    let Some((from, to)) = time_range(state) else {
        ui.add_space(8.0);
        ui.weak("Waiting for samples: connect to a drive (or the simulated one).");
        return;
    };
    let analog: Vec<(usize, &SignalDef)> = state
        .scope
        .signals()
        .iter()
        .enumerate()
        .filter(|(_, s)| state.scope.is_drawn(s) && s.kind == Kind::Analog)
        .collect();
    let lanes = lanes(state, from, to);
    let (plot_height, lanes_height) = heights(ui.available_height(), analog.len(), lanes.len());
    let view = View::new(state, from, to);
    let mut interaction = Interaction::default();
    let top = ui.cursor().min;

    for (n, (index, signal)) in analog.iter().enumerate() {
        // The time labels once, under the lowest plot.
        let time_labels = n + 1 == analog.len() && lanes.is_empty();
        let response = analog_plot_ui(ui, &view, *index, signal, plot_height, n == 0, time_labels);
        interaction.absorb(ui, &response.response, response.inner);
    }
    if !lanes.is_empty() {
        let response = lanes_plot_ui(ui, &view, &lanes, lanes_height);
        interaction.absorb(ui, &response.response, response.inner);
    }

    let bottom = ui.cursor().min;
    let plots = egui::Rect::from_min_max(top, egui::pos2(top.x + ui.available_width(), bottom.y));
    remember_view(state, &interaction, plots, (from, to));
}

/// The height of each analog plot and of the lanes' plot: the lanes take what they need
/// (up to 35 % while analog plots share the panel), the analog plots share the rest.
fn heights(available: f32, analog: usize, lanes: usize) -> (f32, f32) {
    let lanes_height = if lanes == 0 {
        0.0
    } else {
        let share = if analog == 0 { 1.0 } else { 0.35 };
        let lane = ((available * share - 40.0) / lanes as f32).clamp(LANE_HEIGHT_MIN, LANE_HEIGHT);
        lanes as f32 * lane + 40.0
    };
    let plot_height = if analog == 0 {
        0.0
    } else {
        ((available - lanes_height - 8.0) / analog as f32).max(PLOT_HEIGHT_MIN)
    };
    (plot_height, lanes_height)
}

/// One analog signal's plot, on the shared time axis; the first labels the markers, the
/// lowest the time axis.
fn analog_plot_ui(
    ui: &mut Ui,
    view: &View<'_>,
    index: usize,
    signal: &SignalDef,
    height: f32,
    first: bool,
    time_labels: bool,
) -> egui_plot::PlotResponse<Seen> {
    let label = if signal.info.unit.is_empty() {
        signal.info.name.clone()
    } else {
        format!("{} [{}]", signal.info.name, signal.info.unit)
    };
    let color = color_of(signal, index);
    let column = signal.column;
    let level = view.threshold.filter(|(c, _)| *c == column).map(|(_, l)| l);
    Plot::new(("plot", signal.info.id.as_str()))
        .height(height)
        .link_axis(view.group, [true, false])
        .link_cursor(view.group, [true, false])
        // Top left: the newest samples come in on the right.
        .legend(Legend::default().position(egui_plot::Corner::LeftTop))
        .allow_double_click_reset(false)
        // Three or four labelled values on a low plot (egui_plot's decades give one).
        .custom_y_axes(vec![
            egui_plot::AxisHints::new_y().label_spacing(10.0..=16.0),
        ])
        .y_grid_spacer(nice_steps)
        .y_axis_min_width(Y_AXIS_WIDTH)
        .custom_x_axes(time_axis())
        .show_axes([time_labels, true])
        .show(ui, |plot_ui| {
            let (from, to) = visible(plot_ui, view.follow, view.from, view.to);
            let columns = plot_ui.transform().frame().width().max(1.0) as usize;
            let points = view.ring.decimate(column, from, to, columns);
            if view.follow {
                plot_ui.set_plot_bounds(follow_bounds(&points, from, to, level));
            }
            draw_bands(plot_ui, &view.bands, first);
            draw_markers(plot_ui, &view.markers, first);
            draw_moments(plot_ui, view, level);
            for run in split_at_bands(&points, &view.bands) {
                plot_ui.line(Line::new(label.as_str(), run.to_vec()).color(color));
            }
            (plot_ui.pointer_coordinate().map(|p| p.x), (from, to))
        })
}

/// The trigger's moment and level, and the moment marked from the timeline.
fn draw_moments(plot_ui: &mut PlotUi, view: &View<'_>, level: Option<f64>) {
    if let Some(at) = view.trigger_at {
        plot_ui.add(VLine::new("trigger", at).color(RED).width(1.5));
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

/// The digital lanes, one plot under the analog ones, on the same time axis.
fn lanes_plot_ui(
    ui: &mut Ui,
    view: &View<'_>,
    lanes: &[Lane],
    height: f32,
) -> egui_plot::PlotResponse<Seen> {
    Plot::new("plot_lanes")
        .height(height - 8.0)
        .link_axis(view.group, [true, false])
        .link_cursor(view.group, [true, false])
        .allow_double_click_reset(false)
        .allow_zoom([true, false])
        .allow_drag([true, false])
        .show_grid([true, false])
        .y_axis_min_width(Y_AXIS_WIDTH)
        .y_axis_formatter(|_, _| String::new())
        .y_grid_spacer(|_| Vec::new())
        .custom_x_axes(time_axis())
        .show(ui, |plot_ui| {
            let (from, to) = visible(plot_ui, view.follow, view.from, view.to);
            if view.follow {
                plot_ui.set_plot_bounds(PlotBounds::from_min_max(
                    [from, -0.5],
                    [to, lanes.len() as f64 * 1.5],
                ));
            }
            draw_bands(plot_ui, &view.bands, false);
            draw_markers(plot_ui, &view.markers, false);
            draw_lanes(plot_ui, view, lanes, from, to);
            (plot_ui.pointer_coordinate().map(|p| p.x), (from, to))
        })
}

/// Each lane's line, 1.5 apart, its name at the left edge over the trace.
fn draw_lanes(plot_ui: &mut PlotUi, view: &View<'_>, lanes: &[Lane], from: f64, to: f64) {
    let columns = plot_ui.transform().frame().width().max(1.0) as usize;
    let mut last_column = None;
    let mut spans: Vec<BitSpan> = Vec::new();
    for (k, lane) in lanes.iter().enumerate() {
        if last_column != Some(lane.column) {
            spans = view.ring.decimate_bits(lane.column, from, to, columns);
            last_column = Some(lane.column);
        }
        let base = k as f64 * 1.5;
        let color = if k % 2 == 0 { GREEN } else { BLUE };
        let points = lane_points(&spans, lane.bit, base);
        for run in split_at_bands(&points, &view.bands) {
            plot_ui.line(Line::new("", run.to_vec()).color(color));
        }
        plot_ui.text(
            Text::new("", egui_plot::PlotPoint::new(from, base + 0.5), &lane.name)
                .anchor(egui::Align2::LEFT_CENTER)
                .color(Color32::from_gray(210))
                .allow_hover(false),
        );
    }
}

/// What the next frame needs of this one: where the plots were, the cursor, whether to
/// follow, and the span shown.
fn remember_view(
    state: &mut AppState,
    interaction: &Interaction,
    plots: egui::Rect,
    (from, to): (f64, f64),
) {
    state.plot.plots_rect = Some(plots);
    state.plot.cursor = interaction.cursor;
    if interaction.follow_again {
        state.plot.follow = true;
    } else if interaction.user_moved {
        state.plot.follow = false;
    }
    if !state.plot.follow || interaction.user_moved {
        state.plot.shown_range = interaction.range;
    } else {
        state.plot.shown_range = Some((from, to));
    }
}

/// Grid marks at 1, 2 or 5 × 10ⁿ, about three per plot, with finer unlabelled lines.
fn nice_steps(input: egui_plot::GridInput) -> Vec<egui_plot::GridMark> {
    let (min, max) = input.bounds;
    let span = max - min;
    if !span.is_finite() || span <= 0.0 {
        return Vec::new();
    }
    let raw = span / 3.0;
    let decade = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * decade);
    let mut marks = Vec::new();
    for (size, limit) in [(step, 16), (step / 5.0, 80)] {
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

/// The time axis: labels closer together than egui_plot's default (which shows one
/// label per 10 s on a 10 s window).
fn time_axis<'a>() -> Vec<egui_plot::AxisHints<'a>> {
    vec![
        egui_plot::AxisHints::new_x()
            .label("time [s]")
            .label_spacing(34.0..=48.0),
    ]
}

impl Interaction {
    fn absorb(&mut self, ui: &Ui, response: &egui::Response, (cursor, range): Seen) {
        if cursor.is_some() && response.hovered() {
            self.cursor = cursor;
        }
        self.range.get_or_insert(range);
        if response.double_clicked() {
            self.follow_again = true;
        } else if response.dragged()
            || (response.hovered()
                && ui.input(|i| i.smooth_scroll_delta != egui::Vec2::ZERO || i.zoom_delta() != 1.0))
        {
            self.user_moved = true;
        }
    }
}

/// The time span this plot shows: ours while following, the plot's own (zoomed, panned)
/// otherwise.
fn visible(plot_ui: &PlotUi, follow: bool, from: f64, to: f64) -> (f64, f64) {
    if follow {
        return (from, to);
    }
    let b = plot_ui.plot_bounds();
    let (min, max) = (b.min()[0], b.max()[0]);
    if min.is_finite() && max.is_finite() && max > min {
        (min, max)
    } else {
        (from, to)
    }
}

/// The time span on x, the data's range with a margin on y (a flat line is not squeezed
/// into nothing); a trigger level stays in view.
fn follow_bounds(points: &[[f64; 2]], from: f64, to: f64, level: Option<f64>) -> PlotBounds {
    let (mut low, mut high) = points
        .iter()
        .filter(|p| p[0] >= from && p[0] <= to)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[1]), hi.max(p[1]))
        });
    if let Some(level) = level {
        low = low.min(level);
        high = high.max(level);
    }
    if !low.is_finite() || !high.is_finite() {
        (low, high) = (-1.0, 1.0);
    }
    let span = (high - low).max(2.0);
    let margin = span * 0.08;
    let middle = (high + low) / 2.0;
    PlotBounds::from_min_max(
        [from, middle - span / 2.0 - margin],
        [to, middle + span / 2.0 + margin],
    )
}

/// Every stretch without samples shaded, with its edges; labelled ("no link 12.3 s") on
/// the top plot.
fn draw_bands(plot_ui: &mut PlotUi, bands: &[Band], labels: bool) {
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
fn draw_markers(plot_ui: &mut PlotUi, markers: &[(f64, &str)], labels: bool) {
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

/// The lanes to draw: every named PDI-Status bit, and the digital inputs that were on
/// somewhere in view (the limit and home switches when none was).
fn lanes(state: &AppState, from: f64, to: f64) -> Vec<Lane> {
    let ring = state.scope.ring();
    let mut lanes = Vec::new();
    for signal in state.scope.signals() {
        if !state.scope.is_drawn(signal)
            || signal.kind != Kind::Bits
            || ring.latest(signal.column).is_none()
        {
            continue;
        }
        let builtin = signal.builtin();
        let bits: Vec<u8> = match builtin {
            Some(Builtin::PdiStatus) => crate::pdi::StatusBit::ALL
                .into_iter()
                .map(|b| b.bit())
                .collect(),
            _ => {
                let any = ring
                    .decimate_bits(signal.column, from, to, 1)
                    .iter()
                    .fold(0, |acc, s| acc | s.any);
                let on: Vec<u8> = (0..32).filter(|b| any & (1 << b) != 0).collect();
                if on.is_empty() { vec![0, 1, 2] } else { on }
            }
        };
        lanes.extend(bits.into_iter().map(|bit| Lane {
            column: signal.column,
            bit,
            name: bit_name(builtin, bit),
        }));
    }
    lanes
}

/// One lane's line: low (base) where the bit was 0 throughout a pixel column, high where
/// it was 1 throughout, a filled-looking zigzag where it changed inside the column.
fn lane_points(spans: &[BitSpan], bit: u8, base: f64) -> Vec<[f64; 2]> {
    let mask = 1u32 << bit;
    let high = base + 1.0;
    let mut out = Vec::with_capacity(spans.len() * 2);
    for span in spans {
        let any = span.any & mask != 0;
        let all = span.all & mask != 0;
        if all {
            out.push([span.t0, high]);
            out.push([span.t1, high]);
        } else if !any {
            out.push([span.t0, base]);
            out.push([span.t1, base]);
        } else {
            out.push([span.t0, base]);
            out.push([span.t0, high]);
            out.push([span.t1, base]);
            out.push([span.t1, high]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
