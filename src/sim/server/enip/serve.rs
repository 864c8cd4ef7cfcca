//! The glue: the adapter's three sockets, its accept loop and discovery on tokio, and the
//! class 1 I/O producer and consumer on threads of their own, so that the T→O packets keep
//! the RPI (the OS's high-resolution timer, not tokio's millisecond wheel) whatever the
//! runtime is busy with.

use std::io;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};

use super::adapter::Adapter;
use super::{AdapterOptions, StreamId};
use crate::sim::server::SharedDrive;

// ------------------------------------------------------------------------------ sockets

/// The three sockets of an adapter: TCP for explicit messages and UDP on the same address
/// and port for discovery, UDP on the same IP for class 1 I/O.
#[derive(Debug)]
pub struct Sockets {
    pub tcp: std::net::TcpListener,
    pub discovery: std::net::UdpSocket,
    pub io: std::net::UdpSocket,
}

fn ipv4(addr: SocketAddr) -> io::Result<SocketAddrV4> {
    match addr {
        SocketAddr::V4(v4) => Ok(v4),
        SocketAddr::V6(v6) => match v6.ip().to_ipv4_mapped() {
            Some(ip) => Ok(SocketAddrV4::new(ip, v6.port())),
            None => Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{addr}: EtherNet/IP runs on IPv4; give an IPv4 address such as 127.0.0.1:44818"
                ),
            )),
        },
    }
}

impl Sockets {
    /// Bind TCP and discovery UDP on `addr` (port 0: a port free for both) and the I/O
    /// UDP socket on `addr`'s IP and `io_port` (0: any free port).
    pub fn bind(addr: SocketAddr, io_port: u16) -> io::Result<Sockets> {
        let addr = ipv4(addr)?;
        let mut attempts = 0;
        let (tcp, discovery) = loop {
            attempts += 1;
            let tcp = std::net::TcpListener::bind(addr)?;
            let port = tcp.local_addr()?.port();
            match std::net::UdpSocket::bind(SocketAddrV4::new(*addr.ip(), port)) {
                Ok(udp) => break (tcp, udp),
                // Port 0 gave a TCP port whose UDP twin is taken: try another.
                Err(e) if addr.port() == 0 && attempts < 20 => {
                    tracing::debug!("UDP port {port} taken ({e}), trying another");
                }
                Err(e) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("cannot bind UDP {}:{port} for ListIdentity: {e}", addr.ip()),
                    ));
                }
            }
        };
        let io = std::net::UdpSocket::bind(SocketAddrV4::new(*addr.ip(), io_port)).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!(
                    "cannot bind the class 1 I/O UDP port {}:{io_port}: {e} (--enip-io-port 0 takes any free port)",
                    addr.ip()
                ),
            )
        })?;
        let _ = discovery.set_broadcast(true);
        tcp.set_nonblocking(true)?;
        discovery.set_nonblocking(true)?;
        io.set_nonblocking(true)?;
        Ok(Sockets { tcp, discovery, io })
    }

    /// Where explicit messages (TCP) and ListIdentity (UDP) are served.
    pub fn tcp_addr(&self) -> io::Result<SocketAddr> {
        self.tcp.local_addr()
    }

    /// Where class 1 O→T datagrams are received.
    pub fn io_addr(&self) -> io::Result<SocketAddr> {
        self.io.local_addr()
    }
}

type Shared = Arc<Mutex<Adapter>>;

fn lock(adapter: &Shared) -> MutexGuard<'_, Adapter> {
    adapter.lock().unwrap_or_else(|p| p.into_inner())
}

/// Serve the adapter on `sockets` until the future is dropped (which closes every
/// connection and stops the I/O threads) or the listener fails.
pub async fn serve(
    sockets: Sockets,
    shared: SharedDrive,
    options: AdapterOptions,
) -> io::Result<()> {
    let listener = TcpListener::from_std(sockets.tcp)?;
    let discovery = UdpSocket::from_std(sockets.discovery)?;
    let io_port = sockets.io.local_addr()?.port();
    let discovery_local = ipv4(discovery.local_addr()?)?;
    let adapter: Shared = Arc::new(Mutex::new(Adapter::new(options.max_sessions, io_port)));
    let class1 = Class1::start(sockets.io, adapter.clone(), shared.clone())?;
    let wake = class1.waker();
    // TCP connections beyond the sessions (unregistered, or refused with 0002h) are
    // bounded too, so a flood of idle connections cannot exhaust the process.
    let max_streams = options.max_sessions.saturating_add(8);
    tokio::select! {
        r = accept(listener, adapter.clone(), shared.clone(), wake, max_streams) => r,
        r = answer_discovery(discovery, discovery_local, adapter.clone(), shared.clone()) => r,
    }
}

/// Wakes the producer thread: a Forward_Open may have started production.
#[derive(Clone, Debug)]
struct Wake(std::thread::Thread);

impl Wake {
    fn notify_one(&self) {
        self.0.unpark();
    }
}

/// How long the producer sleeps when no connection is open (a Forward_Open wakes it).
const IDLE_WAIT: Duration = Duration::from_millis(100);

/// The class 1 threads; dropping this stops them and waits for them.
struct Class1 {
    stop: Arc<std::sync::atomic::AtomicBool>,
    local: SocketAddr,
    producer: Option<std::thread::JoinHandle<()>>,
    consumer: Option<std::thread::JoinHandle<()>>,
}

impl Class1 {
    fn start(io: std::net::UdpSocket, adapter: Shared, shared: SharedDrive) -> io::Result<Class1> {
        use std::sync::atomic::AtomicBool;
        io.set_nonblocking(false)?;
        // Only so that the consumer notices a stop even if the wake-up datagram is lost.
        io.set_read_timeout(Some(IDLE_WAIT))?;
        let local = io.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let mut class1 = Class1 {
            stop: stop.clone(),
            local,
            producer: None,
            consumer: None,
        };
        let socket = io.try_clone()?;
        let (a, d, s) = (adapter.clone(), shared.clone(), stop.clone());
        class1.consumer = Some(
            std::thread::Builder::new()
                .name("sim-enip-io-consumer".into())
                .spawn(move || consume(&socket, &a, &d, &s))?,
        );
        class1.producer = Some(
            std::thread::Builder::new()
                .name("sim-enip-io-producer".into())
                .spawn(move || produce(&io, &adapter, &shared, &stop))?,
        );
        Ok(class1)
    }

    fn waker(&self) -> Wake {
        match &self.producer {
            Some(producer) => Wake(producer.thread().clone()),
            None => Wake(std::thread::current()),
        }
    }
}

impl Drop for Class1 {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Release);
        if let Some(producer) = self.producer.take() {
            producer.thread().unpark();
            let _ = producer.join();
        }
        if let Some(consumer) = self.consumer.take() {
            // An empty datagram ends the consumer's blocking receive.
            let to = if self.local.ip().is_unspecified() {
                SocketAddr::new(Ipv4Addr::LOCALHOST.into(), self.local.port())
            } else {
                self.local
            };
            if let Ok(socket) =
                std::net::UdpSocket::bind(SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, 0))
            {
                let _ = socket.send_to(&[], to);
            }
            let _ = consumer.join();
        }
    }
}

async fn accept(
    listener: TcpListener,
    adapter: Shared,
    shared: SharedDrive,
    wake: Wake,
    max_streams: usize,
) -> io::Result<()> {
    let mut connections = tokio::task::JoinSet::new();
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(accepted) => accepted,
                Err(e) => {
                    // Out of file descriptors, say: keep the adapter up.
                    tracing::debug!("EtherNet/IP accept: {e}");
                    tokio::time::sleep(Duration::from_millis(10)).await;
                    continue;
                }
            },
            Some(_) = connections.join_next(), if !connections.is_empty() => continue,
        };
        let (Ok(local), Ok(peer4)) = (stream.local_addr().and_then(ipv4), ipv4(peer)) else {
            continue;
        };
        let id = {
            let mut adapter = lock(&adapter);
            if adapter.streams() >= max_streams {
                tracing::info!("refused EtherNet/IP client {peer}: {max_streams} connections open");
                continue;
            }
            adapter.accept(local, peer4)
        };
        connections.spawn(serve_stream(
            stream,
            id,
            adapter.clone(),
            shared.clone(),
            wake.clone(),
        ));
    }
}

async fn serve_stream(
    mut stream: TcpStream,
    id: StreamId,
    adapter: Shared,
    shared: SharedDrive,
    wake: Wake,
) {
    let _ = stream.set_nodelay(true);
    let mut chunk = vec![0u8; 4096];
    loop {
        let n = match stream.read(&mut chunk).await {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        let (received, rescheduled) = {
            let mut adapter = lock(&adapter);
            let mut drive = shared.lock();
            let due = adapter.next_due();
            let received = adapter.receive(id, &chunk[..n], &mut drive, Instant::now());
            (received, adapter.next_due() != due)
        };
        // A Forward_Open may have started production (a Forward_Close ended it): the
        // producer sleeps to the next datagram due, so only a change to that wakes it, not
        // every explicit message (a thread switch and a poll of the adapter each).
        if rescheduled {
            wake.notify_one();
        }
        if !received.reply.is_empty() && stream.write_all(&received.reply).await.is_err() {
            break;
        }
        if received.close {
            // Send what was written, then drain the rest so the close is a FIN, not a
            // reset that could swallow the last reply.
            let _ = stream.shutdown().await;
            let _ = tokio::time::timeout(Duration::from_millis(500), async {
                while matches!(stream.read(&mut chunk).await, Ok(n) if n > 0) {}
            })
            .await;
            break;
        }
    }
    lock(&adapter).disconnect(id);
}

fn consume(
    io: &std::net::UdpSocket,
    adapter: &Shared,
    shared: &SharedDrive,
    stop: &std::sync::atomic::AtomicBool,
) {
    use std::sync::atomic::Ordering;
    let mut buffer = vec![0u8; 2048];
    while !stop.load(Ordering::Acquire) {
        let (n, from) = match io.recv_from(&mut buffer) {
            Ok(received) => received,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                continue;
            }
            Err(_) => {
                // e.g. an ICMP error reported on some platforms: keep serving.
                std::thread::sleep(Duration::from_millis(1));
                continue;
            }
        };
        let Ok(from) = ipv4(from) else {
            continue;
        };
        let mut adapter = lock(adapter);
        let mut drive = shared.lock();
        adapter.io_datagram(from, &buffer[..n], &mut drive, Instant::now());
    }
}

/// The T→O datagrams when due, sleeping to the next one in between.
fn produce(
    io: &std::net::UdpSocket,
    adapter: &Shared,
    shared: &SharedDrive,
    stop: &std::sync::atomic::AtomicBool,
) {
    use std::sync::atomic::Ordering;
    let got = crate::link::enip::priority::raise_current_thread();
    tracing::debug!("simulated adapter's class 1 producer: {got} priority");
    while !stop.load(Ordering::Acquire) {
        let (datagrams, due) = {
            let mut adapter = lock(adapter);
            let mut drive = shared.lock();
            let datagrams = adapter.poll(&mut drive, Instant::now());
            (datagrams, adapter.next_due())
        };
        for datagram in datagrams {
            let _ = io.send_to(&datagram.bytes, datagram.to);
        }
        // Unparked early by a Forward_Open or a stop: look again.
        let now = Instant::now();
        let until = due.unwrap_or(now + IDLE_WAIT);
        if until > now {
            std::thread::park_timeout(until - now);
        }
    }
}

async fn answer_discovery(
    socket: UdpSocket,
    local: SocketAddrV4,
    adapter: Shared,
    shared: SharedDrive,
) -> io::Result<()> {
    let mut buffer = vec![0u8; 2048];
    loop {
        let (n, from) = match socket.recv_from(&mut buffer).await {
            Ok(received) => received,
            Err(_) => {
                tokio::time::sleep(Duration::from_millis(1)).await;
                continue;
            }
        };
        let reply = {
            let adapter = lock(&adapter);
            let drive = shared.lock();
            adapter.discovery(&buffer[..n], local, &drive)
        };
        if let Some(reply) = reply {
            let _ = socket.send_to(&reply, from).await;
        }
    }
}
