//! The scanner side of a class 1 I/O connection: a producer that sends the O→T assembly at
//! the RPI, a consumer that takes in the adapter's T→O packets, and the connection
//! declared dead when they stop for the connection timeout. The link hands them outputs
//! and waits for inputs.
//!
//! Both run on threads of their own, not on the worker's runtime: a slow request, a
//! dictionary read or anything else that holds the worker's thread cannot delay an O→T
//! packet (which the adapter times out on) nor the taking of a T→O one. The producer
//! sleeps to absolute deadlines (start + k × RPI, [`Schedule`]) on the OS's
//! high-resolution timer rather than tokio's millisecond wheel, at real-time priority where
//! the OS grants it ([`priority`]). The worker and the
//! threads share the outputs, the newest input and the counters under one mutex held for
//! a copy at a time.
//!
//! UDP may lose, repeat or reorder datagrams: only one newer (by its encapsulation
//! sequence number) than every one before carries the current image, and only such a one
//! keeps the connection alive (protocol notes §3.5). Copies and stale ones are dropped,
//! counted, and reported as troubles got over, at a bounded rate.

use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::Notify;

use super::priority::{self, FloodGuard, Priority};
use crate::link::{RawFrames, TraceRecord};
use crate::proto::enip::io::{Arrival, IoPacket, Newest, Schedule, Spread};
use crate::proto::enip::wire::hex;

/// What the I/O task needs to know.
#[derive(Clone, Debug)]
pub struct IoConfig {
    /// The O→T connection id the adapter chose.
    pub ot_connection: u32,
    /// The T→O connection id we proposed (the adapter's packets carry it).
    pub to_connection: u32,
    /// Where O→T packets go.
    pub target: SocketAddr,
    pub ot_rpi: Duration,
    /// The RPI the adapter produces T→O packets at.
    pub to_rpi: Duration,
    /// The connection timeout in RPIs (4 << the timeout multiplier, protocol notes §3.4).
    pub timeout_factor: u32,
    /// No T→O packet for this long (`to_rpi` × `timeout_factor`): the connection is dead.
    pub to_timeout: Duration,
    /// Whether O→T packets carry the run/idle header (they do, in RUN).
    pub ot_header: bool,
    /// Whether T→O packets carry it (Nanotec: no, modeless).
    pub to_header: bool,
    /// The first O→T assembly: what the drive holds already, so opening moves nothing.
    pub output: Vec<u8>,
    /// The T→O assembly length the packets must have.
    pub input_len: usize,
}

/// Dropped T→O datagrams are reported at most this often: a network that reorders does
/// so again and again, and the log must not fill at the RPI.
pub const REPORT_EVERY: Duration = Duration::from_secs(1);

/// One T→O assembly as it arrived.
#[derive(Clone, Debug)]
pub struct Input {
    pub data: Vec<u8>,
    /// Packets taken up to and including this one.
    pub number: u64,
}

/// T→O datagrams of this connection dropped by their sequence number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Dropped {
    /// Older than one already taken.
    out_of_order: u64,
    /// The same number as the newest taken.
    duplicate: u64,
}

impl Dropped {
    fn is_empty(&self) -> bool {
        *self == Dropped::default()
    }

    /// The troubles in words, one line per kind.
    fn words(&self) -> Vec<String> {
        let many = |n: u64| if n == 1 { "" } else { "s" };
        let mut out = vec![];
        if self.out_of_order > 0 {
            out.push(format!(
                "{} T→O datagram{} came out of order and {} dropped (older than one already taken)",
                self.out_of_order,
                many(self.out_of_order),
                if self.out_of_order == 1 {
                    "was"
                } else {
                    "were"
                }
            ));
        }
        if self.duplicate > 0 {
            out.push(format!(
                "{} T→O datagram{} came twice and the {} dropped",
                self.duplicate,
                many(self.duplicate),
                if self.duplicate == 1 {
                    "copy was"
                } else {
                    "copies were"
                }
            ));
        }
        out
    }
}

/// The production intervals looked at when a connection opens, to tell whether this
/// computer keeps the RPI: those of the first [`STARTUP_SPAN`], at least
/// [`STARTUP_MIN`] of them.
pub const STARTUP_SPAN: Duration = Duration::from_secs(1);
const STARTUP_MIN: usize = 10;
/// An RPI is kept when the 99th percentile of the production intervals is within this
/// fraction of it (a fifth: 2.4 ms at 2 ms).
pub const KEPT_WITHIN: f64 = 0.2;
/// Intervals kept while recording for a measurement (10 minutes at 1 ms).
const MAX_RECORDED: usize = 600_000;

/// Production and arrival intervals of a connection, as measured by its threads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IoTiming {
    /// Between consecutive O→T packets sent.
    pub ot: Vec<Duration>,
    /// Between consecutive T→O packets taken (the newest so far each).
    pub to: Vec<Duration>,
}

#[derive(Debug, Default)]
struct Timing {
    last_sent: Option<Instant>,
    last_input: Option<Instant>,
    /// The intervals of the first [`STARTUP_SPAN`] after the first packet.
    startup: Vec<Duration>,
    first_sent: Option<Instant>,
    /// The startup figures are complete: the verdict, once, for the link's notices.
    verdict: Option<Option<String>>,
    recording: bool,
    recorded: IoTiming,
    /// What the producer thread got from the OS.
    priority: Option<Priority>,
    /// What the consumer thread runs at: real-time where granted, until a flood.
    consumer_priority: Option<Priority>,
}

#[derive(Debug)]
struct Shared {
    output: Vec<u8>,
    input: Option<Input>,
    /// Packets taken (each the newest so far).
    received: u64,
    sent: u64,
    /// Packets for other connections, or with the wrong size.
    stray: u64,
    /// The sequence numbers of the packets taken.
    newest: Newest,
    /// Dropped since the last report.
    unreported: Dropped,
    reported_at: Option<Instant>,
    error: Option<String>,
    /// Said once, with the troubles got over (a flood that lowered the consumer).
    notices: Vec<String>,
    trace: RawFrames<IoFrame>,
    timing: Timing,
}

impl Default for Shared {
    fn default() -> Self {
        Shared {
            output: Vec::new(),
            input: None,
            received: 0,
            sent: 0,
            stray: 0,
            newest: Newest::default(),
            unreported: Dropped::default(),
            reported_at: None,
            error: None,
            notices: Vec::new(),
            trace: RawFrames::new(TRACE_BYTES),
            timing: Timing::default(),
        }
    }
}

/// Bytes of an I/O packet kept for the frame log (an assembly is at most 500 bytes).
const TRACE_BYTES: usize = 1024;

/// What an I/O datagram was, kept with its bytes; the frame log's words are written from
/// both when it is taken, not at the RPI.
#[derive(Clone, Debug)]
enum IoFrame {
    /// An O→T packet sent.
    Sent,
    /// A T→O packet taken as the newest.
    Taken,
    /// A T→O packet dropped: the newest sequence number before it, and why.
    Dropped { newest: u32, why: &'static str },
    /// A class 1 packet of another connection or size.
    Stray,
    /// Not a class 1 packet at all.
    Bad(String),
}

impl Shared {
    fn record(&mut self, sent: bool, bytes: &[u8], frame: IoFrame) {
        self.trace.record(sent, frame, bytes);
    }

    /// An O→T packet left at `now`.
    fn on_sent(&mut self, now: Instant, rpi: Duration) {
        let t = &mut self.timing;
        if let Some(last) = t.last_sent.replace(now) {
            let interval = now - last;
            if t.recording && t.recorded.ot.len() < MAX_RECORDED {
                t.recorded.ot.push(interval);
            }
            if t.verdict.is_none() {
                t.startup.push(interval);
                let first = *t.first_sent.get_or_insert(last);
                if now - first >= STARTUP_SPAN && t.startup.len() >= STARTUP_MIN {
                    t.verdict = Some(verdict(&Spread::of(&t.startup), rpi, t.priority));
                    t.startup = vec![];
                }
            }
        }
    }

    /// The newest T→O packet came at `now`.
    fn on_input(&mut self, now: Instant) {
        let t = &mut self.timing;
        if let Some(last) = t.last_input.replace(now)
            && t.recording
            && t.recorded.to.len() < MAX_RECORDED
        {
            t.recorded.to.push(now - last);
        }
    }
}

/// What the first intervals of a connection say: a warning with the figures when this
/// computer did not keep the RPI, `None` when it did.
fn verdict(spread: &Spread, rpi: Duration, priority: Option<Priority>) -> Option<String> {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    if ms(spread.p99) <= ms(rpi) * (1.0 + KEPT_WITHIN) {
        return None;
    }
    let hint = match priority {
        Some(Priority::Realtime(_)) | None => String::new(),
        Some(Priority::Normal) => format!(
            "; the I/O thread runs at ordinary priority (real-time needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least 1, e.g. `ulimit -r {}`)",
            priority::REALTIME_PRIORITY
        ),
    };
    Some(format!(
        "class 1 I/O: this computer does not keep the RPI of {} ms: over the first {} O→T packets the interval was {:.2} ms at the median, {:.2} ms at the 99th percentile, {:.2} ms at most; the adapter sees the outputs that much later (a larger RPI, or a less loaded computer, keeps time){hint}",
        rpi.as_millis(),
        spread.count + 1,
        ms(spread.p50),
        ms(spread.p99),
        ms(spread.max),
    ))
}

/// The threads of a running connection, and how to stop them.
#[derive(Debug, Default)]
struct Threads {
    producer: Option<JoinHandle<()>>,
    consumer: Option<JoinHandle<()>>,
    /// A task on the runtime that opened the connection, holding what the producer
    /// watches: when that runtime ends (the worker is gone, whatever became of the link),
    /// production stops, so the adapter times out as it would on a scanner that died.
    tie: Option<tokio::task::JoinHandle<()>>,
}

/// A running I/O connection.
#[derive(Debug)]
pub struct IoHandle {
    shared: Arc<Mutex<Shared>>,
    notify: Arc<Notify>,
    stop: Arc<AtomicBool>,
    threads: Mutex<Threads>,
    pub local: SocketAddr,
    pub config: IoConfig,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

impl IoHandle {
    /// Start producing at once on `socket`, on threads of its own.
    pub fn start(socket: UdpSocket, config: IoConfig) -> std::io::Result<IoHandle> {
        let local = socket.local_addr()?;
        socket.set_nonblocking(false)?;
        // Only so that the consumer notices a stop even if the wake-up datagram is lost.
        socket.set_read_timeout(Some(Duration::from_millis(100)))?;
        let shared = Arc::new(Mutex::new(Shared {
            output: config.output.clone(),
            ..Shared::default()
        }));
        let notify = Arc::new(Notify::new());
        let stop = Arc::new(AtomicBool::new(false));
        let alive = Arc::new(());
        let owner = Arc::downgrade(&alive);
        let tie = tokio::runtime::Handle::try_current().ok().map(|runtime| {
            runtime.spawn(async move {
                let _alive = alive;
                std::future::pending::<()>().await
            })
        });
        let consumer = Consumer {
            socket: socket.try_clone()?,
            config: config.clone(),
            shared: shared.clone(),
            notify: notify.clone(),
            stop: stop.clone(),
        };
        let consumer = std::thread::Builder::new()
            .name("enip-io-consumer".into())
            .spawn(move || consumer.run())?;
        let producer = Producer {
            opened: Instant::now(),
            first_grace: config.to_timeout.max(Duration::from_secs(1)),
            socket,
            config: config.clone(),
            shared: shared.clone(),
            notify: notify.clone(),
            stop: stop.clone(),
            owner: tie.as_ref().map(|_| owner),
            sequence: 0,
            count: 0,
            last_sent: None,
        };
        let producer = match std::thread::Builder::new()
            .name("enip-io-producer".into())
            .spawn(move || producer.run())
        {
            Ok(producer) => producer,
            Err(e) => {
                stop.store(true, Ordering::Release);
                wake_consumer(local);
                let _ = consumer.join();
                if let Some(tie) = tie {
                    tie.abort();
                }
                return Err(e);
            }
        };
        Ok(IoHandle {
            shared,
            notify,
            stop,
            threads: Mutex::new(Threads {
                producer: Some(producer),
                consumer: Some(consumer),
                tie,
            }),
            local,
            config,
        })
    }

    /// The O→T assembly from the next packet on.
    pub fn set_output(&self, output: Vec<u8>) {
        lock(&self.shared).output = output;
    }

    /// Packets received so far.
    pub fn received(&self) -> u64 {
        lock(&self.shared).received
    }

    /// (sent, received, stray) packet counts.
    pub fn counts(&self) -> (u64, u64, u64) {
        let s = lock(&self.shared);
        (s.sent, s.received, s.stray)
    }

    /// Start (clearing what was recorded) or stop recording the production and arrival
    /// intervals, for a measurement.
    pub fn record_timing(&self, on: bool) {
        let mut s = lock(&self.shared);
        s.timing.recording = on;
        if on {
            s.timing.recorded = IoTiming::default();
        }
    }

    /// The intervals recorded since [`IoHandle::record_timing`], taken.
    pub fn take_timing(&self) -> IoTiming {
        std::mem::take(&mut lock(&self.shared).timing.recorded)
    }

    /// The priority the producer thread got from the OS, once it started.
    pub fn priority(&self) -> Option<Priority> {
        lock(&self.shared).timing.priority
    }

    /// The priority the consumer thread runs at now (ordinary after a flood).
    pub fn consumer_priority(&self) -> Option<Priority> {
        lock(&self.shared).timing.consumer_priority
    }

    /// Once the first second of production was measured: a warning with the figures if
    /// this computer did not keep the RPI. Given once.
    pub fn take_timing_notice(&self) -> Option<String> {
        let mut s = lock(&self.shared);
        match &mut s.timing.verdict {
            Some(verdict) => verdict.take(),
            None => None,
        }
    }

    /// A flood that lowered the consumer's priority (once), and the datagrams dropped
    /// since the last report, in words: at once the first time,
    /// then at most every [`REPORT_EVERY`] (the counts add up in between).
    pub fn take_recovered(&self) -> Vec<String> {
        let mut s = lock(&self.shared);
        let mut out = std::mem::take(&mut s.notices);
        let now = Instant::now();
        if s.unreported.is_empty() || s.reported_at.is_some_and(|at| now - at < REPORT_EVERY) {
            return out;
        }
        s.reported_at = Some(now);
        out.extend(
            std::mem::take(&mut s.unreported)
                .words()
                .into_iter()
                .map(|w| format!("class 1 I/O: {w}")),
        );
        out
    }

    /// The first input after packet number `after`, waiting up to `timeout`. An error says
    /// why the connection is dead.
    pub async fn input_after(&self, after: u64, timeout: Duration) -> Result<Input, String> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let notified = self.notify.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            {
                let s = lock(&self.shared);
                if let Some(error) = &s.error {
                    return Err(error.clone());
                }
                if let Some(input) = &s.input
                    && input.number > after
                {
                    return Ok(input.clone());
                }
            }
            if tokio::time::timeout_at(deadline, notified).await.is_err() {
                // The producer declares the timeout first unless it was kept from running.
                return Err(timed_out(&self.config, timeout));
            }
        }
    }

    pub fn take_trace(&self) -> Vec<TraceRecord> {
        let (ot_header, to_header) = (self.config.ot_header, self.config.to_header);
        lock(&self.shared).trace.take(|sent, frame, bytes| {
            let header = if sent { ot_header } else { to_header };
            let packet = IoPacket::decode(bytes, header);
            let text = match (frame, packet) {
                (IoFrame::Bad(why), _) => format!("not a class 1 packet: {why}"),
                (_, Err(e)) => format!("class 1 packet (cut for the frame log: {e})"),
                (IoFrame::Sent, Ok(p)) => format!(
                    "class 1 O→T #{} count {}: {}",
                    p.sequence,
                    p.count,
                    hex(&p.data)
                ),
                (IoFrame::Taken, Ok(p)) => format!(
                    "class 1 T→O #{} count {}: {}",
                    p.sequence,
                    p.count,
                    hex(&p.data)
                ),
                (IoFrame::Dropped { newest, why }, Ok(p)) => format!(
                    "class 1 T→O #{} count {} after #{newest}: {why}",
                    p.sequence, p.count
                ),
                (IoFrame::Stray, Ok(p)) => format!(
                    "class 1 packet for connection {:08X}h with {} bytes, ignored",
                    p.connection,
                    p.data.len()
                ),
            };
            (hex(bytes), text)
        })
    }

    /// Stop producing and consuming, and wait for both threads to let go of the socket
    /// (a reconnect may bind its port again). Takes about a wake-up of each thread.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Release);
        let mut threads = self.threads.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(tie) = threads.tie.take() {
            tie.abort();
        }
        if let Some(producer) = threads.producer.take() {
            producer.thread().unpark();
            let _ = producer.join();
        }
        if let Some(consumer) = threads.consumer.take() {
            wake_consumer(self.local);
            let _ = consumer.join();
        }
    }
}

impl Drop for IoHandle {
    fn drop(&mut self) {
        self.stop();
    }
}

/// An empty datagram to the consumer's own socket, so that a blocking receive returns
/// and sees the stop.
fn wake_consumer(local: SocketAddr) {
    let to = if local.ip().is_unspecified() {
        SocketAddr::new(Ipv4Addr::LOCALHOST.into(), local.port())
    } else {
        local
    };
    if let Ok(socket) = UdpSocket::bind(SocketAddr::new(
        if to.is_ipv4() {
            Ipv4Addr::UNSPECIFIED.into()
        } else {
            std::net::Ipv6Addr::UNSPECIFIED.into()
        },
        0,
    )) {
        let _ = socket.send_to(&[], to);
    }
}

/// The connection timed out after `silence` without a T→O datagram: what happened, and
/// what brings it back. Both sides close a timed-out connection (protocol notes §3.4,
/// §3.5: the scanner stops producing, so the adapter's own timeout follows), so only a
/// new Forward_Open reopens it.
fn timed_out(config: &IoConfig, silence: Duration) -> String {
    let waited = if silence > config.to_timeout + config.to_rpi {
        format!(" (none for {} ms)", silence.as_millis())
    } else {
        String::new()
    };
    format!(
        "no T→O datagram for {} ms ({} × RPI {} ms): the I/O connection timed out{waited}; reconnecting opens it again",
        config.to_timeout.as_millis(),
        config.timeout_factor,
        config.to_rpi.as_millis(),
    )
}

/// The producer thread: the O→T packets at the RPI, and the connection's timeout.
struct Producer {
    socket: UdpSocket,
    config: IoConfig,
    shared: Arc<Mutex<Shared>>,
    notify: Arc<Notify>,
    stop: Arc<AtomicBool>,
    /// Gone when the runtime that opened the connection ended (see [`Threads::tie`]).
    owner: Option<std::sync::Weak<()>>,
    opened: Instant,
    /// The first packet may take a little longer than the steady-state timeout.
    first_grace: Duration,
    sequence: u32,
    count: u16,
    last_sent: Option<Vec<u8>>,
}

impl Producer {
    fn run(mut self) {
        let got = priority::raise_current_thread();
        lock(&self.shared).timing.priority = Some(got);
        let mut schedule = Schedule::new(Instant::now(), self.config.ot_rpi);
        loop {
            // Park to the deadline: the OS's high-resolution timer, and `stop` unparks.
            loop {
                if self.stop.load(Ordering::Acquire) {
                    return;
                }
                let now = Instant::now();
                if now >= schedule.due() {
                    break;
                }
                std::thread::park_timeout(schedule.due() - now);
            }
            if self.owner.as_ref().is_some_and(|o| o.strong_count() == 0) {
                // Nobody is left to take the inputs or change the outputs.
                let _ = self.fail("the runtime that owned the link ended".into());
                return;
            }
            if self.on_tick().is_break() {
                return;
            }
            schedule.sent(Instant::now());
        }
    }

    /// At each RPI: declare the connection dead after its timeout, else send the outputs.
    fn on_tick(&mut self) -> ControlFlow<()> {
        let now = Instant::now();
        let (received, last_input) = {
            let s = lock(&self.shared);
            (s.received, s.timing.last_input)
        };
        let silent = match last_input {
            Some(at) => (now.saturating_duration_since(at) > self.config.to_timeout)
                .then(|| now.saturating_duration_since(at)),
            None => (now - self.opened > self.first_grace).then(|| now - self.opened),
        };
        if let Some(silence) = silent {
            let error = if received == 0 {
                format!(
                    "no T→O datagram in {} ms since the I/O connection opened; none ever reached UDP port {} here (a firewall, or another program on that port?)",
                    silence.as_millis(),
                    self.socket.local_addr().map(|a| a.port()).unwrap_or(0)
                )
            } else {
                timed_out(&self.config, silence)
            };
            return self.fail(error);
        }
        self.send()
    }

    /// The O→T packet with the outputs as they are now (a new count when they changed).
    fn send(&mut self) -> ControlFlow<()> {
        let output = lock(&self.shared).output.clone();
        if self.last_sent.as_ref() != Some(&output) {
            self.count = self.count.wrapping_add(1);
        }
        self.sequence = self.sequence.wrapping_add(1);
        let (sequence, count) = (self.sequence, self.count);
        let packet = IoPacket {
            connection: self.config.ot_connection,
            sequence,
            count,
            run: self.config.ot_header.then_some(true),
            data: output.clone(),
        };
        let bytes = packet.encode();
        if let Err(e) = self.socket.send_to(&bytes, self.config.target) {
            return self.fail(format!("sending I/O to {}: {e}", self.config.target));
        }
        let sent_at = Instant::now();
        let mut s = lock(&self.shared);
        s.sent += 1;
        s.on_sent(sent_at, self.config.ot_rpi);
        s.record(true, &bytes, IoFrame::Sent);
        drop(s);
        self.last_sent = Some(output);
        ControlFlow::Continue(())
    }

    /// The connection is dead: say why to whoever waits, stop the consumer, end.
    fn fail(&self, error: String) -> ControlFlow<()> {
        lock(&self.shared).error = Some(error);
        self.notify.notify_waiters();
        self.stop.store(true, Ordering::Release);
        if let Ok(local) = self.socket.local_addr() {
            wake_consumer(local);
        }
        ControlFlow::Break(())
    }
}

/// The consumer thread: every datagram on the socket as it arrives.
struct Consumer {
    socket: UdpSocket,
    config: IoConfig,
    shared: Arc<Mutex<Shared>>,
    notify: Arc<Notify>,
    stop: Arc<AtomicBool>,
}

impl Consumer {
    /// Real-time priority where granted, as the producer: a consumer woken late takes a
    /// T→O packet late, and the worker waits for it. A flood (see [`FloodGuard`]) sends it
    /// back to ordinary priority, said once in the log.
    fn run(self) {
        let got = priority::raise_current_thread();
        lock(&self.shared).timing.consumer_priority = Some(got);
        let mut guard = FloodGuard::new(self.config.to_rpi);
        let mut buffer = vec![0u8; 1500];
        while !self.stop.load(Ordering::Acquire) {
            match self.socket.recv_from(&mut buffer) {
                Ok((n, from)) => {
                    if self.stop.load(Ordering::Acquire) {
                        return;
                    }
                    if let Some(count) = guard.arrived(Instant::now())
                        && matches!(got, Priority::Realtime(_))
                    {
                        self.on_flood(count, from);
                    }
                    self.on_datagram(&buffer[..n]);
                }
                // The read timeout, only there to look at `stop`.
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                // ICMP errors from an earlier send surface here on some systems: keep
                // listening (without spinning); the timeout decides.
                Err(_) => std::thread::sleep(Duration::from_millis(1)),
            }
        }
    }

    /// More datagrams than the RPI can explain: back to ordinary priority, and say so.
    fn on_flood(&self, count: u32, from: SocketAddr) {
        let now = priority::lower_current_thread();
        let mut s = lock(&self.shared);
        s.timing.consumer_priority = Some(now);
        let what = match now {
            Priority::Normal => {
                "the I/O consumer went back to ordinary priority so that a flood cannot take a core"
                    .to_owned()
            }
            Priority::Realtime(_) => format!(
                "the I/O consumer could not leave {now} priority, so the flood may take a core"
            ),
        };
        s.notices.push(format!(
            "class 1 I/O: {count} datagrams reached the T→O socket within {} ms (the last from {from}), more than four times what an RPI of {} ms sends: {what}; the I/O goes on (find what else sends to this port: a second scanner, a device given this address)",
            FloodGuard::WINDOW.as_millis(),
            self.config.to_rpi.as_secs_f64() * 1e3,
        ));
    }

    /// A datagram on the socket: this connection's T→O packet, or a stray one.
    fn on_datagram(&self, bytes: &[u8]) {
        match IoPacket::decode(bytes, self.config.to_header) {
            Ok(packet)
                if packet.connection == self.config.to_connection
                    && packet.data.len() == self.config.input_len =>
            {
                self.on_input(bytes, packet);
            }
            Ok(_) => {
                let mut s = lock(&self.shared);
                s.stray += 1;
                s.record(false, bytes, IoFrame::Stray);
            }
            Err(e) => {
                let mut s = lock(&self.shared);
                s.stray += 1;
                s.record(false, bytes, IoFrame::Bad(e.to_string()));
            }
        }
    }

    /// A T→O packet of this connection: the new input if it is the newest so far.
    fn on_input(&self, bytes: &[u8], packet: IoPacket) {
        let now = Instant::now();
        let mut s = lock(&self.shared);
        let newest = s.newest.sequence().unwrap_or(0);
        let dropped = match s.newest.arrive(packet.sequence) {
            Arrival::Newest => None,
            Arrival::Duplicate => {
                s.unreported.duplicate += 1;
                Some("a copy, dropped")
            }
            Arrival::OutOfOrder => {
                s.unreported.out_of_order += 1;
                Some("out of order, dropped")
            }
        };
        if let Some(why) = dropped {
            // A stale image neither replaces the newest nor keeps the connection alive
            // (protocol notes §3.5).
            s.record(false, bytes, IoFrame::Dropped { newest, why });
            return;
        }
        s.on_input(now);
        s.received += 1;
        let number = s.received;
        s.record(false, bytes, IoFrame::Taken);
        s.input = Some(Input {
            data: packet.data,
            number,
        });
        drop(s);
        self.notify.notify_waiters();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_startup_verdict_warns_with_the_figures_only_when_the_rpi_is_not_kept() {
        let ms = Duration::from_millis;
        let kept = Spread {
            count: 100,
            p50: ms(2),
            p99: Duration::from_micros(2_300),
            max: ms(3),
        };
        assert_eq!(verdict(&kept, ms(2), Some(Priority::Normal)), None);
        let late = Spread {
            p99: Duration::from_micros(2_500),
            ..kept
        };
        let warning = verdict(&late, ms(2), Some(Priority::Normal)).expect("a warning");
        for said in [
            "RPI of 2 ms",
            "first 101 O→T packets",
            "2.00 ms at the median",
            "2.50 ms at the 99th percentile",
            "3.00 ms at most",
            "ordinary priority",
        ] {
            assert!(warning.contains(said), "{said:?} in {warning}");
        }
        let warning = verdict(&late, ms(2), Some(Priority::Realtime(10))).expect("a warning");
        assert!(!warning.contains("ordinary"), "{warning}");
    }

    #[test]
    fn the_verdict_comes_once_after_the_first_second_of_production() {
        let rpi = Duration::from_millis(100);
        let t0 = Instant::now();
        let mut kept = Shared::default();
        for k in 0..10 {
            kept.on_sent(t0 + rpi * k, rpi);
        }
        assert_eq!(kept.timing.verdict, None, "0.9 s: not yet");
        kept.on_sent(t0 + rpi * 10, rpi);
        assert_eq!(kept.timing.verdict, Some(None), "1 s, the RPI kept");
        assert!(kept.timing.startup.is_empty());

        let mut late = Shared::default();
        let mut at = t0;
        for k in 0..=10 {
            late.on_sent(at, rpi);
            at += if k == 4 { rpi * 3 / 2 } else { rpi };
        }
        let Some(Some(warning)) = &late.timing.verdict else {
            panic!("a warning: {:?}", late.timing.verdict);
        };
        assert!(
            warning.contains("150.00 ms at the 99th percentile"),
            "{warning}"
        );
        // Recording is off unless asked: nothing kept beyond the startup window.
        assert!(late.timing.recorded.ot.is_empty());
    }
}
