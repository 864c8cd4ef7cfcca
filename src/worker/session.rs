//! One connection's state: the open link, the PDI master that drives it, the queued jobs,
//! the samples on their way, the health counters; how a session starts on an open link
//! and how it ends.

use std::collections::{HashMap, VecDeque};
use std::time::{Duration, Instant};

use super::commands::Purpose;
use super::cycle::WatchState;
use super::limiter::Limiter;
use super::protocol::{CommandProgress, Event, Rejection, RequestId, Sample, WORKER_ID};
use super::sink::EventSink;
use super::{Config, Envelope};
use crate::connect::AnyLink;
use crate::link::{self, Link, Signal};
use crate::od::{Address, DataType, Value};
use crate::pdi::PdiMaster;

pub(super) struct Session {
    pub(super) link: AnyLink,
    pub(super) native_objects: bool,
    /// Whether the device has the PDI at all.
    pub(super) pdi: bool,
    pub(super) master: PdiMaster,
    /// Time zero of the samples' clock: the worker's first connection, kept for the
    /// worker's whole life so that times go on increasing across reconnects.
    pub(super) epoch: Instant,
    pub(super) queue: VecDeque<Envelope>,
    pub(super) purposes: HashMap<RequestId, Purpose>,
    pub(super) samples: Vec<Sample>,
    pub(super) last_batch: Instant,
    // health
    pub(super) cycles: u64,
    pub(super) rtt_sum: Duration,
    pub(super) rtt_max: Duration,
    pub(super) errors: u64,
    pub(super) last_health: Instant,
    /// Exchanges failed in a row (the link counts as lost at `Config::lost_after`).
    pub(super) failures: u32,
    /// The connection closed or reset under the session (`Config::reconnect_in_session`):
    /// it is opened again, not exchanged on, from this time on.
    pub(super) reopen_at: Option<Instant>,
    /// Why it closed (for the notice when it is open again).
    pub(super) reopen_why: Option<String>,
    /// Troubles the link got over by sending again, since connecting.
    pub(super) recovered: u64,
    /// The log lines about failed exchanges and recoveries, at a bounded rate.
    pub(super) failure_notices: Limiter,
    pub(super) recovery_notices: Limiter,
    /// The next plot signal to read when the exchange did not bring it.
    pub(super) next_extra: usize,
    /// Signals the device refused to read: never asked again this session.
    pub(super) unreadable: Vec<Signal>,
    /// The watched objects' state this session.
    pub(super) watch: WatchState,
    /// A jog runs: halt it unless a keep-alive comes before this.
    pub(super) jog_deadline: Option<Instant>,
    /// Objects written this session, with the value before the first write (`None`:
    /// could not be read first), for undo.
    pub(super) before: HashMap<Address, Option<Value>>,
    /// Ids for the worker's own PDI reads (counting down from below `WORKER_ID`).
    pub(super) next_internal: RequestId,
    /// Whether the frames exchanged go to the window or the terminal (`Event::Frames`).
    pub(super) trace: bool,
}

impl Session {
    /// Start a session on an open link; its times count from `epoch` (the worker's first
    /// connection), or from now when this is the first.
    pub(super) async fn start(
        mut link: AnyLink,
        config: &Config,
        watch: &[(Address, DataType)],
        epoch: Option<Instant>,
        sink: &mut EventSink,
    ) -> link::Traced<Session> {
        let mut master = PdiMaster::new(config.timing);
        // Start from what the drive holds, so connecting replays no command.
        let first = match Self::first_exchange(&mut link, &mut master).await {
            Ok(first) => first,
            Err(error) => {
                let mut frames = link.take_trace();
                super::supervisor::close_link(&mut link, false, sink).await;
                frames.extend(link.take_trace());
                return Err((error, frames));
            }
        };
        let now = super::clock::now();
        master.on_tx(first.tx, now);
        let info = link.info();
        let native_objects = info.native_objects;
        Ok(Session {
            link,
            native_objects,
            pdi: info.pdi,
            master,
            epoch: epoch.unwrap_or(now),
            queue: VecDeque::new(),
            purposes: HashMap::new(),
            samples: Vec::new(),
            last_batch: now,
            cycles: 0,
            rtt_sum: Duration::ZERO,
            rtt_max: Duration::ZERO,
            errors: 0,
            last_health: now,
            failures: 0,
            reopen_at: None,
            reopen_why: None,
            recovered: 0,
            failure_notices: Limiter::default(),
            recovery_notices: Limiter::default(),
            next_extra: 0,
            unreadable: Vec::new(),
            watch: WatchState::new(watch),
            jog_deadline: None,
            before: HashMap::new(),
            next_internal: WORKER_ID - 1,
            trace: config.trace,
        })
    }

    /// The RX image the drive holds (adopted, so connecting replays no command) and the
    /// first exchange.
    async fn first_exchange(
        link: &mut AnyLink,
        master: &mut PdiMaster,
    ) -> Result<link::Exchange, link::Error> {
        if let Some(rx) = link.read_rx().await? {
            master.adopt(rx);
        }
        link.exchange(None).await
    }

    /// `at` on the samples' clock: seconds since the epoch.
    pub(super) fn time(&self, at: Instant) -> f64 {
        at.saturating_duration_since(self.epoch).as_secs_f64()
    }

    /// The frames exchanged since the last call, where they are traced: sent ahead of any
    /// outcome, so that a refusal or a failed command follows the frames that carried it.
    pub(super) fn trace_out(&mut self, sink: &mut EventSink) {
        let frames = self.link.take_trace();
        if self.trace && !frames.is_empty() {
            sink.emit(Event::Frames(frames));
        }
    }

    /// The link is gone or closed: every command in flight and every queued job ends here,
    /// and none is replayed on the next connection.
    pub(super) fn abandon_all(&mut self, reason: &str, sink: &mut EventSink) {
        for id in self.master.abandon() {
            self.purposes.remove(&id);
            sink.emit(Event::Progress {
                id,
                progress: CommandProgress::LinkLost {
                    reason: reason.to_owned(),
                },
            });
        }
        for (id, request) in self.queue.drain(..) {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::LinkGone(reason.to_owned()),
            });
        }
        if !self.samples.is_empty() {
            sink.emit(Event::Samples(std::mem::take(&mut self.samples)));
        }
    }
}
