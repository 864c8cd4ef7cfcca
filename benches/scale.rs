//! Scale: what 10 minutes of 1 kHz history cost with the built-in signals alone and with
//! the 8 watched objects a drive may sample besides them — the memory the plot history
//! holds (counted by a global allocator that tracks live bytes) and the plot frame with the
//! whole history in view (layout and tessellation through a headless egui context, no
//! GPU), the two states measured in alternating rounds.
//!
//! `cargo bench --bench scale` (prints a table; no criterion: each figure is the median of
//! the rounds).

use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use drivedeck::od::Address;
use drivedeck::pdi::{Status, TxImage};
use drivedeck::signal::{MAX_WATCHED, Signal, Signals};
use drivedeck::telemetry::WatchedObject;
use drivedeck::ui::plots::Alone;
use drivedeck::worker::Sample;
use eframe::egui;

/// The system's allocator, counting the bytes live.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is passed on unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LIVE.fetch_add(new_size, Ordering::Relaxed);
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// 10 minutes at 1 kHz.
const ROWS: usize = 600_000;

/// A plot panel with 10 minutes of 1 kHz samples, and `watched` objects sampled besides.
fn state_with(watched: usize) -> Alone {
    let mut state = Alone::new(ROWS);
    state.settings.window_s = 0.0;
    let objects: Vec<WatchedObject> = (0..watched)
        .map(|i| WatchedObject {
            address: Address::new(0x2400 + i as u16, 1),
            name: format!("User object {i}"),
            unit: String::new(),
        })
        .collect();
    state.drive.scope.set_watched(&objects);
    for i in 0..ROWS {
        let t = i as f64 * 0.001;
        let noise = ((i * 7919) % 101) as f64 - 50.0;
        let mut values = [None; MAX_WATCHED];
        for (k, v) in values.iter_mut().take(watched).enumerate() {
            *v = Some((t * (0.3 + k as f64 * 0.2)).sin() * 1000.0 + noise);
        }
        state.drive.scope.push(&Sample {
            t,
            signals: Signals::default()
                .with(Signal::Position, (t * 0.7).sin() * 36_000.0 + noise)
                .with(Signal::Velocity, (t * 0.7).cos() * 2_500.0 + noise)
                .with(Signal::Torque, (t * 3.0).sin() * 400.0 + noise)
                .with(Signal::FollowingError, noise),
            tx: TxImage {
                status: Status(if (i / 1500) % 2 == 0 { 0x0009 } else { 0x0001 }),
                error_code: 0,
                return_value: i as i32,
            },
            watched: values,
        });
    }
    // Every user signal drawn, as a technician who pinned them would have it.
    for signal in state.drive.scope.signals_mut() {
        if signal.info.name.starts_with("User object") {
            signal.shown = true;
        }
    }
    state
}

fn frame(ctx: &egui::Context, state: &mut Alone) -> usize {
    drivedeck::ui::plots::headless_frame(ctx, state)
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let mut cases = Vec::new();
    for watched in [0, MAX_WATCHED] {
        let before = LIVE.load(Ordering::Relaxed);
        let state = state_with(watched);
        let bytes = LIVE.load(Ordering::Relaxed).saturating_sub(before);
        let channels = state.drive.scope.signals().len();
        cases.push((watched, channels, bytes, state, egui::Context::default()));
    }
    let before_frames = LIVE.load(Ordering::Relaxed);
    // Fonts and the first layout out of the measurement.
    for (_, _, _, state, ctx) in cases.iter_mut() {
        frame(ctx, state);
        frame(ctx, state);
    }
    const ROUNDS: usize = 15;
    const FRAMES: usize = 4;
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
    for _ in 0..ROUNDS {
        for (i, (_, _, _, state, ctx)) in cases.iter_mut().enumerate() {
            let started = Instant::now();
            for _ in 0..FRAMES {
                black_box(frame(ctx, state));
            }
            times[i].push(started.elapsed().as_secs_f64() * 1e3 / FRAMES as f64);
        }
    }
    let frames_kept = LIVE.load(Ordering::Relaxed).saturating_sub(before_frames);
    println!("10 minutes at 1 kHz ({ROWS} rows), the whole history in view, 1600x1000:");
    println!(
        "| signals | channels in the history | history memory | plot frame (median of {ROUNDS} rounds) |"
    );
    println!("| --- | ---: | ---: | ---: |");
    for ((watched, channels, bytes, _, _), times) in cases.iter().zip(times.iter_mut()) {
        let what = if *watched == 0 {
            "built-in only".to_owned()
        } else {
            format!("built-in + {watched} watched objects")
        };
        println!(
            "| {what} | {channels} | {:.1} MB | {:.2} ms |",
            *bytes as f64 / 1e6,
            median(times)
        );
    }
    println!(
        "kept by the frames besides (decimation caches, fonts, egui's memory; the first two frames included), both states together: {:.1} MB",
        frames_kept as f64 / 1e6
    );
}
