//! What the live window costs as it runs: frames drawn per second, and CPU milliseconds per
//! second of the UI thread and of the workers' threads, with the simulated drive polled at
//! 100 Hz and 1 kHz, and with four simulated drives at 100 Hz each.
//!
//! Headless: the whole `App` (every panel, the workers, the in-process simulated drives)
//! runs through a bare `egui::Context`, frames paced the way eframe paces them (a frame
//! when a repaint asked for through the context's repaint callback falls due), each frame
//! laid out (`run_ui`) and tessellated. Not included: turning the triangles into pixels
//! (no GPU, no OpenGL driver, no window system, no buffer swap), which the real window
//! adds on top of the UI thread's figure.
//!
//! Two repaint policies, the same frame code:
//! - `every wake`: each worker wake asks egui for a frame 5 ms later (the policy before
//!   the redraw rate; a frame follows every burst of samples);
//! - `paced`: the window's pace (`drivedeck::ui::pace`), at the default 30 Hz.
//!
//! `cargo bench --bench live` (or `-- --seconds 20`); the window is 1366 × 768 points.

use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use drivedeck::ui::Command;
use drivedeck::ui::pace::{Pace, stat_cpu};
use drivedeck::ui::plots::PlotCommand;
use drivedeck::ui::{App, Settings};
use drivedeck::worker::Notify;
use eframe::egui;

#[derive(Clone, Copy, PartialEq)]
enum Policy {
    EveryWake,
    Paced,
}

struct Scenario {
    policy: Policy,
    drives: usize,
    poll_hz: f64,
    paused: bool,
    /// Every drive ticked to be drawn in the plots beside the one shown (the worst case;
    /// by default the plots draw the drive shown only).
    all_in_plots: bool,
}

/// When the next frame is due, as eframe's event loop keeps it.
#[derive(Default)]
struct Due {
    at: Mutex<Option<Instant>>,
    changed: Condvar,
}

impl Due {
    fn ask(&self, delay: Duration) {
        let when = Instant::now() + delay;
        if let Ok(mut at) = self.at.lock() {
            *at = Some(at.map_or(when, |t| t.min(when)));
            self.changed.notify_one();
        }
    }

    /// Wait until a frame is due (true) or `end` comes (false).
    fn wait(&self, end: Instant) -> bool {
        let Ok(mut at) = self.at.lock() else {
            return false;
        };
        loop {
            let now = Instant::now();
            if now >= end {
                return false;
            }
            match *at {
                Some(t) if t <= now => {
                    *at = None;
                    return true;
                }
                Some(t) => {
                    let wait = (t - now).min(end - now);
                    match self.changed.wait_timeout(at, wait) {
                        Ok((guard, _)) => at = guard,
                        Err(_) => return false,
                    }
                }
                None => match self.changed.wait_timeout(at, end - now) {
                    Ok((guard, _)) => at = guard,
                    Err(_) => return false,
                },
            }
        }
    }
}

/// Every thread of this process: its id, name and CPU time so far.
fn threads() -> Vec<(String, String, Duration)> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    dir.filter_map(Result::ok)
        .filter_map(|task| {
            let path = task.path();
            let stat = std::fs::read_to_string(path.join("stat")).ok()?;
            let name = std::fs::read_to_string(path.join("comm")).ok()?;
            Some((
                task.file_name().to_string_lossy().into_owned(),
                name.trim().to_owned(),
                stat_cpu(&stat)?,
            ))
        })
        .collect()
}

struct Figures {
    frames_per_s: f64,
    ui_ms_per_s: f64,
    workers_ms_per_s: Vec<f64>,
    other_ms_per_s: f64,
    samples_lost: u64,
}

fn run(scenario: &Scenario, warm_up: Duration, seconds: Duration) -> Figures {
    let ctx = egui::Context::default();
    let due = Arc::new(Due::default());
    {
        let due = Arc::clone(&due);
        ctx.set_request_repaint_callback(move |info| due.ask(info.delay));
    }
    let pace = Pace::new(ctx.clone());
    let notify: Notify = match scenario.policy {
        Policy::Paced => pace.notify(),
        Policy::EveryWake => {
            let ctx = ctx.clone();
            Arc::new(move || ctx.request_repaint_after(Duration::from_millis(5)))
        }
    };
    let settings = Settings {
        poll_rate: scenario.poll_hz,
        ..Settings::default()
    };
    let mut app = App::new(settings, notify, true);
    if scenario.policy == Policy::Paced {
        app.set_pace(Arc::clone(&pace));
    }
    for k in 1..scenario.drives {
        match app.add_drive(format!("Drive {}", k + 1), "sim://") {
            Ok(index) if scenario.all_in_plots => {
                app.apply_command(Command::PlotBeside(index, true));
            }
            Ok(_) => {}
            Err(e) => eprintln!("drive {}: {e}", k + 1),
        }
    }
    let started = Instant::now();
    let frame = |app: &mut App| {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1366.0, 768.0),
            )),
            time: Some(started.elapsed().as_secs_f64()),
            ..Default::default()
        };
        let output = ctx.run_ui(input, |ui| app.frame(ui));
        ctx.tessellate(output.shapes, output.pixels_per_point).len()
    };
    // The first frame, then the warm-up (fonts, the connection, a few seconds of samples).
    frame(&mut app);
    let warm_end = Instant::now() + warm_up;
    let mut paused = false;
    while due.wait(warm_end) {
        frame(&mut app);
        if scenario.paused && !paused && app.shown().scope.ring().last_time().is_some() {
            app.apply_command(Command::Plot(PlotCommand::Pause));
            paused = true;
        }
    }
    let before = threads();
    let t0 = Instant::now();
    let end = t0 + seconds;
    let mut frames = 0u64;
    while due.wait(end) {
        frame(&mut app);
        frames += 1;
    }
    let elapsed = t0.elapsed().as_secs_f64();
    let after = threads();
    // Samples a worker could not hand the window (its channel was full), all drives.
    let samples_lost: u64 = (0..app.drive_count())
        .filter_map(|i| app.drive(i))
        .filter_map(|d| d.link.health)
        .map(|h| h.dropped_samples)
        .sum();
    let pid = std::process::id().to_string();
    let mut ui = 0.0;
    let mut workers = Vec::new();
    let mut other = 0.0;
    for (tid, name, cpu) in &after {
        let was = before
            .iter()
            .find(|(t, _, _)| t == tid)
            .map_or(Duration::ZERO, |b| b.2);
        let ms = cpu.saturating_sub(was).as_secs_f64() * 1e3 / elapsed;
        if *tid == pid {
            ui += ms;
        } else if name.starts_with("drivedeck-work") {
            workers.push(ms);
        } else {
            other += ms;
        }
    }
    drop(app);
    Figures {
        frames_per_s: frames as f64 / elapsed,
        ui_ms_per_s: ui,
        workers_ms_per_s: workers,
        other_ms_per_s: other,
        samples_lost,
    }
}

fn main() {
    let mut seconds = 10.0;
    let mut machine = false;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        if arg == "--seconds"
            && let Some(s) = args.next().and_then(|s| s.parse().ok())
        {
            seconds = s;
        }
        // The machine sizes only: 1, 4, 16 and 32 drives at 100 Hz, paced.
        if arg == "--machine" {
            machine = true;
        }
    }
    let scenarios: Vec<(Policy, usize, f64, bool, bool)> = if machine {
        vec![
            (Policy::Paced, 1, 100.0, false, false),
            (Policy::Paced, 4, 100.0, false, false),
            (Policy::Paced, 4, 100.0, false, true),
            (Policy::Paced, 16, 100.0, false, false),
            (Policy::Paced, 16, 100.0, false, true),
            (Policy::Paced, 32, 100.0, false, false),
            (Policy::Paced, 32, 100.0, false, true),
        ]
    } else {
        vec![
            (Policy::EveryWake, 1, 100.0, false, false),
            (Policy::Paced, 1, 100.0, false, false),
            (Policy::EveryWake, 1, 1000.0, false, false),
            (Policy::Paced, 1, 1000.0, false, false),
            (Policy::EveryWake, 4, 100.0, false, true),
            (Policy::Paced, 4, 100.0, false, true),
            (Policy::EveryWake, 1, 1000.0, true, false),
            (Policy::Paced, 1, 1000.0, true, false),
        ]
    };
    println!(
        "live window, headless 1366x768, layout + tessellation, no GPU; {seconds} s each after 3 s"
    );
    println!(
        "| policy | drives × poll | plots | frames/s | UI ms/frame | UI thread ms/s | workers ms/s (each) | other threads ms/s | samples lost |"
    );
    println!("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for (policy, drives, poll_hz, paused, all_in_plots) in scenarios {
        let scenario = Scenario {
            policy,
            drives,
            poll_hz,
            paused,
            all_in_plots,
        };
        let f = run(
            &scenario,
            Duration::from_secs(3),
            Duration::from_secs_f64(seconds),
        );
        let each: Vec<String> = f
            .workers_ms_per_s
            .iter()
            .map(|ms| format!("{ms:.0}"))
            .collect();
        let plots = match (paused, all_in_plots && drives > 1) {
            (true, _) => "paused",
            (false, true) => "live, every drive drawn",
            (false, false) => "live, the drive shown",
        };
        println!(
            "| {} | {drives} × {poll_hz:.0} Hz | {plots} | {:.1} | {:.1} | {:.0} | {:.0} ({}) | {:.0} | {} |",
            match policy {
                Policy::EveryWake => "every wake, new frame code",
                Policy::Paced => "paced, 30 Hz (after)",
            },
            f.frames_per_s,
            f.ui_ms_per_s / f.frames_per_s.max(f64::MIN_POSITIVE),
            f.ui_ms_per_s,
            f.workers_ms_per_s.iter().sum::<f64>(),
            each.join(" + "),
            f.other_ms_per_s,
            f.samples_lost,
        );
    }
}
