//! Pan and zoom of the plots' time axis, headless: a drag, the wheel and Ctrl+wheel over a
//! plot move every plot to one new span, each drawn from the history's samples of that
//! span, and the read-out's "pointer t" is the time on the axis under the pointer.

// Tests may panic: that is how they fail (clippy.toml covers #[test] fns, not helpers).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod window;

use drivedeck::signal::{Signal, Signals};
use drivedeck::ui::Settings;
use drivedeck::ui::plots::{Alone, DrawnPlot};
use drivedeck::worker::{Event, Sample};
use eframe::egui;
use egui_kittest::Harness;

/// Seconds between two samples fed: finer than a pixel of the 10 s window (about 7.8 ms),
/// so the read-out (the time of the sample at or before the pointer) is within a pixel.
const PERIOD: f64 = 0.001;
/// Seconds of history fed.
const HISTORY_S: f64 = 60.0;

/// The position at `t`: two sines, so every stretch has a highest and a lowest sample of
/// its own.
fn position(t: f64) -> f64 {
    1000.0 * (t * 0.7).sin() + 300.0 * (t * 5.3).sin()
}

/// The plot panel alone, as under Xvfb at 1366×768, with a minute of samples at 1 kHz,
/// following the newest.
fn panel() -> Harness<'static, Alone> {
    let mut harness = Harness::builder()
        .with_size(egui::vec2(1366.0, 768.0))
        .build_ui_state(
            |ui, alone: &mut Alone| alone.ui(ui),
            Alone::new(Settings::default().plot.history_rows),
        );
    let rows = (HISTORY_S / PERIOD) as i32;
    let samples = (0..rows)
        .map(|i| {
            let t = f64::from(i) * PERIOD;
            Sample {
                t,
                signals: Signals::default()
                    .with(Signal::Position, position(t))
                    .with(Signal::Velocity, f64::from(i % 5000)),
                ..Default::default()
            }
        })
        .collect();
    harness.state_mut().apply_event(Event::Samples(samples));
    harness.step();
    harness.step();
    assert!(harness.state().view.follows());
    harness
}

fn drawn(harness: &Harness<'_, Alone>) -> Vec<DrawnPlot> {
    harness.state().view.drawn().to_vec()
}

/// The plot that carries the time labels (the lowest).
fn axis_plot(harness: &Harness<'_, Alone>) -> DrawnPlot {
    drawn(harness).pop().expect("plots drawn")
}

/// The time `plot`'s axis puts at screen x (egui_plot's own mapping).
fn time_at(plot: &DrawnPlot, x: f32) -> f64 {
    let [left, _, right, _] = plot.frame;
    let (from, to) = plot.axis;
    from + f64::from(x - left) / f64::from(right - left) * (to - from)
}

/// Seconds per point of `plot`'s axis.
fn pixel(plot: &DrawnPlot) -> f64 {
    let [left, _, right, _] = plot.frame;
    (plot.axis.1 - plot.axis.0) / f64::from(right - left)
}

/// A point on the top plot at `fraction` of its width.
fn on_top_plot(harness: &Harness<'_, Alone>, fraction: f32) -> egui::Pos2 {
    let top = drawn(harness).first().cloned().expect("plots drawn");
    let [left, t, right, b] = top.frame;
    egui::pos2(left + (right - left) * fraction, (t + b) / 2.0)
}

fn hover(harness: &mut Harness<'_, Alone>, pos: egui::Pos2) {
    harness.event(egui::Event::PointerMoved(pos));
    harness.step();
}

/// The time the read-out gives for the pointer ("pointer t = 12.345 s").
fn read_out(harness: &Harness<'_, Alone>) -> f64 {
    let text = window::text_containing(harness, "pointer t = ");
    text.trim_start_matches("pointer t = ")
        .trim_end_matches(" s")
        .parse()
        .unwrap_or_else(|_| panic!("no time in '{text}'"))
}

/// The lowest and highest position among the samples between `from` and `to`.
fn ring_extremes(harness: &Harness<'_, Alone>, from: f64, to: f64) -> (f64, f64) {
    let scope = harness.state().shown_scope();
    let column = scope.signal("position").expect("position").column;
    let ring = scope.ring();
    (0..ring.len())
        .filter(|&i| ring.time(i).is_some_and(|t| t >= from && t <= to))
        .filter_map(|i| ring.value(i, column))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// Every plot drawn on `span` (the one the view keeps), its points decimated for that span
/// and reaching both its edges, the position's line holding the span's extremes; and the
/// read-out at two places on the top plot giving the time on the axis there.
fn drawn_on(harness: &mut Harness<'_, Alone>, span: (f64, f64)) {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + a.abs());
    assert_eq!(harness.state().view.shown_range(), Some(span));
    assert!(!harness.state().view.follows(), "following stopped");
    let plots = drawn(harness);
    assert!(plots.len() >= 3, "{plots:?}");
    let newest = harness.state().drive.sample_time().expect("samples");
    for plot in &plots {
        assert!(
            close(plot.axis.0, span.0) && close(plot.axis.1, span.1),
            "{}'s axis shows {:?}, the view is {span:?}",
            plot.id,
            plot.axis
        );
        assert_eq!(
            plot.decimated, plot.axis,
            "{}: points of another span than its axis",
            plot.id
        );
        if let Some(line) = plot.line {
            // To both edges, or as far as there are samples.
            assert!(
                line.first <= span.0.max(0.0) && line.last >= span.1.min(newest),
                "{}'s line covers {}..{}, not {span:?}",
                plot.id,
                line.first,
                line.last
            );
        }
    }
    // The position's line: no sample of the span lower or higher than drawn, and the
    // extremes of the span's inside (not the columns at its edges) drawn.
    let line = plots[0].line.expect("the position's line");
    let edge = 2.0 * pixel(&plots[0]);
    let (low, high) = ring_extremes(harness, span.0, span.1);
    let (inner_low, inner_high) = ring_extremes(harness, span.0 + edge, span.1 - edge);
    assert!(
        line.low >= low && line.low <= inner_low && line.high <= high && line.high >= inner_high,
        "drawn {}..{}, the samples {low}..{high} ({inner_low}..{inner_high} inside)",
        line.low,
        line.high
    );
    for fraction in [0.22, 0.85] {
        let pos = on_top_plot(harness, fraction);
        hover(harness, pos);
        let axis = axis_plot(harness);
        let (read, under) = (read_out(harness), time_at(&axis, pos.x).min(newest));
        // The sample at or before the pointer (the newest past the last one), printed to
        // the millisecond.
        let slack = pixel(&axis) + PERIOD + 0.0005;
        assert!(
            (read - under).abs() <= slack,
            "pointer at x = {}: the read-out says {read} s, the axis {under} s",
            pos.x
        );
    }
}

#[test]
fn a_drag_pans_every_plot_and_the_read_out_follows_the_axis() {
    let mut harness = panel();
    let start = harness.state().view.shown_range().expect("a span");
    let (x0, x1) = (on_top_plot(&harness, 0.4), on_top_plot(&harness, 0.75));
    let grabbed = time_at(&axis_plot(&harness), x0.x);
    drag(&mut harness, egui::PointerButton::Primary, 0.4, 0.75);
    let span = harness.state().view.shown_range().expect("a span");
    // Dragged to the right: earlier times, the same width, the time grabbed under the
    // pointer where it was let go.
    assert!(span.0 < start.0 - 1.0, "{start:?} → {span:?}");
    assert!(((span.1 - span.0) - (start.1 - start.0)).abs() < 1e-9);
    let axis = axis_plot(&harness);
    assert!(
        (time_at(&axis, x1.x) - grabbed).abs() <= pixel(&axis),
        "grabbed {grabbed} s, under the pointer now {} s",
        time_at(&axis, x1.x)
    );
    drawn_on(&mut harness, span);
}

/// The wheel turned over the top plot at `fraction` of its width, `modifiers` held; the
/// span before and after, and the time under the pointer before.
fn wheel(
    harness: &mut Harness<'_, Alone>,
    fraction: f32,
    notches: f32,
    modifiers: egui::Modifiers,
) -> ((f64, f64), (f64, f64), f64) {
    let pos = on_top_plot(harness, fraction);
    hover(harness, pos);
    let before = harness.state().view.shown_range().expect("a span");
    let at = time_at(&axis_plot(harness), pos.x);
    harness.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Line,
        delta: egui::vec2(0.0, notches),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Wheel,
        modifiers,
    });
    // The wheel is smoothed over a few frames.
    for _ in 0..40 {
        harness.step();
    }
    let after = harness.state().view.shown_range().expect("a span");
    (before, after, at)
}

/// Zoomed in about the pointer: narrower, the time under the pointer kept.
fn zoomed_in_about(
    harness: &Harness<'_, Alone>,
    (before, after, at): ((f64, f64), (f64, f64), f64),
    x: f32,
) {
    let width = |s: (f64, f64)| s.1 - s.0;
    assert!(
        width(after) < 0.8 * width(before),
        "not zoomed in: {before:?} → {after:?}"
    );
    let axis = axis_plot(harness);
    assert!(
        (time_at(&axis, x) - at).abs() <= 2.0 * pixel(&axis),
        "{at} s was under the pointer, now {} s",
        time_at(&axis, x)
    );
}

#[test]
fn the_wheel_zooms_every_plot_about_the_pointer() {
    let mut harness = panel();
    let x = on_top_plot(&harness, 0.3).x;
    let moved = wheel(&mut harness, 0.3, 2.0, egui::Modifiers::NONE);
    zoomed_in_about(&harness, moved, x);
    drawn_on(&mut harness, moved.1);
    // And out again, past the span first shown.
    let out = wheel(&mut harness, 0.3, -4.0, egui::Modifiers::NONE);
    assert!(out.1.1 - out.1.0 > out.0.1 - out.0.0, "{out:?}");
    drawn_on(&mut harness, out.1);
    // With Shift (the wheel sideways) it pans: earlier times, the same width.
    let (before, after, _) = wheel(&mut harness, 0.3, 2.0, egui::Modifiers::SHIFT);
    assert!(after.0 < before.0, "{before:?} → {after:?}");
    assert!(((after.1 - after.0) - (before.1 - before.0)).abs() < 1e-9);
    drawn_on(&mut harness, after);
}

#[test]
fn ctrl_wheel_zooms_every_plot_about_the_pointer() {
    let mut harness = panel();
    let x = on_top_plot(&harness, 0.6).x;
    // Ctrl as egui-winit gives it on Linux (Ctrl is the command key there).
    let ctrl = egui::Modifiers {
        ctrl: true,
        command: true,
        ..Default::default()
    };
    let moved = wheel(&mut harness, 0.6, 2.0, ctrl);
    zoomed_in_about(&harness, moved, x);
    drawn_on(&mut harness, moved.1);
}

/// A drag with `button` on the top plot from `from` to `to` (fractions of its width).
fn drag(harness: &mut Harness<'_, Alone>, button: egui::PointerButton, from: f32, to: f32) {
    let (x0, x1) = (on_top_plot(harness, from), on_top_plot(harness, to));
    hover(harness, x0);
    harness.event(egui::Event::PointerButton {
        pos: x0,
        button,
        pressed: true,
        modifiers: egui::Modifiers::NONE,
    });
    harness.step();
    for k in 1..=5 {
        let x = x0.x + (x1.x - x0.x) * k as f32 / 5.0;
        hover(harness, egui::pos2(x, x0.y));
    }
    harness.event(egui::Event::PointerButton {
        pos: x1,
        button,
        pressed: false,
        modifiers: egui::Modifiers::NONE,
    });
    harness.step();
    harness.step();
}

#[test]
fn a_right_drag_shows_the_span_between_its_ends() {
    let mut harness = panel();
    let axis = axis_plot(&harness);
    let (a, b) = (on_top_plot(&harness, 0.7).x, on_top_plot(&harness, 0.3).x);
    let picked = (time_at(&axis, b), time_at(&axis, a));
    drag(&mut harness, egui::PointerButton::Secondary, 0.7, 0.3);
    let span = harness.state().view.shown_range().expect("a span");
    assert!(
        (span.0 - picked.0).abs() <= pixel(&axis) && (span.1 - picked.1).abs() <= pixel(&axis),
        "picked {picked:?}, shown {span:?}"
    );
    assert_eq!(
        harness.state().view.cursors(),
        [None, None],
        "no cursor placed"
    );
    drawn_on(&mut harness, span);
    // A double click follows the newest samples again.
    let pos = on_top_plot(&harness, 0.5);
    // A click a frame (a frame is 0.25 s here, the second within egui's 0.3 s).
    for _ in 0..2 {
        for pressed in [true, false] {
            harness.input_mut().events.push(egui::Event::PointerButton {
                pos,
                button: egui::PointerButton::Primary,
                pressed,
                modifiers: egui::Modifiers::NONE,
            });
        }
        harness.step();
    }
    harness.step();
    assert!(harness.state().view.follows());
}
