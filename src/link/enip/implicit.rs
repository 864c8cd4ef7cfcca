//! The scanner side of a class 1 I/O connection: a task that sends the O→T assembly at
//! the RPI, takes in the adapter's T→O packets, and declares the connection dead when
//! they stop for the connection timeout. The link hands it outputs and waits for inputs.
//!
//! UDP may lose, repeat or reorder datagrams: only one newer (by its encapsulation
//! sequence number) than every one before carries the current image, and only such a one
//! keeps the connection alive (protocol notes §3.5). Copies and stale ones are dropped,
//! counted, and reported as troubles got over, at a bounded rate.

use std::net::SocketAddr;
use std::ops::ControlFlow;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use tokio::net::UdpSocket;
use tokio::sync::Notify;

use crate::link::{TraceRecord, TraceRing};
use crate::proto::enip::io::{Arrival, IoPacket, Newest};
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

#[derive(Debug, Default)]
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
    trace: TraceRing,
}

impl Shared {
    fn record(&mut self, sent: bool, bytes: &[u8], text: String) {
        self.trace.record(sent, hex(bytes), text);
    }
}

/// A running I/O connection.
#[derive(Debug)]
pub struct IoHandle {
    shared: Arc<Mutex<Shared>>,
    notify: Arc<Notify>,
    task: tokio::task::JoinHandle<()>,
    pub local: SocketAddr,
    pub config: IoConfig,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

impl IoHandle {
    /// Start producing at once on `socket`.
    pub fn start(socket: UdpSocket, config: IoConfig) -> std::io::Result<IoHandle> {
        let local = socket.local_addr()?;
        let shared = Arc::new(Mutex::new(Shared {
            output: config.output.clone(),
            ..Shared::default()
        }));
        let notify = Arc::new(Notify::new());
        let task = tokio::spawn(run(socket, config.clone(), shared.clone(), notify.clone()));
        Ok(IoHandle {
            shared,
            notify,
            task,
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

    /// The datagrams dropped since the last report, in words: at once the first time,
    /// then at most every [`REPORT_EVERY`] (the counts add up in between).
    pub fn take_recovered(&self) -> Vec<String> {
        let mut s = lock(&self.shared);
        let now = Instant::now();
        if s.unreported.is_empty() || s.reported_at.is_some_and(|at| now - at < REPORT_EVERY) {
            return vec![];
        }
        s.reported_at = Some(now);
        std::mem::take(&mut s.unreported)
            .words()
            .into_iter()
            .map(|w| format!("class 1 I/O: {w}"))
            .collect()
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
                // The task declares the timeout first unless it was kept from running.
                return Err(timed_out(&self.config, timeout));
            }
        }
    }

    pub fn take_trace(&self) -> Vec<TraceRecord> {
        lock(&self.shared).trace.take()
    }

    pub fn stop(&self) {
        self.task.abort();
    }
}

impl Drop for IoHandle {
    fn drop(&mut self) {
        self.task.abort();
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

/// The I/O task's state between packets.
struct Task {
    socket: UdpSocket,
    config: IoConfig,
    shared: Arc<Mutex<Shared>>,
    notify: Arc<Notify>,
    opened: Instant,
    /// The first packet may take a little longer than the steady-state timeout.
    first_grace: Duration,
    last_input: Option<Instant>,
    sequence: u32,
    count: u16,
    last_sent: Option<Vec<u8>>,
}

async fn run(socket: UdpSocket, config: IoConfig, shared: Arc<Mutex<Shared>>, notify: Arc<Notify>) {
    let mut ticker = tokio::time::interval(config.ot_rpi);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut task = Task {
        socket,
        opened: Instant::now(),
        first_grace: config.to_timeout.max(Duration::from_secs(1)),
        config,
        shared,
        notify,
        last_input: None,
        sequence: 0,
        count: 0,
        last_sent: None,
    };
    let mut buffer = vec![0u8; 1500];
    loop {
        tokio::select! {
            _ = ticker.tick() => {
                if task.on_tick().await.is_break() {
                    return;
                }
            }
            received = task.socket.recv_from(&mut buffer) => {
                // ICMP errors from an earlier send surface here on some systems: keep
                // listening; the timeout decides.
                if let Ok((n, _from)) = received {
                    task.on_datagram(&buffer[..n]);
                }
            }
        }
    }
}

impl Task {
    /// At each RPI: declare the connection dead after its timeout, else send the outputs.
    async fn on_tick(&mut self) -> ControlFlow<()> {
        let now = Instant::now();
        let silent = match self.last_input {
            Some(at) => (now - at > self.config.to_timeout).then(|| now - at),
            None => (now - self.opened > self.first_grace).then(|| now - self.opened),
        };
        if let Some(silence) = silent {
            let error = if lock(&self.shared).received == 0 {
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
        self.send().await
    }

    /// The O→T packet with the outputs as they are now (a new count when they changed).
    async fn send(&mut self) -> ControlFlow<()> {
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
        if let Err(e) = self.socket.send_to(&bytes, self.config.target).await {
            return self.fail(format!("sending I/O to {}: {e}", self.config.target));
        }
        let mut s = lock(&self.shared);
        s.sent += 1;
        s.record(
            true,
            &bytes,
            format!("class 1 O→T #{sequence} count {count}: {}", hex(&output)),
        );
        self.last_sent = Some(output);
        ControlFlow::Continue(())
    }

    /// The connection is dead: say why to whoever waits, and end the task.
    fn fail(&self, error: String) -> ControlFlow<()> {
        lock(&self.shared).error = Some(error);
        self.notify.notify_waiters();
        ControlFlow::Break(())
    }

    /// A datagram on the socket: this connection's T→O packet, or a stray one.
    fn on_datagram(&mut self, bytes: &[u8]) {
        match IoPacket::decode(bytes, self.config.to_header) {
            Ok(packet)
                if packet.connection == self.config.to_connection
                    && packet.data.len() == self.config.input_len =>
            {
                self.on_input(bytes, packet);
            }
            Ok(packet) => {
                let mut s = lock(&self.shared);
                s.stray += 1;
                s.record(
                    false,
                    bytes,
                    format!(
                        "class 1 packet for connection {:08X}h with {} bytes, ignored",
                        packet.connection,
                        packet.data.len()
                    ),
                );
            }
            Err(e) => {
                let mut s = lock(&self.shared);
                s.stray += 1;
                s.record(false, bytes, format!("not a class 1 packet: {e}"));
            }
        }
    }

    /// A T→O packet of this connection: the new input if it is the newest so far.
    fn on_input(&mut self, bytes: &[u8], packet: IoPacket) {
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
            s.record(
                false,
                bytes,
                format!(
                    "class 1 T→O #{} count {} after #{newest}: {why}",
                    packet.sequence, packet.count
                ),
            );
            return;
        }
        self.last_input = Some(Instant::now());
        s.received += 1;
        let number = s.received;
        s.record(
            false,
            bytes,
            format!(
                "class 1 T→O #{} count {}: {}",
                packet.sequence,
                packet.count,
                hex(&packet.data)
            ),
        );
        s.input = Some(Input {
            data: packet.data,
            number,
        });
        drop(s);
        self.notify.notify_waiters();
    }
}
