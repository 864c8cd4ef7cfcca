//! `drivedeck bench` on an EtherNet/IP link with class 1 I/O: does the I/O keep its time?
//!
//! The O→T production intervals (what the adapter times out on) and the T→O arrival
//! intervals, measured by the I/O threads themselves, under three loads of the thread
//! that owns the link (the worker's, here the bench's), interleaved in rounds because the
//! machine is shared:
//!
//! * **idle**: PDI exchanges only;
//! * **dictionary**: the worker's "Read all": each cycle one PDI exchange, then object
//!   reads through the whole built-in catalog for up to half an RPI (at least one);
//! * **held**: the thread sleeps 20 ms at a stretch between exchanges (a slow task that
//!   blocks and never yields), which a producer running as a task on that runtime could
//!   not get past;
//! * **busy**: the same, spinning (a slow task that burns a core while it holds the
//!   thread): on a machine of two cores this also takes CPU from the I/O threads;
//! * **plotting**: another thread draws the plot panel, as the window does, 60 frames a
//!   second through a headless egui context with ten minutes of 1 kHz samples (about 5 ms
//!   a frame, BENCHMARKS.md), while the link's thread exchanges the PDI.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::link::enip::client::EnipLink;
use crate::link::enip::{IoTiming, KEPT_WITHIN};
use crate::link::{self, Link, LinkSpec};
use crate::od::{Address, DataType};
use crate::proto::enip::io::Spread;

/// Rounds each load is measured in, in turn.
const ROUNDS: u32 = 3;
/// How long the blocked load holds the thread at a stretch.
const BLOCK: Duration = Duration::from_millis(20);

/// The intervals of one direction under one load.
#[derive(Serialize, Debug)]
pub struct Intervals {
    pub what: String,
    pub rpi_ms: f64,
    pub count: usize,
    pub per_second: f64,
    pub median_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    /// The 99th percentile within [`KEPT_WITHIN`] of the RPI.
    pub kept: bool,
    /// What the scanner's thread of this direction got from the OS: the producer's for
    /// O→T, the consumer's (at the end: lowered after a flood) for T→O.
    pub thread_priority: String,
}

impl Intervals {
    fn from(what: String, rpi: Duration, intervals: &[Duration], priority: &str) -> Intervals {
        let spread = Spread::of(intervals);
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let total: Duration = intervals.iter().sum();
        Intervals {
            what,
            rpi_ms: ms(rpi),
            count: spread.count,
            per_second: spread.count as f64 / total.as_secs_f64().max(1e-9),
            median_ms: ms(spread.p50),
            p99_ms: ms(spread.p99),
            max_ms: ms(spread.max),
            kept: ms(spread.p99) <= ms(rpi) * (1.0 + KEPT_WITHIN),
            thread_priority: priority.to_owned(),
        }
    }
}

impl std::fmt::Display for Intervals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:<34} {:>8} packets = {:>8.0}/s   interval median {:.3} ms, p99 {:.3} ms, max {:.3} ms (RPI {} ms{})",
            self.what,
            self.count,
            self.per_second,
            self.median_ms,
            self.p99_ms,
            self.max_ms,
            self.rpi_ms,
            if self.kept {
                ", kept"
            } else {
                ", NOT kept within 20 %"
            }
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Load {
    Idle,
    Dictionary,
    Held,
    Busy,
    Plotting,
}

impl Load {
    const ALL: [Load; 5] = [
        Load::Idle,
        Load::Dictionary,
        Load::Held,
        Load::Busy,
        Load::Plotting,
    ];

    fn name(self) -> &'static str {
        match self {
            Load::Idle => "idle",
            Load::Dictionary => "dictionary read",
            Load::Held => "thread held 20 ms",
            Load::Busy => "thread busy 20 ms",
            Load::Plotting => "window plotting",
        }
    }
}

/// Samples in the plot history of the plotting load: the window's default, ten minutes
/// at 1 kHz.
const PLOT_ROWS: usize = 600_000;
const FRAME: Duration = Duration::from_micros(16_667);

/// A thread that draws the plot panel at 60 frames a second while `active`, until `stop`.
struct Plotter {
    /// The history is built: frames cost what a running window's do.
    ready: Arc<AtomicBool>,
    active: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Plotter {
    fn start() -> std::io::Result<Plotter> {
        let ready = Arc::new(AtomicBool::new(false));
        let active = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let (r, a, s) = (ready.clone(), active.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("bench-plotting".into())
            .spawn(move || plot_frames(&r, &a, &s))?;
        Ok(Plotter {
            ready,
            active,
            stop,
            thread: Some(thread),
        })
    }

    /// The history is built (or the thread ended: nothing to wait for).
    fn ready(&self) -> bool {
        self.ready.load(Ordering::Acquire) || self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    fn set_active(&self, on: bool) {
        self.active.store(on, Ordering::Release);
    }
}

impl Drop for Plotter {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            thread.thread().unpark();
            let _ = thread.join();
        }
    }
}

fn plot_frames(ready: &AtomicBool, active: &AtomicBool, stop: &AtomicBool) {
    use crate::pdi::{Status, TxImage};
    use crate::signal::{Signal, Signals};
    use eframe::egui;
    let mut plots = crate::ui::plots::Alone::new(PLOT_ROWS);
    for i in 0..PLOT_ROWS {
        let t = i as f64 * 0.001;
        let noise = ((i * 7919) % 101) as f64 - 50.0;
        plots.drive.scope.push(&crate::worker::Sample {
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
            ..crate::worker::Sample::default()
        });
    }
    let ctx = egui::Context::default();
    ready.store(true, Ordering::Release);
    let mut next = Instant::now();
    while !stop.load(Ordering::Acquire) {
        if !active.load(Ordering::Acquire) {
            std::thread::park_timeout(Duration::from_millis(5));
            next = Instant::now();
            continue;
        }
        std::hint::black_box(crate::ui::plots::headless_frame(&ctx, &mut plots));
        next += FRAME;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
}

/// Whether `spec` is an EtherNet/IP link that runs class 1 I/O.
pub fn applies(spec: &LinkSpec) -> bool {
    matches!(spec, LinkSpec::Enip { enip, .. } if !matches!(enip.io, crate::link::spec::EnipIo::Explicit))
}

/// The intervals under each load, `span` per load in all (the plotting thread first builds
/// its history, a second or so); empty when the link opened
/// without I/O (the adapter refused it).
pub async fn measure(spec: &LinkSpec, span: Duration) -> Result<Vec<Intervals>, link::Error> {
    let mut link = EnipLink::connect(spec).await?;
    let Some(rpi) = link.io_rpi() else {
        let _ = link.close().await;
        return Ok(vec![]);
    };
    let rx = link.read_rx().await?;
    let objects: Vec<(Address, DataType)> = crate::od::builtin()
        .entries()
        .filter(|e| e.access.readable())
        .map(|e| (e.address, e.dtype))
        .collect();
    let mut next_object = 0;
    let mut gathered: Vec<(Load, IoTiming)> = Load::ALL
        .iter()
        .map(|l| (*l, IoTiming::default()))
        .collect();
    let slice = span / ROUNDS;
    let plotter = Plotter::start().map_err(|e| link::Error::Io {
        context: "starting the plotting thread".into(),
        source: e,
    })?;
    while !plotter.ready() {
        link.exchange(rx.as_ref()).await?;
    }
    for _ in 0..ROUNDS {
        for (load, timing) in gathered.iter_mut() {
            plotter.set_active(*load == Load::Plotting);
            if *load == Load::Plotting {
                // The first frames lay out and cache fonts: not what a running window costs.
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
            link.record_io_timing(true);
            let start = Instant::now();
            while start.elapsed() < slice {
                link.exchange(rx.as_ref()).await?;
                match load {
                    Load::Idle | Load::Plotting => {}
                    Load::Held => std::thread::sleep(BLOCK),
                    Load::Dictionary => {
                        let cycle = Instant::now();
                        loop {
                            if let Some(&(address, dtype)) = objects.get(next_object) {
                                // A refusal is an answer too: the read took its time.
                                let _ = link.read_object(address, dtype).await?;
                            }
                            next_object = (next_object + 1) % objects.len().max(1);
                            if cycle.elapsed() >= rpi / 2 {
                                break;
                            }
                        }
                    }
                    Load::Busy => {
                        let spin = Instant::now();
                        while spin.elapsed() < BLOCK {
                            std::hint::spin_loop();
                        }
                    }
                }
            }
            if let Some(taken) = link.take_io_timing() {
                timing.ot.extend(taken.ot);
                timing.to.extend(taken.to);
            }
            link.record_io_timing(false);
        }
    }
    plotter.set_active(false);
    drop(plotter);
    let said = |p: Option<crate::link::enip::priority::Priority>| {
        p.map_or_else(|| "unknown".to_owned(), |p| p.to_string())
    };
    let (producer, consumer) = (said(link.io_priority()), said(link.io_consumer_priority()));
    let _ = link.close().await;
    let mut out = vec![];
    for (load, timing) in &gathered {
        out.push(Intervals::from(
            format!("O→T sent, {}", load.name()),
            rpi,
            &timing.ot,
            &producer,
        ));
    }
    for (load, timing) in &gathered {
        out.push(Intervals::from(
            format!("T→O taken, {}", load.name()),
            rpi,
            &timing.to,
            &consumer,
        ));
    }
    Ok(out)
}

/// [`measure`] for a target of `drivedeck bench`, printed unless `json`: nothing for a
/// link that is not EtherNet/IP with class 1 I/O; `Err` says why it failed.
pub fn run(
    runtime: &tokio::runtime::Runtime,
    spec: &LinkSpec,
    span: Duration,
    json: bool,
) -> Result<Vec<Intervals>, link::Error> {
    if !applies(spec) {
        return Ok(vec![]);
    }
    let intervals = runtime.block_on(measure(spec, span))?;
    let first = |direction: &str| intervals.iter().find(|i| i.what.starts_with(direction));
    if let (false, Some(ot), Some(to)) = (json, first("O→T"), first("T→O")) {
        outln!(
            "  class 1 threads: producer {} priority, consumer {} priority (${}=normal for ordinary)",
            ot.thread_priority,
            to.thread_priority,
            crate::link::enip::priority::PRIORITY_ENV
        );
    }
    if !json {
        for i in &intervals {
            outln!("  {i}");
        }
    }
    Ok(intervals)
}
