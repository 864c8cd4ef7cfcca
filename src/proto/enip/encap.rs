//! The encapsulation layer (protocol notes §3.1): a 24-byte header in front of every TCP message
//! and UDP discovery datagram, and the bodies of the commands drivedeck uses.
//!
//! ```text
//! command u16 | length u16 | session handle u32 | status u32 | sender context 8 B | options u32
//! ```

use std::fmt;

use super::cpf::{self, Item};
use super::wire::{DecodeError, Put, Reader};

pub const HEADER_LEN: usize = 24;
/// The explicit-messaging TCP port (and the UDP port of ListIdentity).
pub const TCP_PORT: u16 = 44818;
/// The Class 1 I/O UDP port.
pub const UDP_IO_PORT: u16 = 2222;
/// The largest body drivedeck accepts. CIP explicit messages are at most 504 bytes
/// unconnected (and ~4000 with Large_Forward_Open connections); a header that announces
/// more is not a drive talking.
pub const MAX_BODY: usize = 4096;

/// An encapsulation command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Command(pub u16);

impl Command {
    pub const NOP: Command = Command(0x0000);
    pub const LIST_SERVICES: Command = Command(0x0004);
    pub const LIST_IDENTITY: Command = Command(0x0063);
    pub const LIST_INTERFACES: Command = Command(0x0064);
    pub const REGISTER_SESSION: Command = Command(0x0065);
    pub const UNREGISTER_SESSION: Command = Command(0x0066);
    pub const SEND_RR_DATA: Command = Command(0x006F);
    pub const SEND_UNIT_DATA: Command = Command(0x0070);

    pub fn name(self) -> &'static str {
        match self {
            Command::NOP => "NOP",
            Command::LIST_SERVICES => "ListServices",
            Command::LIST_IDENTITY => "ListIdentity",
            Command::LIST_INTERFACES => "ListInterfaces",
            Command::REGISTER_SESSION => "RegisterSession",
            Command::UNREGISTER_SESSION => "UnRegisterSession",
            Command::SEND_RR_DATA => "SendRRData",
            Command::SEND_UNIT_DATA => "SendUnitData",
            _ => "unknown command",
        }
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({:04X}h)", self.name(), self.0)
    }
}

/// The status field of the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Status(pub u32);

impl Status {
    pub const SUCCESS: Status = Status(0x0000);
    pub const INVALID_COMMAND: Status = Status(0x0001);
    pub const INSUFFICIENT_MEMORY: Status = Status(0x0002);
    pub const INCORRECT_DATA: Status = Status(0x0003);
    pub const INVALID_SESSION: Status = Status(0x0064);
    pub const INVALID_LENGTH: Status = Status(0x0065);
    pub const UNSUPPORTED_PROTOCOL: Status = Status(0x0069);

    pub fn text(self) -> &'static str {
        match self {
            Status::SUCCESS => "success",
            Status::INVALID_COMMAND => "invalid or unsupported encapsulation command",
            Status::INSUFFICIENT_MEMORY => "insufficient memory in the target",
            Status::INCORRECT_DATA => "poorly formed or incorrect data",
            Status::INVALID_SESSION => "invalid session handle",
            Status::INVALID_LENGTH => "invalid length",
            Status::UNSUPPORTED_PROTOCOL => "unsupported encapsulation protocol revision",
            _ => "unknown encapsulation status",
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "encapsulation status {:04X}h ({})", self.0, self.text())
    }
}

/// The 24-byte header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub command: Command,
    /// Bytes after the header.
    pub length: u16,
    pub session: u32,
    pub status: Status,
    /// Echoed by the target; the client matches replies with it.
    pub context: [u8; 8],
    pub options: u32,
}

impl Header {
    pub fn decode(bytes: &[u8]) -> Result<Header, DecodeError> {
        let mut r = Reader::new("encapsulation header", bytes);
        let command = Command(r.u16("command")?);
        let length = r.u16("length")?;
        let session = r.u32("session handle")?;
        let status = Status(r.u32("status")?);
        let mut context = [0u8; 8];
        context.copy_from_slice(r.take(8, "sender context")?);
        let options = r.u32("options")?;
        Ok(Header {
            command,
            length,
            session,
            status,
            context,
            options,
        })
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        out.put_u16(self.command.0);
        out.put_u16(self.length);
        out.put_u32(self.session);
        out.put_u32(self.status.0);
        out.extend_from_slice(&self.context);
        out.put_u32(self.options);
    }
}

/// A whole encapsulation message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Packet {
    pub command: Command,
    pub session: u32,
    pub status: Status,
    pub context: [u8; 8],
    pub options: u32,
    pub data: Vec<u8>,
}

impl Packet {
    pub fn new(command: Command, session: u32, context: [u8; 8], data: Vec<u8>) -> Packet {
        Packet {
            command,
            session,
            status: Status::SUCCESS,
            context,
            options: 0,
            data,
        }
    }

    /// The answer to `request` with the same command, session and context.
    pub fn reply_to(request: &Header, status: Status, data: Vec<u8>) -> Packet {
        Packet {
            command: request.command,
            session: request.session,
            status,
            context: request.context,
            options: 0,
            data,
        }
    }

    pub fn header(&self) -> Header {
        Header {
            command: self.command,
            length: self.data.len().min(usize::from(u16::MAX)) as u16,
            session: self.session,
            status: self.status,
            context: self.context,
            options: self.options,
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + self.data.len());
        self.header().encode_into(&mut out);
        out.extend_from_slice(&self.data);
        out
    }

    /// A request (status and options 0) with `data` written onto `out` (cleared first), as
    /// [`Packet::encode`] writes it, without building the packet: a session sends one per
    /// exchange and keeps the buffer.
    pub fn encode_request_into(
        out: &mut Vec<u8>,
        command: Command,
        session: u32,
        context: [u8; 8],
        data: &[u8],
    ) {
        out.clear();
        Header {
            command,
            length: data.len().min(usize::from(u16::MAX)) as u16,
            session,
            status: Status::SUCCESS,
            context,
            options: 0,
        }
        .encode_into(out);
        out.extend_from_slice(data);
    }

    /// One whole datagram (UDP): the header's length must match what came.
    pub fn decode(bytes: &[u8]) -> Result<Packet, DecodeError> {
        let header = Header::decode(bytes)?;
        let body = &bytes[HEADER_LEN..];
        if body.len() != usize::from(header.length) {
            return Err(DecodeError::invalid(
                "encapsulation message",
                format!(
                    "the header announces {} bytes after it, {} came",
                    header.length,
                    body.len()
                ),
            ));
        }
        Ok(Packet::from_parts(header, body.to_vec()))
    }

    fn from_parts(header: Header, data: Vec<u8>) -> Packet {
        Packet {
            command: header.command,
            session: header.session,
            status: header.status,
            context: header.context,
            options: header.options,
            data,
        }
    }
}

/// What the front of a TCP stream holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Framed {
    /// Not a whole message yet.
    Incomplete,
    /// A whole message and how many bytes it took.
    Packet(Packet, usize),
    /// A header announcing more than [`MAX_BODY`]: the stream cannot be trusted any more.
    TooLong(Header),
}

/// Cut one message off the front of a TCP stream.
pub fn split(buffer: &[u8]) -> Framed {
    let Ok(header) = Header::decode(buffer) else {
        return Framed::Incomplete;
    };
    let length = usize::from(header.length);
    if length > MAX_BODY {
        return Framed::TooLong(header);
    }
    if buffer.len() < HEADER_LEN + length {
        return Framed::Incomplete;
    }
    let data = buffer[HEADER_LEN..HEADER_LEN + length].to_vec();
    Framed::Packet(Packet::from_parts(header, data), HEADER_LEN + length)
}

/// RegisterSession's body: protocol version 1, options 0.
pub fn register_session_data() -> Vec<u8> {
    vec![0x01, 0x00, 0x00, 0x00]
}

/// The protocol version and options of a RegisterSession body.
pub fn decode_register_session(data: &[u8]) -> Result<(u16, u16), DecodeError> {
    let mut r = Reader::new("RegisterSession", data);
    let version = r.u16("protocol version")?;
    let options = r.u16("options flags")?;
    r.end()?;
    Ok((version, options))
}

/// The body of SendRRData and SendUnitData: interface handle, timeout, CPF items.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RrData {
    /// 0 for CIP.
    pub interface: u32,
    /// Seconds the target may take (SendRRData); 0 for SendUnitData.
    pub timeout: u16,
    pub items: Vec<Item>,
}

impl RrData {
    pub fn new(timeout: u16, items: Vec<Item>) -> RrData {
        RrData {
            interface: 0,
            timeout,
            items,
        }
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(64);
        out.put_u32(self.interface);
        out.put_u16(self.timeout);
        cpf::encode(&self.items, &mut out);
        out
    }

    pub fn decode(data: &[u8]) -> Result<RrData, DecodeError> {
        let mut r = Reader::new("SendRRData/SendUnitData", data);
        let interface = r.u32("interface handle")?;
        let timeout = r.u16("timeout")?;
        let items = cpf::decode(r.rest())?;
        Ok(RrData {
            interface,
            timeout,
            items,
        })
    }

    /// The unconnected data item (a Message Router request or reply).
    pub fn unconnected(&self) -> Option<&[u8]> {
        self.items.iter().find_map(|i| match i {
            Item::UnconnectedData(d) => Some(d.as_slice()),
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn register_session_is_28_bytes_and_round_trips() {
        let packet = Packet::new(
            Command::REGISTER_SESSION,
            0,
            *b"drivedk\0",
            register_session_data(),
        );
        let bytes = packet.encode();
        assert_eq!(
            bytes,
            [
                0x65, 0x00, 0x04, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, b'd', b'r', b'i', b'v', b'e', b'd',
                b'k', 0, 0, 0, 0, 0, 0x01, 0x00, 0x00, 0x00
            ]
        );
        assert_eq!(Packet::decode(&bytes), Ok(packet));
        assert_eq!(decode_register_session(&bytes[24..]), Ok((1, 0)));
    }

    #[test]
    fn the_stream_is_cut_into_messages() {
        let a = Packet::new(Command::NOP, 7, [1; 8], vec![9, 9]).encode();
        let b = Packet::new(Command::LIST_IDENTITY, 0, [2; 8], vec![]).encode();
        let mut stream = a.clone();
        stream.extend_from_slice(&b[..10]);
        let Framed::Packet(first, used) = split(&stream) else {
            panic!("first message")
        };
        assert_eq!(
            (first.command, first.data, used),
            (Command::NOP, vec![9, 9], 26)
        );
        assert_eq!(split(&stream[used..]), Framed::Incomplete);
        stream.extend_from_slice(&b[10..]);
        assert!(
            matches!(split(&stream[used..]), Framed::Packet(p, 24) if p.command == Command::LIST_IDENTITY)
        );
        assert_eq!(split(&a[..23]), Framed::Incomplete);
    }

    #[test]
    fn an_overlong_length_is_refused_before_waiting_for_it() {
        let mut bytes = Packet::new(Command::SEND_RR_DATA, 1, [0; 8], vec![]).encode();
        bytes[2..4].copy_from_slice(&0xFFFFu16.to_le_bytes());
        assert!(matches!(split(&bytes), Framed::TooLong(h) if h.length == 0xFFFF));
        // A datagram whose length disagrees with what came is refused by name.
        assert!(
            Packet::decode(&bytes)
                .unwrap_err()
                .to_string()
                .contains("announces 65535 bytes after it, 0 came")
        );
    }

    #[test]
    fn statuses_and_commands_have_names() {
        assert_eq!(
            Status(0x64).to_string(),
            "encapsulation status 0064h (invalid session handle)"
        );
        assert_eq!(Command(0x6F).to_string(), "SendRRData (006Fh)");
        assert_eq!(Command(0x1234).name(), "unknown command");
    }
}
