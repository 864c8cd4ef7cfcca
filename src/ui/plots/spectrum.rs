//! The spectrum of the span in view: the samples of the time span the plots show (live or
//! a recording under review) captured when asked, one of their signals chosen, a window
//! function chosen, the amplitude spectrum and its strongest peaks (`telemetry::spectrum`),
//! so a technician can find a resonance without leaving the window.
//!
//! A model: no egui here.

use crate::telemetry::Recording;
use crate::telemetry::spectrum::{Peak, Spectrum, Window, spectrum};
use crate::ui::panel::PanelModel;

/// Peaks listed.
pub const PEAKS: usize = 5;

/// The spectrum window of one drive (kept with its panels, shown over the plots).
#[derive(Debug, Default)]
pub struct SpectrumPanel {
    pub open: bool,
    /// The span captured when the spectrum was asked for.
    pub recording: Option<Recording>,
    /// The chosen column of `recording`.
    pub signal: usize,
    pub window: Window,
    /// The spectrum and its peaks, or why there is none.
    pub result: Option<Result<(Spectrum, Vec<Peak>), String>>,
}

impl PanelModel for SpectrumPanel {}

impl SpectrumPanel {
    /// Open on a captured span: its velocity if it has one (where resonances show), else
    /// its first signal.
    pub fn open_on(&mut self, recording: Recording) {
        self.signal = recording
            .channels
            .iter()
            .position(|c| c.id == "velocity")
            .unwrap_or(0);
        self.recording = Some(recording);
        self.open = true;
        self.compute();
    }

    /// Choose the signal (a column of the captured span).
    pub fn choose_signal(&mut self, signal: usize) {
        if self.signal != signal {
            self.signal = signal;
            self.compute();
        }
    }

    pub fn choose_window(&mut self, window: Window) {
        if self.window != window {
            self.window = window;
            self.compute();
        }
    }

    /// The chosen signal's name and unit.
    pub fn signal_name(&self) -> Option<(String, String)> {
        let channel = self.recording.as_ref()?.channels.get(self.signal)?;
        let name = if channel.name.is_empty() {
            channel.id.clone()
        } else {
            channel.name.clone()
        };
        Some((name, channel.unit.clone()))
    }

    fn compute(&mut self) {
        let Some(recording) = &self.recording else {
            self.result = None;
            return;
        };
        let Some(column) = recording.columns.get(self.signal) else {
            self.result = Some(Err("no such signal in the span".into()));
            return;
        };
        self.result = Some(
            spectrum(&recording.times, column, self.window)
                .map(|s| {
                    let peaks = s.peaks(PEAKS);
                    (s, peaks)
                })
                .map_err(|e| e.to_string()),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::telemetry::{ChannelInfo, Metadata};

    fn ringing() -> Recording {
        let times: Vec<f64> = (0..1000).map(|i| i as f64 * 0.005).collect();
        let velocity = times
            .iter()
            .map(|t| 50.0 + 2.0 * (std::f64::consts::TAU * 20.0 * t).sin())
            .collect();
        let position = times.iter().map(|t| t * 100.0).collect();
        let channel = |id: &str| ChannelInfo {
            id: id.into(),
            name: String::new(),
            unit: String::new(),
        };
        Recording {
            meta: Metadata::default(),
            channels: vec![channel("position"), channel("velocity")],
            times,
            columns: vec![position, velocity],
            markers: vec![],
        }
    }

    #[test]
    fn the_span_s_velocity_is_chosen_and_its_ringing_found() {
        let mut panel = SpectrumPanel::default();
        panel.open_on(ringing());
        assert_eq!(panel.signal, 1, "the velocity");
        let Some(Ok((_, peaks))) = &panel.result else {
            panic!("{:?}", panel.result);
        };
        assert!((peaks[0].frequency_hz - 20.0).abs() < 0.1, "{peaks:?}");
        assert!((peaks[0].amplitude - 2.0).abs() < 0.2, "{peaks:?}");
        panel.choose_window(Window::Blackman);
        assert!(matches!(&panel.result, Some(Ok(_))));
    }

    #[test]
    fn too_short_a_span_says_why() {
        let mut recording = ringing();
        recording.times.truncate(5);
        for c in &mut recording.columns {
            c.truncate(5);
        }
        let mut panel = SpectrumPanel::default();
        panel.open_on(recording);
        assert!(
            matches!(&panel.result, Some(Err(e)) if e.contains("at least 16")),
            "{:?}",
            panel.result
        );
    }
}
