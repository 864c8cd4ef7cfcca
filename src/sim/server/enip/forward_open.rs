//! Forward_Open and Forward_Close: the checks a connection request passes, in the documented order.

use std::net::{Ipv4Addr, SocketAddrV4};
use std::time::Duration;

use super::adapter::Adapter;
use super::{
    CLASS3_PER_SESSION, Class3, Context, IoConnection, RPI_RANGE_US, StreamId, error, malformed,
};
use crate::proto::enip::assembly::{AssemblySet, CmdOffset};
use crate::proto::enip::cip::{GeneralStatus, Path, Reply, Segment, class, service};
use crate::proto::enip::connection::{
    ConnectionType, ForwardClose, ForwardOpen, ForwardOpenFailure, ForwardOpenReply,
    TRANSPORT_CLASS1_CYCLIC, Triad, encode_forward_close_reply, extended,
};
use crate::proto::enip::cpf::{Item, SockAddr};
use crate::proto::enip::encap;
use crate::proto::enip::identity::NANOTEC_VENDOR;
use crate::proto::enip::io::{RUN_IDLE_LEN, SEQUENCE_COUNT_LEN};

impl Adapter {
    pub(super) fn forward_open(
        &mut self,
        service: u8,
        data: &[u8],
        context: Context,
    ) -> (Reply, Vec<Item>) {
        let large = service == service::LARGE_FORWARD_OPEN;
        let open = match ForwardOpen::decode(large, data) {
            Ok(open) => open,
            Err(e) => return (error(service, malformed(&e)), vec![]),
        };
        match self.open_connection(&open, &context) {
            Ok((reply, items)) => (Reply::success(service, reply.encode()), items),
            Err(refused) => (refused.reply(service, open.triad()), vec![]),
        }
    }

    /// Checks 1 to 7 of the module documentation, then the connection.
    fn open_connection(
        &mut self,
        open: &ForwardOpen,
        context: &Context,
    ) -> Result<(ForwardOpenReply, Vec<Item>), Refused> {
        let class1 = open.transport == TRANSPORT_CLASS1_CYCLIC;
        let class3 = open.transport & 0x0F == 3;
        if !class1 && !class3 {
            return Err(Refused::new(extended::TRANSPORT_NOT_SUPPORTED));
        }
        let target = Target::of(&open.path)?;
        if !self.streams.contains_key(&context.stream) {
            return Err(Refused::new(extended::OUT_OF_CONNECTIONS));
        }
        if class3 {
            self.open_class3(open, &target, context.stream)
                .map(|reply| (reply, vec![]))
        } else {
            self.open_class1(open, target, context)
        }
    }

    /// Check 3: a class 3 connection to the Message Router, a few per session.
    fn open_class3(
        &mut self,
        open: &ForwardOpen,
        target: &Target,
        stream: StreamId,
    ) -> Result<ForwardOpenReply, Refused> {
        if target.class != Some(class::MESSAGE_ROUTER) || target.instances.first() != Some(&1) {
            return Err(Refused::new(extended::INVALID_CONNECTION_POINT));
        }
        let open_here = self.streams.get(&stream).map_or(&[][..], |s| &s.class3[..]);
        if open_here.iter().any(|c| c.triad == open.triad()) {
            return Err(Refused::new(extended::CONNECTION_IN_USE));
        }
        if open_here.len() >= CLASS3_PER_SESSION {
            return Err(Refused::new(extended::OUT_OF_CONNECTIONS));
        }
        let ot = self.new_connection_id();
        let to = match open.to_connection {
            0 => self.new_connection_id(),
            to => to,
        };
        if let Some(stream) = self.streams.get_mut(&stream) {
            stream.class3.push(Class3 {
                ot,
                to,
                triad: open.triad(),
                last: None,
            });
        }
        Ok(granted(open, ot, to))
    }

    /// Checks 4 to 7: the class 1 I/O connection, one at a time.
    fn open_class1(
        &mut self,
        open: &ForwardOpen,
        target: Target,
        context: &Context,
    ) -> Result<(ForwardOpenReply, Vec<Item>), Refused> {
        let set = self.class1_set(open, target)?;
        let format = IoFormat::of(open, set)?;
        let Some(stream) = self.streams.get(&context.stream) else {
            return Err(Refused::new(extended::OUT_OF_CONNECTIONS));
        };
        let (peer_ip, local_ip) = (*stream.peer.ip(), *stream.local.ip());
        let ot_id = self.new_connection_id();
        let to_id = match open.to_connection {
            0 => self.new_connection_id(),
            to => to,
        };
        self.io = Some(IoConnection {
            set,
            cmd: format.cmd,
            triad: open.triad(),
            ot_id,
            to_id,
            ot_header: format.ot_header,
            to_header: format.to_header,
            to_rpi: Duration::from_micros(u64::from(open.to_rpi_us)),
            ot_timeout: open.ot_timeout(),
            originator: peer_ip,
            target: t_to_o_destination(context.sockaddr_to, peer_ip),
            opened: context.now,
            last_ot: None,
            last_sequence: None,
            received: 0,
            next_send: context.now,
            sequence: 0,
            count: 0,
        });
        let ot_socket = SockAddr::new(SocketAddrV4::new(local_ip, self.io_port));
        Ok((
            granted(open, ot_id, to_id),
            vec![Item::SockaddrOt(ot_socket)],
        ))
    }

    /// The assembly set a class 1 Forward_Open asks for, if this adapter can open it now:
    /// a known set, no other I/O connection, an RPI in range, point-to-point O→T and
    /// point-to-point or multicast T→O.
    fn class1_set(&self, open: &ForwardOpen, target: Target) -> Result<AssemblySet, Refused> {
        let set = target
            .assembly_set()
            .ok_or(Refused::new(extended::INVALID_CONNECTION_POINT))?;
        if let Some(io) = &self.io {
            return Err(Refused::new(if io.triad == open.triad() {
                extended::CONNECTION_IN_USE
            } else {
                extended::OWNERSHIP_CONFLICT
            }));
        }
        if !RPI_RANGE_US.contains(&open.ot_rpi_us) || !RPI_RANGE_US.contains(&open.to_rpi_us) {
            return Err(Refused::new(extended::RPI_NOT_SUPPORTED));
        }
        let usable = |kind: ConnectionType, multicast: bool| {
            kind == ConnectionType::PointToPoint || (multicast && kind == ConnectionType::Multicast)
        };
        if !usable(open.ot_params.kind, false) || !usable(open.to_params.kind, true) {
            return Err(Refused::new(extended::INVALID_CONNECTION_TYPE));
        }
        Ok(set)
    }

    pub(super) fn forward_close(&mut self, data: &[u8], context: Context) -> Reply {
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
}

/// A Forward_Open refused: general status 01h with this extended status (and, for a size,
/// the size expected).
#[derive(Clone, Copy, Debug)]
pub(super) struct Refused {
    code: u16,
    expected: Option<u16>,
}

impl Refused {
    fn new(code: u16) -> Refused {
        Refused {
            code,
            expected: None,
        }
    }

    fn reply(self, service: u8, triad: Triad) -> Reply {
        let mut additional = vec![self.code];
        additional.extend(self.expected);
        Reply {
            service: service | service::REPLY,
            status: GeneralStatus::CONNECTION_FAILURE,
            additional,
            data: ForwardOpenFailure {
                triad,
                remaining_path: 0,
            }
            .encode(),
        }
    }
}

/// What a connection path names (check 2): the class, instances and connection points.
#[derive(Debug, Default)]
pub(super) struct Target {
    class: Option<u16>,
    instances: Vec<u16>,
    points: Vec<u16>,
}

impl Target {
    fn of(path: &[u8]) -> Result<Target, Refused> {
        let path = Path::decode(path).map_err(|_| Refused::new(extended::INVALID_SEGMENT))?;
        let mut target = Target::default();
        for segment in &path.0 {
            match segment {
                Segment::ElectronicKey(key) => {
                    let vendor = u16::from_le_bytes([key[0], key[1]]);
                    if vendor != 0 && vendor != NANOTEC_VENDOR {
                        return Err(Refused::new(extended::VENDOR_OR_PRODUCT_MISMATCH));
                    }
                }
                Segment::Class(c) => {
                    target.class.get_or_insert(*c);
                }
                Segment::Instance(i) => target.instances.push(*i),
                Segment::ConnectionPoint(p) => target.points.push(*p),
                // Routes end here; configuration data has nowhere to go.
                Segment::Port { .. } | Segment::Data(_) => {}
                Segment::Attribute(_) | Segment::Member(_) => {
                    return Err(Refused::new(extended::INVALID_SEGMENT));
                }
            }
        }
        Ok(target)
    }

    /// Check 4: the assembly pair O→T, T→O. Some originators give the connection points
    /// as instance segments (configuration, O→T, T→O).
    fn assembly_set(&self) -> Option<AssemblySet> {
        let points = if self.points.is_empty() && self.instances.len() == 3 {
            &self.instances[1..]
        } else {
            &self.points[..]
        };
        match (self.class, points) {
            (Some(class::ASSEMBLY), [ot, to]) => AssemblySet::from_points(*ot, *to),
            _ => None,
        }
    }
}

/// Check 7: where PDI-Cmd sits and which data carry a run/idle header.
#[derive(Clone, Copy, Debug)]
pub(super) struct IoFormat {
    cmd: CmdOffset,
    ot_header: bool,
    to_header: bool,
}

impl IoFormat {
    fn of(open: &ForwardOpen, set: AssemblySet) -> Result<IoFormat, Refused> {
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
            return Err(Refused {
                code: extended::INVALID_OT_SIZE,
                expected: Some(set.ot_len(CmdOffset::Seven) as u16 + header),
            });
        };
        let to_len = set.to_len() as u16;
        let to_header = if open.to_params.size == to_len + modeless {
            false
        } else if open.to_params.size == to_len + header {
            true
        } else {
            return Err(Refused {
                code: extended::INVALID_TO_SIZE,
                expected: Some(to_len + modeless),
            });
        };
        Ok(IoFormat {
            cmd,
            ot_header,
            to_header,
        })
    }
}

/// Where T→O datagrams go: a sockaddr T→O item of the request (0.0.0.0 = the TCP peer,
/// port 0 = 2222), else the TCP peer on port 2222.
fn t_to_o_destination(sockaddr_to: Option<SockAddr>, peer_ip: Ipv4Addr) -> SocketAddrV4 {
    match sockaddr_to {
        Some(s) => SocketAddrV4::new(
            if s.ip.is_unspecified() { peer_ip } else { s.ip },
            if s.port == 0 {
                encap::UDP_IO_PORT
            } else {
                s.port
            },
        ),
        None => SocketAddrV4::new(peer_ip, encap::UDP_IO_PORT),
    }
}

/// The reply of a granted Forward_Open: the RPIs become the APIs.
fn granted(open: &ForwardOpen, ot: u32, to: u32) -> ForwardOpenReply {
    ForwardOpenReply {
        ot_connection: ot,
        to_connection: to,
        triad: open.triad(),
        ot_api_us: open.ot_rpi_us,
        to_api_us: open.to_rpi_us,
        application: vec![],
    }
}
