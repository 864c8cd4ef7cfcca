//! The status-bit lanes: one plot under the analog ones, on their time axis, with a lane
//! per bit of a bit signal (the PDI-Status bits, the digital inputs). Each lane is a thin
//! line at its low level with the stretches where the bit was high filled in its colour,
//! drawn from the history's per-column bit decimation as one rectangle per high run (not
//! per pixel column), broken where a gap (a lost link) cuts it; its name at the left edge.

use eframe::egui::{self, Color32, Ui};
use egui_plot::{FilledArea, Line, Plot, PlotBounds, PlotUi};

use super::analog::{Axes, blank_y_axes};
use super::navigate;
use super::traces::{
    Band, PALETTE, View, draw_bands, draw_markers, draw_moments, time_axis, time_steps,
};
use crate::telemetry::ring::Decimations;
use crate::telemetry::{BitSpan, Builtin, Kind, Scope, bit_name};

/// The PDI-Status lanes drawn even when low throughout.
const ALWAYS_LANES: [crate::pdi::StatusBit; 3] = [
    crate::pdi::StatusBit::OperationEnabled,
    crate::pdi::StatusBit::TargetReached,
    crate::pdi::StatusBit::Fault,
];
/// The lane labels' size, in points.
const LANE_LABEL_SIZE: f32 = 13.0;

/// A lane's colour: the lamp colour of what its bit means where the status panel has
/// one, a colour of its own otherwise.
fn lane_color(k: usize) -> Color32 {
    PALETTE[k % PALETTE.len()]
}

/// A lane to draw: which bit of which bit signal.
pub(super) struct Lane {
    column: usize,
    bit: u8,
    name: String,
    /// "signal id:bit", how a hidden lane is remembered.
    key: String,
}

/// What the lanes say, for their labels: each lane's name, the value of its middle on
/// the plot's y axis, its colour, and whether it is high at the right edge.
pub(super) struct LaneLabels {
    rows: Vec<(String, f64, Color32, bool)>,
}

/// The lanes to draw: the PDI-Status bits that were high somewhere in view (and always
/// operation enabled, target reached and fault), and the digital inputs that were on
/// somewhere in view (the limit and home switches when none was).
pub(super) fn lanes(scope: &Scope, from: f64, to: f64, decimations: &mut Decimations) -> Vec<Lane> {
    let ring = scope.ring();
    let mut lanes = Vec::new();
    for signal in scope.signals() {
        if !scope.is_drawn(signal)
            || signal.kind != Kind::Bits
            || ring.latest(signal.column).is_none()
        {
            continue;
        }
        let builtin = signal.builtin();
        let any = decimations
            .bits(ring, signal.column, from, to, 1)
            .iter()
            .fold(0, |acc, s| acc | s.any);
        let bits: Vec<u8> = match builtin {
            // The bits that were high somewhere in view, and always whether the drive is
            // on, at its target, faulted: a bit low throughout says nothing new.
            Some(Builtin::PdiStatus) => crate::pdi::StatusBit::ALL
                .into_iter()
                .filter(|b| any & u32::from(b.mask()) != 0 || ALWAYS_LANES.contains(b))
                .map(|b| b.bit())
                .collect(),
            _ => {
                let on: Vec<u8> = (0..32).filter(|b| any & (1 << b) != 0).collect();
                if on.is_empty() { vec![0, 1, 2] } else { on }
            }
        };
        lanes.extend(bits.into_iter().map(|bit| Lane {
            column: signal.column,
            bit,
            name: bit_name(builtin, bit),
            key: super::model::lane_key(&signal.info.id, bit),
        }));
    }
    lanes
}

/// The lanes to draw of `candidates`: those the user did not hide (`hidden`, by key).
pub(super) fn shown_lanes(candidates: Vec<Lane>, hidden: &[String]) -> Vec<Lane> {
    candidates
        .into_iter()
        .filter(|lane| !hidden.contains(&lane.key))
        .collect()
}

impl Lane {
    /// Its key in the settings and its name, for the Signals menu.
    pub(super) fn key_and_name(&self) -> (String, String) {
        (self.key.clone(), self.name.clone())
    }
}

/// The digital lanes, one plot under the analog ones, on the same time axis; the span
/// their bits were decimated for, and their labels.
pub(super) fn lanes_plot_ui(
    ui: &mut Ui,
    view: &View<'_>,
    lanes: &[Lane],
    height: f32,
    axes: Axes,
) -> egui_plot::PlotResponse<((f64, f64), LaneLabels)> {
    navigate::fixed(Plot::new("plot_lanes"))
        .height(height - 8.0)
        .link_cursor(view.group, [true, false])
        .show_grid([true, false])
        .custom_y_axes(blank_y_axes(axes))
        .y_grid_spacer(|_| Vec::new())
        .custom_x_axes(time_axis())
        .x_grid_spacer(time_steps)
        // The time labels are under the plots' scroll area.
        .show_axes([false, true])
        .show(ui, |plot_ui| {
            let (from, to) = (view.from, view.to);
            // Lane k from the top: its low line at (n - 1 - k) * 1.5, its high one 1 above.
            plot_ui.set_plot_bounds(PlotBounds::from_min_max(
                [from, -0.35],
                [to, lanes.len() as f64 * 1.5 - 0.15],
            ));
            draw_bands(plot_ui, &view.bands, false);
            draw_markers(plot_ui, &view.markers, false);
            draw_moments(plot_ui, view, None);
            let labels = draw_lanes(plot_ui, view, lanes, from, to);
            ((from, to), labels)
        })
}

/// Each lane, 1.5 apart, the first on top: its high stretches filled in its colour over
/// a thin low line, so high and low are told apart at a glance. Per lane one filled area
/// (a rectangle per high run) and a line per stretch between gaps (a step at each
/// change), whatever the number of pixel columns.
fn draw_lanes(
    plot_ui: &mut PlotUi,
    view: &View<'_>,
    lanes: &[Lane],
    from: f64,
    to: f64,
) -> LaneLabels {
    // This frame's width (the transform is the last frame's).
    let columns = plot_ui.response().rect.width().max(1.0) as usize;
    let mut last_column = None;
    let mut spans: Vec<BitSpan> = Vec::new();
    let mut rows = Vec::new();
    for (k, lane) in lanes.iter().enumerate() {
        if last_column != Some(lane.column) {
            spans = view
                .decimations
                .borrow_mut()
                .bits(view.ring, lane.column, from, to, columns);
            last_column = Some(lane.column);
        }
        let base = (lanes.len() - 1 - k) as f64 * 1.5;
        let color = lane_color(k);
        let stretches = stretches(&spans, lane.bit, (from, to), columns, &view.bands);
        let (xs, highs) = fill_outline(&stretches, base);
        if !xs.is_empty() {
            let lows = vec![base; xs.len()];
            plot_ui.add(
                FilledArea::new("", &xs, &lows, &highs)
                    .fill_color(color.gamma_multiply(0.55))
                    .allow_hover(false),
            );
        }
        for stretch in &stretches {
            // Not as a band: egui_plot draws a line whose points lie within a pixel of each
            // other as one band between pixel columns, joined by slopes, and a step (two
            // points at one time) far from the point before it became a wedge.
            plot_ui.line(
                Line::new("", step_line(stretch, base))
                    .color(color)
                    .width(1.5)
                    .allow_band(false),
            );
        }
        let high_now = spans.last().is_some_and(|s| s.all & (1 << lane.bit) != 0);
        rows.push((lane.name.clone(), base + 0.5, color, high_now));
    }
    LaneLabels { rows }
}

/// A stretch of one lane with samples and no gap inside: where it begins and ends, and
/// the runs in it where the bit was high (in time order, apart, inside `from..=to`).
#[derive(Debug, Clone, PartialEq)]
struct Stretch {
    from: f64,
    to: f64,
    highs: Vec<(f64, f64)>,
}

/// One lane's runs from the decimation's `spans` (one per pixel column with samples, in
/// time order) of the view `from..to` in `columns` columns: neighbouring columns at one
/// level merge into one run; a column where the bit was high at least once counts as
/// high (a pulse shorter than a column shows, as the per-column drawing showed it); a run
/// narrower than a column is widened to its column (a single high sample is seen), inside
/// the view; a band (a gap) between two columns ends one stretch and begins the next.
fn stretches(
    spans: &[BitSpan],
    bit: u8,
    (from, to): (f64, f64),
    columns: usize,
    bands: &[Band],
) -> Vec<Stretch> {
    let mask = 1u32 << bit;
    let mut out: Vec<Stretch> = Vec::new();
    // The end of the last span, and whether it was high.
    let mut last: Option<(f64, bool)> = None;
    for span in spans {
        let cut = last.is_none_or(|(end, _)| {
            bands
                .iter()
                .any(|band| end <= band.from && span.t0 >= band.to)
        });
        let high = span.any & mask != 0;
        let after_high = !cut && last.is_some_and(|(_, h)| h);
        last = Some((span.t1, high));
        if cut {
            out.push(Stretch {
                from: span.t0,
                to: span.t1,
                highs: Vec::new(),
            });
        }
        let Some(stretch) = out.last_mut() else {
            continue;
        };
        stretch.to = span.t1;
        if !high {
            continue;
        }
        match stretch.highs.last_mut() {
            Some(run) if after_high => run.1 = span.t1,
            _ => stretch.highs.push((span.t0, span.t1)),
        }
    }
    for stretch in &mut out {
        widen(&mut stretch.highs, (from, to), columns);
        if let (Some(first), Some(last)) = (stretch.highs.first(), stretch.highs.last()) {
            stretch.from = stretch.from.min(first.0);
            stretch.to = stretch.to.max(last.1);
        }
    }
    out
}

/// Runs narrower than a column widened to the column their start is in (to its end, or
/// to theirs when they reach into the next one), all kept inside `from..=to`; runs that
/// then touch or overlap merge.
fn widen(runs: &mut Vec<(f64, f64)>, (from, to): (f64, f64), columns: usize) {
    if columns == 0 || to <= from {
        return;
    }
    let width = (to - from) / columns as f64;
    let last = (columns - 1) as f64;
    let mut merged: Vec<(f64, f64)> = Vec::with_capacity(runs.len());
    for &(a, b) in runs.iter() {
        let (a, b) = if b - a < width {
            let start = from + ((a - from) / width).floor().clamp(0.0, last) * width;
            (start, b.max(start + width).min(to))
        } else {
            (a.max(from), b.min(to))
        };
        match merged.last_mut() {
            Some(run) if a <= run.1 => run.1 = run.1.max(b),
            _ => merged.push((a, b)),
        }
    }
    *runs = merged;
}

/// The filled area of a lane's high runs, as [`FilledArea`] takes it (x, upper value; the
/// lower is `base`): per run its four corners, so that between two runs the upper and the
/// lower line meet and nothing is filled; no two points with different heights are
/// joined by a slope, so no run is drawn as a wedge.
fn fill_outline(stretches: &[Stretch], base: f64) -> (Vec<f64>, Vec<f64>) {
    let runs = stretches.iter().map(|s| s.highs.len()).sum::<usize>();
    let (mut xs, mut highs) = (Vec::with_capacity(4 * runs), Vec::with_capacity(4 * runs));
    for &(a, b) in stretches.iter().flat_map(|s| &s.highs) {
        xs.extend([a, a, b, b]);
        highs.extend([base, base + 1.0, base + 1.0, base]);
    }
    (xs, highs)
}

/// A stretch's line: at `base` where low, one above where high, a vertical step at each
/// change; it begins and ends at the level of the stretch's ends.
fn step_line(stretch: &Stretch, base: f64) -> Vec<[f64; 2]> {
    let high = base + 1.0;
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(4 * stretch.highs.len() + 2);
    let mut push = |p: [f64; 2]| {
        if out.last() != Some(&p) {
            out.push(p);
        }
    };
    let starts_high = stretch.highs.first().is_some_and(|r| r.0 <= stretch.from);
    if !starts_high {
        push([stretch.from, base]);
    }
    for &(a, b) in &stretch.highs {
        if a > stretch.from {
            push([a, base]);
        }
        push([a, high]);
        push([b, high]);
        if b < stretch.to {
            push([b, base]);
        }
    }
    if stretch.highs.last().is_none_or(|r| r.1 < stretch.to) {
        push([stretch.to, base]);
    }
    out
}

/// The lanes' names at the left edge of the lanes, legible over any trace: on a dark
/// plate, in the lane's colour, "= 1" after the name of a bit that is high at the right
/// edge.
///
/// Placed with the plot's final transform of this frame (the one inside the plot may be
/// the last frame's when the plot's size changed).
pub(super) fn lane_labels_ui(ui: &Ui, labels: &LaneLabels, transform: &egui_plot::PlotTransform) {
    let rect = *transform.frame();
    let painter = ui.painter_at(rect);
    let font = egui::FontId::proportional(LANE_LABEL_SIZE);
    for (name, middle, color, high) in &labels.rows {
        let y = transform
            .position_from_point(&egui_plot::PlotPoint::new(0.0, *middle))
            .y;
        let text = if *high {
            format!("{name} = 1")
        } else {
            name.clone()
        };
        let galley = painter.layout_no_wrap(text, font.clone(), *color);
        let at = egui::pos2(rect.left() + 4.0, y - galley.size().y / 2.0);
        let plate = egui::Rect::from_min_size(at, galley.size()).expand2(egui::vec2(3.0, 1.0));
        painter.rect_filled(plate, 3.0, Color32::from_black_alpha(200));
        painter.galley(at, galley, *color);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A column's span of 0.5 s (samples at its start and end) with bit 0 high in `any`
    /// and `all` as given.
    fn span(t: f64, any: u32, all: u32) -> BitSpan {
        BitSpan {
            t0: t,
            t1: t + 0.5,
            any,
            all,
        }
    }

    fn gap(from: f64, to: f64) -> Band {
        Band {
            from,
            to,
            label: String::new(),
        }
    }

    /// Ten columns of 1 s between 0 and 10.
    const VIEW: (f64, f64) = (0.0, 10.0);

    #[test]
    fn neighbouring_columns_at_one_level_are_one_run() {
        // High, high, changing, low, low, high, high.
        let spans = [
            span(0.0, 1, 1),
            span(1.0, 1, 1),
            span(2.0, 1, 0),
            span(3.0, 0, 0),
            span(4.0, 0, 0),
            span(5.0, 1, 1),
            span(6.0, 1, 1),
        ];
        let lane = stretches(&spans, 0, VIEW, 10, &[]);
        assert_eq!(
            lane,
            [Stretch {
                from: 0.0,
                to: 6.5,
                highs: vec![(0.0, 2.5), (5.0, 6.5)],
            }]
        );
        // Another bit of the same word: low throughout, one stretch and no run.
        assert!(stretches(&spans, 1, VIEW, 10, &[])[0].highs.is_empty());
        // Two points per change of the bit, not per column: the line is a step each way.
        assert_eq!(
            step_line(&lane[0], 0.0),
            [
                [0.0, 1.0],
                [2.5, 1.0],
                [2.5, 0.0],
                [5.0, 0.0],
                [5.0, 1.0],
                [6.5, 1.0],
            ]
        );
    }

    #[test]
    fn a_gap_cuts_a_lane_and_a_run() {
        // High, high, [gap], high, low: two stretches, each with its run, none across.
        let spans = [
            span(0.0, 1, 1),
            span(1.0, 1, 1),
            span(6.0, 1, 1),
            span(7.0, 0, 0),
        ];
        let lane = stretches(&spans, 0, VIEW, 10, &[gap(1.5, 6.0)]);
        assert_eq!(
            lane,
            [
                Stretch {
                    from: 0.0,
                    to: 1.5,
                    highs: vec![(0.0, 1.5)],
                },
                // Half a column of samples, widened to the column.
                Stretch {
                    from: 6.0,
                    to: 7.5,
                    highs: vec![(6.0, 7.0)],
                },
            ]
        );
        assert_eq!(
            step_line(&lane[1], 3.0),
            [[6.0, 4.0], [7.0, 4.0], [7.0, 3.0], [7.5, 3.0]]
        );
        // A gap elsewhere cuts nothing.
        assert_eq!(stretches(&spans, 0, VIEW, 10, &[gap(8.0, 9.0)]).len(), 1);
    }

    #[test]
    fn a_run_narrower_than_a_column_is_a_column_wide() {
        // One high sample at 4.2 between low columns: its column (1 s) is high.
        let spans = [
            span(3.0, 0, 0),
            BitSpan {
                t0: 4.2,
                t1: 4.2,
                any: 1,
                all: 1,
            },
            span(5.0, 0, 0),
        ];
        let lane = stretches(&spans, 0, VIEW, 10, &[]);
        assert_eq!(lane[0].highs, [(4.0, 5.0)]);
        // Two such runs in neighbouring columns are one.
        let spans = [
            BitSpan {
                t0: 4.2,
                t1: 4.2,
                any: 1,
                all: 1,
            },
            span(4.4, 0, 0),
            BitSpan {
                t0: 5.1,
                t1: 5.1,
                any: 1,
                all: 1,
            },
        ];
        let lane = stretches(&spans, 0, VIEW, 10, &[]);
        assert_eq!(lane[0].highs, [(4.0, 6.0)]);
        // A run over two columns but shorter than one: from its column to a column on.
        let lane = stretches(&[span(5.8, 1, 1)], 0, VIEW, 10, &[]);
        assert_eq!(lane[0].highs, [(5.0, 6.3)]);
    }

    #[test]
    fn a_run_at_the_edges_of_the_view_stays_inside_it() {
        // A single high sample at each edge: a column wide, inside the view.
        let spans = [
            BitSpan {
                t0: 0.0,
                t1: 0.0,
                any: 1,
                all: 1,
            },
            span(4.0, 0, 0),
            BitSpan {
                t0: 10.0,
                t1: 10.0,
                any: 1,
                all: 1,
            },
        ];
        let lane = stretches(&spans, 0, VIEW, 10, &[]);
        assert_eq!(lane[0].highs, [(0.0, 1.0), (9.0, 10.0)]);
        assert_eq!((lane[0].from, lane[0].to), VIEW);
        // High throughout: one run from the first sample to the last, no step down.
        let spans: Vec<BitSpan> = (0..10).map(|k| span(k as f64, 1, 1)).collect();
        let lane = stretches(&spans, 0, VIEW, 10, &[]);
        assert_eq!(lane[0].highs, [(0.0, 9.5)]);
        assert_eq!(step_line(&lane[0], 0.0), [[0.0, 1.0], [9.5, 1.0]]);
        // A view of one column, high in part of it: the run fills it, no more.
        let lane = stretches(&[span(0.1, 1, 0)], 0, (0.0, 2.0), 1, &[]);
        assert_eq!(lane[0].highs, [(0.0, 2.0)]);
        assert_eq!((lane[0].from, lane[0].to), (0.0, 2.0));
    }

    #[test]
    fn the_fill_is_a_rectangle_per_run_and_nothing_between() {
        let lane = [
            Stretch {
                from: 0.0,
                to: 4.0,
                highs: vec![(1.0, 2.0)],
            },
            Stretch {
                from: 6.0,
                to: 9.0,
                highs: vec![(6.0, 7.0), (8.0, 9.0)],
            },
        ];
        let (xs, highs) = fill_outline(&lane, 3.0);
        assert_eq!(
            xs,
            [1.0, 1.0, 2.0, 2.0, 6.0, 6.0, 7.0, 7.0, 8.0, 8.0, 9.0, 9.0]
        );
        assert_eq!(highs, [3.0, 4.0, 4.0, 3.0].repeat(3));
        // Every quad FilledArea fills between two neighbours has no width or the same
        // height at both ends (a rectangle, or nothing at the base): no slope, no wedge.
        for i in 1..xs.len() {
            assert!(xs[i] == xs[i - 1] || highs[i] == highs[i - 1], "{i}");
        }
        assert_eq!(fill_outline(&[], 0.0), (vec![], vec![]));
    }
}
