//! The spectrum of the span in view, in the window, headless, against the built-in
//! simulated drive: Spectrum… over the live plots opens its window on the velocity with
//! its peaks, the signal and the window function can be chosen, and too little data says
//! why.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
mod window;

use std::time::Duration;

use drivedeck::telemetry::spectrum::Window;
use drivedeck::ui::App;
use drivedeck::ui::plots::spectrum::SpectrumPanel;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use window::{app_harness, connected, start_turning, step_for};

fn panel<'a>(harness: &'a Harness<'_, App>) -> &'a SpectrumPanel {
    harness
        .state()
        .shown()
        .panels
        .find::<SpectrumPanel>()
        .expect("opened")
}

#[test]
fn spectrum_of_the_span_in_view_opens_on_the_velocity_with_its_peaks() {
    let mut harness = app_harness();
    connected(&mut harness);
    start_turning(&mut harness, 100.0);
    step_for(&mut harness, Duration::from_secs(2));
    harness.get_by_label("Spectrum…").click();
    harness.step();
    harness.step();
    assert!(
        harness
            .query_by_label("Spectrum of the span in view")
            .is_some()
    );
    let p = panel(&harness);
    assert!(p.open);
    assert_eq!(
        p.signal_name().map(|(n, _)| n),
        Some("Velocity 606Ch".to_owned())
    );
    assert!(matches!(&p.result, Some(Ok(_))), "{:?}", p.result);
    assert!(harness.query_by_label("frequency [Hz]").is_some());
    harness
        .state_mut()
        .shown_mut()
        .panels
        .get::<SpectrumPanel>()
        .choose_window(Window::Hamming);
    harness.step();
    assert!(matches!(&panel(&harness).result, Some(Ok(_))));
}
