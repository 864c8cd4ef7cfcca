//! Fault-injecting proxies for the tests of what one bad frame does: a TCP proxy that
//! passes Modbus TCP or EtherNet/IP frames between a client and a served simulator and
//! drops, delays, corrupts, duplicates or re-numbers the Nth reply; and a serial proxy
//! between two pseudo-terminal pairs that puts noise on the Nth reply of Modbus RTU or
//! into the slcan lines. Shared by the tests (`mod proxy;`).

#![allow(dead_code)]

pub mod udp;
use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::Duration;

/// How the replies of a TCP connection are cut into frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// The MBAP header: 6 bytes, the length at 4..6 (big-endian) counting what follows.
    ModbusTcp,
    /// The 24-byte encapsulation header, the length at 2..4 (little-endian) counting the
    /// data after it.
    Enip,
}

/// What happens to one reply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// It never arrives.
    Drop,
    /// It arrives late (and what comes behind it waits too, as on one TCP stream).
    Delay(Duration),
    /// A byte of its body is changed: the Modbus byte count, the CPF item count.
    Corrupt,
    /// Its header is garbled: the Modbus protocol id, the encapsulation length.
    BreakFraming,
    /// It arrives twice.
    Duplicate,
    /// Modbus: another transaction id; EtherNet/IP: another session handle.
    WrongId,
    /// EtherNet/IP: another command code (RegisterSession instead of SendRRData).
    WrongCommand,
    /// Modbus: the reply replaced by this exception to the same function code.
    Exception(u8),
}

#[derive(Default)]
struct State {
    /// Replies passed (or dropped) so far.
    replies: u64,
    /// (reply number, fault, only to a reply of this Modbus function code) still to do:
    /// the first reply from that number on that fits.
    plan: Vec<(u64, Fault, Option<u8>)>,
    /// What was done, in order, with the reply number.
    applied: Vec<(u64, Fault)>,
    /// Replies up to this number are dropped.
    black_until: u64,
    dropped: u64,
}

/// One client's connection through a proxy, each end twice: one handle to read, one to
/// write.
pub struct Connection {
    pub from_client: TcpStream,
    pub to_server: TcpStream,
    pub from_server: TcpStream,
    pub to_client: TcpStream,
}

/// Listen on a free loopback port; connect every client to `upstream` (no Nagle delay
/// either way) and give the connection to `serve`, on a thread of its own. The address.
pub fn listen(upstream: SocketAddr, serve: impl Fn(Connection) + Send + 'static) -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").expect("proxy port");
    let addr = listener.local_addr().expect("proxy address");
    thread::spawn(move || {
        for client in listener.incoming() {
            let Ok(client) = client else { break };
            let Ok(server) = TcpStream::connect(upstream) else {
                continue;
            };
            let _ = client.set_nodelay(true);
            let _ = server.set_nodelay(true);
            let (Ok(from_client), Ok(from_server)) = (client.try_clone(), server.try_clone())
            else {
                continue;
            };
            serve(Connection {
                from_client,
                to_server: server,
                from_server,
                to_client: client,
            });
        }
    });
    addr
}

/// A TCP proxy on a free loopback port in front of `upstream`.
pub struct Proxy {
    pub addr: SocketAddr,
    state: Arc<Mutex<State>>,
}

impl Proxy {
    pub fn start(upstream: SocketAddr, framing: Framing) -> Proxy {
        let state = Arc::new(Mutex::new(State::default()));
        let shared = state.clone();
        let addr = listen(upstream, move |connection| {
            // Requests pass as they come.
            thread::spawn(move || copy(connection.from_client, connection.to_server));
            let state = shared.clone();
            thread::spawn(move || {
                replies(
                    connection.from_server,
                    connection.to_client,
                    framing,
                    &state,
                )
            });
        });
        Proxy { addr, state }
    }

    /// Do `fault` to the reply `after` replies from now (1: the next one).
    pub fn fault_in(&self, after: u64, fault: Fault) {
        let mut state = self.state.lock().expect("proxy state");
        let at = state.replies + after;
        state.plan.push((at, fault, None));
    }

    /// Do `fault` to the first Modbus reply of `function` from `after` replies on.
    pub fn fault_on(&self, after: u64, fault: Fault, function: u8) {
        let mut state = self.state.lock().expect("proxy state");
        let at = state.replies + after;
        state.plan.push((at, fault, Some(function)));
    }

    /// Drop the next `count` replies.
    pub fn drop_next(&self, count: u64) {
        let mut state = self.state.lock().expect("proxy state");
        state.black_until = state.replies + count;
    }

    /// Drop every reply from now on.
    pub fn drop_all(&self) {
        self.drop_next(u64::MAX / 2);
    }

    /// The faults done so far.
    pub fn applied(&self) -> Vec<Fault> {
        let state = self.state.lock().expect("proxy state");
        state.applied.iter().map(|(_, f)| *f).collect()
    }

    /// Replies dropped by `drop_next`/`drop_all`.
    pub fn dropped(&self) -> u64 {
        self.state.lock().expect("proxy state").dropped
    }

    pub fn replies(&self) -> u64 {
        self.state.lock().expect("proxy state").replies
    }
}

/// SO_LINGER 0: closing the socket (its last handle) resets the connection with an RST
/// instead of closing it.
pub fn abort(stream: &TcpStream) {
    use std::os::fd::AsRawFd;
    let linger = libc::linger {
        l_onoff: 1,
        l_linger: 0,
    };
    // SAFETY: a valid socket descriptor and a linger struct of the size given.
    let _ = unsafe {
        libc::setsockopt(
            stream.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            (&linger as *const libc::linger).cast(),
            std::mem::size_of::<libc::linger>() as libc::socklen_t,
        )
    };
}

fn copy(mut from: TcpStream, mut to: TcpStream) {
    let mut buf = [0u8; 4096];
    loop {
        match from.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => {
                if to.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
        }
    }
    let _ = to.shutdown(Shutdown::Write);
}

/// One frame from the server, or `None` at the end of the stream.
pub fn read_frame(stream: &mut TcpStream, framing: Framing) -> Option<Vec<u8>> {
    let (header, length) = match framing {
        Framing::ModbusTcp => {
            let mut header = [0u8; 6];
            stream.read_exact(&mut header).ok()?;
            (
                header.to_vec(),
                usize::from(u16::from_be_bytes([header[4], header[5]])),
            )
        }
        Framing::Enip => {
            let mut header = [0u8; 24];
            stream.read_exact(&mut header).ok()?;
            (
                header.to_vec(),
                usize::from(u16::from_le_bytes([header[2], header[3]])),
            )
        }
    };
    let mut frame = header;
    let mut body = vec![0u8; length];
    stream.read_exact(&mut body).ok()?;
    frame.extend_from_slice(&body);
    Some(frame)
}

fn replies(mut server: TcpStream, mut client: TcpStream, framing: Framing, state: &Mutex<State>) {
    while let Some(frame) = read_frame(&mut server, framing) {
        let (fault, black) = {
            let Ok(mut s) = state.lock() else { break };
            s.replies += 1;
            let n = s.replies;
            let black = n <= s.black_until;
            if black {
                s.dropped += 1;
            }
            let function = frame.get(7).copied();
            let fault = s
                .plan
                .iter()
                .position(|(at, _, only)| *at <= n && only.is_none_or(|f| Some(f) == function))
                .map(|i| s.plan.remove(i).1);
            if let Some(f) = fault {
                s.applied.push((n, f));
            }
            (fault, black)
        };
        if black {
            continue;
        }
        let sent = match fault {
            None => client.write_all(&frame),
            Some(Fault::Drop) => Ok(()),
            Some(Fault::Delay(d)) => {
                thread::sleep(d);
                client.write_all(&frame)
            }
            Some(Fault::Duplicate) => client
                .write_all(&frame)
                .and_then(|()| client.write_all(&frame)),
            Some(fault) => client.write_all(&damaged(frame, framing, fault)),
        };
        if sent.is_err() {
            break;
        }
    }
    let _ = client.shutdown(Shutdown::Both);
}

fn damaged(mut frame: Vec<u8>, framing: Framing, fault: Fault) -> Vec<u8> {
    match (framing, fault) {
        // MBAP: tid tid 00 00 len len unit | fc count data…
        (Framing::ModbusTcp, Fault::Corrupt) => {
            if let Some(count) = frame.get_mut(8) {
                *count ^= 0x55;
            }
        }
        (Framing::ModbusTcp, Fault::BreakFraming) => {
            frame[2] = 0xAB;
            frame[3] = 0xCD;
        }
        (Framing::ModbusTcp, Fault::WrongId) => {
            frame[0] ^= 0x5A;
            frame[1] ^= 0xA5;
        }
        (Framing::ModbusTcp, Fault::Exception(code)) => {
            let function = frame.get(7).copied().unwrap_or(0);
            frame.truncate(7);
            frame[4] = 0;
            frame[5] = 3;
            frame.push(function | 0x80);
            frame.push(code);
        }
        // Encapsulation: command(2) length(2) session(4) status(4) context(8) options(4) |
        // data: interface handle(4) timeout(2) item count(2) items…
        (Framing::Enip, Fault::Corrupt) if frame.len() >= 32 => {
            frame[30] = 0x7F;
            frame[31] = 0x7F;
        }
        (Framing::Enip, Fault::BreakFraming) => {
            frame[2] = 0xFF;
            frame[3] = 0xFF;
        }
        (Framing::Enip, Fault::WrongId) => {
            for b in &mut frame[4..8] {
                *b ^= 0x5A;
            }
        }
        (Framing::Enip, Fault::WrongCommand) => {
            frame[0] = 0x65;
            frame[1] = 0x00;
        }
        _ => {}
    }
    frame
}

/// What the serial proxy does to one reply (Modbus RTU) or line (slcan).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Noise {
    /// Garbage bytes on the line just before it.
    Before,
    /// One of its bytes changed (a CRC error on RTU, a broken line on slcan).
    Flip,
    /// It never arrives.
    Lost,
    /// A whole line of garbage instead of nothing (slcan), or garbage alone (RTU).
    Garbage,
}

#[derive(Default)]
struct SerialState {
    chunks: u64,
    /// (chunk number, noise, only to a line that starts so): the chunk with that number,
    /// or with a prefix the first line from that number on that starts with it.
    plan: Vec<(u64, Noise, Option<Vec<u8>>)>,
    applied: Vec<Noise>,
    /// The lines applied noise to, as they came from the device.
    spoiled: Vec<Vec<u8>>,
}

/// A proxy between two serial devices (each one end of a pty pair): bytes from `host`
/// go to `device` as they are; what `device` answers goes to `host` in chunks (one
/// Modbus RTU reply per read, or one slcan line), the Nth of them with noise.
pub struct SerialProxy {
    state: Arc<Mutex<SerialState>>,
    lines: bool,
}

impl SerialProxy {
    /// `lines`: cut the device's output at `\r` (slcan) instead of by read (RTU).
    pub fn start(host: &Path, device: &Path, lines: bool) -> SerialProxy {
        let open = |p: &Path| {
            std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(p)
                .unwrap_or_else(|e| panic!("open {}: {e}", p.display()))
        };
        let host_side = open(host);
        let device_side = open(device);
        let (Ok(host_in), Ok(device_out)) = (host_side.try_clone(), device_side.try_clone()) else {
            panic!("cannot clone the serial handles");
        };
        thread::spawn(move || {
            let (mut from, mut to) = (host_in, device_out);
            let mut buf = [0u8; 1024];
            while let Ok(n) = from.read(&mut buf) {
                if n == 0 || to.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
        });
        let state = Arc::new(Mutex::new(SerialState::default()));
        let shared = state.clone();
        thread::spawn(move || {
            let (mut from, mut to) = (device_side, host_side);
            let mut buf = [0u8; 1024];
            let mut line: Vec<u8> = Vec::new();
            while let Ok(n) = from.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let chunks: Vec<Vec<u8>> = if lines {
                    let mut out = vec![];
                    for &b in &buf[..n] {
                        line.push(b);
                        if b == b'\r' || b == 7 {
                            out.push(std::mem::take(&mut line));
                        }
                    }
                    out
                } else {
                    vec![buf[..n].to_vec()]
                };
                for chunk in chunks {
                    let noise = {
                        let Ok(mut s) = shared.lock() else { return };
                        s.chunks += 1;
                        let at = s.chunks;
                        let noise = s
                            .plan
                            .iter()
                            .position(|(n, _, only)| match only {
                                None => *n == at,
                                Some(prefix) => *n <= at && chunk.starts_with(prefix),
                            })
                            .map(|i| s.plan.remove(i).1);
                        if let Some(noise) = noise {
                            s.applied.push(noise);
                            s.spoiled.push(chunk.clone());
                        }
                        noise
                    };
                    let out = match noise {
                        None => chunk,
                        Some(Noise::Lost) => vec![],
                        Some(Noise::Before) => {
                            let mut out = vec![0xFF, 0x13, 0x00, 0x5A];
                            out.extend_from_slice(&chunk);
                            out
                        }
                        Some(Noise::Garbage) if lines => {
                            let mut out = b"Zq#!\r".to_vec();
                            out.extend_from_slice(&chunk);
                            out
                        }
                        Some(Noise::Garbage) => vec![0xFF, 0x13, 0x00, 0x5A, 0xC3],
                        Some(Noise::Flip) => {
                            let mut out = chunk;
                            let at = out.len() / 2;
                            if let Some(b) = out.get_mut(at) {
                                *b = if lines { b'G' } else { *b ^ 0x10 };
                            }
                            out
                        }
                    };
                    if !out.is_empty() && to.write_all(&out).is_err() {
                        return;
                    }
                }
            }
        });
        SerialProxy { state, lines }
    }

    /// Put `noise` on the reply (or line) `after` from now (1: the next one).
    pub fn noise_in(&self, after: u64, noise: Noise) {
        let mut s = self.state.lock().expect("proxy state");
        let at = s.chunks + after;
        s.plan.push((at, noise, None));
    }

    /// Put `noise` on the first line from `after` lines on that starts with `prefix` (slcan:
    /// `t581` for an SDO answer of node 1, `t181` for its TPDO1).
    pub fn noise_on(&self, after: u64, noise: Noise, prefix: &[u8]) {
        let mut s = self.state.lock().expect("proxy state");
        let at = s.chunks + after;
        s.plan.push((at, noise, Some(prefix.to_vec())));
    }

    pub fn applied(&self) -> Vec<Noise> {
        self.state.lock().expect("proxy state").applied.clone()
    }

    /// The lines noise was put on, as the device sent them.
    pub fn spoiled(&self) -> Vec<String> {
        let s = self.state.lock().expect("proxy state");
        s.spoiled
            .iter()
            .map(|l| String::from_utf8_lossy(l).trim_end().to_owned())
            .collect()
    }
}
