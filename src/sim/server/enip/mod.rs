//! The simulated drive as an EtherNet/IP adapter (target): explicit messages over TCP
//! (unconnected, through Unconnected_Send, and class 3 connected), one class 1 I/O
//! connection over UDP carrying the PDI or the Common assembly set, and ListIdentity over
//! UDP for discovery (protocol notes §3, EtherNet/IP chapter).
//!
//! [`Adapter`] is sans-IO: TCP bytes in per stream, replies out; I/O datagrams in;
//! [`Adapter::poll`] gives the T→O datagrams that are due and ends a connection whose
//! originator went silent. [`serve`] is the thin glue around it (tokio for TCP and
//! discovery, two threads of their own for class 1 I/O).
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

use std::net::{Ipv4Addr, SocketAddrV4};
use std::time::{Duration, Instant};

use crate::cia::AbortCode;
use crate::od::Address;
use crate::proto::enip::assembly::{AssemblySet, CmdOffset};
use crate::proto::enip::cip::{GeneralStatus, Reply};
use crate::proto::enip::connection::Triad;
use crate::proto::enip::cpf::SockAddr;
use crate::proto::enip::encap::{self, Packet, Status};
use crate::proto::enip::wire::DecodeError;
use crate::sim::{Drive, wrap_integer};

mod adapter;
mod class1;
mod forward_open;
mod images;
mod serve;
mod services;

pub use adapter::Adapter;
pub use serve::{Sockets, serve};

#[cfg(test)]
mod tests;

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
pub struct AdapterOptions {
    /// Registered sessions at a time; RegisterSession beyond them gets status 0002h.
    pub max_sessions: usize,
    /// The class 1 I/O UDP port (2222; 0 = any free port).
    pub io_port: u16,
}

impl Default for AdapterOptions {
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

/// The answer to `request`: its command, session and context.
fn answer(request: &Packet, status: Status, data: Vec<u8>) -> Packet {
    Packet::reply_to(&request.header(), status, data)
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
