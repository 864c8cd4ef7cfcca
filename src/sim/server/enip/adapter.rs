//! The adapter's sessions and streams: encapsulation commands, explicit messages and the Message Router.

use std::collections::BTreeMap;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::time::Instant;

use super::images::{common_in, common_out, cpf_data, identity_of, services_item};
use super::services::{identity_service, od_service};
use super::{
    Action, Context, IoConnection, IoInfo, Received, Stream, StreamId, answer, error, malformed,
};
use crate::proto::enip::assembly::{self, AssemblySet, CmdOffset};
use crate::proto::enip::cip::{GeneralStatus, Path, Reply, UnconnectedSend, class, service};
use crate::proto::enip::cpf::Item;
use crate::proto::enip::encap::{self, Command, Framed, Packet, RrData, Status};
use crate::proto::enip::identity::Identity;
use crate::sim::Drive;

/// The simulated EtherNet/IP adapter, sans IO.
#[derive(Debug)]
pub struct Adapter {
    max_sessions: usize,
    pub(super) io_port: u16,
    pub(super) streams: BTreeMap<StreamId, Stream>,
    next_stream: u64,
    next_session: u32,
    next_connection: u32,
    pub(super) io: Option<IoConnection>,
    /// The drive's restarts seen: one more means every session and connection is gone.
    reboots: u32,
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
            reboots: 0,
        }
    }

    /// Whether the drive is restarting or has restarted since it was last looked at: its
    /// sessions and I/O connection went with the old firmware.
    pub(super) fn restarted(&mut self, drive: &Drive) -> bool {
        if drive.rebooting() || drive.reboots() != self.reboots {
            self.reboots = drive.reboots();
            self.io = None;
            for stream in self.streams.values_mut() {
                stream.session = None;
                stream.class3.clear();
            }
            return true;
        }
        false
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
        if self.restarted(drive) {
            // The TCP connection did not survive the restart.
            self.streams.remove(&stream);
            out.close = true;
            return out;
        }
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
                let context = Context {
                    stream: id,
                    now,
                    sockaddr_to: None,
                    depth: 0,
                };
                Action::reply(self.send_data(packet, context, drive))
            }
            _ => Action::reply(answer(packet, Status::INVALID_COMMAND, vec![])),
        }
    }

    /// SendRRData (unconnected) or SendUnitData (class 3), in a session of the stream.
    fn send_data(&mut self, packet: &Packet, context: Context, drive: &mut Drive) -> Packet {
        let Ok(rr) = RrData::decode(&packet.data) else {
            return answer(packet, Status::INCORRECT_DATA, vec![]);
        };
        let body = if packet.command == Command::SEND_RR_DATA {
            self.rr_data(&rr, context, drive)
        } else {
            self.unit_data(&rr, context, drive)
        };
        match body {
            Some(body) => answer(packet, Status::SUCCESS, body),
            None => answer(packet, Status::INCORRECT_DATA, vec![]),
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

    pub(super) fn new_connection_id(&mut self) -> u32 {
        loop {
            self.next_connection = self.next_connection.wrapping_add(1);
            let candidate = self.next_connection;
            if candidate != 0 && !self.connection_in_use(candidate) {
                return candidate;
            }
        }
    }

    /// The body of a SendRRData reply; `None` when the request is malformed.
    fn rr_data(&mut self, rr: &RrData, context: Context, drive: &mut Drive) -> Option<Vec<u8>> {
        let request = rr.unconnected()?;
        let context = Context {
            sockaddr_to: rr.items.iter().find_map(|i| match i {
                Item::SockaddrTo(s) => Some(*s),
                _ => None,
            }),
            ..context
        };
        let (reply, extra) = self.message(request, context, drive);
        let mut items = vec![Item::Null, Item::UnconnectedData(reply.encode())];
        items.extend(extra);
        Some(RrData::new(0, items).encode())
    }

    /// The body of a SendUnitData reply (class 3); `None` when the request is malformed or
    /// names no connection of its stream.
    fn unit_data(&mut self, rr: &RrData, context: Context, drive: &mut Drive) -> Option<Vec<u8>> {
        let address = rr.items.iter().find_map(|i| match i {
            Item::ConnectedAddress(a) => Some(*a),
            _ => None,
        });
        let data = rr.items.iter().find_map(|i| match i {
            Item::ConnectedData(d) => Some(d.as_slice()),
            _ => None,
        });
        let (Some(address), Some(data)) = (address, data) else {
            return None;
        };
        let stream = self.streams.get(&context.stream)?;
        let connection = stream.class3.iter().find(|c| c.ot == address)?;
        if data.len() < 2 {
            return None;
        }
        let sequence = u16::from_le_bytes([data[0], data[1]]);
        let to = connection.to;
        let payload = match &connection.last {
            // A repeated sequence count: the originator missed the reply, not a new request.
            Some((last, payload)) if *last == sequence => payload.clone(),
            _ => {
                let (reply, _) = self.message(&data[2..], context, drive);
                let mut payload = sequence.to_le_bytes().to_vec();
                payload.extend_from_slice(&reply.encode());
                if let Some(c) = self
                    .streams
                    .get_mut(&context.stream)
                    .and_then(|s| s.class3.iter_mut().find(|c| c.ot == address))
                {
                    c.last = Some((sequence, payload.clone()));
                }
                payload
            }
        };
        let items = [Item::ConnectedAddress(to), Item::ConnectedData(payload)];
        Some(RrData::new(0, items.to_vec()).encode())
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
            class::CONNECTION_MANAGER if instance == Some(1) => {
                self.connection_manager(service, data, context, drive)
            }
            _ => (
                error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN),
                vec![],
            ),
        }
    }

    /// The Connection Manager (instance 1): Forward_Open, Forward_Close and one level of
    /// Unconnected_Send.
    fn connection_manager(
        &mut self,
        service: u8,
        data: &[u8],
        context: Context,
        drive: &mut Drive,
    ) -> (Reply, Vec<Item>) {
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
}
