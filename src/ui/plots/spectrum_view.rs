//! The spectrum window over the plots: the signal and the window function chosen, the
//! strongest peaks by frequency and amplitude, and the amplitude spectrum drawn.

use eframe::egui::{self, Ui};
use egui_plot::{Line, Plot};

use super::spectrum::SpectrumPanel;
use crate::telemetry::spectrum::Window;
use crate::ui::widgets::{BLUE, RED};

/// The "Spectrum…" button's window, while open.
pub(super) fn spectrum_window_ui(ui: &mut Ui, panel: &mut SpectrumPanel) {
    if !panel.open {
        return;
    }
    let mut open = true;
    // Over the plots, below the toolbar it was asked from.
    let at = ui.min_rect().left_bottom() + egui::vec2(0.0, 40.0);
    egui::Window::new("Spectrum of the span in view")
        .open(&mut open)
        .default_pos(at)
        .default_size([460.0, 360.0])
        .resizable(true)
        .show(ui.ctx(), |ui| contents_ui(ui, panel));
    panel.open &= open;
}

fn contents_ui(ui: &mut Ui, panel: &mut SpectrumPanel) {
    let Some(recording) = &panel.recording else {
        return;
    };
    let names: Vec<String> = recording.channels.iter().map(|c| c.id.clone()).collect();
    let mut signal = panel.signal;
    let mut window = panel.window;
    ui.horizontal(|ui| {
        egui::ComboBox::from_label("signal")
            .selected_text(names.get(signal).cloned().unwrap_or_default())
            .show_ui(ui, |ui| {
                for (k, name) in names.iter().enumerate() {
                    ui.selectable_value(&mut signal, k, name);
                }
            });
        egui::ComboBox::from_label("window")
            .selected_text(window.name())
            .show_ui(ui, |ui| {
                for w in Window::ALL {
                    ui.selectable_value(&mut window, w, w.name());
                }
            });
    });
    panel.choose_signal(signal);
    panel.choose_window(window);
    let unit = panel.signal_name().map(|(_, u)| u).unwrap_or_default();
    match &panel.result {
        None => {}
        Some(Err(why)) => {
            ui.colored_label(RED, why);
        }
        Some(Ok((spectrum, peaks))) => {
            ui.weak(format!(
                "{} samples at {:.1} Hz, bins {:.3} Hz apart up to {:.1} Hz",
                spectrum.points,
                spectrum.rate_hz,
                spectrum.rate_hz / spectrum.points as f64,
                spectrum.rate_hz / 2.0
            ));
            egui::Grid::new("spectrum_peaks")
                .striped(true)
                .show(ui, |ui| {
                    ui.strong("peak");
                    ui.strong("frequency [Hz]");
                    ui.strong(format!("amplitude [{unit}]"));
                    ui.end_row();
                    for (k, peak) in peaks.iter().enumerate() {
                        ui.monospace((k + 1).to_string());
                        ui.monospace(format!("{:.3}", peak.frequency_hz));
                        ui.monospace(format!("{:.4}", peak.amplitude));
                        ui.end_row();
                    }
                    if peaks.is_empty() {
                        ui.weak("no peak: the signal is constant");
                        ui.end_row();
                    }
                });
            let points: Vec<[f64; 2]> = spectrum
                .frequencies
                .iter()
                .zip(&spectrum.amplitudes)
                .skip(1)
                .map(|(f, a)| [*f, *a])
                .collect();
            Plot::new("spectrum_plot")
                .height(ui.available_height().max(140.0))
                .x_axis_label("frequency [Hz]")
                .y_axis_label(format!("amplitude [{unit}]"))
                .show(ui, |plot_ui| {
                    plot_ui.line(Line::new("amplitude", points).color(BLUE).width(1.2));
                });
        }
    }
}
