//! The worker's loop: connect, exchange the process images at the poll rate, feed the PDI
//! master, sample, run queued jobs, report, reconnect.

use std::collections::{HashMap, VecDeque};
use std::time::{Duration, Instant};

use tokio::sync::mpsc;
use tokio::time::MissedTickBehavior;

use super::protocol::{
    CommandProgress, Event, HALT_ON_LOSS_TIMEOUT, Health, JOG_TIMEOUT, LinkLossAction,
    MAX_LOST_AFTER, MAX_WATCHED, ObjectPath, Request, RequestId, Sample, WORKER_ID,
};
use super::sink::EventSink;
use super::{Config, Envelope};
use crate::connect::{self, AnyLink};
use crate::link::{self, Link, LinkSpec, Refusal, Signal, Signals};
use crate::od::{Address, DataType, Value};
use crate::pdi::{Action, PdiMaster, Progress};

/// Jobs waiting for the PDI beyond this many are refused (the request channel bounds the
/// rest).
const JOB_QUEUE: usize = 256;
/// Room in the queue for bulk reads (a whole dictionary, an EDS's worth).
const BULK_QUEUE: usize = 8192;
/// Samples travel to the UI in batches this far apart (one frame's worth).
const SAMPLE_BATCH: Duration = Duration::from_millis(20);
/// The share of a cycle that queued object accesses (those without the PDI) may take, so
/// a long read list never stalls the PDI: at least one runs per cycle, then more while
/// the time spent stays under this fraction of the poll period. A fast link (Modbus TCP,
/// about 0.05 ms a read) does dozens per cycle, a slow one (RTU at 19200 baud) one.
const OBJECT_SHARE_OF_CYCLE: f64 = 0.5;
/// Reconnect backoff.
const BACKOFF_FIRST: Duration = Duration::from_millis(250);
const BACKOFF_MAX: Duration = Duration::from_secs(5);

/// What a PDI command in flight was for.
#[derive(Clone, Debug)]
enum Purpose {
    Command,
    Read {
        address: Address,
        dtype: Option<DataType>,
    },
    Write {
        address: Address,
        dtype: DataType,
        value: Value,
    },
    /// The value an object has before a PDI write changes it (for undo).
    Before {
        address: Address,
        dtype: DataType,
    },
}

struct Session {
    link: AnyLink,
    native_objects: bool,
    /// Whether the device has the PDI at all.
    pdi: bool,
    master: PdiMaster,
    started: Instant,
    queue: VecDeque<Envelope>,
    purposes: HashMap<RequestId, Purpose>,
    samples: Vec<Sample>,
    last_batch: Instant,
    // health
    cycles: u64,
    rtt_sum: Duration,
    rtt_max: Duration,
    errors: u64,
    last_health: Instant,
    /// Exchanges failed in a row (the link counts as lost at `Config::lost_after`).
    failures: u32,
    /// Troubles the link got over by sending again, since connecting.
    recovered: u64,
    /// The log lines about failed exchanges and recoveries, at a bounded rate.
    failure_notices: Limiter,
    recovery_notices: Limiter,
    /// The next plot signal to read when the exchange did not bring it.
    next_extra: usize,
    /// Signals the device refused to read: never asked again this session.
    unreadable: Vec<Signal>,
    /// The watched objects' state this session.
    watch: WatchState,
    /// A jog runs: halt it unless a keep-alive comes before this.
    jog_deadline: Option<Instant>,
    /// Objects written this session, with the value before the first write (`None`:
    /// could not be read first), for undo.
    before: HashMap<Address, Option<Value>>,
    /// Ids for the worker's own PDI reads (counting down from below `WORKER_ID`).
    next_internal: RequestId,
}

/// The objects sampled on request (`Request::Watch`), read round robin.
#[derive(Default)]
struct WatchState {
    objects: Vec<(Address, DataType)>,
    /// The next one to read by object access.
    next: usize,
    /// Refused by the device this session: never asked again (the user was told).
    refused: Vec<Address>,
}

/// The share of a cycle the watched objects' reads may take (at least one per cycle).
const WATCH_SHARE_OF_CYCLE: f64 = 0.25;

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

/// The worker's state between requests.
struct Worker {
    config: Config,
    /// The link the user asked for; kept while reconnecting.
    wanted: Option<LinkSpec>,
    session: Option<Session>,
    /// A link that failed, kept so that reconnecting reaches the same device (and, for
    /// the simulator, the same simulated drive).
    broken: Option<AnyLink>,
    retry_at: Option<Instant>,
    backoff: Duration,
    ticker: tokio::time::Interval,
    /// The objects sampled on request, kept across reconnects.
    watch: Vec<(Address, DataType)>,
}

/// The worker's whole life.
pub async fn run(
    config: Config,
    mut requests: mpsc::Receiver<Envelope>,
    mut urgent: mpsc::Receiver<Envelope>,
    sink: &mut EventSink,
) {
    let mut w = Worker {
        config,
        wanted: None,
        session: None,
        broken: None,
        retry_at: None,
        backoff: BACKOFF_FIRST,
        ticker: new_ticker(config.poll_rate),
        watch: Vec::new(),
    };
    loop {
        tokio::select! {
            biased;
            message = urgent.recv() => {
                let Some((id, request)) = message else { break };
                w.handle(id, request, sink).await;
            }
            message = requests.recv() => {
                let Some((id, request)) = message else { break };
                w.handle(id, request, sink).await;
            }
            _ = w.ticker.tick() => w.tick(sink).await,
        }
        sink.flush();
        sink.wake();
        if sink.closed {
            break;
        }
    }
    if let Some(mut s) = w.session.take() {
        let _ = s.link.close().await;
    }
}

fn new_ticker(rate: f64) -> tokio::time::Interval {
    let period = Duration::from_secs_f64(1.0 / rate.clamp(1.0, 2000.0));
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(MissedTickBehavior::Skip);
    ticker
}

/// Whether two connection strings name the same physical bus (the node may differ).
fn same_bus(a: &LinkSpec, b: &LinkSpec) -> bool {
    match (a, b) {
        (LinkSpec::CanopenSlcan { path: x, .. }, LinkSpec::CanopenSlcan { path: y, .. }) => x == y,
        (
            LinkSpec::CanopenSocketcan { iface: x, .. },
            LinkSpec::CanopenSocketcan { iface: y, .. },
        ) => x == y,
        (LinkSpec::CanopenSim { .. }, LinkSpec::CanopenSim { .. }) => true,
        _ => false,
    }
}

fn reject_unconnected(id: RequestId, request: &Request, sink: &mut EventSink) {
    sink.emit(Event::Rejected {
        id,
        request: request.to_string(),
        reason: "not connected to a drive".into(),
    });
}

impl Worker {
    async fn tick(&mut self, sink: &mut EventSink) {
        if let Some(s) = self.session.as_mut()
            && s.jog_deadline.is_some_and(|d| Instant::now() >= d)
        {
            s.jog_deadline = None;
            s.start_pdi(WORKER_ID, Request::Halt, sink);
            sink.emit(Event::Notice(format!(
                "jog halted: no keep-alive from the window for {:.1} s (frozen, or the focus was lost)",
                JOG_TIMEOUT.as_secs_f64()
            )));
        }
        if let Some(s) = self.session.as_mut() {
            let budget = Duration::from_secs_f64(
                OBJECT_SHARE_OF_CYCLE / self.config.poll_rate.clamp(1.0, 2000.0),
            );
            let result = s.cycle(sink, self.config.trace, budget).await;
            s.report_recovered(sink);
            let error = match result {
                Ok(()) => {
                    if s.failures > 0 {
                        s.failure_notices.say(
                            format!(
                                "the link recovered after {} failed exchange(s) in a row",
                                s.failures
                            ),
                            sink,
                        );
                        s.failures = 0;
                    }
                    return;
                }
                Err(error) => error,
            };
            // The frames of the failed exchange come before its message.
            let frames = s.link.take_trace();
            if self.config.trace && !frames.is_empty() {
                sink.emit(Event::Frames(frames));
            }
            s.errors += 1;
            s.failures += 1;
            let lost_after = self.config.lost_after.clamp(1, MAX_LOST_AFTER);
            if error.is_momentary() && s.failures < lost_after {
                if s.failures == 1 {
                    s.failure_notices.say(
                        format!(
                            "an exchange with the drive failed: {error}; trying again (the link counts as lost after {lost_after} failures in a row)"
                        ),
                        sink,
                    );
                }
                return;
            }
            {
                let Some(mut s) = self.session.take() else {
                    return;
                };
                let spec = s.link.info().spec;
                let reason = if s.failures > 1 {
                    format!(
                        "{} exchanges failed in a row; the last: {error}",
                        s.failures
                    )
                } else {
                    error.to_string()
                };
                let reason = if s.jog_deadline.is_some() || s.master.travel_running() {
                    let done = s
                        .stop_on_loss(&reason, self.config.on_link_loss, sink)
                        .await;
                    format!("{reason}; {done}")
                } else {
                    reason
                };
                s.abandon_all(&reason, sink);
                sink.emit(Event::Disconnected {
                    reason: Some(reason.clone()),
                });
                if self.config.reconnect && error.is_transient() {
                    self.broken = Some(s.link);
                    self.backoff = BACKOFF_FIRST;
                    self.retry_at = Some(Instant::now() + self.backoff);
                    sink.emit(Event::ConnectFailed {
                        spec,
                        error: reason,
                        retry_in: Some(self.backoff),
                    });
                } else {
                    let _ = s.link.close().await;
                    self.wanted = None;
                }
            }
        } else if let (Some(spec), Some(at)) = (self.wanted.clone(), self.retry_at)
            && Instant::now() >= at
        {
            self.connect(&spec, sink).await;
        }
    }

    async fn handle(&mut self, id: RequestId, request: Request, sink: &mut EventSink) {
        match request {
            Request::Connect(spec) => {
                self.close(Some("the link was closed for a new connection"), sink)
                    .await;
                self.wanted = Some(spec.clone());
                self.backoff = BACKOFF_FIRST;
                self.connect(&spec, sink).await;
            }
            Request::Disconnect => {
                // A command just given (the halt or switch-off of leaving) reaches the drive
                // before the link closes.
                if let Some(s) = self.session.as_mut()
                    && s.master.is_awaiting_ack()
                {
                    let outgoing = s.master.outgoing();
                    let _ = tokio::time::timeout(
                        HALT_ON_LOSS_TIMEOUT,
                        s.link.exchange(outgoing.as_ref()),
                    )
                    .await;
                }
                self.close(Some("disconnected"), sink).await;
                self.wanted = None;
                self.retry_at = None;
                sink.emit(Event::Disconnected { reason: None });
            }
            Request::SetTrace(on) => {
                self.config.trace = on;
                if let Some(s) = self.session.as_mut() {
                    // Start from now: older frames are not news.
                    let _ = s.link.take_trace();
                }
            }
            Request::SetLinkLoss(action) => self.config.on_link_loss = action,
            Request::SetLostAfter(n) => {
                if (1..=MAX_LOST_AFTER).contains(&n) {
                    self.config.lost_after = n;
                } else {
                    sink.emit(Event::Rejected {
                        id,
                        request: request.to_string(),
                        reason: format!(
                            "the link can count as lost after 1 to {MAX_LOST_AFTER} failed exchanges in a row, not {n}"
                        ),
                    });
                }
            }
            Request::SetPollRate(rate) => {
                if rate.is_finite() && (1.0..=2000.0).contains(&rate) {
                    self.config.poll_rate = rate;
                    self.ticker = new_ticker(rate);
                } else {
                    sink.emit(Event::Rejected {
                        id,
                        request: request.to_string(),
                        reason: format!("a poll rate of {rate} Hz is outside 1 to 2000 Hz"),
                    });
                }
            }
            Request::Jog { speed } => match self.session.as_mut() {
                None => reject_unconnected(id, &request, sink),
                Some(s) => {
                    s.start_pdi(id, Request::Command(Action::Velocity { speed }), sink);
                    if s.master.pending_tag() == Some(id) {
                        s.jog_deadline = Some(Instant::now() + JOG_TIMEOUT);
                    }
                }
            },
            Request::JogKeepAlive => {
                if let Some(s) = self.session.as_mut()
                    && s.jog_deadline.is_some()
                {
                    s.jog_deadline = Some(Instant::now() + JOG_TIMEOUT);
                }
            }
            Request::JogStop => match self.session.as_mut() {
                None => reject_unconnected(id, &request, sink),
                Some(s) => {
                    s.jog_deadline = None;
                    if s.master.travel_running() {
                        s.start_pdi(id, Request::Halt, sink);
                    } else {
                        sink.emit(Event::Progress {
                            id,
                            progress: CommandProgress::Done { return_value: 0 },
                        });
                    }
                }
            },
            Request::Watch(ref objects) => {
                if objects.len() > MAX_WATCHED {
                    sink.emit(Event::Rejected {
                        id,
                        request: request.to_string(),
                        reason: format!(
                            "at most {MAX_WATCHED} objects can be sampled besides the built-in signals"
                        ),
                    });
                    return;
                }
                self.watch = objects.clone();
                if let Some(s) = self.session.as_mut() {
                    s.watch = WatchState {
                        objects: objects.clone(),
                        ..WatchState::default()
                    };
                    if !s.native_objects {
                        sink.emit(Event::Notice(
                            "this link has no object access of its own: added objects are sampled only where its process image carries them".into(),
                        ));
                    }
                }
            }
            Request::Scan(spec) => {
                let same_bus = self
                    .session
                    .as_ref()
                    .is_some_and(|s| same_bus(&s.link.info().spec, &spec));
                let result = match self.session.as_mut() {
                    Some(s) if same_bus => s.link.scan().await,
                    _ => connect::scan(&spec).await,
                };
                sink.emit(Event::Scanned {
                    id,
                    result: result.map_err(|e| e.to_string()),
                });
            }
            Request::ListSerialPorts => sink.emit(Event::SerialPorts(link::serial_ports())),
            Request::ListInterfaces => {
                sink.emit(Event::Interfaces(link::enip::discovery::interfaces()))
            }
            Request::Discover {
                interface,
                host,
                port,
            } => {
                let discovery = link::enip::discovery::Discovery {
                    port,
                    interface,
                    unicast: host.into_iter().collect(),
                    ..Default::default()
                };
                let result = link::enip::discovery::discover(&discovery).await;
                sink.emit(Event::Scanned {
                    id,
                    result: result.map_err(|e| e.to_string()),
                });
            }
            Request::ReadMany { ref objects, path } => match self.session.as_mut() {
                None => reject_unconnected(id, &request, sink),
                Some(s) => {
                    if s.queue.len() + objects.len() > BULK_QUEUE {
                        sink.emit(Event::Rejected {
                            id,
                            request: request.to_string(),
                            reason: format!(
                                "{} objects at once is more than the {BULK_QUEUE} the worker queues; read them in parts",
                                objects.len()
                            ),
                        });
                    } else {
                        for &(address, dtype) in objects {
                            s.queue.push_back((
                                id,
                                Request::ReadObject {
                                    address,
                                    dtype: Some(dtype),
                                    path,
                                },
                            ));
                        }
                    }
                }
            },
            Request::Cancel(cancelled) => {
                let dropped = match self.session.as_mut() {
                    Some(s) => {
                        let before = s.queue.len();
                        s.queue.retain(|(queued, _)| *queued != cancelled);
                        before - s.queue.len()
                    }
                    None => 0,
                };
                sink.emit(Event::Cancelled {
                    id: cancelled,
                    dropped,
                });
            }
            Request::Inject { injection, active } => match self.session.as_mut() {
                Some(s) => match s.link.inject(injection, active) {
                    Ok(()) => sink.emit(Event::Notice(format!(
                        "{request}: {}",
                        injection.describe()
                    ))),
                    Err(e) => sink.emit(Event::Rejected {
                        id,
                        request: request.to_string(),
                        reason: e.to_string(),
                    }),
                },
                None => reject_unconnected(id, &request, sink),
            },
            _ => match self.session.as_mut() {
                None => reject_unconnected(id, &request, sink),
                Some(s) => {
                    if request.is_urgent() {
                        // Stops go out now, ahead of everything queued.
                        s.start_pdi(id, request, sink);
                    } else if s.queue.len() >= JOB_QUEUE {
                        sink.emit(Event::Rejected {
                            id,
                            request: request.to_string(),
                            reason: format!(
                                "{JOB_QUEUE} requests are already waiting for the drive"
                            ),
                        });
                    } else {
                        s.queue.push_back((id, request));
                    }
                }
            },
        }
    }

    /// Close the session and forget a broken link.
    async fn close(&mut self, reason: Option<&str>, sink: &mut EventSink) {
        if let Some(mut s) = self.session.take() {
            let _ = s.link.close().await;
            s.abandon_all(reason.unwrap_or("closed"), sink);
            if reason.is_some_and(|r| r != "disconnected") {
                sink.emit(Event::Disconnected { reason: None });
            }
        }
        if let Some(mut link) = self.broken.take() {
            let _ = link.close().await;
        }
    }

    /// Open the wanted link, or bring a broken one back.
    async fn connect(&mut self, spec: &LinkSpec, sink: &mut EventSink) {
        sink.emit(Event::Connecting(spec.clone()));
        // The frames of a connection that failed come before its message.
        let mut frames = Vec::new();
        let result: link::Traced<Session> = match self.broken.take() {
            Some(mut link) => match link.reconnect().await {
                Ok(()) => Session::start(link, &self.config, &self.watch).await,
                Err(e) => {
                    let trace = link.take_trace();
                    self.broken = Some(link);
                    Err((e, trace))
                }
            },
            None => match connect::open_traced(spec).await {
                Ok(link) => Session::start(link, &self.config, &self.watch).await,
                Err(failed) => Err(failed),
            },
        };
        if let Err((_, trace)) = &result {
            frames.extend(trace.iter().cloned());
        }
        let result = result.map_err(|(error, _)| error);
        if self.config.trace && !frames.is_empty() {
            sink.emit(Event::Frames(frames));
        }
        match result {
            Ok(mut s) => {
                sink.emit(Event::Connected(s.link.info()));
                sink.emit(Event::LinkOwnChanges(s.link.own_changes()));
                // What connecting took (PDO mapping, for one), and what the link learned.
                let frames = s.link.take_trace();
                if self.config.trace && !frames.is_empty() {
                    sink.emit(Event::Frames(frames));
                }
                for notice in s.link.take_notices() {
                    sink.emit(Event::Notice(notice));
                }
                self.session = Some(s);
                self.retry_at = None;
                self.backoff = BACKOFF_FIRST;
            }
            Err(error) => {
                let retry_in =
                    (self.config.reconnect && error.is_transient()).then_some(self.backoff);
                sink.emit(Event::ConnectFailed {
                    spec: spec.clone(),
                    error: error.to_string(),
                    retry_in,
                });
                self.retry_at = retry_in.map(|d| Instant::now() + d);
                if retry_in.is_none() {
                    self.broken = None;
                }
                self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
            }
        }
    }
}

impl Session {
    /// Start a session on an open link.
    async fn start(
        mut link: AnyLink,
        config: &Config,
        watch: &[(Address, DataType)],
    ) -> link::Traced<Session> {
        let mut master = PdiMaster::new(config.timing);
        // Start from what the drive holds, so connecting replays no command.
        let first = match Self::first_exchange(&mut link, &mut master).await {
            Ok(first) => first,
            Err(error) => {
                let frames = link.take_trace();
                let _ = link.close().await;
                return Err((error, frames));
            }
        };
        let now = Instant::now();
        master.on_tx(first.tx, now);
        let info = link.info();
        let native_objects = info.native_objects;
        Ok(Session {
            link,
            native_objects,
            pdi: info.pdi,
            master,
            started: now,
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
            recovered: 0,
            failure_notices: Limiter::default(),
            recovery_notices: Limiter::default(),
            next_extra: 0,
            unreadable: Vec::new(),
            watch: WatchState {
                objects: watch.to_vec(),
                ..WatchState::default()
            },
            jog_deadline: None,
            before: HashMap::new(),
            next_internal: WORKER_ID - 1,
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

    /// One poll cycle. An error means the link is gone.
    async fn cycle(
        &mut self,
        sink: &mut EventSink,
        trace: bool,
        budget: Duration,
    ) -> Result<(), link::Error> {
        let outgoing = self.master.outgoing();
        let sent = Instant::now();
        let exchange = self.link.exchange(outgoing.as_ref()).await?;
        let tx = exchange.tx;
        let now = Instant::now();
        let rtt = now - sent;
        self.cycles += 1;
        self.rtt_sum += rtt;
        self.rtt_max = self.rtt_max.max(rtt);
        self.master.on_tx(tx, now);
        self.master.poll(now);
        self.report_progress(sink);

        let mut signals = exchange.signals;
        self.fill_one_missing(&mut signals).await?;
        let watched = self.sample_watched(&signals, budget, sink).await?;
        self.samples.push(Sample {
            watched,
            t: (now - self.started).as_secs_f64(),
            tx,
            signals,
        });
        if now - self.last_batch >= SAMPLE_BATCH {
            self.last_batch = now;
            sink.emit(Event::Samples(std::mem::take(&mut self.samples)));
        }

        self.run_jobs(sink, budget).await?;

        let frames = self.link.take_trace();
        if trace && !frames.is_empty() {
            sink.emit(Event::Frames(frames));
        }

        let notices = self.link.take_notices();
        if !notices.is_empty() {
            for notice in notices {
                sink.emit(Event::Notice(notice));
            }
            let info = self.link.info();
            self.native_objects = info.native_objects;
            sink.emit(Event::LinkChanged(info));
            sink.emit(Event::LinkOwnChanges(self.link.own_changes()));
        }

        if now - self.last_health >= Duration::from_secs(1) {
            let span = (now - self.last_health).as_secs_f64();
            sink.emit(Event::Health(Health {
                cycles_per_second: self.cycles as f64 / span,
                rtt_mean: self.rtt_sum / (self.cycles.max(1) as u32),
                rtt_max: self.rtt_max,
                errors: self.errors,
                recovered: self.recovered,
                dropped_samples: sink.dropped_samples,
            }));
            self.cycles = 0;
            self.rtt_sum = Duration::ZERO;
            self.rtt_max = Duration::ZERO;
            self.last_health = now;
        }
        Ok(())
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
        let started = Instant::now();
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
                    sink.emit(Event::Notice(format!(
                        "{address} is no longer sampled: {}",
                        refusal_text(&refusal)
                    )));
                }
            }
        }
        Ok(values)
    }

    /// Whether a PDI read of a value before a write still runs.
    fn awaiting_before(&self) -> bool {
        self.purposes
            .values()
            .any(|p| matches!(p, Purpose::Before { .. }))
    }

    /// Remember a write for undo and tell the window.
    fn record_change(
        &mut self,
        address: Address,
        dtype: DataType,
        before: Option<Value>,
        after: Value,
        sink: &mut EventSink,
    ) {
        let before = self.before.entry(address).or_insert(before).clone();
        sink.emit(Event::Changed {
            address,
            dtype,
            before,
            after,
        });
    }

    /// Before a PDI write of an object not written yet this session, read its value
    /// through the PDI (for undo). `true` when such a read was started: the write waits.
    fn pre_read(&mut self, request: &Request, sink: &mut EventSink) -> bool {
        let Request::WriteObject { address, dtype, .. } = request else {
            return false;
        };
        if self.before.contains_key(address) {
            return false;
        }
        let id = self.next_internal;
        self.next_internal -= 1;
        let started = self.master.start(
            id,
            Action::OdRead {
                index: address.index,
                sub: address.sub,
            },
            Instant::now(),
        );
        match started {
            Ok(_) => {
                self.purposes.insert(
                    id,
                    Purpose::Before {
                        address: *address,
                        dtype: *dtype,
                    },
                );
                self.report_progress(sink);
                true
            }
            Err(_) => {
                self.before.insert(*address, None);
                false
            }
        }
    }

    /// Start queued jobs: object accesses without the PDI right away (as many as fit in
    /// `budget`, at least one), one PDI command once the previous one was acknowledged.
    async fn run_jobs(
        &mut self,
        sink: &mut EventSink,
        budget: Duration,
    ) -> Result<(), link::Error> {
        let started = Instant::now();
        let mut native_done = 0;
        while let Some((id, request)) = self.queue.front().cloned() {
            let native = match &request {
                Request::ReadObject { path, .. } | Request::WriteObject { path, .. } => {
                    *path == ObjectPath::Native
                        || (*path == ObjectPath::Auto && self.native_objects)
                }
                _ => false,
            };
            if native {
                if native_done > 0 && started.elapsed() >= budget {
                    break;
                }
                self.queue.pop_front();
                if let Err(e) = self.native_job(id, request.clone(), sink).await {
                    // Tried again next cycle, or refused with the reason once the link
                    // counts as lost.
                    self.queue.push_front((id, request));
                    return Err(e);
                }
                native_done += 1;
                continue;
            }
            if self.master.is_awaiting_ack() || self.awaiting_before() {
                break;
            }
            if self.pre_read(&request, sink) {
                break;
            }
            self.queue.pop_front();
            self.start_pdi(id, request, sink);
            break;
        }
        Ok(())
    }

    async fn native_job(
        &mut self,
        id: RequestId,
        request: Request,
        sink: &mut EventSink,
    ) -> Result<(), link::Error> {
        let refusal = match &request {
            Request::ReadObject { address, dtype, .. } => {
                let result = self
                    .link
                    .read_object(*address, dtype.unwrap_or(DataType::Integer32))
                    .await?;
                match result {
                    Ok(value) => {
                        sink.emit(Event::ObjectRead {
                            id,
                            address: *address,
                            result: Ok(value),
                        });
                        return Ok(());
                    }
                    Err(refusal) => refusal,
                }
            }
            Request::WriteObject {
                address,
                dtype,
                value,
                ..
            } => {
                // The value before the first write, for undo.
                let before = match self.before.get(address) {
                    Some(known) => known.clone(),
                    None => {
                        let before = self.link.read_object(*address, *dtype).await?.ok();
                        // Kept at once: a write tried again must not take its own value
                        // for the one before.
                        self.before.insert(*address, before.clone());
                        before
                    }
                };
                match self.link.write_object(*address, *dtype, value).await? {
                    Ok(()) => {
                        sink.emit(Event::ObjectWritten {
                            id,
                            address: *address,
                            value: value.clone(),
                            result: Ok(()),
                        });
                        self.record_change(*address, *dtype, before, value.clone(), sink);
                        return Ok(());
                    }
                    Err(refusal) => refusal,
                }
            }
            other => {
                sink.emit(Event::Rejected {
                    id,
                    request: other.to_string(),
                    reason: "not an object access".into(),
                });
                return Ok(());
            }
        };
        // The link has no object access of its own after all (e.g. a Modbus device without
        // FC 43): an automatic request goes through the PDI instead.
        if refusal == Refusal::NotSupported
            && let Some(request) = via_pdi(&request)
        {
            self.native_objects = false;
            self.queue.push_front((id, request));
            return Ok(());
        }
        match request {
            Request::ReadObject { address, .. } => sink.emit(Event::ObjectRead {
                id,
                address,
                result: Err(refusal_text(&refusal)),
            }),
            Request::WriteObject { address, value, .. } => sink.emit(Event::ObjectWritten {
                id,
                address,
                value,
                result: Err(refusal_text(&refusal)),
            }),
            _ => {}
        }
        Ok(())
    }

    /// The link failed during a move: one last try to halt (or switch off) the drive, as
    /// the setting says. Returns what was done, honestly (for the messages of the link
    /// loss and of the commands it ends); the commands that ran end here.
    async fn stop_on_loss(
        &mut self,
        reason: &str,
        action: LinkLossAction,
        sink: &mut EventSink,
    ) -> String {
        self.jog_deadline = None;
        let running: Vec<RequestId> = [self.master.pending_tag(), self.master.background_tag()]
            .into_iter()
            .flatten()
            .collect();
        let made = match action {
            LinkLossAction::Halt => Some(self.master.halt(WORKER_ID, Instant::now())),
            LinkLossAction::SwitchOff => Some(self.master.start(
                WORKER_ID,
                Action::SwitchOff,
                Instant::now(),
            )),
            LinkLossAction::Nothing => None,
        };
        // The commands that ran end with the link, not "superseded" by this last try.
        let _ = self.master.drain_progress();
        let what = if action == LinkLossAction::Halt {
            "a halt"
        } else {
            "a switch-off"
        };
        let done = match made {
            None => "as set, the drive is left alone: it may still be moving".to_owned(),
            Some(Err(e)) => {
                format!("no {what} could be made ({e}): the drive may still be moving")
            }
            Some(Ok(image)) => {
                let attempt =
                    tokio::time::timeout(HALT_ON_LOSS_TIMEOUT, self.link.exchange(Some(&image)))
                        .await;
                match attempt {
                    Ok(Ok(exchange)) => {
                        let status = exchange.tx.status;
                        let confirmed = match action {
                            LinkLossAction::Halt => status.is_set(crate::pdi::StatusBit::QsHaltBit),
                            _ => !status.is_set(crate::pdi::StatusBit::OperationEnabled),
                        };
                        if confirmed {
                            format!("{what} was sent and the drive confirmed it")
                        } else {
                            format!(
                                "{what} was sent and the drive answered, without showing it yet"
                            )
                        }
                    }
                    Ok(Err(e)) => format!(
                        "{what} did not reach the drive ({e}): it may still be moving; stop it at the machine"
                    ),
                    Err(_) => format!(
                        "{what} got no answer within {:.1} s: the drive may still be moving; stop it at the machine",
                        HALT_ON_LOSS_TIMEOUT.as_secs_f64()
                    ),
                }
            }
        };
        sink.emit(Event::Notice(format!(
            "the link failed during a move ({reason}); {done}"
        )));
        let ended = format!("{reason}; {done}");
        for id in running {
            self.purposes.remove(&id);
            sink.emit(Event::Progress {
                id,
                progress: CommandProgress::LinkLost {
                    reason: ended.clone(),
                },
            });
        }
        done
    }

    /// Troubles the link got over by itself (a reply lost or corrupted, then answered on
    /// another try): counted for the health line, named in the log at a bounded rate.
    fn report_recovered(&mut self, sink: &mut EventSink) {
        for trouble in self.link.take_recovered() {
            self.recovered += 1;
            self.recovery_notices.say(format!("link: {trouble}"), sink);
        }
    }

    fn start_pdi(&mut self, id: RequestId, request: Request, sink: &mut EventSink) {
        if !self.pdi {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason:
                    "this device has no Plug & Drive interface (2291h/2292h): object access only"
                        .into(),
            });
            return;
        }
        let now = Instant::now();
        let described = request.to_string();
        if matches!(request, Request::Command(_) | Request::Resume) {
            // Another command takes over from a jog.
            self.jog_deadline = None;
        }
        let (result, purpose) = match &request {
            Request::Command(action) => (self.master.start(id, *action, now), Purpose::Command),
            Request::Halt => (self.master.halt(id, now), Purpose::Command),
            Request::Resume => (self.master.resume(id, now), Purpose::Command),
            Request::ReadObject { address, dtype, .. } => (
                self.master.start(
                    id,
                    Action::OdRead {
                        index: address.index,
                        sub: address.sub,
                    },
                    now,
                ),
                Purpose::Read {
                    address: *address,
                    dtype: *dtype,
                },
            ),
            Request::WriteObject {
                address,
                dtype,
                value,
                ..
            } => match value.to_pdi(*dtype) {
                Ok(raw) => (
                    self.master.start(
                        id,
                        Action::OdWrite {
                            index: address.index,
                            sub: address.sub,
                            value: raw,
                        },
                        now,
                    ),
                    Purpose::Write {
                        address: *address,
                        dtype: *dtype,
                        value: value.clone(),
                    },
                ),
                Err(e) => {
                    sink.emit(Event::Rejected {
                        id,
                        request: described,
                        reason: e.to_string(),
                    });
                    return;
                }
            },
            other => {
                sink.emit(Event::Rejected {
                    id,
                    request: other.to_string(),
                    reason: "not a PDI request".into(),
                });
                return;
            }
        };
        // Commands superseded by this one report at once.
        self.report_progress(sink);
        match result {
            Ok(image) => {
                self.purposes.insert(id, purpose);
                sink.emit(Event::Sent {
                    id,
                    t: (now - self.started).as_secs_f64(),
                    what: described,
                    image,
                });
            }
            Err(e) => sink.emit(Event::Rejected {
                id,
                request: described,
                reason: e.to_string(),
            }),
        }
    }

    fn report_progress(&mut self, sink: &mut EventSink) {
        for progress in self.master.drain_progress() {
            let id = progress.tag();
            let purpose = if progress.is_final() {
                self.purposes.remove(&id)
            } else {
                self.purposes.get(&id).cloned()
            };
            match (purpose, progress) {
                (Some(Purpose::Read { address, dtype }), Progress::Done { return_value, .. }) => {
                    let dtype = dtype.unwrap_or(DataType::Integer32);
                    sink.emit(Event::ObjectRead {
                        id,
                        address,
                        result: Value::from_pdi(dtype, return_value).map_err(|e| e.to_string()),
                    });
                }
                (
                    Some(Purpose::Write {
                        address,
                        dtype,
                        value,
                    }),
                    Progress::Done { .. },
                ) => {
                    sink.emit(Event::ObjectWritten {
                        id,
                        address,
                        value: value.clone(),
                        result: Ok(()),
                    });
                    let before = self.before.get(&address).cloned().flatten();
                    self.record_change(address, dtype, before, value, sink);
                }
                (Some(Purpose::Before { address, dtype }), Progress::Done { return_value, .. }) => {
                    self.before
                        .insert(address, Value::from_pdi(dtype, return_value).ok());
                }
                (Some(Purpose::Before { address, .. }), p) if p.is_final() => {
                    self.before.insert(address, None);
                }
                (Some(Purpose::Before { .. }), _) => {}
                (Some(Purpose::Read { address, .. }), p) if p.is_final() => {
                    sink.emit(Event::ObjectRead {
                        id,
                        address,
                        result: Err(CommandProgress::from(p).to_string()),
                    });
                }
                (Some(Purpose::Write { address, value, .. }), p) if p.is_final() => {
                    sink.emit(Event::ObjectWritten {
                        id,
                        address,
                        value,
                        result: Err(CommandProgress::from(p).to_string()),
                    });
                }
                (_, Progress::Resent { .. }) => sink.emit(Event::Notice(format!(
                    "request {id}: no acknowledgement yet; sent again with ToggleCmd flipped"
                ))),
                (_, p) => sink.emit(Event::Progress {
                    id,
                    progress: CommandProgress::from(p),
                }),
            }
        }
    }

    /// The link is gone or closed: every command in flight and every queued job ends here,
    /// and none is replayed on the next connection.
    fn abandon_all(&mut self, reason: &str, sink: &mut EventSink) {
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
                reason: format!("not sent: {reason}"),
            });
        }
        if !self.samples.is_empty() {
            sink.emit(Event::Samples(std::mem::take(&mut self.samples)));
        }
    }
}

/// Log lines that may repeat at the cycle rate (a noisy line): at most [`Limiter::BURST`]
/// in any [`Limiter::WINDOW`], then a count of the ones held back with the next one said.
#[derive(Default)]
struct Limiter {
    window_start: Option<Instant>,
    said: u32,
    held: u32,
}

impl Limiter {
    const WINDOW: Duration = Duration::from_secs(5);
    const BURST: u32 = 5;

    fn say(&mut self, text: String, sink: &mut EventSink) {
        let now = Instant::now();
        if self
            .window_start
            .is_none_or(|start| now - start >= Self::WINDOW)
        {
            self.window_start = Some(now);
            self.said = 0;
        }
        if self.said >= Self::BURST {
            self.held += 1;
            return;
        }
        self.said += 1;
        let text = match std::mem::take(&mut self.held) {
            0 => text,
            held => format!("{text} (and {held} more like it before, not shown)"),
        };
        sink.emit(Event::Notice(text));
    }
}

/// An automatic object access, redirected to the PDI.
fn via_pdi(request: &Request) -> Option<Request> {
    match request {
        Request::ReadObject {
            address,
            dtype,
            path: ObjectPath::Auto,
        } => Some(Request::ReadObject {
            address: *address,
            dtype: *dtype,
            path: ObjectPath::Pdi,
        }),
        Request::WriteObject {
            address,
            dtype,
            value,
            path: ObjectPath::Auto,
        } => Some(Request::WriteObject {
            address: *address,
            dtype: *dtype,
            value: value.clone(),
            path: ObjectPath::Pdi,
        }),
        _ => None,
    }
}

fn refusal_text(refusal: &Refusal) -> String {
    refusal.to_string()
}

impl From<Progress> for CommandProgress {
    fn from(progress: Progress) -> Self {
        match progress {
            Progress::Accepted { .. } | Progress::Resent { .. } => CommandProgress::Accepted,
            Progress::Done { return_value, .. } => CommandProgress::Done { return_value },
            Progress::Failed { failure, .. } => CommandProgress::Failed(failure),
            Progress::TimedOut {
                waiting_for, after, ..
            } => CommandProgress::TimedOut { waiting_for, after },
            Progress::Superseded { .. } => CommandProgress::Superseded,
        }
    }
}
