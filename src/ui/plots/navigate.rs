//! Pan and zoom of the time axis: one span for every plot, kept by the plot view. egui_plot's
//! own drag, zoom and scroll stay off. Each plot keeps its bounds in a memory of its own and
//! egui_plot moves them after the plot's items are made, so with them on the plot under the
//! pointer moved alone (the others, and the axis labels under the lowest, stayed), drawn
//! that frame with the points of its old span, and the read-out took that plot's times
//! while the axis showed another span. Here the plot under the pointer asks for a new span;
//! the window applies it (`PlotCommand::ShowSpan`) and the next frame decimates and draws
//! every plot on it.

use eframe::egui::{self, Color32, PointerButton, Pos2, Response, Ui};
use egui_plot::{Plot, PlotTransform};

/// The narrowest span a zoom goes to, in seconds (the time labels have decimals for it).
const MIN_SPAN_S: f64 = 1e-4;
/// The widest (about four months; no history is longer).
const MAX_SPAN_S: f64 = 1e7;
/// How much a point of vertical wheel zooms: as much as egui's Ctrl+wheel.
const WHEEL_ZOOM: f64 = 1.0 / 200.0;
/// A right drag shorter than this, in points, picks no span (a right click places cursor B).
const PICK_MIN: f32 = 6.0;
/// The shade of the span being picked.
const PICK_FILL: Color32 = Color32::from_rgba_premultiplied(60, 80, 120, 60);

/// `plot` with egui_plot's own navigation off: its time axis shows the span it is given.
pub(super) fn fixed(plot: Plot<'_>) -> Plot<'_> {
    plot.allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .allow_axis_zoom_drag(false)
        .allow_double_click_reset(false)
}

/// The span asked for over one plot in this frame, from its response and the transform it
/// was drawn with on `span`: a drag pans (the time grabbed stays under the pointer), the
/// wheel over the data area zooms about the pointer (sideways, or with Shift, it pans), Ctrl+wheel or a pinch
/// zooms, a right drag picks the span to show (shaded while dragged). `None`: not moved.
pub(super) fn asked(
    ui: &Ui,
    response: &Response,
    transform: &PlotTransform,
    span: (f64, f64),
) -> Option<(f64, f64)> {
    let frame = transform.frame();
    if frame.width() <= 0.0 {
        return None;
    }
    let per_point = (span.1 - span.0) / f64::from(frame.width());
    let time_at = |x: f32| {
        transform
            .value_from_position(egui::pos2(x, frame.center().y))
            .x
    };
    let mut asked = span;
    if response.dragged_by(PointerButton::Primary) {
        asked = pan(asked, -f64::from(response.drag_delta().x) * per_point);
    }
    // The wheel over the data area moves the time axis, and is taken so that the scroll
    // area around the plots does not scroll too; over the y axes' labels (and the lanes'
    // names) it is left to the scroll area.
    if response.hovered()
        && let Some(pos) = response.hover_pos()
        && frame.contains(pos)
    {
        let (scroll, zoom) = ui.input_mut(|i| {
            let taken = (i.smooth_scroll_delta, i.zoom_delta());
            i.smooth_scroll_delta = egui::Vec2::ZERO;
            taken
        });
        asked = pan(asked, -f64::from(scroll.x) * per_point);
        let factor = f64::from(zoom) * (f64::from(scroll.y) * WHEEL_ZOOM).exp();
        asked = zoom_about(asked, factor, time_at(pos.x));
    }
    if let Some((a, b)) = picked(ui, response) {
        asked = (time_at(a.min(b)), time_at(a.max(b)));
    }
    let valid = asked.0.is_finite() && asked.1.is_finite() && asked.1 > asked.0;
    (valid && asked != span).then_some(asked)
}

/// A right drag over the plot: shaded while it lasts; where it began and ended (screen x)
/// when let go.
fn picked(ui: &Ui, response: &Response) -> Option<(f32, f32)> {
    let id = response.id.with("picked span");
    if response.drag_started_by(PointerButton::Secondary)
        && let Some(origin) = ui.input(|i| i.pointer.press_origin())
    {
        ui.data_mut(|d| d.insert_temp(id, origin.x));
    }
    let start = ui.data(|d| d.get_temp::<f32>(id))?;
    let now = response
        .interact_pointer_pos()
        .or(ui.input(|i| i.pointer.latest_pos()));
    if response.dragged_by(PointerButton::Secondary)
        && let Some(now) = now
    {
        let rect = response.rect;
        let band = egui::Rect::from_x_y_ranges(start.min(now.x)..=start.max(now.x), rect.y_range());
        ui.painter()
            .with_clip_rect(rect)
            .rect_filled(band, 0.0, PICK_FILL);
    }
    if !response.drag_stopped() {
        return None;
    }
    ui.data_mut(|d| d.remove_temp::<f32>(id));
    let end = now.map(|p: Pos2| p.x)?;
    ((end - start).abs() >= PICK_MIN).then_some((start, end))
}

/// `span` moved by `seconds`.
fn pan((from, to): (f64, f64), seconds: f64) -> (f64, f64) {
    if seconds == 0.0 {
        return (from, to);
    }
    (from + seconds, to + seconds)
}

/// `span` narrowed `factor` times (widened when below 1) about the time `at`, which stays
/// where it was on screen; no narrower than [`MIN_SPAN_S`], no wider than [`MAX_SPAN_S`].
fn zoom_about((from, to): (f64, f64), factor: f64, at: f64) -> (f64, f64) {
    if factor == 1.0 || !(factor > 0.0 && factor.is_finite() && at.is_finite()) {
        return (from, to);
    }
    let width = to - from;
    let factor = factor.min(width / MIN_SPAN_S).max(width / MAX_SPAN_S);
    (at - (at - from) / factor, at + (to - at) / factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zoom_keeps_the_time_under_the_pointer_where_it_was() {
        let (from, to) = zoom_about((10.0, 20.0), 2.0, 12.0);
        assert_eq!((from, to), (11.0, 16.0));
        // The pointer's time at the same fraction of the span.
        assert!(((12.0 - from) / (to - from) - 0.2).abs() < 1e-12);
        assert_eq!(zoom_about((10.0, 20.0), 0.5, 20.0), (0.0, 20.0));
        assert_eq!(zoom_about((10.0, 20.0), 1.0, 12.0), (10.0, 20.0));
        assert_eq!(zoom_about((10.0, 20.0), f64::NAN, 12.0), (10.0, 20.0));
        // No narrower than the least span, however far the wheel turns.
        let (from, to) = zoom_about((10.0, 20.0), 1e12, 15.0);
        assert!((to - from - MIN_SPAN_S).abs() < 1e-12, "{from} {to}");
        let (a, b) = zoom_about((from, to), 4.0, 15.0);
        assert!((b - a - MIN_SPAN_S).abs() < 1e-12, "{a} {b}");
        let (a, b) = zoom_about((10.0, 20.0), 1e-12, 15.0);
        assert!((b - a - MAX_SPAN_S).abs() < 1e-3, "{a} {b}");
        assert_eq!(pan((10.0, 20.0), -2.5), (7.5, 17.5));
    }
}
