//! Every anchor in one run: the PDI exchange of drivedeck's Modbus TCP client measured
//! side by side with independent clients, against drivedeck's simulated drive and against
//! independent servers, interleaved in rounds so that the machine's noise hits all alike.
//!
//! ```sh
//! cargo bench --bench anchors -- --seconds 1 --rounds 5
//! cargo bench --bench anchors -- --server "before=127.0.0.1:1502"   # and another server
//! ```
//!
//! One exchange is what drivedeck's PDI cycle puts on the wire: one FC 23 (read/write
//! multiple registers) writing the 4 PDI RX registers at 5996 and reading the 4 PDI TX
//! registers at 4996 with the factory TX process image behind them (11 registers): a
//! 25-byte request and a 31-byte reply.
//!
//! Clients (one at a time, each on a fresh connection):
//! * **drivedeck**: `ModbusLink::exchange`, the product's PDI cycle;
//! * **tokio-modbus**: `read_write_multiple_registers` of tokio-modbus 0.17;
//! * **pymodbus**: `benches/pymodbus_fc23.py` (the Python of `--python`, else
//!   `$DRIVEDECK_PYTHON`, else `./.venv/bin/python` as `cargo test` makes it, else python3);
//! * **raw TCP**: blocking std sockets writing the same 25 bytes and reading the 31 back,
//!   no Modbus code at all.
//!
//! Servers (each a child process of this bench, like `drivedeck sim`, one core's worth):
//! * **drivedeck sim**: the simulated drive's Modbus TCP server (`ServerThread::modbus_tcp`,
//!   what `drivedeck sim --modbus-tcp` serves: current-thread runtime, the drive's clock);
//! * **tokio-modbus server**: a tokio-modbus 0.17 register server on a current-thread
//!   runtime, a register bank behind a mutex;
//! * **raw ping-pong**: blocking std sockets reading a request by its MBAP length and
//!   writing a reply of the size asked for, no Modbus code at all;
//! * any `--server NAME=HOST:PORT` given (another build's `drivedeck sim`, say).
//!
//! The raw client against the raw server is the loopback limit: no client or server can
//! do the same exchange faster on this machine. Every figure is the median of the rounds;
//! every ratio is the median of the ratios within each round.
//!
//! `--enip` measures the simulated drive's EtherNet/IP adapter the same way:
//!
//! ```sh
//! cargo bench --bench anchors -- --enip --seconds 0.5 --rounds 9
//! ```
//!
//! One exchange is an object read as drivedeck's link does it in `io=explicit` (and for
//! every object view and catalog read): GetOD (32h) of 6041h:00 in SendRRData over a
//! registered session, a 49-byte request and a 46-byte reply. Clients: **drivedeck**
//! (`EnipLink::read_object`) and **raw TCP** (blocking std sockets: RegisterSession, then
//! the very bytes drivedeck's session sends, a fresh sender context each time). Servers:
//! **drivedeck sim** (`ServerThread::enip`, what `drivedeck sim --enip` serves) and a
//! **raw ping-pong** (a message read by its encapsulation length, a reply of the same 46
//! bytes, no CIP code), and any `--server` given.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use drivedeck::link::enip::client::EnipLink;
use drivedeck::link::modbus::client::ModbusLink;
use drivedeck::link::{Link, LinkSpec};
use drivedeck::od::{Address, DataType};
use drivedeck::proto::enip::cpf::Item;
use drivedeck::proto::enip::encap::{self, Command as EncapCommand, Packet, RrData};
use drivedeck::proto::enip::nanotec;
use drivedeck::proto::modbus::registers::{
    FACTORY_TX_MAP, ImageLayout, PDI_REGISTERS, PDI_RX, PDI_TX,
};
use drivedeck::sim::server::ServerThread;
use drivedeck::sim::server::enip::AdapterOptions;
use drivedeck::sim::server::modbus::ServerOptions;

/// Registers read by one exchange: the PDI TX block and the factory TX image.
fn read_count() -> u16 {
    PDI_REGISTERS + ImageLayout::from_entries(&FACTORY_TX_MAP).register_len() as u16
}

const CLIENTS: [&str; 4] = ["drivedeck", "tokio-modbus", "pymodbus", "raw TCP"];

/// The command line: `--seconds S --rounds N --python PATH --server NAME=ADDR`, or a
/// server child's `--serve KIND`.
struct Args {
    seconds: f64,
    rounds: usize,
    python: Option<String>,
    servers: Vec<(String, SocketAddr)>,
    serve: Option<String>,
    clients: Vec<String>,
    /// `--enip`: the EtherNet/IP adapter's explicit messaging instead of Modbus TCP.
    enip: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        seconds: 1.0,
        rounds: 3,
        python: None,
        servers: vec![],
        serve: None,
        clients: vec![],
        enip: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            // cargo bench passes --bench to every bench target.
            "--bench" => {}
            "--seconds" => {
                args.seconds = value("--seconds")?
                    .parse()
                    .map_err(|e| format!("--seconds: {e}"))?
            }
            "--rounds" => {
                args.rounds = value("--rounds")?
                    .parse()
                    .map_err(|e| format!("--rounds: {e}"))?
            }
            "--python" => args.python = Some(value("--python")?),
            "--clients" => {
                args.clients = value("--clients")?.split(',').map(str::to_owned).collect()
            }
            "--server" => {
                let text = value("--server")?;
                let (name, addr) = text
                    .split_once('=')
                    .ok_or(format!("--server NAME=HOST:PORT, not {text}"))?;
                let addr = addr.parse().map_err(|e| format!("--server {text}: {e}"))?;
                args.servers.push((name.to_owned(), addr));
            }
            "--serve" => args.serve = Some(value("--serve")?),
            "--enip" => args.enip = true,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if args.clients.is_empty() {
        let all: &[&str] = if args.enip { &ENIP_CLIENTS } else { &CLIENTS };
        args.clients = all.iter().map(|c| c.to_string()).collect();
    }
    Ok(args)
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        Err(e) => {
            eprintln!("anchors: {e}");
            return ExitCode::from(2);
        }
    };
    let result = match &args.serve {
        Some(kind) => serve_child(kind),
        None if args.enip => run_enip(&args),
        None => run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("anchors: {e}");
            ExitCode::FAILURE
        }
    }
}

// ---------------------------------------------------------------------------------------
// The servers, each in a child process of this bench

/// Serve `kind` on a free loopback port, print the port, serve until stdin closes.
fn serve_child(kind: &str) -> Result<(), String> {
    let loopback: SocketAddr = ([127, 0, 0, 1], 0).into();
    // Kept alive until the end of this function: dropping it stops the server.
    let mut _sim = None;
    let port = match kind {
        "sim" => {
            let server = ServerThread::modbus_tcp(loopback, ServerOptions::default())
                .map_err(|e| e.to_string())?;
            let port = server.addr.port();
            _sim = Some(server);
            port
        }
        "tokio-modbus" => listen(loopback, tokio_modbus_server)?,
        "raw" => listen(loopback, raw_server)?,
        "enip-sim" => {
            let options = AdapterOptions {
                io_port: 0,
                ..Default::default()
            };
            let server = ServerThread::enip(loopback, options).map_err(|e| e.to_string())?;
            let port = server.addr.port();
            _sim = Some(server);
            port
        }
        "enip-raw" => listen(loopback, raw_enip_server)?,
        other => return Err(format!("no server {other}")),
    };
    println!("{port}");
    std::io::stdout().flush().map_err(|e| e.to_string())?;
    // The parent closes our stdin (or dies): stop.
    let mut sink = vec![];
    let _ = std::io::stdin().read_to_end(&mut sink);
    Ok(())
}

/// A listener on a free loopback port served by `serve` on a thread of its own; its port.
fn listen(loopback: SocketAddr, serve: fn(TcpListener)) -> Result<u16, String> {
    let listener = TcpListener::bind(loopback).map_err(|e| e.to_string())?;
    let port = listener.local_addr().map_err(|e| e.to_string())?.port();
    std::thread::spawn(move || serve(listener));
    Ok(port)
}

/// A tokio-modbus register server: FC 3 and FC 23 on a bank of 65 536 registers, as a
/// tokio-modbus user would write it, on a current-thread runtime like the simulated drive's.
fn tokio_modbus_server(listener: TcpListener) {
    use tokio_modbus::server::tcp::{Server, accept_tcp_connection};
    use tokio_modbus::{ExceptionCode, Request, Response};

    #[derive(Clone)]
    struct Bank(Arc<Mutex<Vec<u16>>>);

    impl tokio_modbus::server::Service for Bank {
        type Request = Request<'static>;
        type Response = Response;
        type Exception = ExceptionCode;
        type Future = std::future::Ready<Result<Response, ExceptionCode>>;

        fn call(&self, request: Request<'static>) -> Self::Future {
            let mut bank = self.0.lock().unwrap_or_else(|p| p.into_inner());
            let read = |bank: &[u16], address: u16, count: u16| {
                bank.get(usize::from(address)..usize::from(address) + usize::from(count))
                    .map(<[u16]>::to_vec)
                    .ok_or(ExceptionCode::IllegalDataAddress)
            };
            std::future::ready(match request {
                Request::ReadHoldingRegisters(address, count) => {
                    read(&bank, address, count).map(Response::ReadHoldingRegisters)
                }
                Request::ReadWriteMultipleRegisters(read_at, count, write_at, values) => {
                    let start = usize::from(write_at);
                    match bank.get_mut(start..start + values.len()) {
                        Some(slot) => {
                            slot.copy_from_slice(&values);
                            read(&bank, read_at, count).map(Response::ReadWriteMultipleRegisters)
                        }
                        None => Err(ExceptionCode::IllegalDataAddress),
                    }
                }
                _ => Err(ExceptionCode::IllegalFunction),
            })
        }
    }

    let Ok(runtime) = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    else {
        return;
    };
    let bank = Bank(Arc::new(Mutex::new(vec![0; 65_536])));
    runtime.block_on(async move {
        let _ = listener.set_nonblocking(true);
        let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
            return;
        };
        let server = Server::new(listener);
        let on_connected = |stream: tokio::net::TcpStream, peer| {
            let bank = bank.clone();
            async move {
                // As drivedeck's server does: a reply goes out at once.
                let _ = stream.set_nodelay(true);
                accept_tcp_connection(stream, peer, |_| Ok(Some(bank.clone())))
            }
        };
        let _ = server.serve(&on_connected, |_| {}).await;
    });
}

/// The raw ping-pong: a request read by its MBAP length, a reply of the size it asks for
/// (FC 3 and FC 23; registers all zero), no Modbus code.
fn raw_server(listener: TcpListener) {
    for stream in listener.incoming().flatten() {
        std::thread::spawn(move || {
            let _ = raw_connection(stream);
        });
    }
}

/// One whole message into `buffer`, its length told by `total` from its first `header`
/// bytes (at most `limit`), in as few reads as the peer's writes allow: one per message on
/// loopback, as the tokio clients and servers read. (Reading the header and then the rest,
/// two reads a message, made the "limit" slower than tokio-modbus.) The raw peers are
/// strict ping-pong: a byte after the message is an error, not the next one.
fn read_message(
    stream: &mut TcpStream,
    buffer: &mut Vec<u8>,
    header: usize,
    limit: usize,
    total: impl Fn(&[u8]) -> usize,
) -> std::io::Result<usize> {
    buffer.resize(limit, 0);
    let mut have = 0;
    loop {
        let n = stream.read(&mut buffer[have..])?;
        if n == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        have += n;
        if have < header {
            continue;
        }
        let len = total(&buffer[..header]);
        if len > limit || have > len {
            return Err(std::io::Error::other(format!(
                "a message of {len} bytes, {have} read: not one message at a time"
            )));
        }
        if have == len {
            buffer.truncate(len);
            return Ok(len);
        }
    }
}

/// A Modbus TCP message's length from its MBAP header.
fn mbap_total(header: &[u8]) -> usize {
    6 + usize::from(u16::from_be_bytes([header[4], header[5]]))
}

fn raw_connection(mut stream: TcpStream) -> std::io::Result<()> {
    stream.set_nodelay(true)?;
    let mut request = Vec::with_capacity(260);
    let mut reply = Vec::with_capacity(260);
    loop {
        read_message(&mut stream, &mut request, 7, 260, mbap_total)?;
        let len = usize::from(u16::from_be_bytes([request[4], request[5]]));
        if !(2..=254).contains(&len) || request.len() < 12 {
            return Ok(());
        }
        let function = request[7];
        // FC 3 and FC 23 both carry the read count at PDU bytes 3-4.
        let count = usize::from(u16::from_be_bytes([request[10], request[11]])).min(125);
        reply.clear();
        reply.extend_from_slice(&request[..4]);
        reply.extend_from_slice(&((3 + 2 * count) as u16).to_be_bytes());
        reply.extend_from_slice(&[request[6], function, (2 * count) as u8]);
        reply.resize(reply.len() + 2 * count, 0);
        stream.write_all(&reply)?;
    }
}

/// A server child; killed (by its own handle) when dropped.
struct ServerChild {
    child: Child,
    addr: SocketAddr,
}

impl ServerChild {
    fn start(kind: &str) -> Result<ServerChild, String> {
        let exe = std::env::current_exe().map_err(|e| e.to_string())?;
        let mut child = Command::new(exe)
            .args(["--serve", kind])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot start the {kind} server: {e}"))?;
        let mut line = String::new();
        if let Some(out) = child.stdout.take() {
            let _ = BufReader::new(out).read_line(&mut line);
        }
        let port: u16 = line
            .trim()
            .parse()
            .map_err(|_| format!("the {kind} server gave no port: {line:?}"))?;
        Ok(ServerChild {
            child,
            addr: ([127, 0, 0, 1], port).into(),
        })
    }
}

impl Drop for ServerChild {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

// ---------------------------------------------------------------------------------------
// The clients

/// The round trips of one client's run.
struct Run {
    rtts: Vec<Duration>,
    span: Duration,
}

impl Run {
    fn per_second(&self) -> f64 {
        self.rtts.len() as f64 / self.span.as_secs_f64().max(1e-9)
    }

    fn median_ms(&self) -> f64 {
        let mut sorted = self.rtts.clone();
        sorted.sort_unstable();
        sorted
            .get(sorted.len() / 2)
            .map_or(f64::NAN, |d| d.as_secs_f64() * 1e3)
    }
}

fn timed<E>(span: Duration, mut exchange: impl FnMut() -> Result<(), E>) -> Result<Run, E> {
    let mut rtts = Vec::with_capacity(100_000);
    let start = Instant::now();
    while start.elapsed() < span {
        let sent = Instant::now();
        exchange()?;
        rtts.push(sent.elapsed());
    }
    Ok(Run {
        rtts,
        span: start.elapsed(),
    })
}

async fn drivedeck_client(addr: SocketAddr, span: Duration) -> Result<Run, String> {
    let spec = LinkSpec::ModbusTcp {
        host: addr.ip().to_string(),
        port: addr.port(),
        unit: 0,
        words: Default::default(),
    };
    // The factory 3602h, as the simulated drive holds it: asked over FC 43 by a plain
    // connect, which a tokio-modbus server does not know.
    let mut link = ModbusLink::connect_with_tx_map(&spec, Duration::from_secs(2), &FACTORY_TX_MAP)
        .await
        .map_err(|e| e.to_string())?;
    let rx = link.read_rx().await.map_err(|e| e.to_string())?;
    let mut rtts = Vec::with_capacity(100_000);
    let start = Instant::now();
    while start.elapsed() < span {
        let sent = Instant::now();
        link.exchange(rx.as_ref())
            .await
            .map_err(|e| e.to_string())?;
        rtts.push(sent.elapsed());
    }
    let span = start.elapsed();
    let _ = link.close().await;
    Ok(Run { rtts, span })
}

async fn tokio_modbus_client(addr: SocketAddr, span: Duration) -> Result<Run, String> {
    use tokio_modbus::client::Reader;
    let stream = tokio::net::TcpStream::connect(addr)
        .await
        .map_err(|e| e.to_string())?;
    let _ = stream.set_nodelay(true);
    let mut ctx = tokio_modbus::client::tcp::attach_slave(stream, tokio_modbus::Slave(0));
    let rx = ctx
        .read_holding_registers(PDI_RX, PDI_REGISTERS)
        .await
        .map_err(|e| e.to_string())?
        .map_err(|e| e.to_string())?;
    let count = read_count();
    let mut rtts = Vec::with_capacity(100_000);
    let start = Instant::now();
    while start.elapsed() < span {
        let sent = Instant::now();
        ctx.read_write_multiple_registers(PDI_TX, count, PDI_RX, &rx)
            .await
            .map_err(|e| e.to_string())?
            .map_err(|e| e.to_string())?;
        rtts.push(sent.elapsed());
    }
    Ok(Run {
        rtts,
        span: start.elapsed(),
    })
}

/// One raw transaction: `pdu` out under `transaction`, the reply's PDU back.
fn raw_transact(
    stream: &mut TcpStream,
    frame: &mut Vec<u8>,
    transaction: u16,
    pdu: &[u8],
) -> std::io::Result<()> {
    frame.clear();
    frame.extend_from_slice(&transaction.to_be_bytes());
    frame.extend_from_slice(&[0, 0]);
    frame.extend_from_slice(&((pdu.len() + 1) as u16).to_be_bytes());
    frame.push(0);
    frame.extend_from_slice(pdu);
    stream.write_all(frame)?;
    read_message(stream, frame, 7, 260, mbap_total)?;
    let len = usize::from(u16::from_be_bytes([frame[4], frame[5]]));
    if u16::from_be_bytes([frame[0], frame[1]]) != transaction || !(2..=254).contains(&len) {
        return Err(std::io::Error::other("a reply to another request"));
    }
    if frame[7] != pdu[0] {
        return Err(std::io::Error::other(format!(
            "exception {:02X}h",
            frame.get(8).copied().unwrap_or(0)
        )));
    }
    Ok(())
}

fn raw_client(addr: SocketAddr, span: Duration) -> Result<Run, String> {
    let mut stream = TcpStream::connect(addr).map_err(|e| e.to_string())?;
    stream.set_nodelay(true).map_err(|e| e.to_string())?;
    let mut frame = Vec::with_capacity(300);
    let [rx_hi, rx_lo] = PDI_RX.to_be_bytes();
    let [n_hi, n_lo] = PDI_REGISTERS.to_be_bytes();
    raw_transact(&mut stream, &mut frame, 0, &[3, rx_hi, rx_lo, n_hi, n_lo])
        .map_err(|e| e.to_string())?;
    // What the drive holds, written back (the bench never commands anything).
    let rx = frame[9..17].to_vec();
    let [tx_hi, tx_lo] = PDI_TX.to_be_bytes();
    let [c_hi, c_lo] = read_count().to_be_bytes();
    let mut pdu = vec![0x17, tx_hi, tx_lo, c_hi, c_lo, rx_hi, rx_lo, n_hi, n_lo, 8];
    pdu.extend_from_slice(&rx);
    let mut transaction = 0u16;
    timed(span, || {
        transaction = transaction.wrapping_add(1);
        raw_transact(&mut stream, &mut frame, transaction, &pdu)
    })
    .map_err(|e| e.to_string())
}

fn pymodbus_client(python: &str, addr: SocketAddr, span: Duration) -> Result<Run, String> {
    let out = Command::new(python)
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/benches/pymodbus_fc23.py"
        ))
        .arg(addr.ip().to_string())
        .arg(addr.port().to_string())
        .arg(span.as_secs_f64().to_string())
        .arg(read_count().to_string())
        .output()
        .map_err(|e| format!("cannot run {python}: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let value: serde_json::Value = serde_json::from_str(text.trim())
        .map_err(|e| format!("pymodbus gave no figures ({e}): {}", text.trim()))?;
    if let Some(failed) = value["failed"].as_str() {
        return Err(failed.to_owned());
    }
    // The script reports figures, not every round trip: rebuild a run of the same count,
    // span and median.
    let count = value["count"].as_u64().unwrap_or(0) as usize;
    let seconds = value["seconds"].as_f64().unwrap_or(f64::NAN);
    let median = value["median_ms"].as_f64().unwrap_or(f64::NAN);
    Ok(Run {
        rtts: vec![Duration::from_secs_f64(median.max(0.0) / 1e3); count],
        span: Duration::from_secs_f64(seconds.max(1e-9)),
    })
}

fn python(args: &Args) -> String {
    if let Some(p) = &args.python {
        return p.clone();
    }
    if let Ok(p) = std::env::var("DRIVEDECK_PYTHON") {
        return p;
    }
    let venv = concat!(env!("CARGO_MANIFEST_DIR"), "/.venv/bin/python");
    if std::path::Path::new(venv).exists() {
        return venv.to_owned();
    }
    "python3".to_owned()
}

/// One client's run against one server; a client refused (the simulated drive takes one
/// connection at a time and may not have seen the last one close yet) tries again.
fn measure(
    runtime: &tokio::runtime::Runtime,
    client: &str,
    addr: SocketAddr,
    span: Duration,
    python: &str,
) -> Result<Run, String> {
    again(client, addr, || match client {
        "drivedeck" => Some(runtime.block_on(drivedeck_client(addr, span))),
        "tokio-modbus" => Some(runtime.block_on(tokio_modbus_client(addr, span))),
        "pymodbus" => Some(pymodbus_client(python, addr, span)),
        "raw TCP" => Some(raw_client(addr, span)),
        _ => None,
    })
}

/// `run` up to five times, 200 ms apart, until it measures; `None` from it: no such client.
fn again(
    client: &str,
    addr: SocketAddr,
    mut run: impl FnMut() -> Option<Result<Run, String>>,
) -> Result<Run, String> {
    let mut last = String::new();
    for _ in 0..5 {
        match run() {
            None => return Err(format!("no client {client}")),
            Some(Ok(run)) => return Ok(run),
            Some(Err(e)) => last = e,
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    Err(format!("{client} on {addr}: {last}"))
}

// ---------------------------------------------------------------------------------------
// The run and its table

fn median(mut values: Vec<f64>) -> f64 {
    values.retain(|v| v.is_finite());
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => values[n / 2],
        n => (values[n / 2 - 1] + values[n / 2]) / 2.0,
    }
}

fn run(args: &Args) -> Result<(), String> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    let python = python(args);
    let span = Duration::from_secs_f64(args.seconds.clamp(0.1, 60.0));
    let mut children = vec![];
    let mut servers: Vec<(String, SocketAddr)> = vec![];
    for (kind, name) in [
        ("sim", "drivedeck sim"),
        ("tokio-modbus", "tokio-modbus server"),
        ("raw", "raw ping-pong"),
    ] {
        let child = ServerChild::start(kind)?;
        servers.push((name.to_owned(), child.addr));
        children.push(child);
    }
    servers.extend(args.servers.iter().cloned());
    let clients: Vec<&str> = args.clients.iter().map(String::as_str).collect();
    println!(
        "PDI exchange, FC 23: write {} registers at {PDI_RX}, read {} at {PDI_TX}; {} rounds of {:.1} s per client and server, interleaved",
        PDI_REGISTERS,
        read_count(),
        args.rounds,
        span.as_secs_f64()
    );
    let (rates, rtts) = rounds(args.rounds, &servers, &clients, &mut |client, addr| {
        measure(&runtime, client, addr, span, &python)
    });
    print_tables(&servers, &clients, &rates, &rtts);
    drop(children);
    Ok(())
}

/// Cycles/s and median round trips, `[round][server][client]`: every client against every
/// server in each round, who goes first turning with the round so that no one always
/// follows the same.
type Grid = Vec<Vec<Vec<f64>>>;

fn rounds(
    count: usize,
    servers: &[(String, SocketAddr)],
    clients: &[&str],
    measure: &mut dyn FnMut(&str, SocketAddr) -> Result<Run, String>,
) -> (Grid, Grid) {
    let mut rates = vec![vec![vec![f64::NAN; clients.len()]; servers.len()]; count];
    let mut rtts = rates.clone();
    for round in 0..count {
        for s in 0..servers.len() {
            let s = (s + round) % servers.len();
            for c in 0..clients.len() {
                let c = (c + round) % clients.len();
                let (name, addr) = &servers[s];
                match measure(clients[c], *addr) {
                    Ok(run) => {
                        rates[round][s][c] = run.per_second();
                        rtts[round][s][c] = run.median_ms();
                        println!(
                            "round {} {:<22} {:<14} {:>9.0}/s median {:.3} ms",
                            round + 1,
                            name,
                            clients[c],
                            run.per_second(),
                            run.median_ms()
                        );
                    }
                    Err(e) => println!("round {} {name} {}: {e}", round + 1, clients[c]),
                }
                // Let the server see the connection close before the next one.
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
    (rates, rtts)
}

fn print_tables(
    servers: &[(String, SocketAddr)],
    clients: &[&str],
    rates: &[Vec<Vec<f64>>],
    rtts: &[Vec<Vec<f64>>],
) {
    let cell = |s: usize, c: usize| median(rates.iter().map(|r| r[s][c]).collect());
    let rtt = |s: usize, c: usize| median(rtts.iter().map(|r| r[s][c]).collect());
    // The median over the rounds of a ratio taken within each round.
    let ratio = |a: (usize, usize), b: (usize, usize)| {
        median(rates.iter().map(|r| r[a.0][a.1] / r[b.0][b.1]).collect())
    };
    let client = |name: &str| clients.iter().position(|c| *c == name);
    let server = |name: &str| servers.iter().position(|(s, _)| s == name);
    let limit = server("raw ping-pong").zip(client("raw TCP"));

    println!();
    println!(
        "cycles/s (median round trip), median of {} rounds",
        rates.len()
    );
    print!("| client \\ server |");
    for (name, _) in servers {
        print!(" {name} |");
    }
    println!();
    print!("| --- |");
    for _ in servers {
        print!(" ---: |");
    }
    println!();
    for (c, name) in clients.iter().enumerate() {
        print!("| {name} |");
        for s in 0..servers.len() {
            print!(" {:.0} ({:.3} ms) |", cell(s, c), rtt(s, c));
        }
        println!();
    }

    println!();
    println!("ratios (median over the rounds of each round's ratio)");
    print!("| ratio |");
    for (name, _) in servers {
        print!(" {name} |");
    }
    println!();
    print!("| --- |");
    for _ in servers {
        print!(" ---: |");
    }
    println!();
    let row = |label: &str, f: &dyn Fn(usize) -> Option<f64>| {
        // A row of clients or servers not in this run: left out.
        if (0..servers.len()).all(|s| f(s).is_none()) {
            return;
        }
        print!("| {label} |");
        for s in 0..servers.len() {
            match f(s) {
                Some(v) => print!(" {v:.2} |"),
                None => print!(" |"),
            }
        }
        println!();
    };
    let (dd, tm, py) = (
        client("drivedeck"),
        client("tokio-modbus"),
        client("pymodbus"),
    );
    row("drivedeck / tokio-modbus", &|s| {
        Some(ratio((s, dd?), (s, tm?)))
    });
    row("drivedeck / pymodbus", &|s| Some(ratio((s, dd?), (s, py?))));
    for (c, name) in clients.iter().enumerate() {
        row(&format!("{name} / ping-pong limit"), &|s| {
            Some(ratio((s, c), limit?))
        });
    }
    // Each server against the reference server with the same client: the tokio-modbus
    // server for Modbus, the raw ping-pong where there is none (EtherNet/IP).
    let anchor = ["tokio-modbus server", "raw ping-pong"]
        .into_iter()
        .find_map(|a| server(a).map(|s| (a, s)));
    if let Some((anchor_name, anchor)) = anchor {
        for (c, name) in clients.iter().enumerate() {
            row(&format!("server / {anchor_name}, {name} client"), &|s| {
                Some(ratio((s, c), (anchor, c)))
            });
        }
    }
}

// ---------------------------------------------------------------------------------------
// EtherNet/IP (`--enip`): the simulated adapter's explicit messaging against the raw
// exchange of the same bytes

/// The object every EtherNet/IP exchange reads with GetOD: the statusword, UNSIGNED16.
const ENIP_OBJECT: Address = Address {
    index: 0x6041,
    sub: 0,
};
const ENIP_TYPE: DataType = DataType::Unsigned16;
/// The value bytes in GetOD's reply.
const ENIP_VALUE_LEN: usize = 2;
/// The encapsulation header.
const ENCAP_HEADER: usize = 24;
/// The reply to one GetOD: the header, the SendRRData body up to the data item's length
/// (16 bytes), the Message Router reply's 4 bytes, the value.
const ENIP_REPLY_LEN: usize = ENCAP_HEADER + 16 + 4 + ENIP_VALUE_LEN;

const ENIP_CLIENTS: [&str; 2] = ["drivedeck", "raw TCP"];

/// The SendRRData message drivedeck's session sends for a GetOD of [`ENIP_OBJECT`] (its
/// sender context at bytes 12-19 is the caller's to set).
fn enip_get_od(session: u32) -> Vec<u8> {
    let body = RrData::new(
        10,
        vec![
            Item::Null,
            Item::UnconnectedData(nanotec::get_od(ENIP_OBJECT).encode()),
        ],
    )
    .encode();
    Packet::new(EncapCommand::SEND_RR_DATA, session, [0; 8], body).encode()
}

/// The raw ping-pong of EtherNet/IP: a message read by its encapsulation length; the
/// header sent back with the length of the reply; RegisterSession gets handle 1,
/// SendRRData a Message Router reply of [`ENIP_VALUE_LEN`] zero bytes with the request's
/// interface handle, timeout and items, anything else (ListIdentity) no data. No CIP code.
fn raw_enip_server(listener: TcpListener) {
    for stream in listener.incoming().flatten() {
        std::thread::spawn(move || {
            let _ = raw_enip_connection(stream);
        });
    }
}

fn raw_enip_connection(mut stream: TcpStream) -> std::io::Result<()> {
    stream.set_nodelay(true)?;
    let mut request = Vec::with_capacity(ENCAP_HEADER + 600);
    let mut reply = Vec::with_capacity(ENCAP_HEADER + 600);
    loop {
        let end = read_encap(&mut stream, &mut request)?;
        let len = end - ENCAP_HEADER;
        reply.clear();
        reply.extend_from_slice(&request[..ENCAP_HEADER]);
        match u16::from_le_bytes([request[0], request[1]]) {
            // RegisterSession: handle 1, the protocol version and options back.
            0x65 => {
                reply[4..8].copy_from_slice(&1u32.to_le_bytes());
                reply.extend_from_slice(&request[ENCAP_HEADER..end]);
            }
            // SendRRData: interface handle, timeout, item count, null item and the data
            // item's type as asked; the data item: service | 80h, reserved, status 0, no
            // additional status, the value.
            0x6F if len > 16 => {
                let body = &request[ENCAP_HEADER..end];
                reply.extend_from_slice(&body[..14]);
                reply.extend_from_slice(&((4 + ENIP_VALUE_LEN) as u16).to_le_bytes());
                reply.extend_from_slice(&[body[16] | 0x80, 0, 0, 0]);
                reply.resize(reply.len() + ENIP_VALUE_LEN, 0);
            }
            // UnRegisterSession: no reply.
            0x66 => return Ok(()),
            _ => {}
        }
        let data_len = (reply.len() - ENCAP_HEADER) as u16;
        reply[2..4].copy_from_slice(&data_len.to_le_bytes());
        stream.write_all(&reply)?;
    }
}

/// One whole encapsulation message into `buffer`; its length.
fn read_encap(stream: &mut TcpStream, buffer: &mut Vec<u8>) -> std::io::Result<usize> {
    read_message(stream, buffer, ENCAP_HEADER, ENCAP_HEADER + 600, |header| {
        ENCAP_HEADER + usize::from(u16::from_le_bytes([header[2], header[3]]))
    })
}

/// Blocking std sockets: RegisterSession, then the very bytes drivedeck's session sends
/// for a GetOD, a fresh sender context each time, the reply read by its length and
/// checked for its context, status and size.
fn raw_enip_client(addr: SocketAddr, span: Duration) -> Result<Run, String> {
    let mut stream = TcpStream::connect(addr).map_err(|e| e.to_string())?;
    stream.set_nodelay(true).map_err(|e| e.to_string())?;
    let register = Packet::new(
        EncapCommand::REGISTER_SESSION,
        0,
        [0; 8],
        encap::register_session_data(),
    )
    .encode();
    stream.write_all(&register).map_err(|e| e.to_string())?;
    let mut reply = Vec::with_capacity(600);
    read_encap(&mut stream, &mut reply).map_err(|e| e.to_string())?;
    let handle = u32::from_le_bytes([reply[4], reply[5], reply[6], reply[7]]);
    if handle == 0 || reply[8..12] != [0; 4] {
        return Err(format!("RegisterSession refused: {reply:02X?}"));
    }
    let mut request = enip_get_od(handle);
    let mut context = 0u64;
    timed(span, || {
        context = context.wrapping_add(1);
        request[12..20].copy_from_slice(&context.to_le_bytes());
        stream.write_all(&request)?;
        let len = read_encap(&mut stream, &mut reply)?;
        // Status (8-11) zero, our context, the Message Router's general status zero.
        if reply[8..12] != [0; 4]
            || reply[12..20] != request[12..20]
            || len != ENIP_REPLY_LEN
            || reply[ENCAP_HEADER + 18] != 0
        {
            return Err(std::io::Error::other(format!(
                "not the reply expected ({ENIP_REPLY_LEN} bytes): {reply:02X?}"
            )));
        }
        Ok(())
    })
    .map_err(|e| e.to_string())
}

/// drivedeck's link in `io=explicit`: object reads with `read_object`, the GetOD the
/// object views and the catalog read send.
async fn drivedeck_enip_client(addr: SocketAddr, span: Duration) -> Result<Run, String> {
    let spec: LinkSpec = format!("enip://{addr}?io=explicit&udp=0")
        .parse()
        .map_err(|e| format!("{e}"))?;
    let mut link = EnipLink::connect(&spec).await.map_err(|e| e.to_string())?;
    let mut rtts = Vec::with_capacity(100_000);
    let start = Instant::now();
    while start.elapsed() < span {
        let sent = Instant::now();
        link.read_object(ENIP_OBJECT, ENIP_TYPE)
            .await
            .map_err(|e| e.to_string())?
            .map_err(|e| e.to_string())?;
        rtts.push(sent.elapsed());
    }
    let span = start.elapsed();
    let _ = link.close().await;
    Ok(Run { rtts, span })
}

fn measure_enip(
    runtime: &tokio::runtime::Runtime,
    client: &str,
    addr: SocketAddr,
    span: Duration,
) -> Result<Run, String> {
    again(client, addr, || match client {
        "drivedeck" => Some(runtime.block_on(drivedeck_enip_client(addr, span))),
        "raw TCP" => Some(raw_enip_client(addr, span)),
        _ => None,
    })
}

fn run_enip(args: &Args) -> Result<(), String> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?;
    let span = Duration::from_secs_f64(args.seconds.clamp(0.1, 60.0));
    let mut children = vec![];
    let mut servers: Vec<(String, SocketAddr)> = vec![];
    for (kind, name) in [("enip-sim", "drivedeck sim"), ("enip-raw", "raw ping-pong")] {
        let child = ServerChild::start(kind)?;
        servers.push((name.to_owned(), child.addr));
        children.push(child);
    }
    servers.extend(args.servers.iter().cloned());
    let clients: Vec<&str> = args.clients.iter().map(String::as_str).collect();
    println!(
        "EtherNet/IP explicit GetOD {ENIP_OBJECT} in SendRRData over a registered session: a {}-byte request, a {ENIP_REPLY_LEN}-byte reply; {} rounds of {:.1} s per client and server, interleaved",
        enip_get_od(1).len(),
        args.rounds,
        span.as_secs_f64()
    );
    let (rates, rtts) = rounds(args.rounds, &servers, &clients, &mut |client, addr| {
        measure_enip(&runtime, client, addr, span)
    });
    print_tables(&servers, &clients, &rates, &rtts);
    drop(children);
    Ok(())
}
