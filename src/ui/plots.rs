//! Live plots of position, velocity and torque on a shared time axis, with pause and
//! clear.

use eframe::egui::{self, Ui};
use egui_plot::{Legend, Line, Plot};

use super::state::AppState;
use super::widgets::{AMBER, BLUE, GREEN};
use crate::telemetry::Trace;

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
        let n = state
            .history
            .position
            .len()
            .max(state.history.velocity.len());
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
    let group = egui::Id::unique("plots_time_axis");
    let height = ((ui.available_height() - 12.0) / 3.0).max(80.0);
    let traces: [(&str, &str, &Trace, egui::Color32); 3] = [
        (
            "position",
            "Position 6064h [0.1°]",
            &state.history.position,
            BLUE,
        ),
        (
            "velocity",
            "Velocity 606Ch [rpm]",
            &state.history.velocity,
            GREEN,
        ),
        ("torque", "Torque 6077h [‰]", &state.history.torque, AMBER),
    ];
    for (id, name, trace, color) in traces {
        let points = trace.window(from, until);
        Plot::new(id)
            .height(height)
            .link_axis(group, [true, false])
            .link_cursor(group, [true, false])
            .legend(Legend::default())
            .x_axis_label("time [s]")
            .show(ui, |plot_ui| {
                plot_ui.line(Line::new(name, points).color(color));
            });
    }
}
