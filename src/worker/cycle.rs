//! One poll cycle: exchange the process images, feed the PDI master, sample (the signals
//! the exchange brought, one it lacked, the watched objects), run queued jobs, report the
//! frames, the link's news and the health line.

use std::time::{Duration, Instant};

use super::protocol::{Event, Health, MAX_WATCHED, Sample};
use super::session::Session;
use super::sink::EventSink;
use crate::link::Notice;
use crate::link::{self, Link, Refusal, Signal, Signals};
use crate::od::{Address, DataType};

/// Samples travel to the UI in batches this far apart (one frame's worth).
const SAMPLE_BATCH: Duration = Duration::from_millis(20);
/// The share of a cycle that queued object accesses (those without the PDI) may take, so
/// a long read list never stalls the PDI: at least one runs per cycle, then more while
/// the time spent stays under this fraction of the poll period. A fast link (Modbus TCP,
/// about 0.05 ms a read) does dozens per cycle, a slow one (RTU at 19200 baud) one.
pub(super) const OBJECT_SHARE_OF_CYCLE: f64 = 0.5;
/// The share of a cycle the watched objects' reads may take (at least one per cycle).
const WATCH_SHARE_OF_CYCLE: f64 = 0.25;

/// The objects sampled on request (`Request::Watch`), read round robin.
#[derive(Default)]
pub(super) struct WatchState {
    pub(super) objects: Vec<(Address, DataType)>,
    /// The next one to read by object access.
    next: usize,
    /// Refused by the device this session: never asked again (the user was told).
    refused: Vec<Address>,
}

impl WatchState {
    /// Watch these objects from the start, none refused yet.
    pub(super) fn new(objects: &[(Address, DataType)]) -> Self {
        Self {
            objects: objects.to_vec(),
            ..Self::default()
        }
    }
}

/// A watched object the exchange already brought: the cheapest path.
fn from_exchange(signals: &Signals, address: Address) -> Option<f64> {
    Signal::of_address(address).and_then(|signal| signals.get(signal))
}

/// Plot signals a link may not bring with its exchange; one of those it lacks is read per
/// cycle, round robin, where the link has object access of its own. (A sample holds only
/// what was measured in its cycle: no value is repeated with a new time.) The analog input
/// is left to the links whose image carries it.
const EXTRA_SIGNALS: [Signal; 7] = [
    Signal::Velocity,
    Signal::Torque,
    Signal::FollowingError,
    Signal::Position,
    Signal::Statusword,
    Signal::Mode,
    Signal::DigitalInputs,
];

impl Session {
    /// One poll cycle. An error means the link is gone.
    pub(super) async fn cycle(
        &mut self,
        sink: &mut EventSink,
        budget: Duration,
    ) -> Result<(), link::Error> {
        let before = super::clock::now();
        if self.failures == 0 && self.master.read_back_due(before) {
            // Another master's image shows only between its writes and ours: read the
            // drive's RX image back before writing ours again. It is part of the cycle: a
            // read that fails is a failed exchange like any other (and while exchanges
            // fail, only the exchange is tried: it is what tells the link is back).
            self.master.read_back_tried(before);
            if let Some(rx) = self.link.read_rx().await? {
                self.master.on_read_back(rx, before);
            }
        }
        let outgoing = self.master.outgoing();
        let sent = super::clock::now();
        let exchange = self.link.exchange(outgoing.as_ref()).await?;
        let tx = exchange.tx;
        let now = super::clock::now();
        let rtt = now - sent;
        self.cycles += 1;
        self.rtt_sum += rtt;
        self.rtt_max = self.rtt_max.max(rtt);
        self.master.on_tx(tx, now);
        self.master.poll(now);
        if let Some(flips) = self.master.foreign_report(now) {
            sink.emit(Event::Notice(Notice::info(foreign_commands(flips))));
        }
        self.trace_out(sink);
        self.report_progress(sink);

        let mut signals = exchange.signals;
        self.fill_one_missing(&mut signals).await?;
        let watched = self.sample_watched(&signals, budget, sink).await?;
        self.samples.push(Sample {
            watched,
            t: self.time(now),
            tx,
            signals,
        });
        if now - self.last_batch >= SAMPLE_BATCH {
            self.last_batch = now;
            sink.emit(Event::Samples(std::mem::take(&mut self.samples)));
        }

        self.run_jobs(sink, budget).await?;
        self.trace_out(sink);
        self.report_link_news(sink);
        self.report_health(now, sink);
        Ok(())
    }

    /// What the link learned this cycle (its notices), and the link as it is now.
    fn report_link_news(&mut self, sink: &mut EventSink) {
        let notices = self.link.take_notices();
        if notices.is_empty() {
            return;
        }
        for notice in notices {
            sink.emit(Event::Notice(notice));
        }
        let info = self.link.info();
        self.native_objects = info.native_objects;
        sink.emit(Event::LinkChanged(info));
        sink.emit(Event::LinkOwnChanges(self.link.own_changes()));
    }

    /// The health line, once a second.
    fn report_health(&mut self, now: Instant, sink: &mut EventSink) {
        if now - self.last_health < Duration::from_secs(1) {
            return;
        }
        let span = (now - self.last_health).as_secs_f64();
        sink.emit(Event::Health(Health {
            cycles_per_second: self.cycles as f64 / span,
            rtt_mean: self.rtt_sum / (self.cycles.max(1) as u32),
            rtt_max: self.rtt_max,
            errors: self.errors,
            recovered: self.recovered,
            dropped_samples: sink.dropped_samples,
            dropped_frames: sink.dropped_frames,
        }));
        self.cycles = 0;
        self.rtt_sum = Duration::ZERO;
        self.rtt_max = Duration::ZERO;
        self.last_health = now;
    }

    /// Read one plot signal the exchange lacked (round robin), where the link can.
    async fn fill_one_missing(&mut self, signals: &mut Signals) -> Result<(), link::Error> {
        if !self.native_objects {
            return Ok(());
        }
        for step in 0..EXTRA_SIGNALS.len() {
            let signal = EXTRA_SIGNALS[(self.next_extra + step) % EXTRA_SIGNALS.len()];
            if signals.has(signal) || self.unreadable.contains(&signal) {
                continue;
            }
            self.next_extra = (self.next_extra + step + 1) % EXTRA_SIGNALS.len();
            match self
                .link
                .read_object(signal.address(), signal.dtype())
                .await?
            {
                Ok(value) => {
                    if let Some(v) = value.as_f64() {
                        signals.set(signal, v);
                    }
                }
                Err(Refusal::NotSupported) => self.native_objects = false,
                // Busy for now (Modbus 05h acknowledge, 06h busy): asked again later.
                Err(Refusal::Modbus {
                    code: 0x05 | 0x06, ..
                }) => {}
                Err(_) => self.unreadable.push(signal),
            }
            return Ok(());
        }
        Ok(())
    }

    /// The watched objects this cycle: from the exchange where it brought them, the others
    /// by object access, round robin, while the time spent stays under a share of the
    /// cycle (at least one read per cycle).
    async fn sample_watched(
        &mut self,
        signals: &Signals,
        budget: Duration,
        sink: &mut EventSink,
    ) -> Result<[Option<f64>; MAX_WATCHED], link::Error> {
        let mut values = [None; MAX_WATCHED];
        let mut to_read = Vec::new();
        for (slot, &(address, dtype)) in self.watch.objects.iter().enumerate().take(MAX_WATCHED) {
            match from_exchange(signals, address) {
                Some(v) => values[slot] = Some(v),
                None if !self.watch.refused.contains(&address) => {
                    to_read.push((slot, address, dtype))
                }
                None => {}
            }
        }
        if to_read.is_empty() || !self.native_objects {
            return Ok(values);
        }
        let budget = budget.mul_f64(WATCH_SHARE_OF_CYCLE / OBJECT_SHARE_OF_CYCLE);
        let started = super::clock::now();
        let first = self.watch.next % to_read.len();
        for step in 0..to_read.len() {
            if step > 0 && started.elapsed() >= budget {
                break;
            }
            let (slot, address, dtype) = to_read[(first + step) % to_read.len()];
            self.watch.next = first + step + 1;
            match self.link.read_object(address, dtype).await? {
                Ok(value) => values[slot] = value.as_f64(),
                Err(Refusal::NotSupported) => {
                    self.native_objects = false;
                    break;
                }
                Err(refusal) => {
                    self.watch.refused.push(address);
                    sink.emit(Event::Notice(Notice::info(format!(
                        "{address} is no longer sampled: {refusal}"
                    ))));
                }
            }
        }
        Ok(values)
    }
}

/// What the user is told when the drive takes commands this master did not send.
fn foreign_commands(flips: u32) -> String {
    format!(
        "another master writes the PDI image: the drive took {flips} command(s) drivedeck \
         did not send (PdiStatusToggleCmd flipped on its own, or 2291h read back held \
         another image); what the drive does now is \
         not what was asked here. Stop the other master (a PLC, Plug & Drive Studio, a \
         second drivedeck) or command the drive from it"
    )
}
