//! Live plots of position, velocity and torque (and following error and analog input
//! where the link delivers them every cycle) on a shared time axis, with pause and clear.

use eframe::egui::{self, Ui};
use egui_plot::{Legend, Line, Plot, PlotBounds};

use super::state::AppState;
use super::widgets::{AMBER, BLUE, GREEN, RED};
use crate::telemetry::Signal;

pub fn plots_ui(ui: &mut Ui, state: &mut AppState) {
    ui.horizontal(|ui| {
        ui.heading("Live plots");
        let paused = state.plot_paused_at.is_some();
        if ui
            .add(egui::Button::selectable(
                paused,
                if paused { "Resume plot" } else { "Pause plot" },
            ))
            .on_hover_text("Freeze the plots to look closely; recording goes on underneath.")
            .clicked()
        {
            state.plot_paused_at = if paused {
                None
            } else {
                Some(state.history.latest_time().unwrap_or(0.0))
            };
        }
        if ui
            .button("Clear plot")
            .on_hover_text("Forget the recorded history")
            .clicked()
        {
            state.history.clear();
            state.plot_paused_at = None;
        }
        let n = state.history.len();
        ui.weak(format!(
            "{n} samples (last {:.0} s kept)",
            state.history.capacity() as f64 / state.settings.poll_rate.max(1.0)
        ));
    });

    let until = state
        .plot_paused_at
        .or_else(|| state.history.latest_time())
        .unwrap_or(0.0);
    let from = f64::NEG_INFINITY;
    let following = state.plot_paused_at.is_none();
    let group = egui::Id::unique("plots_time_axis");
    let shown: Vec<Signal> = Signal::ALL
        .into_iter()
        .filter(|s| s.always_shown() || !state.history.trace(*s).is_empty())
        .collect();
    let height = ((ui.available_height() - 12.0) / shown.len() as f32).max(80.0);
    for signal in shown {
        let color = match signal {
            Signal::Position => BLUE,
            Signal::Velocity => GREEN,
            Signal::Torque => AMBER,
            Signal::FollowingError => RED,
            Signal::AnalogInput => egui::Color32::from_rgb(150, 110, 210),
        };
        let points = state.history.trace(signal).window(from, until);
        let bounds = following.then(|| follow_bounds(&points)).flatten();
        Plot::new(signal.id())
            .height(height)
            .link_axis(group, [true, false])
            .link_cursor(group, [true, false])
            .legend(Legend::default())
            .x_axis_label("time [s]")
            .show(ui, |plot_ui| {
                if let Some(bounds) = bounds {
                    // Follow the newest samples; a paused plot can be zoomed and panned.
                    plot_ui.set_plot_bounds(bounds);
                }
                plot_ui.line(Line::new(signal.label(), points).color(color));
            });
    }
}

/// The whole recorded span on x, the data's range with a margin on y (never a flat line
/// squeezed into nothing).
fn follow_bounds(points: &[[f64; 2]]) -> Option<PlotBounds> {
    let first = points.first()?;
    let last = points.last()?;
    let (low, high) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[1]), hi.max(p[1]))
        });
    let span = (high - low).max(2.0);
    let margin = span * 0.08;
    let x_end = last[0].max(first[0] + 1.0);
    Some(PlotBounds::from_min_max(
        [first[0], low - margin],
        [x_end, low + span + margin],
    ))
}
