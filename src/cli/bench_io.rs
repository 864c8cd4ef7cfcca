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
//! * **blocked**: the thread spins for 20 ms at a stretch between exchanges (a slow task
//!   that never yields), which the producer of a runtime task could not get past.

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
}

impl Intervals {
    fn from(what: String, rpi: Duration, intervals: &[Duration]) -> Intervals {
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
    Blocked,
}

impl Load {
    const ALL: [Load; 3] = [Load::Idle, Load::Dictionary, Load::Blocked];

    fn name(self) -> &'static str {
        match self {
            Load::Idle => "idle",
            Load::Dictionary => "reading the dictionary",
            Load::Blocked => "thread blocked 20 ms at a time",
        }
    }
}

/// Whether `spec` is an EtherNet/IP link that runs class 1 I/O.
pub fn applies(spec: &LinkSpec) -> bool {
    matches!(spec, LinkSpec::Enip { enip, .. } if !matches!(enip.io, crate::link::spec::EnipIo::Explicit))
}

/// The intervals under each load, `span` per load in all; empty when the link opened
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
    for _ in 0..ROUNDS {
        for (load, timing) in gathered.iter_mut() {
            link.record_io_timing(true);
            let start = Instant::now();
            while start.elapsed() < slice {
                link.exchange(rx.as_ref()).await?;
                match load {
                    Load::Idle => {}
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
                    Load::Blocked => {
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
    let _ = link.close().await;
    let mut out = vec![];
    for (load, timing) in &gathered {
        out.push(Intervals::from(
            format!("O→T sent, {}", load.name()),
            rpi,
            &timing.ot,
        ));
    }
    for (load, timing) in &gathered {
        out.push(Intervals::from(
            format!("T→O taken, {}", load.name()),
            rpi,
            &timing.to,
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
    if !json {
        for i in &intervals {
            outln!("  {i}");
        }
    }
    Ok(intervals)
}
