//! How often the window redraws. A worker's news does not each ask for a frame: the first
//! wake after a frame asks for the next one no sooner than one period of the redraw rate
//! (`PlotSettings::redraw_hz`) after that frame began, and the wakes that follow before it
//! ask nothing. While the plots stand still (paused, moved away from the newest samples,
//! a recording under review) samples wake the window at [`STILL_REDRAW_HZ`] only, so the
//! status panel's figures stay current; with no news at all nothing wakes it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use eframe::egui;

use crate::worker;

pub use super::plots::model::{
    DEFAULT_REDRAW_HZ, REDRAW_HZ_MAX, REDRAW_HZ_MIN, STILL_REDRAW_HZ, redraw_hz,
};

/// A frame asked for that has not begun this long after it fell due (at least a period)
/// is asked for again: egui drops a request made in a pass it then ran again.
const OVERDUE: Duration = Duration::from_millis(250);

/// The window's pace, shared by the window and every worker's wake-up call.
#[derive(Debug)]
pub struct Pace {
    epoch: Instant,
    /// The shortest time between two frames woken by news, in nanoseconds.
    period_ns: AtomicU64,
    /// When the last frame began, nanoseconds after `epoch`.
    last_frame_ns: AtomicU64,
    /// A frame has been asked for since the last one began.
    asked: AtomicBool,
    /// Frames begun, and frames asked for by news.
    frames: AtomicU64,
    asks: AtomicU64,
    /// When the last frame asked for by news falls due, nanoseconds after `epoch`.
    last_due_ns: AtomicU64,
    /// The window's context, asked for frames.
    ctx: OnceLock<egui::Context>,
}

impl Default for Pace {
    fn default() -> Self {
        Self {
            epoch: Instant::now(),
            period_ns: AtomicU64::new(period_ns(DEFAULT_REDRAW_HZ)),
            last_frame_ns: AtomicU64::new(0),
            asked: AtomicBool::new(false),
            frames: AtomicU64::new(0),
            asks: AtomicU64::new(0),
            last_due_ns: AtomicU64::new(0),
            ctx: OnceLock::new(),
        }
    }
}

fn period_ns(hz: f64) -> u64 {
    (1e9 / redraw_hz(hz)) as u64
}

impl Pace {
    /// A pace that asks `ctx` for its frames.
    pub fn new(ctx: egui::Context) -> Arc<Self> {
        let pace = Arc::new(Self::default());
        pace.attach(ctx);
        pace
    }

    /// Ask `ctx` for the frames from now on (once: a pace serves one window). Whether it
    /// was attached now.
    pub fn attach(&self, ctx: egui::Context) -> bool {
        self.ctx.set(ctx).is_ok()
    }

    /// The wake-up call to hand the workers.
    pub fn notify(self: &Arc<Self>) -> worker::Notify {
        let pace = Arc::clone(self);
        Arc::new(move || {
            pace.wake(Instant::now());
        })
    }

    /// News waits: ask for a frame one period after the last began, unless one was asked
    /// for already (and is not overdue). What was asked, if anything.
    pub fn wake(&self, now: Instant) -> Option<Duration> {
        let since = now.saturating_duration_since(self.epoch);
        if self.asked.swap(true, Ordering::AcqRel) {
            let due = Duration::from_nanos(self.last_due_ns.load(Ordering::Acquire));
            if since < due + OVERDUE.max(self.period()) {
                return None;
            }
        }
        let delay = self.delay(now);
        let due = since + delay;
        self.last_due_ns
            .store(due.as_nanos() as u64, Ordering::Release);
        self.asks.fetch_add(1, Ordering::Relaxed);
        if let Some(ctx) = self.ctx.get() {
            ctx.request_repaint_after(delay);
        }
        Some(delay)
    }

    /// How long from `now` until a frame woken by news may begin.
    pub fn delay(&self, now: Instant) -> Duration {
        let since = now.saturating_duration_since(self.epoch).as_nanos() as u64;
        let last = self.last_frame_ns.load(Ordering::Acquire);
        let due = last.saturating_add(self.period_ns.load(Ordering::Acquire));
        Duration::from_nanos(due.saturating_sub(since))
    }

    /// A frame begins at `now`: the news that comes from here on asks for the next one,
    /// `redraw_hz` after this one, or [`STILL_REDRAW_HZ`] after while the plots stand
    /// still.
    pub fn frame_began(&self, now: Instant, redraw_hz: f64, still: bool) {
        let hz = if still {
            STILL_REDRAW_HZ.min(redraw_hz)
        } else {
            redraw_hz
        };
        self.period_ns.store(period_ns(hz), Ordering::Release);
        let since = now.saturating_duration_since(self.epoch).as_nanos() as u64;
        self.last_frame_ns.store(since, Ordering::Release);
        self.frames.fetch_add(1, Ordering::Relaxed);
        self.asked.store(false, Ordering::Release);
    }

    /// The time between frames woken by news, as set by the last frame.
    pub fn period(&self) -> Duration {
        Duration::from_nanos(self.period_ns.load(Ordering::Acquire))
    }

    /// Frames begun so far.
    pub fn frames(&self) -> u64 {
        self.frames.load(Ordering::Relaxed)
    }

    /// Frames asked for by news so far, and when the last one asked falls due.
    pub fn asked(&self) -> (u64, Option<Instant>) {
        let asks = self.asks.load(Ordering::Relaxed);
        let due = Duration::from_nanos(self.last_due_ns.load(Ordering::Acquire));
        (asks, (asks > 0).then(|| self.epoch + due))
    }
}

/// Frames per second and the UI thread's CPU time, said on stderr every few seconds when
/// `DRIVEDECK_FRAME_STATS` is set (for measuring the window as it runs).
#[derive(Debug)]
pub struct FrameStats {
    since: Instant,
    frames: u64,
    cpu: Option<Duration>,
}

/// Seconds between two lines of frame statistics.
const STATS_EVERY_S: f64 = 5.0;

impl FrameStats {
    /// Statistics when the environment asks for them.
    pub fn from_env() -> Option<Self> {
        std::env::var_os("DRIVEDECK_FRAME_STATS").map(|_| Self {
            since: Instant::now(),
            frames: 0,
            cpu: thread_cpu(),
        })
    }

    /// One more frame (on the UI thread).
    pub fn frame(&mut self) {
        self.frames += 1;
        let elapsed = self.since.elapsed().as_secs_f64();
        if elapsed < STATS_EVERY_S {
            return;
        }
        let cpu = thread_cpu();
        let used = match (cpu, self.cpu) {
            (Some(now), Some(then)) => format!(
                "{:.0} ms/s",
                now.saturating_sub(then).as_secs_f64() * 1e3 / elapsed
            ),
            _ => "unknown".into(),
        };
        eprintln!(
            "frame stats: {:.1} frames/s, UI thread CPU {used}",
            self.frames as f64 / elapsed
        );
        *self = Self {
            since: Instant::now(),
            frames: 0,
            cpu,
        };
    }
}

/// The CPU time (user and system) of the calling thread so far, on Linux.
pub fn thread_cpu() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    stat_cpu(&stat)
}

/// The CPU time in a `/proc/…/stat` line: utime and stime, in clock ticks of 10 ms (the
/// USER_HZ of every Linux platform drivedeck runs on).
pub fn stat_cpu(stat: &str) -> Option<Duration> {
    // The name in parentheses may hold spaces: the fields are counted after it.
    let rest = &stat[stat.rfind(')')? + 1..];
    let mut fields = rest.split_whitespace();
    // After the name: state (3), …, utime (14), stime (15).
    let utime: u64 = fields.nth(11)?.parse().ok()?;
    let stime: u64 = fields.next()?.parse().ok()?;
    Some(Duration::from_millis((utime + stime) * 10))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn news_asks_for_one_frame_a_period_after_the_last_began() {
        let pace = Pace::default();
        let start = Instant::now();
        pace.frame_began(start, 30.0, false);
        let period = Duration::from_nanos(period_ns(30.0));
        // Many wakes in a burst: one request, the rest ask nothing.
        let asked = pace.wake(start + Duration::from_millis(1));
        assert_eq!(asked, Some(period - Duration::from_millis(1)));
        for ms in 2..30 {
            assert_eq!(pace.wake(start + Duration::from_millis(ms)), None);
        }
        // The next frame: news asks again, a whole period after it.
        let next = start + period;
        pace.frame_began(next, 30.0, false);
        assert_eq!(pace.wake(next), Some(period));
        // Late news (the period is over): at once.
        pace.frame_began(next, 30.0, false);
        assert_eq!(pace.wake(next + period * 2), Some(Duration::ZERO));
        // A frame asked for that never began (the request lost) is asked for again.
        assert_eq!(pace.wake(next + period * 2 + OVERDUE / 2), None);
        assert_eq!(pace.wake(next + period * 2 + OVERDUE), Some(Duration::ZERO));
        assert_eq!(pace.asked().0, 4);
    }

    #[test]
    fn still_plots_are_woken_by_samples_once_a_second() {
        let pace = Pace::default();
        let start = Instant::now();
        pace.frame_began(start, 30.0, true);
        assert_eq!(pace.wake(start), Some(Duration::from_secs(1)));
        assert_eq!(redraw_hz(f64::NAN), DEFAULT_REDRAW_HZ);
        assert_eq!(redraw_hz(0.0), REDRAW_HZ_MIN);
        assert_eq!(redraw_hz(1e6), REDRAW_HZ_MAX);
    }

    #[test]
    fn cpu_time_is_read_after_a_name_with_spaces() {
        let line = "42 (drive worker) S 1 2 3 4 5 6 7 8 9 10 250 17 0 0 20 0 1 0";
        assert_eq!(stat_cpu(line), Some(Duration::from_millis(2670)));
        assert!(thread_cpu().is_some());
    }
}
