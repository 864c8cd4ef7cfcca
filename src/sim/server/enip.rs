//! The simulated drive as an EtherNet/IP adapter (target): explicit messages over TCP
//! (unconnected, through Unconnected_Send, and class 3 connected), one class 1 I/O
//! connection over UDP carrying the PDI or the Common assembly set, and ListIdentity over
//! UDP for discovery (protocol notes §3, EtherNet/IP chapter).
//!
//! [`Adapter`] is sans-IO: TCP bytes in per stream, replies out; I/O datagrams in;
//! [`Adapter::poll`] gives the T→O datagrams that are due and ends a connection whose
//! originator went silent. [`serve`] is the thin tokio glue around it.
//!
//! # Encapsulation
//!
//! | request | answer |
//! | --- | --- |
//! | RegisterSession, length 4, version 1, options 0 | a unique non-zero handle per TCP connection |
//! | RegisterSession, length ≠ 4 | status 0065h |
//! | RegisterSession, version ≠ 1 or options ≠ 0 | status 0069h, data = version 1 |
//! | RegisterSession on a connection that has a session | status 0001h, the existing handle (as OpENer) |
//! | RegisterSession beyond `max_sessions` | status 0002h |
//! | UnRegisterSession (this session, or none yet) | no reply, the TCP connection closes |
//! | NOP | no reply |
//! | ListIdentity, ListServices, ListInterfaces (any session or none) | the identity, one 0100h item "Communications" (flags 0120h), zero items |
//! | SendRRData / SendUnitData with another handle | status 0064h |
//! | SendRRData / SendUnitData with a malformed body or CPF, or SendUnitData for an unknown connection id | status 0003h |
//! | a header announcing more than [`encap::MAX_BODY`] | status 0065h, then that TCP connection closes |
//! | any other command | the same command with status 0001h |
//!
//! # Message Router (class, instance, service)
//!
//! | target | services |
//! | --- | --- |
//! | 64h/1 Nanotec OD | 32h GetOD, 33h SetOD, 34h GetOD Rockwell; others 08h; other instances 05h |
//! | 01h/1 Identity | 01h Get_Attributes_All (attributes 1–7), 0Eh Get_Attribute_Single 1–7 (else 14h) |
//! | 04h/100, 101, 104, 105 Assembly | 0Eh attribute 3 (the current data) and 4 (its size) |
//! | 06h/1 Connection Manager | 54h/5Bh Forward_Open, 4Eh Forward_Close, 52h Unconnected_Send (the route is ignored: the drive ends every route) |
//! | any other class | 05h |
//!
//! Request framing: fewer than 2 bytes → 13h; a path size reaching past the request → 26h
//! (path size invalid); an EPATH that does not decode or names no class → 04h; the reply
//! bit set in a request → 08h.
//!
//! GetOD data must be exactly index u16 + subindex u8 (less 13h, more 15h); the value comes
//! back little-endian in its native size, strings and domains whole. SetOD carries 1 to 4
//! value bytes, exactly the object's size (shorter 13h, longer 15h; strings take the bytes
//! as the whole value). GetOD Rockwell answers `type u16 | length u16 | value` with the
//! CiA 301 data type code. Abort codes of the drive become CIP statuses by
//! [`status_of_abort`]:
//!
//! | abort code | CIP general status |
//! | --- | --- |
//! | 06020000h object missing | 05h path destination unknown |
//! | 06090011h subindex missing | 14h attribute not supported |
//! | 06010002h read-only | 0Eh attribute not settable |
//! | 06010001h write-only | 2Ch attribute not gettable |
//! | 06090030h/31h/32h/36h value range | 09h invalid attribute value |
//! | 06070013h length too low | 13h not enough data |
//! | 06070012h length too high, 06070010h length mismatch | 15h too much data |
//! | anything else | 1Fh vendor specific, additional status = the abort code, low word first |
//!
//! # Connections
//!
//! Forward_Open (54h) and Large_Forward_Open (5Bh), checked in this order, failures being
//! general status 01h with the extended status:
//!
//! 1. transport 01h (class 1 cyclic) or class 3 (A3h): else 0103h.
//! 2. the connection path decodes (else 0315h); an electronic key with a non-zero vendor
//!    other than 558h (Nanotec's ODVA vendor id): 0114h. Port segments are ignored (routes end here).
//! 3. class 3: class 02h instance 1 (Message Router), else 0117h; at most 4 per TCP
//!    session (0113h); the same triad twice in a session: 0100h. They die with their TCP
//!    session or by Forward_Close, and a repeated sequence count gets the previous reply
//!    again without running the request twice.
//! 4. class 1: class 04h, any configuration instance (the drive has no configuration
//!    assembly), connection points O→T then T→O = 105/104 (PDI) or 101/100 (Common), else
//!    0117h. (Paths that give the points as instance segments are accepted too.)
//! 5. only one class 1 connection (the spec: never Common and PDI together): 0106h, or
//!    0100h for the same triad.
//! 6. RPIs of 1 ms to 10 s: else 0111h. Null connection types: 0108h (multicast T→O is
//!    accepted and sent point-to-point).
//! 7. O→T size: the assembly + 2 (sequence count) + 4 (run/idle header), or + 2 alone
//!    (modeless). PDI: 8 bytes (PDI-Cmd at byte 7) or 9 (at byte 8, protocol notes §5.1); Common:
//!    128. Else 0127h, T→O size: 8 or 128, + 2, or + 6 with a run/idle header; else 0128h.
//!    Both add a second word: the size expected (with header for O→T, modeless for T→O).
//!
//! The adapter picks the O→T id; the T→O id is the originator's (or the adapter's when the
//! originator proposed 0). The reply carries the RPIs as APIs and a sockaddr O→T item (the
//! IP the TCP connection was accepted on, the real I/O port). T→O datagrams go where a
//! sockaddr T→O item in the request says (0.0.0.0 = the TCP peer), else to the TCP peer's
//! IP, port 2222. O→T datagrams are taken from the originator's IP only, with a newer
//! encapsulation sequence number; RUN applies them to the drive, IDLE does not; modeless
//! always applies. A silent originator (RPI × 4 << multiplier; the first packet may take up
//! to 1 s) loses the connection and the drive latches fault 8000h (fieldbus monitoring).
//! Forward_Close with the triad (from the originator's IP for class 1, from the session
//! for class 3) closes without a fault; an unknown triad gets 01h + 0107h. A class 1
//! connection outlives the TCP session that opened it.
//!
//! # Identity
//!
//! Vendor 558h (Nanotec's ODVA vendor id; 26Ch is its CiA id, in 1018h:01); device type 2Bh, "generic device (keyable)": the device type
//! Nanotec's own EDS declares is not in the public record. Product code = the low 16 bits
//! of 1018h:02; revision = bits 16–23 (major, clamped to 1..127 as CIP requires) and bits
//! 0–7 (minor) of 1018h:03; serial = 1018h:04; name = 1008h cut to 32 bytes; state 3
//! (operational); status bit 0 (owned) while a class 1 connection is open.

use std::collections::BTreeMap;
use std::io;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::Notify;

use super::SharedDrive;
use crate::cia::AbortCode;
use crate::od::{Address, Value};
use crate::proto::enip::assembly::{self, AssemblySet, CmdOffset, CommonIn, CommonOut};
use crate::proto::enip::cip::{
    GeneralStatus, Path, Reply, Segment, UnconnectedSend, class, service,
};
use crate::proto::enip::connection::{
    ConnectionType, ForwardClose, ForwardOpen, ForwardOpenFailure, ForwardOpenReply,
    TRANSPORT_CLASS1_CYCLIC, Triad, encode_forward_close_reply, extended,
};
use crate::proto::enip::cpf::{self, Item, SockAddr};
use crate::proto::enip::encap::{self, Command, Framed, Packet, RrData, Status};
use crate::proto::enip::identity::{Identity, NANOTEC_VENDOR};
use crate::proto::enip::io::{IoPacket, RUN_IDLE_LEN, SEQUENCE_COUNT_LEN};
use crate::proto::enip::nanotec::{self, Typed};
use crate::proto::enip::wire::{DecodeError, Put};
use crate::sim::{Drive, wrap_integer};

/// Device type 2Bh, generic device (keyable). Nanotec's own is not public.
pub const DEVICE_TYPE: u16 = 0x2B;
/// Registered sessions at a time unless told otherwise.
pub const DEFAULT_MAX_SESSIONS: usize = 8;
/// Class 3 connections one TCP session may hold.
pub const CLASS3_PER_SESSION: usize = 4;
/// The RPIs the adapter accepts, µs.
pub const RPI_RANGE_US: std::ops::RangeInclusive<u32> = 1_000..=10_000_000;
/// The first O→T packet may take this long even when the connection timeout is shorter.
pub const FIRST_PACKET_GRACE: Duration = Duration::from_secs(1);
/// The largest reply data an unconnected message carries (504 bytes less the reply header).
const MAX_REPLY_DATA: usize = 500;
/// Identity state: operational.
const STATE_OPERATIONAL: u8 = 3;
/// Identity status bit 0: owned (a class 1 connection is open).
const STATUS_OWNED: u16 = 0x0001;
/// ListServices capability flags: CIP encapsulation over TCP (bit 5), class 0/1 over UDP
/// (bit 8).
const SERVICE_FLAGS: u16 = 0x0120;

/// Server settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// Registered sessions at a time; RegisterSession beyond them gets status 0002h.
    pub max_sessions: usize,
    /// The class 1 I/O UDP port (2222; 0 = any free port).
    pub io_port: u16,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            max_sessions: DEFAULT_MAX_SESSIONS,
            io_port: encap::UDP_IO_PORT,
        }
    }
}

/// The CIP status for a drive's abort code (table in the module doc).
pub fn status_of_abort(abort: AbortCode) -> (GeneralStatus, Vec<u16>) {
    match abort {
        AbortCode::NO_OBJECT => (GeneralStatus::PATH_DESTINATION_UNKNOWN, vec![]),
        AbortCode::NO_SUBINDEX => (GeneralStatus::ATTRIBUTE_NOT_SUPPORTED, vec![]),
        AbortCode::READ_ONLY => (GeneralStatus::ATTRIBUTE_NOT_SETTABLE, vec![]),
        AbortCode::WRITE_ONLY => (GeneralStatus::ATTRIBUTE_NOT_GETTABLE, vec![]),
        AbortCode::VALUE_RANGE
        | AbortCode::VALUE_TOO_HIGH
        | AbortCode::VALUE_TOO_LOW
        | AbortCode::MAX_LESS_THAN_MIN => (GeneralStatus::INVALID_ATTRIBUTE_VALUE, vec![]),
        AbortCode::TYPE_LENGTH_TOO_LOW => (GeneralStatus::NOT_ENOUGH_DATA, vec![]),
        AbortCode::TYPE_LENGTH_TOO_HIGH | AbortCode::TYPE_LENGTH_MISMATCH => {
            (GeneralStatus::TOO_MUCH_DATA, vec![])
        }
        other => (
            GeneralStatus(0x1F),
            vec![(other.0 & 0xFFFF) as u16, (other.0 >> 16) as u16],
        ),
    }
}

/// One TCP connection, as the glue names it to the adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StreamId(u64);

/// What the adapter answers to bytes from a TCP stream.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Received {
    /// Bytes to write back (zero or more whole encapsulation messages).
    pub reply: Vec<u8>,
    /// Close the connection after writing the reply.
    pub close: bool,
}

/// A UDP datagram to send.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Datagram {
    pub to: SocketAddrV4,
    pub bytes: Vec<u8>,
}

/// The open class 1 connection, as tests and the verbose output see it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IoInfo {
    pub set: AssemblySet,
    pub cmd: CmdOffset,
    pub ot_connection: u32,
    pub to_connection: u32,
    pub triad: Triad,
    /// Where the T→O datagrams go.
    pub target: SocketAddrV4,
    /// O→T datagrams accepted so far.
    pub received: u64,
}

/// A class 3 connection of one session.
#[derive(Debug)]
struct Class3 {
    ot: u32,
    to: u32,
    triad: Triad,
    /// The last sequence count and the connected data answered to it.
    last: Option<(u16, Vec<u8>)>,
}

#[derive(Debug)]
struct Stream {
    local: SocketAddrV4,
    peer: SocketAddrV4,
    buffer: Vec<u8>,
    session: Option<u32>,
    class3: Vec<Class3>,
}

/// The class 1 connection.
#[derive(Debug)]
struct IoConnection {
    set: AssemblySet,
    cmd: CmdOffset,
    triad: Triad,
    ot_id: u32,
    to_id: u32,
    ot_header: bool,
    to_header: bool,
    to_rpi: Duration,
    ot_timeout: Duration,
    originator: Ipv4Addr,
    target: SocketAddrV4,
    opened: Instant,
    last_ot: Option<Instant>,
    last_sequence: Option<u32>,
    received: u64,
    next_send: Instant,
    sequence: u32,
    count: u16,
}

impl IoConnection {
    fn deadline(&self) -> Instant {
        match self.last_ot {
            Some(t) => t + self.ot_timeout,
            None => self.opened + self.ot_timeout.max(FIRST_PACKET_GRACE),
        }
    }
}

/// What one encapsulation message leads to.
#[derive(Default)]
struct Action {
    reply: Option<Packet>,
    close: bool,
}

impl Action {
    fn reply(packet: Packet) -> Action {
        Action {
            reply: Some(packet),
            close: false,
        }
    }
}

/// Where a Message Router request came from.
#[derive(Clone, Copy)]
struct Context {
    stream: StreamId,
    now: Instant,
    /// The sockaddr T→O item of the SendRRData, if any.
    sockaddr_to: Option<SockAddr>,
    /// Unconnected_Send levels already unwrapped.
    depth: u8,
}

fn answer(request: &Packet, status: Status, data: Vec<u8>) -> Packet {
    Packet {
        command: request.command,
        session: request.session,
        status,
        context: request.context,
        options: 0,
        data,
    }
}

fn error(service: u8, status: GeneralStatus) -> Reply {
    Reply::error(service, status, vec![])
}

fn abort_reply(service: u8, abort: AbortCode) -> Reply {
    let (status, additional) = status_of_abort(abort);
    Reply::error(service, status, additional)
}

/// The status for a request's data that does not decode.
fn malformed(e: &DecodeError) -> GeneralStatus {
    match e {
        DecodeError::Short { .. } => GeneralStatus::NOT_ENOUGH_DATA,
        DecodeError::Invalid { .. } => GeneralStatus::TOO_MUCH_DATA,
    }
}

/// `a` comes after `b` in 32-bit sequence arithmetic.
fn newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

fn int_of(drive: &Drive, index: u16, sub: u8) -> i64 {
    drive
        .read(Address::new(index, sub))
        .ok()
        .and_then(|v| v.as_i128())
        .map_or(0, |v| v as i64)
}

/// Write an integer object where the dictionary has it; refusals are ignored (a cyclic
/// image does not answer).
fn write_int(drive: &mut Drive, index: u16, sub: u8, value: i64) {
    let address = Address::new(index, sub);
    if let Some(dtype) = drive.entry(address).map(|e| e.dtype) {
        let _ = drive.write(address, wrap_integer(dtype, value));
    }
}

/// Assembly 100 from the drive.
pub fn common_in(drive: &Drive) -> CommonIn {
    let mut nanoj_outputs = [0i32; assembly::NANOJ_OUTPUTS];
    for (i, v) in nanoj_outputs.iter_mut().enumerate() {
        *v = int_of(drive, 0x2500, i as u8 + 1) as i32;
    }
    CommonIn {
        tx: drive.tx_image(),
        position: int_of(drive, 0x6064, 0) as i32,
        velocity: int_of(drive, 0x606C, 0) as i32,
        digital_inputs: int_of(drive, 0x60FD, 0) as u32,
        torque: int_of(drive, 0x6077, 0) as i16,
        analog_input: int_of(drive, 0x3220, 1) as i16,
        following_error: int_of(drive, 0x60F4, 0) as i32,
        nanoj_outputs,
    }
}

/// Assembly 101 as the drive holds it now.
pub fn common_out(drive: &Drive) -> CommonOut {
    let mut nanoj_inputs = [0i32; assembly::NANOJ_INPUTS];
    for (i, v) in nanoj_inputs.iter_mut().enumerate() {
        *v = int_of(drive, 0x2400, i as u8 + 1) as i32;
    }
    CommonOut {
        rx: drive.rx_image(),
        digital_outputs: int_of(drive, 0x60FE, 1) as u32,
        nanoj_inputs,
    }
}

/// The drive's identity, announced at `socket`.
pub fn identity_of(drive: &Drive, socket: SocketAddrV4, owned: bool) -> Identity {
    let revision = int_of(drive, 0x1018, 3) as u32;
    let mut name = match drive.read(Address::new(0x1008, 0)) {
        Ok(Value::Text(text)) => text,
        _ => String::new(),
    };
    let mut cut = name.len().min(32);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    name.truncate(cut);
    Identity {
        encap_version: 1,
        socket: SockAddr::new(socket),
        vendor: NANOTEC_VENDOR,
        device_type: DEVICE_TYPE,
        product_code: int_of(drive, 0x1018, 2) as u16,
        revision: (((revision >> 16) as u8).clamp(1, 127), revision as u8),
        status: if owned { STATUS_OWNED } else { 0 },
        serial: int_of(drive, 0x1018, 4) as u32,
        product_name: name,
        state: STATE_OPERATIONAL,
    }
}

fn services_item() -> Item {
    let mut data = Vec::with_capacity(20);
    data.put_u16(1);
    data.put_u16(SERVICE_FLAGS);
    data.extend_from_slice(b"Communications\0\0");
    Item::Other {
        kind: cpf::LIST_SERVICES,
        data,
    }
}

fn cpf_data(items: &[Item]) -> Vec<u8> {
    let mut out = Vec::new();
    cpf::encode(items, &mut out);
    out
}

/// The simulated EtherNet/IP adapter, sans IO.
#[derive(Debug)]
pub struct Adapter {
    max_sessions: usize,
    io_port: u16,
    streams: BTreeMap<StreamId, Stream>,
    next_stream: u64,
    next_session: u32,
    next_connection: u32,
    io: Option<IoConnection>,
}

impl Adapter {
    /// An adapter allowing `max_sessions` sessions whose I/O UDP socket is on `io_port`.
    pub fn new(max_sessions: usize, io_port: u16) -> Adapter {
        Adapter {
            max_sessions,
            io_port,
            streams: BTreeMap::new(),
            next_stream: 0,
            next_session: 0,
            next_connection: 0x5D00_0000,
            io: None,
        }
    }

    /// A TCP connection was accepted on `local` from `peer`.
    pub fn accept(&mut self, local: SocketAddrV4, peer: SocketAddrV4) -> StreamId {
        self.next_stream += 1;
        let id = StreamId(self.next_stream);
        self.streams.insert(
            id,
            Stream {
                local,
                peer,
                buffer: Vec::new(),
                session: None,
                class3: Vec::new(),
            },
        );
        id
    }

    /// The TCP connection closed: its session and class 3 connections end (its class 1
    /// connection does not).
    pub fn disconnect(&mut self, stream: StreamId) {
        self.streams.remove(&stream);
    }

    /// TCP connections open.
    pub fn streams(&self) -> usize {
        self.streams.len()
    }

    /// Registered sessions.
    pub fn sessions(&self) -> usize {
        self.streams
            .values()
            .filter(|s| s.session.is_some())
            .count()
    }

    /// The session handle of a stream, once registered.
    pub fn session(&self, stream: StreamId) -> Option<u32> {
        self.streams.get(&stream).and_then(|s| s.session)
    }

    /// The class 1 connection, if one is open.
    pub fn io_connection(&self) -> Option<IoInfo> {
        self.io.as_ref().map(|io| IoInfo {
            set: io.set,
            cmd: io.cmd,
            ot_connection: io.ot_id,
            to_connection: io.to_id,
            triad: io.triad,
            target: io.target,
            received: io.received,
        })
    }

    /// The identity announced at `socket`.
    pub fn identity(&self, drive: &Drive, socket: SocketAddrV4) -> Identity {
        identity_of(drive, socket, self.io.is_some())
    }

    /// Bytes from a TCP stream, in any chunks.
    pub fn receive(
        &mut self,
        stream: StreamId,
        bytes: &[u8],
        drive: &mut Drive,
        now: Instant,
    ) -> Received {
        let mut out = Received::default();
        let Some(state) = self.streams.get_mut(&stream) else {
            out.close = true;
            return out;
        };
        let mut buffer = std::mem::take(&mut state.buffer);
        buffer.extend_from_slice(bytes);
        let mut used = 0;
        loop {
            match encap::split(&buffer[used..]) {
                Framed::Incomplete => break,
                Framed::TooLong(header) => {
                    // The body cannot be skipped reliably: answer and hang up.
                    let packet = Packet::reply_to(&header, Status::INVALID_LENGTH, vec![]);
                    out.reply.extend_from_slice(&packet.encode());
                    out.close = true;
                    break;
                }
                Framed::Packet(packet, n) => {
                    used += n;
                    let action = self.handle(stream, &packet, drive, now);
                    if let Some(reply) = action.reply {
                        out.reply.extend_from_slice(&reply.encode());
                    }
                    if action.close {
                        out.close = true;
                        break;
                    }
                }
            }
        }
        if out.close {
            self.streams.remove(&stream);
        } else if let Some(state) = self.streams.get_mut(&stream) {
            buffer.drain(..used);
            state.buffer = buffer;
        }
        out
    }

    fn handle(&mut self, id: StreamId, packet: &Packet, drive: &mut Drive, now: Instant) -> Action {
        let Some(stream) = self.streams.get(&id) else {
            return Action {
                reply: None,
                close: true,
            };
        };
        let session = stream.session;
        let local = stream.local;
        match packet.command {
            Command::NOP => Action::default(),
            Command::REGISTER_SESSION => Action::reply(self.register(id, packet)),
            Command::UNREGISTER_SESSION => {
                if session.is_none() || session == Some(packet.session) {
                    Action {
                        reply: None,
                        close: true,
                    }
                } else {
                    Action::reply(answer(packet, Status::INVALID_SESSION, vec![]))
                }
            }
            Command::LIST_IDENTITY => {
                let identity = self.identity(drive, local);
                Action::reply(answer(
                    packet,
                    Status::SUCCESS,
                    cpf_data(&[Item::Identity(Box::new(identity))]),
                ))
            }
            Command::LIST_SERVICES => Action::reply(answer(
                packet,
                Status::SUCCESS,
                cpf_data(&[services_item()]),
            )),
            Command::LIST_INTERFACES => {
                Action::reply(answer(packet, Status::SUCCESS, cpf_data(&[])))
            }
            Command::SEND_RR_DATA | Command::SEND_UNIT_DATA => {
                if session.is_none() || session != Some(packet.session) {
                    return Action::reply(answer(packet, Status::INVALID_SESSION, vec![]));
                }
                let Ok(rr) = RrData::decode(&packet.data) else {
                    return Action::reply(answer(packet, Status::INCORRECT_DATA, vec![]));
                };
                let reply = if packet.command == Command::SEND_RR_DATA {
                    self.rr_data(id, packet, &rr, drive, now)
                } else {
                    self.unit_data(id, packet, &rr, drive, now)
                };
                Action::reply(reply)
            }
            _ => Action::reply(answer(packet, Status::INVALID_COMMAND, vec![])),
        }
    }

    fn register(&mut self, id: StreamId, packet: &Packet) -> Packet {
        let mut reply = answer(packet, Status::SUCCESS, packet.data.clone());
        reply.session = 0;
        if packet.data.len() != 4 {
            reply.status = Status::INVALID_LENGTH;
            reply.data = vec![];
            return reply;
        }
        match encap::decode_register_session(&packet.data) {
            Ok((1, 0)) => {}
            _ => {
                reply.status = Status::UNSUPPORTED_PROTOCOL;
                reply.data = encap::register_session_data();
                return reply;
            }
        }
        if let Some(existing) = self.streams.get(&id).and_then(|s| s.session) {
            reply.status = Status::INVALID_COMMAND;
            reply.session = existing;
            return reply;
        }
        if self.sessions() >= self.max_sessions {
            reply.status = Status::INSUFFICIENT_MEMORY;
            return reply;
        }
        let handle = self.new_session_handle();
        if let Some(stream) = self.streams.get_mut(&id) {
            stream.session = Some(handle);
        }
        reply.session = handle;
        reply
    }

    fn new_session_handle(&mut self) -> u32 {
        loop {
            self.next_session = self.next_session.wrapping_add(1);
            let candidate = self.next_session;
            if candidate != 0 && !self.streams.values().any(|s| s.session == Some(candidate)) {
                return candidate;
            }
        }
    }

    fn connection_in_use(&self, id: u32) -> bool {
        self.io
            .as_ref()
            .is_some_and(|io| io.ot_id == id || io.to_id == id)
            || self
                .streams
                .values()
                .flat_map(|s| s.class3.iter())
                .any(|c| c.ot == id || c.to == id)
    }

    fn new_connection_id(&mut self) -> u32 {
        loop {
            self.next_connection = self.next_connection.wrapping_add(1);
            let candidate = self.next_connection;
            if candidate != 0 && !self.connection_in_use(candidate) {
                return candidate;
            }
        }
    }

    fn rr_data(
        &mut self,
        id: StreamId,
        packet: &Packet,
        rr: &RrData,
        drive: &mut Drive,
        now: Instant,
    ) -> Packet {
        let Some(request) = rr.unconnected() else {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        };
        let context = Context {
            stream: id,
            now,
            sockaddr_to: rr.items.iter().find_map(|i| match i {
                Item::SockaddrTo(s) => Some(*s),
                _ => None,
            }),
            depth: 0,
        };
        let (reply, extra) = self.message(request, context, drive);
        let mut items = vec![Item::Null, Item::UnconnectedData(reply.encode())];
        items.extend(extra);
        answer(packet, Status::SUCCESS, RrData::new(0, items).encode())
    }

    fn unit_data(
        &mut self,
        id: StreamId,
        packet: &Packet,
        rr: &RrData,
        drive: &mut Drive,
        now: Instant,
    ) -> Packet {
        let address = rr.items.iter().find_map(|i| match i {
            Item::ConnectedAddress(a) => Some(*a),
            _ => None,
        });
        let data = rr.items.iter().find_map(|i| match i {
            Item::ConnectedData(d) => Some(d.as_slice()),
            _ => None,
        });
        let (Some(address), Some(data)) = (address, data) else {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        };
        let Some(stream) = self.streams.get(&id) else {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        };
        let Some(connection) = stream.class3.iter().find(|c| c.ot == address) else {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        };
        if data.len() < 2 {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        }
        let sequence = u16::from_le_bytes([data[0], data[1]]);
        let to = connection.to;
        let payload = match &connection.last {
            // A repeated sequence count: the originator missed the reply, not a new request.
            Some((last, payload)) if *last == sequence => payload.clone(),
            _ => {
                let context = Context {
                    stream: id,
                    now,
                    sockaddr_to: None,
                    depth: 0,
                };
                let (reply, _) = self.message(&data[2..], context, drive);
                let mut payload = sequence.to_le_bytes().to_vec();
                payload.extend_from_slice(&reply.encode());
                if let Some(c) = self
                    .streams
                    .get_mut(&id)
                    .and_then(|s| s.class3.iter_mut().find(|c| c.ot == address))
                {
                    c.last = Some((sequence, payload.clone()));
                }
                payload
            }
        };
        let items = [Item::ConnectedAddress(to), Item::ConnectedData(payload)];
        answer(
            packet,
            Status::SUCCESS,
            RrData::new(0, items.to_vec()).encode(),
        )
    }

    /// Answer one Message Router request; the items to append to a SendRRData reply.
    fn message(&mut self, bytes: &[u8], context: Context, drive: &mut Drive) -> (Reply, Vec<Item>) {
        let service = bytes.first().copied().unwrap_or(0);
        if bytes.len() < 2 {
            return (
                error(service & 0x7F, GeneralStatus::NOT_ENOUGH_DATA),
                vec![],
            );
        }
        if service & service::REPLY != 0 {
            return (error(service, GeneralStatus::SERVICE_NOT_SUPPORTED), vec![]);
        }
        let path_len = 2 * usize::from(bytes[1]);
        if bytes.len() < 2 + path_len {
            return (error(service, GeneralStatus::PATH_SIZE_INVALID), vec![]);
        }
        let data = &bytes[2 + path_len..];
        let Ok(path) = Path::decode(&bytes[2..2 + path_len]) else {
            return (error(service, GeneralStatus::PATH_SEGMENT_ERROR), vec![]);
        };
        let Some(target) = path.class() else {
            return (error(service, GeneralStatus::PATH_SEGMENT_ERROR), vec![]);
        };
        let instance = path.instance();
        match target {
            class::NANOTEC_OD => (od_service(service, instance, data, drive), vec![]),
            class::IDENTITY => {
                let identity = self.identity(drive, SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, 0));
                (
                    identity_service(service, instance, path.attribute_id(), &identity),
                    vec![],
                )
            }
            class::ASSEMBLY => (
                self.assembly_service(service, instance, path.attribute_id(), drive),
                vec![],
            ),
            class::CONNECTION_MANAGER => {
                if instance != Some(1) {
                    return (
                        error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN),
                        vec![],
                    );
                }
                match service {
                    service::FORWARD_OPEN | service::LARGE_FORWARD_OPEN => {
                        self.forward_open(service, data, context)
                    }
                    service::FORWARD_CLOSE => (self.forward_close(data, context), vec![]),
                    service::UNCONNECTED_SEND if context.depth == 0 => {
                        match UnconnectedSend::decode(data) {
                            // The route is ignored: every route ends at this drive.
                            Ok(wrapped) => self.message(
                                &wrapped.request,
                                Context {
                                    depth: context.depth + 1,
                                    ..context
                                },
                                drive,
                            ),
                            Err(e) => (error(service, malformed(&e)), vec![]),
                        }
                    }
                    _ => (error(service, GeneralStatus::SERVICE_NOT_SUPPORTED), vec![]),
                }
            }
            _ => (
                error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN),
                vec![],
            ),
        }
    }

    fn assembly_service(
        &self,
        service: u8,
        instance: Option<u16>,
        attribute: Option<u16>,
        drive: &Drive,
    ) -> Reply {
        let cmd = match &self.io {
            Some(io) if io.set == AssemblySet::Pdi => io.cmd,
            _ => CmdOffset::Seven,
        };
        let data = match instance {
            Some(assembly::COMMON_TO) => common_in(drive).encode().to_vec(),
            Some(assembly::COMMON_OT) => common_out(drive).encode().to_vec(),
            Some(assembly::PDI_TO) => drive.tx_image().to_bytes().to_vec(),
            Some(assembly::PDI_OT) => assembly::encode_pdi_ot(&drive.rx_image(), cmd),
            _ => return error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN),
        };
        if service != service::GET_ATTRIBUTE_SINGLE {
            return error(service, GeneralStatus::SERVICE_NOT_SUPPORTED);
        }
        match attribute {
            Some(3) => Reply::success(service, data),
            Some(4) => Reply::success(service, (data.len() as u16).to_le_bytes().to_vec()),
            _ => error(service, GeneralStatus::ATTRIBUTE_NOT_SUPPORTED),
        }
    }

    fn forward_open(&mut self, service: u8, data: &[u8], context: Context) -> (Reply, Vec<Item>) {
        let large = service == service::LARGE_FORWARD_OPEN;
        let open = match ForwardOpen::decode(large, data) {
            Ok(open) => open,
            Err(e) => return (error(service, malformed(&e)), vec![]),
        };
        let fail = |code: u16, extra: Option<u16>| {
            let mut additional = vec![code];
            additional.extend(extra);
            (
                Reply {
                    service: service | service::REPLY,
                    status: GeneralStatus::CONNECTION_FAILURE,
                    additional,
                    data: ForwardOpenFailure {
                        triad: open.triad(),
                        remaining_path: 0,
                    }
                    .encode(),
                },
                vec![],
            )
        };
        let class1 = open.transport == TRANSPORT_CLASS1_CYCLIC;
        let class3 = open.transport & 0x0F == 3;
        if !class1 && !class3 {
            return fail(extended::TRANSPORT_NOT_SUPPORTED, None);
        }
        let Ok(path) = Path::decode(&open.path) else {
            return fail(extended::INVALID_SEGMENT, None);
        };
        let mut target_class = None;
        let mut instances = vec![];
        let mut points = vec![];
        for segment in &path.0 {
            match segment {
                Segment::ElectronicKey(key) => {
                    let vendor = u16::from_le_bytes([key[0], key[1]]);
                    if vendor != 0 && vendor != NANOTEC_VENDOR {
                        return fail(extended::VENDOR_OR_PRODUCT_MISMATCH, None);
                    }
                }
                Segment::Class(c) => {
                    target_class.get_or_insert(*c);
                }
                Segment::Instance(i) => instances.push(*i),
                Segment::ConnectionPoint(p) => points.push(*p),
                // Routes end here; configuration data has nowhere to go.
                Segment::Port { .. } | Segment::Data(_) => {}
                Segment::Attribute(_) | Segment::Member(_) => {
                    return fail(extended::INVALID_SEGMENT, None);
                }
            }
        }
        let Some(stream) = self.streams.get(&context.stream) else {
            return fail(extended::OUT_OF_CONNECTIONS, None);
        };
        if class3 {
            if target_class != Some(class::MESSAGE_ROUTER) || instances.first() != Some(&1) {
                return fail(extended::INVALID_CONNECTION_POINT, None);
            }
            if stream.class3.iter().any(|c| c.triad == open.triad()) {
                return fail(extended::CONNECTION_IN_USE, None);
            }
            if stream.class3.len() >= CLASS3_PER_SESSION {
                return fail(extended::OUT_OF_CONNECTIONS, None);
            }
            let ot = self.new_connection_id();
            let to = match open.to_connection {
                0 => self.new_connection_id(),
                to => to,
            };
            if let Some(stream) = self.streams.get_mut(&context.stream) {
                stream.class3.push(Class3 {
                    ot,
                    to,
                    triad: open.triad(),
                    last: None,
                });
            }
            let reply = ForwardOpenReply {
                ot_connection: ot,
                to_connection: to,
                triad: open.triad(),
                ot_api_us: open.ot_rpi_us,
                to_api_us: open.to_rpi_us,
                application: vec![],
            };
            return (Reply::success(service, reply.encode()), vec![]);
        }
        // Class 1. Some originators give the connection points as instance segments.
        if points.is_empty() && instances.len() == 3 {
            points = instances[1..].to_vec();
        }
        let set = match (target_class, points.as_slice()) {
            (Some(class::ASSEMBLY), [ot, to]) => AssemblySet::from_points(*ot, *to),
            _ => None,
        };
        let Some(set) = set else {
            return fail(extended::INVALID_CONNECTION_POINT, None);
        };
        if let Some(io) = &self.io {
            return if io.triad == open.triad() {
                fail(extended::CONNECTION_IN_USE, None)
            } else {
                fail(extended::OWNERSHIP_CONFLICT, None)
            };
        }
        if !RPI_RANGE_US.contains(&open.ot_rpi_us) || !RPI_RANGE_US.contains(&open.to_rpi_us) {
            return fail(extended::RPI_NOT_SUPPORTED, None);
        }
        let usable = |kind: ConnectionType, multicast: bool| {
            kind == ConnectionType::PointToPoint || (multicast && kind == ConnectionType::Multicast)
        };
        if !usable(open.ot_params.kind, false) || !usable(open.to_params.kind, true) {
            return fail(extended::INVALID_CONNECTION_TYPE, None);
        }
        let header = SEQUENCE_COUNT_LEN + RUN_IDLE_LEN;
        let modeless = SEQUENCE_COUNT_LEN;
        let ot_format = [CmdOffset::Seven, CmdOffset::Eight]
            .into_iter()
            .flat_map(|cmd| [(cmd, true), (cmd, false)])
            .find(|(cmd, with_header)| {
                let len = set.ot_len(*cmd) as u16;
                open.ot_params.size == len + if *with_header { header } else { modeless }
            });
        let Some((cmd, ot_header)) = ot_format else {
            let expected = set.ot_len(CmdOffset::Seven) as u16 + header;
            return fail(extended::INVALID_OT_SIZE, Some(expected));
        };
        let to_len = set.to_len() as u16;
        let to_header = if open.to_params.size == to_len + modeless {
            false
        } else if open.to_params.size == to_len + header {
            true
        } else {
            return fail(extended::INVALID_TO_SIZE, Some(to_len + modeless));
        };
        let peer_ip = *stream.peer.ip();
        let local_ip = *stream.local.ip();
        let target = match context.sockaddr_to {
            Some(s) => SocketAddrV4::new(
                if s.ip.is_unspecified() { peer_ip } else { s.ip },
                if s.port == 0 {
                    encap::UDP_IO_PORT
                } else {
                    s.port
                },
            ),
            None => SocketAddrV4::new(peer_ip, encap::UDP_IO_PORT),
        };
        let ot_id = self.new_connection_id();
        let to_id = match open.to_connection {
            0 => self.new_connection_id(),
            to => to,
        };
        let to_rpi = Duration::from_micros(u64::from(open.to_rpi_us));
        self.io = Some(IoConnection {
            set,
            cmd,
            triad: open.triad(),
            ot_id,
            to_id,
            ot_header,
            to_header,
            to_rpi,
            ot_timeout: open.ot_timeout(),
            originator: peer_ip,
            target,
            opened: context.now,
            last_ot: None,
            last_sequence: None,
            received: 0,
            next_send: context.now,
            sequence: 0,
            count: 0,
        });
        let reply = ForwardOpenReply {
            ot_connection: ot_id,
            to_connection: to_id,
            triad: open.triad(),
            ot_api_us: open.ot_rpi_us,
            to_api_us: open.to_rpi_us,
            application: vec![],
        };
        (
            Reply::success(service, reply.encode()),
            vec![Item::SockaddrOt(SockAddr::new(SocketAddrV4::new(
                local_ip,
                self.io_port,
            )))],
        )
    }

    fn forward_close(&mut self, data: &[u8], context: Context) -> Reply {
        let service = service::FORWARD_CLOSE;
        let close = match ForwardClose::decode(data) {
            Ok(close) => close,
            Err(e) => return error(service, malformed(&e)),
        };
        let Some(stream) = self.streams.get_mut(&context.stream) else {
            return error(service, GeneralStatus::RESOURCE_UNAVAILABLE);
        };
        let peer_ip = *stream.peer.ip();
        if let Some(at) = stream.class3.iter().position(|c| c.triad == close.triad) {
            stream.class3.remove(at);
            return Reply::success(service, encode_forward_close_reply(&close.triad));
        }
        if self
            .io
            .as_ref()
            .is_some_and(|io| io.triad == close.triad && io.originator == peer_ip)
        {
            self.io = None;
            return Reply::success(service, encode_forward_close_reply(&close.triad));
        }
        Reply {
            service: service | service::REPLY,
            status: GeneralStatus::CONNECTION_FAILURE,
            additional: vec![extended::CONNECTION_NOT_FOUND],
            data: ForwardOpenFailure {
                triad: close.triad,
                remaining_path: 0,
            }
            .encode(),
        }
    }

    /// A datagram on the I/O UDP socket.
    pub fn io_datagram(
        &mut self,
        from: SocketAddrV4,
        bytes: &[u8],
        drive: &mut Drive,
        now: Instant,
    ) {
        let Some(io) = self.io.as_mut() else {
            return;
        };
        if IoPacket::connection_of(bytes) != Some(io.ot_id) || *from.ip() != io.originator {
            return;
        }
        let Ok(packet) = IoPacket::decode(bytes, io.ot_header) else {
            return;
        };
        if packet.data.len() != io.set.ot_len(io.cmd) {
            return;
        }
        if io
            .last_sequence
            .is_some_and(|last| !newer(packet.sequence, last))
        {
            return;
        }
        io.last_sequence = Some(packet.sequence);
        io.last_ot = Some(now);
        io.received += 1;
        if packet.run == Some(false) {
            return; // idle: the originator holds its outputs back
        }
        match io.set {
            AssemblySet::Pdi => {
                if let Ok(rx) = assembly::decode_pdi_ot(&packet.data, io.cmd) {
                    drive.write_rx(&rx);
                }
            }
            AssemblySet::Common => {
                if let Ok(out) = CommonOut::decode(&packet.data) {
                    write_int(drive, 0x60FE, 1, i64::from(out.digital_outputs));
                    for (i, v) in out.nanoj_inputs.iter().enumerate() {
                        write_int(drive, 0x2400, i as u8 + 1, i64::from(*v));
                    }
                    drive.write_rx(&out.rx);
                }
            }
        }
    }

    /// Time passes: the T→O datagram when one is due, and the end of a connection whose
    /// originator went silent (the drive latches fault 8000h).
    pub fn poll(&mut self, drive: &mut Drive, now: Instant) -> Vec<Datagram> {
        let Some(io) = self.io.as_mut() else {
            return vec![];
        };
        if now >= io.deadline() {
            self.io = None;
            drive.fieldbus_lost();
            return vec![];
        }
        if now < io.next_send {
            return vec![];
        }
        io.sequence = io.sequence.wrapping_add(1);
        io.count = io.count.wrapping_add(1);
        let data = match io.set {
            AssemblySet::Pdi => drive.tx_image().to_bytes().to_vec(),
            AssemblySet::Common => common_in(drive).encode().to_vec(),
        };
        let packet = IoPacket {
            connection: io.to_id,
            sequence: io.sequence,
            count: io.count,
            run: io.to_header.then_some(true),
            data,
        };
        io.next_send += io.to_rpi;
        if io.next_send <= now {
            // Late (a loaded machine): no burst to catch up.
            io.next_send = now + io.to_rpi;
        }
        vec![Datagram {
            to: io.target,
            bytes: packet.encode(),
        }]
    }

    /// When [`Adapter::poll`] has something to do next.
    pub fn next_due(&self) -> Option<Instant> {
        self.io.as_ref().map(|io| io.next_send.min(io.deadline()))
    }

    /// A datagram on the discovery UDP socket (the TCP port): ListIdentity and
    /// ListServices are answered, everything else ignored. `local` is the socket's address.
    pub fn discovery(&self, bytes: &[u8], local: SocketAddrV4, drive: &Drive) -> Option<Vec<u8>> {
        let packet = Packet::decode(bytes).ok()?;
        let items = match packet.command {
            Command::LIST_IDENTITY => vec![Item::Identity(Box::new(self.identity(drive, local)))],
            Command::LIST_SERVICES => vec![services_item()],
            _ => return None,
        };
        Some(answer(&packet, Status::SUCCESS, cpf_data(&items)).encode())
    }
}

fn od_service(service: u8, instance: Option<u16>, data: &[u8], drive: &mut Drive) -> Reply {
    if instance != Some(1) {
        return error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN);
    }
    match service {
        service::GET_OD | service::GET_OD_ROCKWELL => {
            if data.len() < 3 {
                return error(service, GeneralStatus::NOT_ENOUGH_DATA);
            }
            if data.len() > 3 {
                return error(service, GeneralStatus::TOO_MUCH_DATA);
            }
            let Ok((address, _)) = nanotec::decode_request_data(data) else {
                return error(service, GeneralStatus::NOT_ENOUGH_DATA);
            };
            let read = drive.read(address).and_then(|value| {
                let dtype = drive
                    .entry(address)
                    .map(|e| e.dtype)
                    .ok_or(AbortCode::NO_OBJECT)?;
                let bytes = value
                    .to_le_bytes(dtype)
                    .map_err(|_| AbortCode::GENERAL_ERROR)?;
                Ok((dtype, bytes))
            });
            match read {
                Err(abort) => abort_reply(service, abort),
                Ok((_, bytes)) if bytes.len() > MAX_REPLY_DATA => {
                    error(service, GeneralStatus::REPLY_TOO_LARGE)
                }
                Ok((_, bytes)) if service == service::GET_OD => Reply::success(service, bytes),
                Ok((dtype, bytes)) => Reply::success(
                    service,
                    Typed {
                        dtype_code: dtype.code(),
                        data: bytes,
                    }
                    .encode(),
                ),
            }
        }
        service::SET_OD => {
            if data.len() < 4 {
                return error(service, GeneralStatus::NOT_ENOUGH_DATA);
            }
            let Ok((address, value)) = nanotec::decode_request_data(data) else {
                return error(service, GeneralStatus::NOT_ENOUGH_DATA);
            };
            if value.len() > 4 {
                return error(service, GeneralStatus::TOO_MUCH_DATA);
            }
            let Some(entry) = drive.entry(address) else {
                return abort_reply(
                    service,
                    drive.read(address).err().unwrap_or(AbortCode::NO_OBJECT),
                );
            };
            if !entry.access.writable() {
                return abort_reply(service, AbortCode::READ_ONLY);
            }
            let dtype = entry.dtype;
            match dtype.size() {
                Some(size) if value.len() < size => {
                    return error(service, GeneralStatus::NOT_ENOUGH_DATA);
                }
                Some(size) if value.len() > size => {
                    return error(service, GeneralStatus::TOO_MUCH_DATA);
                }
                _ => {}
            }
            let Ok(value) = Value::from_le_bytes(dtype, value) else {
                return abort_reply(service, AbortCode::TYPE_LENGTH_MISMATCH);
            };
            match drive.write(address, value) {
                Ok(()) => Reply::success(service, vec![]),
                Err(abort) => abort_reply(service, abort),
            }
        }
        _ => error(service, GeneralStatus::SERVICE_NOT_SUPPORTED),
    }
}

fn identity_service(
    service: u8,
    instance: Option<u16>,
    attribute: Option<u16>,
    identity: &Identity,
) -> Reply {
    if instance != Some(1) {
        return error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN);
    }
    let mut all = Vec::with_capacity(48);
    identity.encode_attributes(&mut all);
    match service {
        service::GET_ATTRIBUTES_ALL => Reply::success(service, all),
        service::GET_ATTRIBUTE_SINGLE => {
            // Offsets of attributes 1 to 7 in Get_Attributes_All.
            let range = match attribute {
                Some(1) => 0..2,
                Some(2) => 2..4,
                Some(3) => 4..6,
                Some(4) => 6..8,
                Some(5) => 8..10,
                Some(6) => 10..14,
                Some(7) => 14..all.len(),
                _ => return error(service, GeneralStatus::ATTRIBUTE_NOT_SUPPORTED),
            };
            Reply::success(service, all.get(range).unwrap_or_default().to_vec())
        }
        _ => error(service, GeneralStatus::SERVICE_NOT_SUPPORTED),
    }
}

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
/// connection) or the listener fails.
pub async fn serve(sockets: Sockets, shared: SharedDrive, options: Options) -> io::Result<()> {
    let listener = TcpListener::from_std(sockets.tcp)?;
    let discovery = UdpSocket::from_std(sockets.discovery)?;
    let io = UdpSocket::from_std(sockets.io)?;
    let io_port = io.local_addr()?.port();
    let discovery_local = ipv4(discovery.local_addr()?)?;
    let adapter: Shared = Arc::new(Mutex::new(Adapter::new(options.max_sessions, io_port)));
    let wake = Arc::new(Notify::new());
    // TCP connections beyond the sessions (unregistered, or refused with 0002h) are
    // bounded too, so a flood of idle connections cannot exhaust the process.
    let max_streams = options.max_sessions.saturating_add(8);
    tokio::select! {
        r = accept(listener, adapter.clone(), shared.clone(), wake.clone(), max_streams) => r,
        r = consume(&io, adapter.clone(), shared.clone()) => r,
        r = produce(&io, adapter.clone(), shared.clone(), wake.clone()) => r,
        r = answer_discovery(discovery, discovery_local, adapter.clone(), shared.clone()) => r,
    }
}

async fn accept(
    listener: TcpListener,
    adapter: Shared,
    shared: SharedDrive,
    wake: Arc<Notify>,
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
    wake: Arc<Notify>,
) {
    let _ = stream.set_nodelay(true);
    let mut chunk = vec![0u8; 4096];
    loop {
        let n = match stream.read(&mut chunk).await {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        let received = {
            let mut adapter = lock(&adapter);
            let mut drive = shared.lock();
            adapter.receive(id, &chunk[..n], &mut drive, Instant::now())
        };
        // A Forward_Open may have started production.
        wake.notify_one();
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

async fn consume(io: &UdpSocket, adapter: Shared, shared: SharedDrive) -> io::Result<()> {
    let mut buffer = vec![0u8; 2048];
    loop {
        let (n, from) = match io.recv_from(&mut buffer).await {
            Ok(received) => received,
            Err(_) => {
                // e.g. an ICMP error reported on some platforms: keep serving.
                tokio::time::sleep(Duration::from_millis(1)).await;
                continue;
            }
        };
        let Ok(from) = ipv4(from) else {
            continue;
        };
        let mut adapter = lock(&adapter);
        let mut drive = shared.lock();
        adapter.io_datagram(from, &buffer[..n], &mut drive, Instant::now());
    }
}

async fn produce(
    io: &UdpSocket,
    adapter: Shared,
    shared: SharedDrive,
    wake: Arc<Notify>,
) -> io::Result<()> {
    loop {
        let (datagrams, due) = {
            let mut adapter = lock(&adapter);
            let mut drive = shared.lock();
            let datagrams = adapter.poll(&mut drive, Instant::now());
            (datagrams, adapter.next_due())
        };
        for datagram in datagrams {
            let _ = io.send_to(&datagram.bytes, datagram.to).await;
        }
        match due {
            Some(due) => {
                tokio::select! {
                    _ = tokio::time::sleep_until(tokio::time::Instant::from_std(due)) => {}
                    _ = wake.notified() => {}
                }
            }
            None => wake.notified().await,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Command as PdiCommand, Opcode, RxImage, SetValues};
    use crate::proto::enip::cip::Request;
    use crate::proto::enip::connection::NetworkParams;
    use proptest::prelude::*;

    const B_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 2);
    const A_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 9);
    const LOCAL: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 1), 44818);

    fn packet(command: Command, session: u32, data: Vec<u8>) -> Vec<u8> {
        Packet::new(command, session, *b"testctx\0", data).encode()
    }

    fn rr(session: u32, request: &Request, extra: Vec<Item>) -> Vec<u8> {
        let mut items = vec![Item::Null, Item::UnconnectedData(request.encode())];
        items.extend(extra);
        packet(
            Command::SEND_RR_DATA,
            session,
            RrData::new(5, items).encode(),
        )
    }

    /// The packets of a reply stream.
    fn packets(mut bytes: &[u8]) -> Vec<Packet> {
        let mut out = vec![];
        while let Framed::Packet(p, n) = encap::split(bytes) {
            out.push(p);
            bytes = &bytes[n..];
        }
        assert!(bytes.is_empty(), "a partial reply: {bytes:?}");
        out
    }

    fn mr_reply(bytes: &[u8]) -> (Reply, Vec<Item>) {
        let replies = packets(bytes);
        assert_eq!(replies.len(), 1, "{replies:?}");
        let rr = RrData::decode(&replies[0].data).expect("SendRRData body");
        let reply = Reply::decode(rr.unconnected().expect("unconnected item")).expect("reply");
        (reply, rr.items)
    }

    struct Bench {
        adapter: Adapter,
        drive: Drive,
        now: Instant,
    }

    impl Bench {
        fn new() -> Bench {
            Bench {
                adapter: Adapter::new(DEFAULT_MAX_SESSIONS, 2222),
                drive: Drive::new(),
                now: Instant::now(),
            }
        }

        fn send(&mut self, stream: StreamId, bytes: &[u8]) -> Received {
            self.adapter
                .receive(stream, bytes, &mut self.drive, self.now)
        }

        fn client(&mut self, ip: Ipv4Addr) -> (StreamId, u32) {
            let id = self.adapter.accept(LOCAL, SocketAddrV4::new(ip, 50000));
            let out = self.send(
                id,
                &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
            );
            let reply = packets(&out.reply).remove(0);
            assert_eq!(reply.status, Status::SUCCESS);
            (id, reply.session)
        }

        fn request(&mut self, (id, session): (StreamId, u32), request: &Request) -> Reply {
            let out = self.send(id, &rr(session, request, vec![]));
            mr_reply(&out.reply).0
        }
    }

    fn forward_open(transport: u8, path: Vec<u8>, ot: u16, to: u16, serial: u16) -> ForwardOpen {
        ForwardOpen {
            large: false,
            tick: 0x0A,
            timeout_ticks: 0x0E,
            ot_connection: 0,
            to_connection: 0x7000_0000 + u32::from(serial),
            serial,
            vendor: 0x1234,
            originator_serial: 0xABCD_0000 + u32::from(serial),
            timeout_multiplier: 0,
            ot_rpi_us: 10_000,
            ot_params: NetworkParams::point_to_point(ot),
            to_rpi_us: 10_000,
            to_params: NetworkParams::point_to_point(to),
            transport,
            path,
        }
    }

    fn pdi_open(serial: u16) -> ForwardOpen {
        forward_open(
            TRANSPORT_CLASS1_CYCLIC,
            vec![0x20, 0x04, 0x24, 0x64, 0x2C, 0x69, 0x2C, 0x68],
            14,
            10,
            serial,
        )
    }

    fn class3_open(serial: u16) -> ForwardOpen {
        forward_open(0xA3, vec![0x20, 0x02, 0x24, 0x01], 504, 504, serial)
    }

    fn cm(service: u8, data: Vec<u8>) -> Request {
        Request::new(service, &Path::object(class::CONNECTION_MANAGER, 1), data)
    }

    fn opened(reply: &Reply) -> ForwardOpenReply {
        assert!(reply.status.is_success(), "{}", reply.status_text());
        ForwardOpenReply::decode(&reply.data).expect("Forward_Open reply")
    }

    fn unit_data(session: u32, connection: u32, sequence: u16, request: &Request) -> Vec<u8> {
        let mut data = sequence.to_le_bytes().to_vec();
        data.extend_from_slice(&request.encode());
        let items = vec![
            Item::ConnectedAddress(connection),
            Item::ConnectedData(data),
        ];
        packet(
            Command::SEND_UNIT_DATA,
            session,
            RrData::new(0, items).encode(),
        )
    }

    fn vendor_id() -> Request {
        nanotec::get_od(Address::new(0x1018, 1))
    }

    #[test]
    fn abort_codes_map_to_the_documented_statuses() {
        let s = |code: AbortCode| status_of_abort(code);
        assert_eq!(s(AbortCode::NO_OBJECT).0, GeneralStatus(0x05));
        assert_eq!(s(AbortCode::NO_SUBINDEX).0, GeneralStatus(0x14));
        assert_eq!(s(AbortCode::READ_ONLY).0, GeneralStatus(0x0E));
        assert_eq!(s(AbortCode::WRITE_ONLY).0, GeneralStatus(0x2C));
        for code in [0x0609_0030, 0x0609_0031, 0x0609_0032, 0x0609_0036] {
            assert_eq!(s(AbortCode(code)), (GeneralStatus(0x09), vec![]));
        }
        assert_eq!(s(AbortCode(0x0607_0013)).0, GeneralStatus(0x13));
        assert_eq!(s(AbortCode(0x0607_0012)).0, GeneralStatus(0x15));
        assert_eq!(s(AbortCode(0x0607_0010)).0, GeneralStatus(0x15));
        assert_eq!(
            s(AbortCode::CANNOT_STORE),
            (GeneralStatus(0x1F), vec![0x0020, 0x0800])
        );
    }

    #[test]
    fn the_identity_comes_from_1018h_and_1008h() {
        let drive = Drive::new();
        let id = identity_of(&drive, LOCAL, false);
        assert_eq!((id.vendor, id.device_type), (0x0558, 0x2B));
        assert_eq!(id.product_code, 0x42);
        // 1018h:03 = 08030000h: major = bits 16-23, minor = bits 0-7.
        assert_eq!(id.revision, (3, 0));
        assert_eq!(id.serial, 0x1234);
        assert_eq!(id.product_name, "drivedeck simulated drive");
        assert_eq!((id.status, id.state), (0, 3));
        assert_eq!(identity_of(&drive, LOCAL, true).status, 1);
    }

    #[test]
    fn production_follows_the_rpi_and_silence_latches_fault_8000h() {
        let mut b = Bench::new();
        let client = b.client(B_IP);
        let reply = b.request(client, &cm(service::FORWARD_OPEN, pdi_open(1).encode()));
        let accepted = opened(&reply);
        let t0 = b.now;
        let first = b.adapter.poll(&mut b.drive, t0);
        assert_eq!(first.len(), 1);
        assert_eq!(first[0].to, SocketAddrV4::new(B_IP, 2222));
        let p = IoPacket::decode(&first[0].bytes, false).expect("T→O");
        assert_eq!(
            (p.connection, p.sequence, p.count, p.run),
            (accepted.to_connection, 1, 1, None)
        );
        assert_eq!(p.data, b.drive.tx_image().to_bytes());
        assert!(
            b.adapter
                .poll(&mut b.drive, t0 + Duration::from_millis(5))
                .is_empty()
        );
        let second = b.adapter.poll(&mut b.drive, t0 + Duration::from_millis(10));
        assert_eq!(
            IoPacket::decode(&second[0].bytes, false).map(|p| p.sequence),
            Ok(2)
        );
        // The first O→T packet may take up to a second (the timeout itself is 40 ms).
        let at = t0 + Duration::from_millis(900);
        assert!(!b.adapter.poll(&mut b.drive, at).is_empty());
        let ot = |sequence: u32, run: bool, data: Vec<u8>| {
            IoPacket {
                connection: accepted.ot_connection,
                sequence,
                count: sequence as u16,
                run: Some(run),
                data,
            }
            .encode()
        };
        let rx = RxImage::new(
            SetValues {
                value1: 2000,
                value2: 200,
                value3: 0,
            },
            PdiCommand::new(Opcode::MoveAbsolute),
        );
        let image = rx.to_bytes().to_vec();
        // Idle, then from a stranger, then old: nothing applies.
        b.adapter.io_datagram(
            SocketAddrV4::new(B_IP, 2222),
            &ot(5, false, image.clone()),
            &mut b.drive,
            at,
        );
        b.adapter.io_datagram(
            SocketAddrV4::new(A_IP, 2222),
            &ot(6, true, image.clone()),
            &mut b.drive,
            at,
        );
        b.adapter.io_datagram(
            SocketAddrV4::new(B_IP, 2222),
            &ot(4, true, image.clone()),
            &mut b.drive,
            at,
        );
        assert_eq!(b.drive.rx_image(), RxImage::default());
        assert_eq!(b.adapter.io_connection().map(|io| io.received), Some(1));
        b.adapter.io_datagram(
            SocketAddrV4::new(B_IP, 2222),
            &ot(7, true, image),
            &mut b.drive,
            at,
        );
        assert_eq!(b.drive.rx_image(), rx);
        // Fed at `at`: alive 39 ms later, gone at 40 ms with the fault.
        assert!(
            !b.adapter
                .poll(&mut b.drive, at + Duration::from_millis(39))
                .is_empty()
        );
        assert!(
            b.adapter
                .poll(&mut b.drive, at + Duration::from_millis(40))
                .is_empty()
        );
        assert!(b.adapter.io_connection().is_none());
        assert_eq!(b.drive.tx_image().error_code, 0x8000);
        assert_eq!(b.adapter.next_due(), None);
    }

    #[test]
    fn a_class_1_connection_outlives_its_session_and_closes_by_triad() {
        let mut b = Bench::new();
        let first = b.client(B_IP);
        opened(&b.request(first, &cm(service::FORWARD_OPEN, pdi_open(1).encode())));
        b.adapter.disconnect(first.0);
        assert!(b.adapter.io_connection().is_some());
        let again = b.client(B_IP);
        let close = ForwardClose {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: pdi_open(1).triad(),
            path: vec![],
        };
        let reply = b.request(again, &cm(service::FORWARD_CLOSE, close.encode()));
        assert!(reply.status.is_success());
        assert_eq!(reply.data, encode_forward_close_reply(&pdi_open(1).triad()));
        assert!(b.adapter.io_connection().is_none());
        assert_eq!(
            b.drive.tx_image().error_code,
            0,
            "no fault on Forward_Close"
        );
    }

    #[test]
    fn class_3_repeats_the_reply_to_a_repeated_sequence_count() {
        let mut b = Bench::new();
        let client = b.client(B_IP);
        let c3 = opened(&b.request(client, &cm(service::FORWARD_OPEN, class3_open(3).encode())));
        let write =
            nanotec::set_od(Address::new(0x2031, 0), &1000u32.to_le_bytes()).expect("SetOD");
        let first = b.send(client.0, &unit_data(client.1, c3.ot_connection, 9, &write));
        b.drive
            .write(Address::new(0x2031, 0), Value::Uint(1200))
            .expect("write");
        let again = b.send(client.0, &unit_data(client.1, c3.ot_connection, 9, &write));
        assert_eq!(first.reply, again.reply);
        assert_eq!(
            b.drive.read(Address::new(0x2031, 0)),
            Ok(Value::Uint(1200)),
            "not run twice"
        );
        let reply = packets(&again.reply).remove(0);
        let rr = RrData::decode(&reply.data).expect("body");
        assert_eq!(rr.items[0], Item::ConnectedAddress(c3.to_connection));
    }

    /// Valid packets of client A, to be mutated.
    fn a_packets(session: u32) -> Vec<Vec<u8>> {
        let close = ForwardClose {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: class3_open(40).triad(),
            path: vec![],
        };
        let wrapped = UnconnectedSend {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            request: vendor_id().encode(),
            route: vec![0x01, 0x00],
        };
        vec![
            packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
            packet(Command::LIST_IDENTITY, 0, vec![]),
            packet(Command::LIST_SERVICES, 0, vec![]),
            packet(Command::NOP, 0, vec![1, 2]),
            rr(session, &vendor_id(), vec![]),
            rr(
                session,
                &nanotec::set_od(Address::new(0x2031, 0), &[1, 2, 3, 4]).expect("SetOD"),
                vec![],
            ),
            rr(
                session,
                &nanotec::get_od_rockwell(Address::new(0x1008, 0)),
                vec![],
            ),
            rr(
                session,
                &cm(service::FORWARD_OPEN, class3_open(40).encode()),
                vec![],
            ),
            rr(
                session,
                &cm(service::FORWARD_OPEN, pdi_open(41).encode()),
                vec![Item::SockaddrTo(SockAddr::new(SocketAddrV4::new(
                    A_IP, 2222,
                )))],
            ),
            rr(session, &cm(service::FORWARD_CLOSE, close.encode()), vec![]),
            rr(
                session,
                &cm(service::UNCONNECTED_SEND, wrapped.encode()),
                vec![],
            ),
            unit_data(session, 0x5D00_0001, 1, &vendor_id()),
            rr(
                session,
                &Request::new(0x0E, &Path::attribute(4, 104, 3), vec![]),
                vec![],
            ),
            rr(
                session,
                &Request::new(0x01, &Path::object(1, 1), vec![]),
                vec![],
            ),
            packet(Command::UNREGISTER_SESSION, session, vec![]),
        ]
    }

    /// B registered, with a class 3 and the class 1 connection; A connected.
    fn two_clients() -> (Bench, (StreamId, u32), ForwardOpenReply, IoInfo, StreamId) {
        let mut b = Bench::new();
        let client = b.client(B_IP);
        let c3 = opened(&b.request(client, &cm(service::FORWARD_OPEN, class3_open(1).encode())));
        opened(&b.request(client, &cm(service::FORWARD_OPEN, pdi_open(2).encode())));
        let io = b.adapter.io_connection().expect("class 1");
        let a = b.adapter.accept(LOCAL, SocketAddrV4::new(A_IP, 40000));
        (b, client, c3, io, a)
    }

    /// B's session, class 3 and class 1 connections all still work.
    fn b_is_untouched(b: &mut Bench, client: (StreamId, u32), c3: &ForwardOpenReply, io: &IoInfo) {
        assert_eq!(b.adapter.session(client.0), Some(client.1));
        let reply = b.request(client, &vendor_id());
        assert_eq!(
            (reply.status, reply.data),
            (GeneralStatus::SUCCESS, vec![0x6C, 2, 0, 0])
        );
        let out = b.send(
            client.0,
            &unit_data(client.1, c3.ot_connection, 0xBEEF, &vendor_id()),
        );
        let reply = packets(&out.reply).remove(0);
        assert_eq!(reply.status, Status::SUCCESS);
        let items = RrData::decode(&reply.data).expect("body").items;
        assert_eq!(items[0], Item::ConnectedAddress(c3.to_connection));
        let mut expected = 0xBEEFu16.to_le_bytes().to_vec();
        expected.extend_from_slice(&Reply::success(0x32, vec![0x6C, 2, 0, 0]).encode());
        assert_eq!(items[1], Item::ConnectedData(expected));
        let now = b.adapter.io_connection().expect("class 1 still open");
        assert_eq!(
            (now.ot_connection, now.to_connection, now.triad, now.target),
            (io.ot_connection, io.to_connection, io.triad, io.target)
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

        #[test]
        fn arbitrary_bytes_never_disturb_another_session(
            chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..80), 0..12),
            register_first in any::<bool>(),
        ) {
            let (mut b, client, c3, io, a) = two_clients();
            if register_first {
                b.send(a, &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()));
            }
            for chunk in &chunks {
                let out = b.send(a, chunk);
                packets(&out.reply);
                if out.close {
                    break;
                }
            }
            for chunk in &chunks {
                b.adapter.io_datagram(SocketAddrV4::new(A_IP, 2222), chunk, &mut b.drive, b.now);
                let _ = b.adapter.discovery(chunk, LOCAL, &b.drive);
            }
            b_is_untouched(&mut b, client, &c3, &io);
        }

        #[test]
        fn mutated_packets_never_disturb_another_session(
            picks in proptest::collection::vec(0usize..15, 1..8),
            mutations in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
            cut in any::<prop::sample::Index>(),
            truncate in any::<bool>(),
            chunk in 1usize..64,
        ) {
            let (mut b, client, c3, io, a) = two_clients();
            let out = b.send(a, &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()));
            let session = packets(&out.reply)[0].session;
            let all = a_packets(session);
            let mut stream: Vec<u8> = picks.iter().flat_map(|i| all[*i].clone()).collect();
            for (at, byte) in &mutations {
                let at = at.index(stream.len());
                stream[at] = *byte;
            }
            if truncate {
                stream.truncate(cut.index(stream.len() + 1));
            }
            for piece in stream.chunks(chunk) {
                let out = b.send(a, piece);
                packets(&out.reply);
                if out.close {
                    break;
                }
            }
            b_is_untouched(&mut b, client, &c3, &io);
        }
    }

    #[test]
    fn the_mutation_base_is_valid() {
        // Every packet of `a_packets` gets its answer (the proptest mutates real requests).
        let (mut b, client, c3, io, a) = two_clients();
        let out = b.send(
            a,
            &packet(Command::REGISTER_SESSION, 0, encap::register_session_data()),
        );
        let session = packets(&out.reply)[0].session;
        let all = a_packets(session);
        let replies: Vec<Packet> = all[1..all.len() - 1]
            .iter()
            .flat_map(|p| packets(&b.send(a, p).reply))
            .collect();
        // NOP has no reply; everything else succeeds at the encapsulation level, except the
        // SendUnitData to a connection A does not have.
        assert_eq!(replies.len(), all.len() - 3);
        let statuses: Vec<u32> = replies.iter().map(|p| p.status.0).collect();
        assert_eq!(statuses, [0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0]);
        let (conflict, _) = mr_reply(&replies[6].encode());
        assert_eq!(conflict.additional, [extended::OWNERSHIP_CONFLICT]);
        let (closed, _) = mr_reply(&replies[7].encode());
        assert!(
            closed.status.is_success(),
            "A closes its own class 3 connection"
        );
        let out = b.send(a, &all[all.len() - 1]);
        assert!(out.close && out.reply.is_empty(), "UnRegisterSession");
        b_is_untouched(&mut b, client, &c3, &io);
    }
}
