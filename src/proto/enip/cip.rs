//! CIP messages (protocol notes §3.3, §3.6): general status codes, EPATHs of logical segments, and
//! the Message Router request and reply.
//!
//! ```text
//! request: service u8 | path size u8 (words) | EPATH | data
//! reply:   service|80h | 00 | general status u8 | additional size u8 (words) | [u16…] | data
//! ```

use std::fmt;

use super::wire::{DecodeError, Put, Reader, hex};

/// Service codes drivedeck sends or serves.
pub mod service {
    pub const GET_ATTRIBUTES_ALL: u8 = 0x01;
    pub const MULTIPLE_SERVICE_PACKET: u8 = 0x0A;
    pub const GET_ATTRIBUTE_SINGLE: u8 = 0x0E;
    pub const SET_ATTRIBUTE_SINGLE: u8 = 0x10;
    /// Nanotec: read an object dictionary entry (class 64h).
    pub const GET_OD: u8 = 0x32;
    /// Nanotec: write an object dictionary entry (class 64h).
    pub const SET_OD: u8 = 0x33;
    /// Nanotec: read with type and length in front ("Rockwell").
    pub const GET_OD_ROCKWELL: u8 = 0x34;
    pub const FORWARD_CLOSE: u8 = 0x4E;
    pub const UNCONNECTED_SEND: u8 = 0x52;
    pub const FORWARD_OPEN: u8 = 0x54;
    pub const LARGE_FORWARD_OPEN: u8 = 0x5B;
    /// Set in the service byte of every reply.
    pub const REPLY: u8 = 0x80;

    pub fn name(code: u8) -> &'static str {
        match code & !REPLY {
            GET_ATTRIBUTES_ALL => "Get_Attributes_All",
            MULTIPLE_SERVICE_PACKET => "Multiple_Service_Packet",
            GET_ATTRIBUTE_SINGLE => "Get_Attribute_Single",
            SET_ATTRIBUTE_SINGLE => "Set_Attribute_Single",
            GET_OD => "GetOD",
            SET_OD => "SetOD",
            GET_OD_ROCKWELL => "GetOD Rockwell",
            FORWARD_CLOSE => "Forward_Close",
            UNCONNECTED_SEND => "Unconnected_Send",
            FORWARD_OPEN => "Forward_Open",
            LARGE_FORWARD_OPEN => "Large_Forward_Open",
            _ => "service",
        }
    }
}

/// Classes drivedeck addresses or serves.
pub mod class {
    pub const IDENTITY: u16 = 0x01;
    pub const MESSAGE_ROUTER: u16 = 0x02;
    pub const ASSEMBLY: u16 = 0x04;
    pub const CONNECTION_MANAGER: u16 = 0x06;
    /// Nanotec's object dictionary bridge.
    pub const NANOTEC_OD: u16 = 0x64;
    pub const TCP_IP: u16 = 0xF5;
    pub const ETHERNET_LINK: u16 = 0xF6;
}

/// A CIP general status (protocol notes §3.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GeneralStatus(pub u8);

impl GeneralStatus {
    pub const SUCCESS: GeneralStatus = GeneralStatus(0x00);
    pub const CONNECTION_FAILURE: GeneralStatus = GeneralStatus(0x01);
    pub const RESOURCE_UNAVAILABLE: GeneralStatus = GeneralStatus(0x02);
    pub const INVALID_PARAMETER_VALUE: GeneralStatus = GeneralStatus(0x03);
    pub const PATH_SEGMENT_ERROR: GeneralStatus = GeneralStatus(0x04);
    pub const PATH_DESTINATION_UNKNOWN: GeneralStatus = GeneralStatus(0x05);
    pub const SERVICE_NOT_SUPPORTED: GeneralStatus = GeneralStatus(0x08);
    pub const INVALID_ATTRIBUTE_VALUE: GeneralStatus = GeneralStatus(0x09);
    pub const ATTRIBUTE_NOT_SETTABLE: GeneralStatus = GeneralStatus(0x0E);
    pub const DEVICE_STATE_CONFLICT: GeneralStatus = GeneralStatus(0x10);
    pub const REPLY_TOO_LARGE: GeneralStatus = GeneralStatus(0x11);
    pub const NOT_ENOUGH_DATA: GeneralStatus = GeneralStatus(0x13);
    pub const ATTRIBUTE_NOT_SUPPORTED: GeneralStatus = GeneralStatus(0x14);
    pub const TOO_MUCH_DATA: GeneralStatus = GeneralStatus(0x15);
    pub const OBJECT_DOES_NOT_EXIST: GeneralStatus = GeneralStatus(0x16);
    pub const INVALID_PARAMETER: GeneralStatus = GeneralStatus(0x20);
    pub const PATH_SIZE_INVALID: GeneralStatus = GeneralStatus(0x26);
    pub const ATTRIBUTE_NOT_GETTABLE: GeneralStatus = GeneralStatus(0x2C);

    pub fn is_success(self) -> bool {
        self.0 == 0
    }

    pub fn text(self) -> &'static str {
        match self.0 {
            0x00 => "success",
            0x01 => "connection failure",
            0x02 => "resource unavailable",
            0x03 => "invalid parameter value",
            0x04 => "path segment error",
            0x05 => "path destination unknown",
            0x06 => "partial transfer",
            0x07 => "connection lost",
            0x08 => "service not supported",
            0x09 => "invalid attribute value",
            0x0A => "attribute list error",
            0x0B => "already in requested mode/state",
            0x0C => "object state conflict",
            0x0D => "object already exists",
            0x0E => "attribute not settable",
            0x0F => "privilege violation",
            0x10 => "device state conflict",
            0x11 => "reply data too large",
            0x12 => "fragmentation of a primitive value",
            0x13 => "not enough data",
            0x14 => "attribute not supported",
            0x15 => "too much data",
            0x16 => "object does not exist",
            0x17 => "service fragmentation sequence not in progress",
            0x18 => "no stored attribute data",
            0x19 => "store operation failure",
            0x1A => "routing failure, request packet too large",
            0x1B => "routing failure, response packet too large",
            0x1C => "missing attribute list entry data",
            0x1D => "invalid attribute value list",
            0x1E => "embedded service error",
            0x1F => "vendor specific error",
            0x20 => "invalid parameter",
            0x21 => "write-once value or medium already written",
            0x22 => "invalid reply received",
            0x25 => "key failure in path",
            0x26 => "path size invalid",
            0x27 => "unexpected attribute in list",
            0x28 => "invalid member ID",
            0x29 => "member not settable",
            0x2C => "attribute not gettable",
            0x2E => "service not supported for specified path",
            _ => "unknown general status",
        }
    }
}

impl fmt::Display for GeneralStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CIP status {:02X}h ({})", self.0, self.text())
    }
}

/// One segment of an EPATH.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Segment {
    Class(u16),
    Instance(u16),
    Attribute(u16),
    /// An assembly's connection point in a Forward_Open path.
    ConnectionPoint(u16),
    Member(u16),
    /// A route hop: port and link address (Unconnected_Send route paths).
    Port {
        port: u16,
        link: Vec<u8>,
    },
    /// The electronic key (format 4): vendor, device type, product code, revision.
    ElectronicKey([u8; 8]),
    /// A simple data segment (words).
    Data(Vec<u8>),
}

/// An EPATH (padded logical segments).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Path(pub Vec<Segment>);

impl Path {
    /// Class / instance.
    pub fn object(class: u16, instance: u16) -> Path {
        Path(vec![Segment::Class(class), Segment::Instance(instance)])
    }

    /// Class / instance / attribute.
    pub fn attribute(class: u16, instance: u16, attribute: u16) -> Path {
        Path(vec![
            Segment::Class(class),
            Segment::Instance(instance),
            Segment::Attribute(attribute),
        ])
    }

    fn first(&self, pick: impl Fn(&Segment) -> Option<u16>) -> Option<u16> {
        self.0.iter().find_map(pick)
    }

    pub fn class(&self) -> Option<u16> {
        self.first(|s| match s {
            Segment::Class(c) => Some(*c),
            _ => None,
        })
    }

    pub fn instance(&self) -> Option<u16> {
        self.first(|s| match s {
            Segment::Instance(c) => Some(*c),
            _ => None,
        })
    }

    pub fn attribute_id(&self) -> Option<u16> {
        self.first(|s| match s {
            Segment::Attribute(c) => Some(*c),
            _ => None,
        })
    }

    /// The connection points in order (Forward_Open: consumed O→T, then produced T→O).
    pub fn connection_points(&self) -> Vec<u16> {
        self.0
            .iter()
            .filter_map(|s| match s {
                Segment::ConnectionPoint(p) => Some(*p),
                _ => None,
            })
            .collect()
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(8);
        for segment in &self.0 {
            let logical = |out: &mut Vec<u8>, kind: u8, value: u16| {
                if value <= 0xFF {
                    out.push(kind);
                    out.push(value as u8);
                } else {
                    out.push(kind | 1);
                    out.push(0);
                    out.put_u16(value);
                }
            };
            match segment {
                Segment::Class(v) => logical(&mut out, 0x20, *v),
                Segment::Instance(v) => logical(&mut out, 0x24, *v),
                Segment::Member(v) => logical(&mut out, 0x28, *v),
                Segment::ConnectionPoint(v) => logical(&mut out, 0x2C, *v),
                Segment::Attribute(v) => logical(&mut out, 0x30, *v),
                Segment::ElectronicKey(key) => {
                    out.extend_from_slice(&[0x34, 0x04]);
                    out.extend_from_slice(key);
                }
                Segment::Port { port, link } => {
                    let small = *port < 15;
                    let extended = link.len() > 1;
                    let mut first = if small { *port as u8 } else { 0x0F };
                    if extended {
                        first |= 0x10;
                    }
                    out.push(first);
                    if extended {
                        out.push(link.len() as u8);
                    }
                    if !small {
                        out.put_u16(*port);
                    }
                    out.extend_from_slice(link);
                    if out.len() % 2 == 1 {
                        out.push(0);
                    }
                }
                Segment::Data(words) => {
                    out.push(0x80);
                    out.push((words.len() / 2) as u8);
                    out.extend_from_slice(words);
                    if words.len() % 2 == 1 {
                        out.push(0);
                    }
                }
            }
        }
        out
    }

    /// Decode padded EPATH bytes (the whole slice is the path).
    pub fn decode(bytes: &[u8]) -> Result<Path, DecodeError> {
        let mut r = Reader::new("EPATH", bytes);
        let mut segments = Vec::new();
        while r.remaining() > 0 {
            let kind = r.u8("segment type")?;
            let segment = match kind {
                0x20..=0x22 => Segment::Class(logical(&mut r, kind)?),
                0x24..=0x26 => Segment::Instance(logical(&mut r, kind)?),
                0x28..=0x2A => Segment::Member(logical(&mut r, kind)?),
                0x2C..=0x2E => Segment::ConnectionPoint(logical(&mut r, kind)?),
                0x30..=0x32 => Segment::Attribute(logical(&mut r, kind)?),
                0x34 => {
                    let format = r.u8("key format")?;
                    if format != 4 {
                        return Err(DecodeError::invalid(
                            "EPATH",
                            format!("electronic key format {format} (only 4 exists)"),
                        ));
                    }
                    let mut key = [0u8; 8];
                    key.copy_from_slice(r.take(8, "electronic key")?);
                    Segment::ElectronicKey(key)
                }
                0x00..=0x1F => port_segment(&mut r, kind)?,
                0x80 => {
                    let words = usize::from(r.u8("data size")?);
                    Segment::Data(r.take(words * 2, "data words")?.to_vec())
                }
                other => {
                    return Err(DecodeError::invalid(
                        "EPATH",
                        format!("segment type {other:02X}h is not supported"),
                    ));
                }
            };
            segments.push(segment);
        }
        Ok(Path(segments))
    }
}

/// The value of a logical segment of type `kind`: 8 or 16 bits (after a pad byte).
fn logical(r: &mut Reader<'_>, kind: u8) -> Result<u16, DecodeError> {
    match kind & 0x03 {
        0 => Ok(u16::from(r.u8("8-bit logical value")?)),
        1 => {
            r.u8("pad byte")?;
            r.u16("16-bit logical value")
        }
        _ => Err(DecodeError::invalid(
            "EPATH",
            format!("logical segment {kind:02X}h: 32-bit values are not supported"),
        )),
    }
}

/// A port segment of type `kind` (already read): the port, extended or not, and the
/// link address, padded to an even length.
fn port_segment(r: &mut Reader<'_>, kind: u8) -> Result<Segment, DecodeError> {
    let start = r.position() - 1;
    let link_size = if kind & 0x10 != 0 {
        usize::from(r.u8("link address size")?)
    } else {
        1
    };
    let port = if kind & 0x0F == 0x0F {
        r.u16("extended port")?
    } else {
        u16::from(kind & 0x0F)
    };
    let link = r.take(link_size, "link address")?.to_vec();
    if (r.position() - start) % 2 == 1 {
        r.u8("pad byte")?;
    }
    Ok(Segment::Port { port, link })
}

impl fmt::Display for Path {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = self
            .0
            .iter()
            .map(|s| match s {
                Segment::Class(v) => format!("class {v:X}h"),
                Segment::Instance(v) => format!("instance {v}"),
                Segment::Attribute(v) => format!("attribute {v}"),
                Segment::ConnectionPoint(v) => format!("connection point {v}"),
                Segment::Member(v) => format!("member {v}"),
                Segment::Port { port, link } => format!("port {port} link {}", hex(link)),
                Segment::ElectronicKey(_) => "electronic key".into(),
                Segment::Data(d) => format!("data {}", hex(d)),
            })
            .collect();
        f.write_str(&parts.join(" / "))
    }
}

/// A Message Router request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    pub service: u8,
    /// The padded EPATH bytes (an even count).
    pub path: Vec<u8>,
    pub data: Vec<u8>,
}

impl Request {
    pub fn new(service: u8, path: &Path, data: Vec<u8>) -> Request {
        Request {
            service,
            path: path.encode(),
            data,
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(2 + self.path.len() + self.data.len());
        out.put_u8(self.service);
        out.put_u8((self.path.len() / 2) as u8);
        out.extend_from_slice(&self.path);
        out.extend_from_slice(&self.data);
        out
    }

    pub fn decode(bytes: &[u8]) -> Result<Request, DecodeError> {
        let mut r = Reader::new("Message Router request", bytes);
        let service = r.u8("service")?;
        if service & service::REPLY != 0 {
            return Err(DecodeError::invalid(
                "Message Router request",
                format!("service {service:02X}h has the reply bit set"),
            ));
        }
        let words = usize::from(r.u8("path size")?);
        let path = r.take(words * 2, "path")?.to_vec();
        let data = r.rest().to_vec();
        Ok(Request {
            service,
            path,
            data,
        })
    }

    pub fn path(&self) -> Result<Path, DecodeError> {
        Path::decode(&self.path)
    }
}

/// A Message Router reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reply {
    /// The request's service with the reply bit (80h) set.
    pub service: u8,
    pub status: GeneralStatus,
    pub additional: Vec<u16>,
    pub data: Vec<u8>,
}

impl Reply {
    pub fn success(request_service: u8, data: Vec<u8>) -> Reply {
        Reply {
            service: request_service | service::REPLY,
            status: GeneralStatus::SUCCESS,
            additional: vec![],
            data,
        }
    }

    pub fn error(request_service: u8, status: GeneralStatus, additional: Vec<u16>) -> Reply {
        Reply {
            service: request_service | service::REPLY,
            status,
            additional,
            data: vec![],
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(4 + 2 * self.additional.len() + self.data.len());
        out.put_u8(self.service);
        out.put_u8(0);
        out.put_u8(self.status.0);
        out.put_u8(self.additional.len() as u8);
        for word in &self.additional {
            out.put_u16(*word);
        }
        out.extend_from_slice(&self.data);
        out
    }

    pub fn decode(bytes: &[u8]) -> Result<Reply, DecodeError> {
        let mut r = Reader::new("Message Router reply", bytes);
        let service = r.u8("service")?;
        if service & service::REPLY == 0 {
            return Err(DecodeError::invalid(
                "Message Router reply",
                format!("service {service:02X}h lacks the reply bit"),
            ));
        }
        r.u8("reserved")?;
        let status = GeneralStatus(r.u8("general status")?);
        let words = r.u8("additional status size")?;
        let mut additional = Vec::with_capacity(usize::from(words));
        for _ in 0..words {
            additional.push(r.u16("additional status")?);
        }
        Ok(Reply {
            service,
            status,
            additional,
            data: r.rest().to_vec(),
        })
    }

    /// The reply to `request_service`, or an error naming what came instead.
    pub fn expect(self, request_service: u8) -> Result<Reply, DecodeError> {
        if self.service != request_service | service::REPLY {
            return Err(DecodeError::invalid(
                "Message Router reply",
                format!(
                    "reply to service {:02X}h where {:02X}h ({}) was asked",
                    self.service & !service::REPLY,
                    request_service,
                    service::name(request_service)
                ),
            ));
        }
        Ok(self)
    }

    /// The status with its additional words, for messages: `CIP status 01h (connection
    /// failure), extended 0100h`.
    pub fn status_text(&self) -> String {
        let mut text = self.status.to_string();
        if let Some(first) = self.additional.first() {
            text.push_str(&format!(", extended status {first:04X}h"));
            if self.status == GeneralStatus::CONNECTION_FAILURE {
                text.push_str(&format!(
                    " ({})",
                    super::connection::extended_status_text(*first)
                ));
            }
        }
        text
    }
}

/// The request inside an Unconnected_Send (52h) to the Connection Manager, which some
/// clients (rseip, pycomm3 with a route path) wrap around every explicit message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnconnectedSend {
    pub tick: u8,
    pub timeout_ticks: u8,
    pub request: Vec<u8>,
    pub route: Vec<u8>,
}

impl UnconnectedSend {
    pub fn decode(data: &[u8]) -> Result<UnconnectedSend, DecodeError> {
        let mut r = Reader::new("Unconnected_Send", data);
        let tick = r.u8("priority/time tick")?;
        let timeout_ticks = r.u8("timeout ticks")?;
        let size = usize::from(r.u16("message request size")?);
        let request = r.take(size, "message request")?.to_vec();
        if size % 2 == 1 {
            r.u8("pad byte")?;
        }
        let words = usize::from(r.u8("route path size")?);
        r.u8("reserved")?;
        let route = r.take(words * 2, "route path")?.to_vec();
        Ok(UnconnectedSend {
            tick,
            timeout_ticks,
            request,
            route,
        })
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(8 + self.request.len() + self.route.len());
        out.put_u8(self.tick);
        out.put_u8(self.timeout_ticks);
        out.put_u16(self.request.len() as u16);
        out.extend_from_slice(&self.request);
        if self.request.len() % 2 == 1 {
            out.put_u8(0);
        }
        out.put_u8((self.route.len() / 2) as u8);
        out.put_u8(0);
        out.extend_from_slice(&self.route);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logical_segments_in_8_and_16_bits() {
        let path = Path(vec![
            Segment::Class(0x64),
            Segment::Instance(1),
            Segment::Attribute(0x1234),
        ]);
        let bytes = path.encode();
        assert_eq!(bytes, [0x20, 0x64, 0x24, 0x01, 0x31, 0x00, 0x34, 0x12]);
        assert_eq!(Path::decode(&bytes), Ok(path));
        assert_eq!(
            Path::decode(&[0x20, 0x04, 0x24, 0x64, 0x2C, 0x69, 0x2C, 0x68])
                .unwrap()
                .connection_points(),
            [0x69, 0x68]
        );
    }

    #[test]
    fn port_and_key_segments() {
        // Backplane, slot 0: the route pycomm3 and rseip put behind Unconnected_Send.
        let route = Path(vec![Segment::Port {
            port: 1,
            link: vec![0],
        }]);
        assert_eq!(route.encode(), [0x01, 0x00]);
        assert_eq!(Path::decode(&[0x01, 0x00]), Ok(route));
        // An extended link address (an IP) is padded to a word.
        let ip = Path(vec![Segment::Port {
            port: 2,
            link: b"10.0.0.1".to_vec(),
        }]);
        let bytes = ip.encode();
        assert_eq!(&bytes[..2], &[0x12, 0x08]);
        assert_eq!(bytes.len(), 10);
        assert_eq!(Path::decode(&bytes), Ok(ip));
        let key = Path(vec![Segment::ElectronicKey([0x6C, 0x02, 0, 0, 0, 0, 1, 0])]);
        assert_eq!(Path::decode(&key.encode()), Ok(key));
        assert!(Path::decode(&[0x34, 0x05, 0, 0, 0, 0, 0, 0, 0, 0]).is_err());
        assert!(Path::decode(&[0x20]).is_err());
        assert!(
            Path::decode(&[0x23, 0, 0, 0, 0, 0]).is_err(),
            "32-bit class"
        );
        assert!(Path::decode(&[0x60, 0]).is_err(), "network segment");
    }

    #[test]
    fn request_and_reply_framing() {
        let request = Request::new(0x0E, &Path::attribute(1, 1, 7), vec![]);
        assert_eq!(
            request.encode(),
            [0x0E, 0x03, 0x20, 0x01, 0x24, 0x01, 0x30, 0x07]
        );
        assert_eq!(Request::decode(&request.encode()), Ok(request));
        assert!(Request::decode(&[0x0E, 0x05, 0x20]).is_err());
        assert!(Request::decode(&[0x8E, 0x00]).is_err());

        let reply = Reply::decode(&[0xD4, 0x00, 0x01, 0x01, 0x00, 0x01]).unwrap();
        assert_eq!(reply.status, GeneralStatus::CONNECTION_FAILURE);
        assert_eq!(reply.additional, [0x0100]);
        assert_eq!(
            reply.status_text(),
            "CIP status 01h (connection failure), extended status 0100h (connection in use or duplicate Forward_Open)"
        );
        assert_eq!(Reply::decode(&reply.encode()), Ok(reply.clone()));
        assert!(reply.clone().expect(0x54).is_ok());
        assert!(
            reply
                .expect(0x4E)
                .unwrap_err()
                .to_string()
                .contains("reply to service 54h where 4Eh (Forward_Close) was asked")
        );
        assert!(Reply::decode(&[0x32, 0, 0, 0]).is_err(), "no reply bit");
        assert!(Reply::decode(&[0xB2, 0, 0x05, 0x02, 0x00]).is_err());
    }

    #[test]
    fn unconnected_send_round_trips_with_its_pad_byte() {
        let wrapped = UnconnectedSend {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            request: vec![0x32, 0x02, 0x20, 0x64, 0x24, 0x01, 0x14, 0x20, 0x00],
            route: vec![0x01, 0x00],
        };
        let bytes = wrapped.encode();
        assert_eq!(bytes.len(), 4 + 9 + 1 + 2 + 2);
        assert_eq!(UnconnectedSend::decode(&bytes), Ok(wrapped));
    }

    #[test]
    fn every_documented_status_has_text() {
        for code in [
            0x00u8, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B, 0x0C, 0x0D,
            0x0E, 0x0F, 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16, 0x19, 0x1E, 0x1F, 0x20, 0x26,
            0x2C, 0x2E,
        ] {
            assert_ne!(
                GeneralStatus(code).text(),
                "unknown general status",
                "{code:02X}"
            );
        }
        assert_eq!(
            GeneralStatus(0x05).to_string(),
            "CIP status 05h (path destination unknown)"
        );
    }
}
