//! What one frame of the plot panel costs with 10 k, 1 M and 5 M samples in the history,
//! the whole history in view: layout (decimation, plot items) and tessellation through a
//! headless egui context, no GPU. Also the decimation alone.
//!
//! `cargo bench --bench plot` (criterion prints time per frame).

use std::hint::black_box;

use criterion::{Criterion, criterion_group};
use drivedeck::pdi::{Status, TxImage};
use drivedeck::signal::{Signal, Signals};
use drivedeck::ui::plots::Alone;
use drivedeck::worker::Sample;
use eframe::egui;

/// A plot panel holding `rows` samples at 1 kHz: a moving motor with noise, a few
/// one-sample spikes, status bits toggling.
fn state_with(rows: usize) -> Alone {
    let mut state = Alone::new(rows);
    // The whole history in view: the worst case.
    state.settings.window_s = 0.0;
    for i in 0..rows {
        state.drive.scope.push(&sample(i));
    }
    state
}

/// Sample `i` of the history (1 kHz).
fn sample(i: usize) -> Sample {
    let t = i as f64 * 0.001;
    let noise = ((i * 7919) % 101) as f64 - 50.0;
    let spike = if i.is_multiple_of(100_003) {
        5000.0
    } else {
        0.0
    };
    Sample {
        t,
        signals: Signals::default()
            .with(Signal::Position, (t * 0.7).sin() * 36_000.0 + noise + spike)
            .with(Signal::Velocity, (t * 0.7).cos() * 2_500.0 + noise)
            .with(Signal::Torque, (t * 3.0).sin() * 400.0 + noise)
            .with(Signal::FollowingError, noise),
        tx: TxImage {
            status: Status(if (i / 1500).is_multiple_of(2) {
                0x0009
            } else {
                0x0001
            }),
            error_code: 0,
            return_value: i as i32,
        },
        ..Sample::default()
    }
}

fn frame(ctx: &egui::Context, state: &mut Alone) -> usize {
    drivedeck::ui::plots::headless_frame(ctx, state)
}

fn plot_frames(c: &mut Criterion) {
    let mut g = c.benchmark_group("plot frame (layout + tessellation, 1600x1000)");
    g.sample_size(20);
    for rows in [10_000, 600_000, 1_000_000, 5_000_000] {
        let mut state = state_with(rows);
        let ctx = egui::Context::default();
        // Fonts and first-frame layout out of the measurement.
        frame(&ctx, &mut state);
        frame(&ctx, &mut state);
        g.bench_function(format!("{rows} samples"), |b| {
            b.iter(|| black_box(frame(&ctx, &mut state)))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("decimation, one signal, 1600 columns");
    for rows in [10_000, 600_000, 1_000_000, 5_000_000] {
        let state = state_with(rows);
        let ring = state.drive.scope.ring();
        let (from, to) = (
            ring.first_time().unwrap_or(0.0),
            ring.last_time().unwrap_or(0.0),
        );
        g.bench_function(format!("{rows} samples"), |b| {
            b.iter(|| black_box(ring.decimate(0, from, to, 1600).len()))
        });
    }
    g.finish();
}

/// Frames of the plot panel with one new sample per frame: the view moves, as in a live
/// plot following the newest samples (the whole decimations cannot be reused; the grid
/// columns the newest row has passed are).
fn live_frames(c: &mut Criterion) {
    let mut g = c.benchmark_group("plot frame, one new sample per frame (the view moves)");
    g.sample_size(20);
    for rows in [10_000, 600_000] {
        let mut state = state_with(rows);
        let ctx = egui::Context::default();
        frame(&ctx, &mut state);
        frame(&ctx, &mut state);
        let mut i = rows;
        g.bench_function(format!("{rows} samples"), |b| {
            b.iter(|| {
                state.drive.scope.push(&sample(i));
                i += 1;
                black_box(frame(&ctx, &mut state))
            })
        });
    }
    g.finish();
}

/// `PLOT_PROFILE_ROWS=10000 PLOT_PROFILE_FRAMES=50`: only that many frames with that many
/// samples, no criterion (for `valgrind --tool=callgrind`); with `PLOT_PROFILE_LIVE=1` a new
/// sample comes before each frame.
fn profile() -> bool {
    let rows = std::env::var("PLOT_PROFILE_ROWS")
        .ok()
        .and_then(|r| r.parse().ok());
    let Some(rows) = rows else {
        return false;
    };
    let frames: usize = std::env::var("PLOT_PROFILE_FRAMES")
        .ok()
        .and_then(|f| f.parse().ok())
        .unwrap_or(50);
    // PLOT_PROFILE_LIVE: a new sample before every frame (the view moves).
    let live = std::env::var_os("PLOT_PROFILE_LIVE").is_some();
    let mut state = state_with(rows);
    let ctx = egui::Context::default();
    let mut n = 0;
    for k in 0..frames {
        if live {
            state.drive.scope.push(&sample(rows + k));
        }
        n += frame(&ctx, &mut state);
    }
    println!("{frames} frames, {n} primitives");
    true
}

criterion_group!(benches, plot_frames, live_frames);

fn main() {
    if profile() {
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
