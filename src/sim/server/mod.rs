//! The simulated drive on real sockets, for any client: ours, a PLC, pymodbus.
//!
//! Each drive is shared by the server tasks that serve it (one drive on every bus, or
//! several drives each behind its own node id, slave address or port) and advanced on real
//! time by a ticker, so a client sees the motor move whether it polls or not.

pub mod canopen;
pub mod enip;
pub mod modbus;
pub mod modbus_rtu;

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::Drive;

/// How often the shared drive is advanced when nobody asks.
const TICK: Duration = Duration::from_millis(2);

/// Requests closer together than this find the drive as the last one left it, not advanced:
/// its model steps in 1 ms (`STEP`) and a real drive refreshes its objects once per control
/// cycle, while advancing it (a step, then every published object set, ~3 000 instructions)
/// was a fifth of what the Modbus TCP server spent per request at tens of thousands of
/// requests a second. Half a step: a client polling every millisecond (1 kHz, with jitter)
/// still finds the drive advanced on every poll, and one polling flat out pays for an
/// advance on one request in seven or more instead of every other one (at 100 µs). No time
/// is lost: the next advance covers it. A write still takes effect at once (the drive
/// publishes after every write).
const MIN_ADVANCE: Duration = Duration::from_micros(500);

/// The drive and the time it was last advanced to.
#[derive(Debug)]
struct Clocked {
    drive: Drive,
    last: Instant,
}

/// The simulated drive shared by the servers of one process.
#[derive(Clone, Debug)]
pub struct SharedDrive {
    inner: Arc<Mutex<Clocked>>,
}

impl SharedDrive {
    pub fn new(drive: Drive) -> Self {
        Self {
            inner: Arc::new(Mutex::new(Clocked {
                drive,
                last: Instant::now(),
            })),
        }
    }

    /// The drive, advanced to now (to within `MIN_ADVANCE`). A poisoned lock (a panic
    /// elsewhere) still yields the drive: a simulator keeps serving.
    pub fn lock(&self) -> DriveGuard<'_> {
        let mut guard = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let now = Instant::now();
        let elapsed = now.saturating_duration_since(guard.last);
        if elapsed >= MIN_ADVANCE {
            guard.last = now;
            guard.drive.tick(elapsed.min(Duration::from_secs(60)));
        }
        DriveGuard { guard }
    }
}

impl SharedDrive {
    /// Whether the drive is restarting (it answers nothing on any bus meanwhile).
    pub fn rebooting(&self) -> bool {
        self.lock().rebooting()
    }
}

/// Advances drives on real time when nobody asks, on a thread of its own, until dropped.
///
/// Every lock advances a drive to now, so a client that polls never needs this; it is there
/// for the drive that nobody polls (a move that runs into a limit switch, a fault timer)
/// and for servers that publish on their own (heartbeats, PDOs, class 1 I/O). It is a
/// thread, not a timer on a server's runtime: a timer armed on a current-thread runtime
/// made every park of it work out the next expiration, ~700 instructions per Modbus
/// request, and the server ran at 0.90–0.99 of the tokio-modbus server's rate with it and
/// 1.03–1.18 without it, the same clients in the same run (BENCHMARKS.md).
#[derive(Debug)]
pub struct Clock {
    stop: Option<std::sync::mpsc::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Clock {
    /// Advance every one of `drives` every [`TICK`] (a drive a request advanced since is
    /// left as it is, see [`MIN_ADVANCE`]).
    pub fn start(drives: Vec<SharedDrive>) -> std::io::Result<Clock> {
        let (stop, stopped) = std::sync::mpsc::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("sim-clock".into())
            .spawn(move || {
                // Ends when the sender is dropped (Disconnected), not on a timeout.
                while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                    stopped.recv_timeout(TICK)
                {
                    for drive in &drives {
                        drop(drive.lock());
                    }
                }
            })?;
        Ok(Clock {
            stop: Some(stop),
            thread: Some(thread),
        })
    }
}

impl Drop for Clock {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A locked, up-to-date drive.
pub struct DriveGuard<'a> {
    guard: MutexGuard<'a, Clocked>,
}

impl std::ops::Deref for DriveGuard<'_> {
    type Target = Drive;
    fn deref(&self) -> &Drive {
        &self.guard.drive
    }
}

impl std::ops::DerefMut for DriveGuard<'_> {
    fn deref_mut(&mut self) -> &mut Drive {
        &mut self.guard.drive
    }
}

/// A simulated drive served on its own thread and runtime (tests, and embedding in other
/// tools). Dropping it stops the server and closes every connection, like pulling the
/// drive's plug.
pub struct ServerThread {
    pub addr: std::net::SocketAddr,
    /// The class 1 I/O UDP address (EtherNet/IP only).
    pub io: Option<std::net::SocketAddr>,
    drive: SharedDrive,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
    /// Stopped after the server (dropped last).
    _clock: Clock,
}

impl ServerThread {
    /// Serve Modbus TCP on `addr` (port 0 picks a free one) with a fresh drive.
    pub fn modbus_tcp(
        addr: std::net::SocketAddr,
        options: modbus::ServerOptions,
    ) -> std::io::Result<ServerThread> {
        Self::modbus_tcp_with(addr, options, SharedDrive::new(Drive::new()))
    }

    /// Serve Modbus TCP for an existing shared drive.
    pub fn modbus_tcp_with(
        addr: std::net::SocketAddr,
        options: modbus::ServerOptions,
        drive: SharedDrive,
    ) -> std::io::Result<ServerThread> {
        let listener = std::net::TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        Self::spawn(
            format!("sim-modbus-{addr}"),
            addr,
            None,
            drive,
            move |served| async move {
                let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                    return;
                };
                let _ = modbus::serve_tcp(listener, served, options).await;
            },
        )
    }

    /// Serve EtherNet/IP on `addr` (port 0 picks a free one, for TCP and the ListIdentity
    /// UDP socket alike) with a fresh drive; class 1 I/O on `options.io_port` (0: any).
    pub fn enip(
        addr: std::net::SocketAddr,
        options: enip::AdapterOptions,
    ) -> std::io::Result<ServerThread> {
        Self::enip_with(addr, options, SharedDrive::new(Drive::new()))
    }

    /// Serve EtherNet/IP for an existing shared drive.
    pub fn enip_with(
        addr: std::net::SocketAddr,
        options: enip::AdapterOptions,
        drive: SharedDrive,
    ) -> std::io::Result<ServerThread> {
        let sockets = enip::Sockets::bind(addr, options.io_port)?;
        let addr = sockets.tcp_addr()?;
        let io = sockets.io_addr()?;
        Self::spawn(
            format!("sim-enip-{addr}"),
            addr,
            Some(io),
            drive,
            move |served| async move {
                if let Err(e) = enip::serve(sockets, served, options).await {
                    tracing::warn!("EtherNet/IP adapter stopped: {e}");
                }
            },
        )
    }

    /// Run `serve` (given the drive) on a thread and runtime of its own, beside the drive's
    /// clock, until it ends or the returned server is dropped.
    fn spawn<F, Fut>(
        name: String,
        addr: std::net::SocketAddr,
        io: Option<std::net::SocketAddr>,
        drive: SharedDrive,
        serve: F,
    ) -> std::io::Result<ServerThread>
    where
        F: FnOnce(SharedDrive) -> Fut + Send + 'static,
        Fut: std::future::Future<Output = ()>,
    {
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel();
        let served = drive.clone();
        let clock = Clock::start(vec![drive.clone()])?;
        let thread = std::thread::Builder::new().name(name).spawn(move || {
            let Ok(runtime) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            else {
                return;
            };
            runtime.block_on(async move {
                tokio::select! {
                    _ = stop_rx => {}
                    _ = serve(served) => {}
                }
            });
        })?;
        Ok(ServerThread {
            addr,
            io,
            drive,
            stop: Some(stop_tx),
            thread: Some(thread),
            _clock: clock,
        })
    }

    /// The drive behind the server.
    pub fn drive(&self) -> &SharedDrive {
        &self.drive
    }
}

impl Drop for ServerThread {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
