//! A proxy for EtherNet/IP class 1 I/O: explicit messages pass through its TCP port as
//! they are, except that Forward_Open's socket address items are rewritten (the scanner's
//! T→O item in the request, the adapter's O→T item in the reply, protocol notes §3.2,
//! §3.4) so that both directions of the connection's UDP datagrams pass through it too.
//! There it can drop, delay, duplicate or reorder the Nth datagram of either direction, or
//! keep the T→O direction silent until the next Forward_Open. For a soak it can also drop
//! or hold back every datagram of a direction for a while, hold the TCP session for a
//! while, and reset it.

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, TcpStream, UdpSocket};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

use drivedeck::proto::enip::cpf::{Item, SockAddr};
use drivedeck::proto::enip::encap::{Command, Packet, RrData};

use super::{Framing, read_frame};

/// Which way a datagram goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Way {
    /// Adapter to scanner: the drive's inputs.
    TtoO,
    /// Scanner to adapter: the outputs.
    OtoT,
}

/// What happens to one datagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mishap {
    /// It never arrives.
    Drop,
    /// It arrives this much later (those behind it do not wait: UDP keeps no order).
    Delay(Duration),
    /// It arrives twice.
    Duplicate,
    /// It is held back and arrives just after the next one: an older image after a newer.
    Reorder,
    /// Its CPF item count is garbled: a datagram that makes no sense.
    Garble,
}

#[derive(Default)]
struct Direction {
    /// Datagrams that came to the proxy this way so far.
    passed: u64,
    /// (datagram number, mishap) still to do.
    plan: Vec<(u64, Mishap)>,
    applied: Vec<Mishap>,
    /// A datagram held back for [`Mishap::Reorder`].
    held: Option<Vec<u8>>,
    /// Every datagram is dropped until then.
    drop_until: Option<Instant>,
    /// Nothing passes until then: what comes waits (in the socket's buffer, as far as it
    /// holds), then passes in order.
    hold_until: Option<Instant>,
    /// Datagrams dropped for `drop_until`.
    dropped: u64,
}

#[derive(Default)]
struct State {
    t_to_o: Direction,
    o_to_t: Direction,
    /// Where the scanner wants its T→O datagrams, and where the adapter takes O→T ones.
    scanner: Option<SocketAddr>,
    adapter: Option<SocketAddr>,
    /// Forward_Open replies that granted a class 1 connection.
    opens: u64,
    /// T→O datagrams are dropped until the next Forward_Open is granted.
    silent: bool,
    /// T→O datagrams dropped for the silence.
    silenced: u64,
    /// The TCP session passes nothing either way until then.
    tcp_hold_until: Option<Instant>,
    /// The TCP connections open now: (the client's side, the server's side).
    sessions: Vec<(TcpStream, TcpStream)>,
    /// A reset is under way: the client's side is closed without a FIN (an RST).
    resetting: bool,
}

impl State {
    fn way(&mut self, way: Way) -> &mut Direction {
        match way {
            Way::TtoO => &mut self.t_to_o,
            Way::OtoT => &mut self.o_to_t,
        }
    }
}

/// The proxy: the scanner connects to `addr` (`enip://ADDR?udp=0&io=pdi`).
pub struct UdpProxy {
    pub addr: SocketAddr,
    state: Arc<Mutex<State>>,
}

fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    state.lock().unwrap_or_else(|p| p.into_inner())
}

impl UdpProxy {
    /// A proxy in front of the adapter whose TCP (explicit messages) address is `upstream`.
    pub fn start(upstream: SocketAddr) -> UdpProxy {
        // The adapter sends T→O datagrams to `from_adapter`, the scanner O→T ones to
        // `from_scanner`; each is passed on from the other socket.
        let from_adapter = UdpSocket::bind("127.0.0.1:0").expect("T→O port");
        let from_scanner = UdpSocket::bind("127.0.0.1:0").expect("O→T port");
        let to_port = from_adapter.local_addr().expect("T→O address").port();
        let ot_port = from_scanner.local_addr().expect("O→T address").port();
        let state = Arc::new(Mutex::new(State::default()));
        let shared = state.clone();
        let addr = super::listen(upstream, move |connection| {
            if let (Ok(client), Ok(server)) = (
                connection.to_client.try_clone(),
                connection.to_server.try_clone(),
            ) {
                let mut state = lock(&shared);
                state.sessions.push((client, server));
                state.resetting = false;
            }
            let requests = shared.clone();
            let held = shared.clone();
            thread::spawn(move || {
                relay(connection.from_client, connection.to_server, &held, &|p| {
                    rewrite(p, |item| {
                        if let Item::SockaddrTo(s) = item {
                            let ip = if s.ip.is_unspecified() {
                                Ipv4Addr::LOCALHOST
                            } else {
                                s.ip
                            };
                            lock(&requests).scanner = Some(SocketAddrV4::new(ip, s.port).into());
                            s.port = to_port;
                        }
                    })
                })
            });
            let replies = shared.clone();
            let held = shared.clone();
            thread::spawn(move || {
                relay(connection.from_server, connection.to_client, &held, &|p| {
                    rewrite(p, |item| {
                        if let Item::SockaddrOt(s) = item {
                            let mut state = lock(&replies);
                            state.adapter = Some(s.socket().into());
                            state.opens += 1;
                            state.silent = false;
                            *s = SockAddr::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, ot_port));
                        }
                    })
                })
            });
        });
        let (Ok(adapter_side), Ok(scanner_side)) =
            (from_adapter.try_clone(), from_scanner.try_clone())
        else {
            panic!("cannot clone the UDP sockets");
        };
        let t_to_o = state.clone();
        thread::spawn(move || pass(from_adapter, scanner_side, Way::TtoO, &t_to_o));
        let o_to_t = state.clone();
        thread::spawn(move || pass(from_scanner, adapter_side, Way::OtoT, &o_to_t));
        UdpProxy { addr, state }
    }

    /// Do `mishap` to the datagram going `way` that is `after` from now (1: the next one).
    pub fn mishap_in(&self, way: Way, after: u64, mishap: Mishap) {
        let mut state = lock(&self.state);
        let direction = state.way(way);
        let at = direction.passed + after;
        direction.plan.push((at, mishap));
    }

    /// Drop every T→O datagram until a new class 1 connection is granted.
    pub fn silence_until_reopened(&self) {
        lock(&self.state).silent = true;
    }

    /// Drop every datagram going `way` for `time` from now.
    pub fn drop_for(&self, way: Way, time: Duration) {
        lock(&self.state).way(way).drop_until = Some(Instant::now() + time);
    }

    /// Let nothing pass going `way` for `time` from now; what comes meanwhile passes then.
    pub fn hold_for(&self, way: Way, time: Duration) {
        lock(&self.state).way(way).hold_until = Some(Instant::now() + time);
    }

    /// Let nothing pass either way on the TCP session for `time` from now.
    pub fn hold_tcp_for(&self, time: Duration) {
        lock(&self.state).tcp_hold_until = Some(Instant::now() + time);
    }

    /// Reset the TCP connections open now: the client's side with an RST, the server's
    /// closed. The class 1 connection outlives them.
    pub fn reset_sessions(&self) -> usize {
        let mut state = lock(&self.state);
        state.resetting = true;
        let sessions: Vec<_> = state.sessions.drain(..).collect();
        drop(state);
        let count = sessions.len();
        for (client, server) in sessions {
            super::abort(&client);
            let _ = client.shutdown(std::net::Shutdown::Read);
            let _ = server.shutdown(std::net::Shutdown::Both);
        }
        count
    }

    /// Datagrams going `way` dropped for `drop_for`.
    pub fn dropped(&self, way: Way) -> u64 {
        lock(&self.state).way(way).dropped
    }

    /// The mishaps done so far going `way`, in order.
    pub fn applied(&self, way: Way) -> Vec<Mishap> {
        lock(&self.state).way(way).applied.clone()
    }

    /// Datagrams that came to the proxy going `way`.
    pub fn passed(&self, way: Way) -> u64 {
        lock(&self.state).way(way).passed
    }

    /// Class 1 connections granted through the proxy.
    pub fn opens(&self) -> u64 {
        lock(&self.state).opens
    }

    /// T→O datagrams dropped for a silence.
    pub fn silenced(&self) -> u64 {
        lock(&self.state).silenced
    }
}

/// Sleep while `until` (read anew each time) lies ahead.
fn wait_out(until: impl Fn() -> Option<Instant>) {
    while let Some(rest) = until().and_then(|u| u.checked_duration_since(Instant::now())) {
        thread::sleep(rest);
    }
}

/// Pass encapsulation messages from `from` to `to`, each through `change` (and held while
/// the session is held).
fn relay(
    mut from: TcpStream,
    mut to: TcpStream,
    state: &Mutex<State>,
    change: &dyn Fn(Vec<u8>) -> Vec<u8>,
) {
    use std::io::Write;
    while let Some(frame) = read_frame(&mut from, Framing::Enip) {
        wait_out(|| lock(state).tcp_hold_until);
        if to.write_all(&change(frame)).is_err() {
            break;
        }
    }
    // A reset leaves the client's side to be closed with an RST by its last handle.
    if !lock(state).resetting {
        let _ = to.shutdown(std::net::Shutdown::Both);
    }
}

/// A SendRRData message with `edit` applied to its CPF items (the socket address items
/// keep their size, so nothing else changes); any other message as it is.
fn rewrite(frame: Vec<u8>, mut edit: impl FnMut(&mut Item)) -> Vec<u8> {
    let Ok(mut packet) = Packet::decode(&frame) else {
        return frame;
    };
    if packet.command != Command::SEND_RR_DATA {
        return frame;
    }
    let Ok(mut data) = RrData::decode(&packet.data) else {
        return frame;
    };
    if !data
        .items
        .iter()
        .any(|i| matches!(i, Item::SockaddrOt(_) | Item::SockaddrTo(_)))
    {
        return frame;
    }
    data.items.iter_mut().for_each(&mut edit);
    packet.data = data.encode();
    packet.encode()
}

/// Datagrams coming in on `inbound` go out of `outbound` to where the connection wants
/// them going `way`, with the planned mishaps.
fn pass(inbound: UdpSocket, outbound: UdpSocket, way: Way, state: &Mutex<State>) {
    let mut buffer = [0u8; 2048];
    loop {
        let Ok((n, _)) = inbound.recv_from(&mut buffer) else {
            continue;
        };
        let datagram = buffer[..n].to_vec();
        wait_out(|| lock(state).way(way).hold_until);
        let (to, mishap, held) = {
            let mut s = lock(state);
            let to = match way {
                Way::TtoO => s.scanner,
                Way::OtoT => s.adapter,
            };
            if way == Way::TtoO && s.silent {
                s.silenced += 1;
                continue;
            }
            let direction = s.way(way);
            if direction
                .drop_until
                .is_some_and(|until| Instant::now() < until)
            {
                direction.dropped += 1;
                continue;
            }
            direction.passed += 1;
            let at = direction.passed;
            let mishap = direction
                .plan
                .iter()
                .position(|(n, _)| *n <= at)
                .map(|i| direction.plan.remove(i).1);
            if let Some(m) = mishap {
                direction.applied.push(m);
            }
            let held = match mishap {
                Some(Mishap::Reorder) => {
                    direction.held = Some(datagram.clone());
                    None
                }
                _ => direction.held.take(),
            };
            (to, mishap, held)
        };
        let Some(to) = to else { continue };
        let send = |bytes: &[u8]| {
            let _ = outbound.send_to(bytes, to);
        };
        match mishap {
            None => send(&datagram),
            Some(Mishap::Drop | Mishap::Reorder) => {}
            Some(Mishap::Garble) => {
                let mut garbled = datagram.clone();
                for b in garbled.iter_mut().take(2) {
                    *b = 0x7F;
                }
                send(&garbled);
            }
            Some(Mishap::Duplicate) => {
                send(&datagram);
                send(&datagram);
            }
            Some(Mishap::Delay(d)) => {
                let Ok(late) = outbound.try_clone() else {
                    continue;
                };
                thread::spawn(move || {
                    thread::sleep(d);
                    let _ = late.send_to(&datagram, to);
                });
            }
        }
        // The one held back comes after the newer one.
        if let Some(older) = held {
            send(&older);
        }
    }
}
