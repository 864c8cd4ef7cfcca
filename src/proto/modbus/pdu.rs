//! Modbus PDUs: the function code and its data, without slave address, CRC or MBAP header
//! (those belong to [`super::frame`]). Sans-IO: bytes in, values out, nothing else.
//!
//! Byte order (NT-GEN, protocol notes §1.1): everything is big-endian except the CANopen
//! *data values* carried by FC 43, 101 and 102, which are little-endian. This module only
//! carries those data bytes; it never interprets an object value. FC 101 frames are the one
//! place where this module reads little-endian fields itself (index low byte first,
//! NT-FC101).
//!
//! Every decoder is total: any byte slice gives a value or a [`PduError`], never a panic.
//! A device's refusal is data ([`Exception`]), a malformed answer is an error ([`PduError`]),
//! hence [`Response::decode`] returns `Result<Result<Response, Exception>, PduError>`.

use std::fmt;

use crate::cia::AbortCode;

/// Function codes drivedeck speaks (protocol notes §1.4).
pub mod fc {
    pub const READ_HOLDING: u8 = 0x03;
    pub const READ_INPUT: u8 = 0x04;
    pub const WRITE_SINGLE: u8 = 0x06;
    pub const WRITE_MULTIPLE: u8 = 0x10;
    pub const READ_WRITE: u8 = 0x17;
    /// Encapsulated Interface Transport; with MEI 0Dh the CANopen general reference.
    pub const ENCAPSULATED: u8 = 0x2B;
    /// Nanotec: read the complete object dictionary (FC 101, NT-FC101).
    pub const READ_DICTIONARY: u8 = 0x65;
    /// Nanotec: read a complete array or record (FC 102, NT-FC101).
    pub const READ_ARRAY: u8 = 0x66;
}

/// MEI type of the CANopen general reference (CiA 309-2), FC 43/13.
pub const MEI_CANOPEN: u8 = 0x0D;
/// MEI type of Read Device Identification, FC 43/14. Not documented for Nanotec drives
/// (protocol notes §5.19): decoded as [`Request::Other`] so a server can refuse it.
pub const MEI_DEVICE_ID: u8 = 0x0E;

/// The longest PDU the Modbus spec allows: a 256-byte serial ADU minus address and CRC
/// (Modbus Application Protocol V1.1b3 §4.1).
pub const MAX_PDU: usize = 253;

/// Quantity limits of the Modbus Application Protocol V1.1b3 (§6.3, §6.4, §6.12, §6.17).
pub mod limits {
    /// FC 3, FC 4 and the read part of FC 23: 1..=125 registers (7Dh, also NT-FC).
    pub const READ_MAX: u16 = 125;
    /// FC 16: 1..=123 registers (7Bh).
    pub const WRITE_MULTIPLE_MAX: u16 = 123;
    /// The write part of FC 23: 1..=121 registers (79h).
    pub const READ_WRITE_WRITE_MAX: u16 = 121;
}

/// Standard exception codes (Modbus Application Protocol V1.1b3 §7) and Nanotec's
/// extended-exception marker (protocol notes §1.5).
pub mod exception {
    pub const ILLEGAL_FUNCTION: u8 = 0x01;
    pub const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
    pub const ILLEGAL_DATA_VALUE: u8 = 0x03;
    pub const SERVER_DEVICE_FAILURE: u8 = 0x04;
    pub const ACKNOWLEDGE: u8 = 0x05;
    pub const SERVER_DEVICE_BUSY: u8 = 0x06;
    pub const MEMORY_PARITY_ERROR: u8 = 0x08;
    pub const GATEWAY_PATH_UNAVAILABLE: u8 = 0x0A;
    pub const GATEWAY_TARGET_NO_RESPONSE: u8 = 0x0B;
    /// Second byte of Nanotec's extended exception (FC 43/101/102).
    pub const EXTENDED: u8 = 0xFF;
    /// The exception code inside the extended exception, after MEI 0Dh.
    pub const CANOPEN_ERROR: u8 = 0xCE;
}

/// FC 101 sub-function: start over at object 0000h (NT-FC101).
pub const DICTIONARY_RESTART: u8 = 0x55;
/// FC 101 sub-function: the next part of the dictionary (NT-FC101).
pub const DICTIONARY_NEXT: u8 = 0xAA;

/// A PDU that is not what the protocol allows, with the function code and the field at fault.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PduError {
    #[error("empty PDU: there is no function code")]
    Empty,

    #[error("FC {function}: the PDU ends after {len} bytes, before the {what}")]
    Truncated {
        function: u8,
        len: usize,
        what: &'static str,
    },

    #[error("FC {function}: {extra} unexpected bytes after the {after}")]
    Trailing {
        function: u8,
        extra: usize,
        after: &'static str,
    },

    #[error("FC {function}: {what} is {value}, the Modbus limit is {min}..={max}")]
    Quantity {
        function: u8,
        what: &'static str,
        value: usize,
        min: u16,
        max: u16,
    },

    #[error(
        "FC {function}: byte count {byte_count} does not match {count} registers (must be {})",
        2 * count
    )]
    ByteCount {
        function: u8,
        byte_count: usize,
        count: usize,
    },

    #[error("FC {function}: the length byte says {declared} bytes follow, but {actual} do")]
    LengthByte {
        function: u8,
        declared: usize,
        actual: usize,
    },

    #[error("the response to {request} has function code {got} ({got:02X}h)")]
    FunctionMismatch { request: String, got: u8 },

    #[error("FC {function}: the response gives {what} {got}, the request sent {expected}")]
    Echo {
        function: u8,
        what: &'static str,
        expected: String,
        got: String,
    },

    #[error(
        "FC 43 {access}: the number-of-data field says {count} bytes, but {actual} data bytes follow"
    )]
    CanopenDataLength {
        access: &'static str,
        count: u16,
        actual: usize,
    },

    #[error(
        "FC 43: {len} data bytes do not fit one PDU (at most {max} with this header); split the transfer"
    )]
    CanopenTooLong { len: usize, max: usize },

    #[error("FC {function}: the PDU would be {len} bytes, Modbus allows at most 253")]
    TooLong { function: u8, len: usize },

    #[error("FC 101: sub-function {0:02X}h is neither 55h (restart) nor AAh (next)")]
    DictionarySubFunction(u8),

    #[error(
        "FC 101: object frame {index:04X}h:{subindex:02X} has {data} data bytes, at most 255 fit"
    )]
    DictionaryFrameTooLong {
        index: u16,
        subindex: u8,
        data: usize,
    },

    #[error(
        "FC {function}: extended exception not in Nanotec's layout (FF, length 0006h, 0Dh, CEh, 4-byte code): {bytes}"
    )]
    ExtendedException { function: u8, bytes: String },

    #[error("function code {0:02X}h is not an exception response (bit 7 clear)")]
    NotException(u8),

    #[error("FC {function}: drivedeck has no decoder for the response to this function code")]
    NoResponseDecoder { function: u8 },
}

// ---------------------------------------------------------------------------------------------
// A bounds-checked reader: the only way decoders touch input bytes.

struct Reader<'a> {
    function: u8,
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// A reader positioned after the function code.
    fn after_function(function: u8, pdu: &'a [u8]) -> Self {
        Self {
            function,
            bytes: pdu,
            pos: 1,
        }
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], PduError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&end| end <= self.bytes.len());
        match end {
            Some(end) => {
                let slice = &self.bytes[self.pos..end];
                self.pos = end;
                Ok(slice)
            }
            None => Err(PduError::Truncated {
                function: self.function,
                len: self.bytes.len(),
                what,
            }),
        }
    }

    fn u8(&mut self, what: &'static str) -> Result<u8, PduError> {
        Ok(self.take(1, what)?[0])
    }

    fn u16_be(&mut self, what: &'static str) -> Result<u16, PduError> {
        let b = self.take(2, what)?;
        Ok(u16::from_be_bytes([b[0], b[1]]))
    }

    fn rest(&mut self) -> &'a [u8] {
        let rest = self.bytes.get(self.pos..).unwrap_or_default();
        self.pos = self.bytes.len();
        rest
    }

    /// Everything after the function code, wherever the reader stands.
    fn rest_after_function(&mut self) -> &'a [u8] {
        self.pos = 1;
        self.rest()
    }

    fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    fn finish(&self, after: &'static str) -> Result<(), PduError> {
        match self.remaining() {
            0 => Ok(()),
            extra => Err(PduError::Trailing {
                function: self.function,
                extra,
                after,
            }),
        }
    }
}

fn check_quantity(
    function: u8,
    what: &'static str,
    value: usize,
    max: u16,
) -> Result<(), PduError> {
    if (1..=usize::from(max)).contains(&value) {
        Ok(())
    } else {
        Err(PduError::Quantity {
            function,
            what,
            value,
            min: 1,
            max,
        })
    }
}

fn check_byte_count(function: u8, byte_count: usize, count: usize) -> Result<(), PduError> {
    if byte_count == 2 * count {
        Ok(())
    } else {
        Err(PduError::ByteCount {
            function,
            byte_count,
            count,
        })
    }
}

fn registers(r: &mut Reader<'_>, count: usize) -> Result<Vec<u16>, PduError> {
    let bytes = r.take(2 * count, "register values")?;
    Ok(bytes
        .chunks_exact(2)
        .map(|pair| u16::from_be_bytes([pair[0], pair[1]]))
        .collect())
}

fn push_u16(out: &mut Vec<u8>, value: u16) {
    out.extend_from_slice(&value.to_be_bytes());
}

fn push_registers(out: &mut Vec<u8>, values: &[u16]) {
    for &value in values {
        push_u16(out, value);
    }
}

/// The byte-count field for `values`, saturated: an oversized list is caught by
/// [`Request::validate`], never silently wrapped.
fn byte_count(values: &[u16]) -> u8 {
    u8::try_from(2 * values.len()).unwrap_or(u8::MAX)
}

fn saturating_u16(n: usize) -> u16 {
    u16::try_from(n).unwrap_or(u16::MAX)
}

/// "4996-4999", "4996" or "4996 (0 registers)".
fn register_range(address: u16, count: usize) -> String {
    match count {
        0 => format!("{address} (0 registers)"),
        1 => address.to_string(),
        n => format!("{address}-{}", u64::from(address) + n as u64 - 1),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

// ---------------------------------------------------------------------------------------------
// FC 43 / MEI 0Dh: CANopen general reference (CiA 309-2).

/// Bits of the first protocol-control byte of FC 43/0Dh.
///
/// Nanotec numbers bit 0 as the **most** significant bit (NT-FC43: "The most significant bit
/// (MSB) is bit 0 for protocol control byte 1, and bit 8 for protocol control byte 2"). The
/// bit list is from the N5 Modbus TCP manual (manualslib.de, N5 technical manual v3.3.0,
/// p. 127): bit 0 extend flag, 1 extended protocol control, 2 counter byte option, 3 and 4
/// reserved, 5 network-id option, 6 encoded-data option ("not supported, must be 0" for both),
/// 7 access flag ("0" = read, "1" = write), 8–15 reserved. Public code agrees on the access
/// flag: HAN `MotorModbusMaster.cpp` sends control 00h to read and 01h to write (protocol
/// notes §1.4).
pub mod control {
    /// NT bit 0: part of a multi-message transfer; 0 = single message or the last one.
    pub const EXTEND: u8 = 0x80;
    /// NT bit 1: the protocol control field is 2 bytes long.
    pub const EXTENDED_CONTROL: u8 = 0x40;
    /// NT bit 2: a counter byte follows the reserved byte.
    pub const COUNTER: u8 = 0x20;
    /// NT bits 3 and 4: reserved. Ignored when decoding, never set when encoding.
    pub const RESERVED: u8 = 0x18;
    /// NT bit 5: a network-id byte follows (Nanotec: not supported).
    pub const NETWORK_ID: u8 = 0x04;
    /// NT bit 6: an encoded-data byte follows (Nanotec: not supported).
    pub const ENCODED_DATA: u8 = 0x02;
    /// NT bit 7: access flag, 0 = read, 1 = write.
    pub const WRITE: u8 = 0x01;
}

/// The protocol-option and address fields of an FC 43/0Dh message, shared by request and
/// response (a response echoes the request's header, NT-FC43).
///
/// Wire layout after `2B 0D` (NT-FC43, protocol notes §1.4; HAN for the address fields):
/// `control [control2] 00 [counter] [network id] [encoded data] node idxHi idxLo sub
/// startHi startLo countHi countLo`. Index, starting address and number of data bytes are
/// big-endian (message body); the data bytes that follow are the object value, little-endian
/// per NT-GEN, and carried untouched.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct CanopenHeader {
    /// Access flag (control NT bit 7): write when set, read when clear.
    pub write: bool,
    /// Extend flag (control NT bit 0): more fragments of this transfer follow.
    pub extend: bool,
    /// Second protocol-control byte (NT bits 8–15, all reserved); present when the extended
    /// protocol control bit is set.
    pub control2: Option<u8>,
    /// Counter byte, present when the counter byte option is set.
    pub counter: Option<u8>,
    /// Network id, present when the network-id option is set.
    pub network_id: Option<u8>,
    /// Encoded-data byte, present when the encoded-data option is set.
    pub encoded_data: Option<u8>,
    /// CANopen node id. HAN sends the drive's node id; a Modbus drive answers for itself.
    pub node_id: u8,
    /// Object index (big-endian on the wire).
    pub index: u16,
    pub subindex: u8,
    /// Starting address: byte offset into the object for transfers split over several
    /// messages; 0 for a whole object.
    pub start: u16,
    /// Number of data bytes. In a read request: how many bytes are asked for, which must
    /// match the object's size (the N5 manual's example reads 2 bytes of a 1-byte object and
    /// gets abort 06070012h). In a write request and a read response: the bytes that follow.
    pub count: u16,
}

impl CanopenHeader {
    /// The first protocol-control byte for these fields.
    pub fn control(&self) -> u8 {
        let mut c = 0;
        for (flag, bit) in [
            (self.extend, control::EXTEND),
            (self.control2.is_some(), control::EXTENDED_CONTROL),
            (self.counter.is_some(), control::COUNTER),
            (self.network_id.is_some(), control::NETWORK_ID),
            (self.encoded_data.is_some(), control::ENCODED_DATA),
            (self.write, control::WRITE),
        ] {
            if flag {
                c |= bit;
            }
        }
        c
    }

    /// Bytes of the PDU from the function code through the number-of-data field, for a
    /// message whose first protocol-control byte is `control`. `frame` uses this to predict
    /// the length of an RTU frame.
    pub fn pdu_len(control: u8) -> usize {
        let flag = |bit: u8| usize::from(control & bit != 0);
        // FC, MEI, control, [control2], reserved, options, node, index, sub, start, count
        2 + 1
            + flag(control::EXTENDED_CONTROL)
            + 1
            + flag(control::COUNTER)
            + flag(control::NETWORK_ID)
            + flag(control::ENCODED_DATA)
            + 8
    }

    /// Bytes this header takes in a PDU, function code and MEI included.
    pub fn encoded_len(&self) -> usize {
        Self::pdu_len(self.control())
    }

    /// The largest data block that fits one PDU after this header.
    pub fn max_data(&self) -> usize {
        MAX_PDU.saturating_sub(self.encoded_len())
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&[fc::ENCAPSULATED, MEI_CANOPEN, self.control()]);
        out.extend(self.control2);
        out.push(0); // reserved, always 0 (NT-FC43)
        out.extend(self.counter);
        out.extend(self.network_id);
        out.extend(self.encoded_data);
        out.push(self.node_id);
        push_u16(out, self.index);
        out.push(self.subindex);
        push_u16(out, self.start);
        push_u16(out, self.count);
    }

    /// Reads the header after the MEI byte. The reserved byte and the reserved control bits
    /// are ignored (tolerant: a device that fills them in still gets understood).
    fn decode(r: &mut Reader<'_>) -> Result<Self, PduError> {
        let c = r.u8("protocol control")?;
        let flag = |bit: u8| c & bit != 0;
        let control2 = if flag(control::EXTENDED_CONTROL) {
            Some(r.u8("second protocol control byte")?)
        } else {
            None
        };
        r.u8("reserved byte")?;
        let mut optional = |bit: u8, what: &'static str| -> Result<Option<u8>, PduError> {
            if flag(bit) {
                r.u8(what).map(Some)
            } else {
                Ok(None)
            }
        };
        let counter = optional(control::COUNTER, "counter byte")?;
        let network_id = optional(control::NETWORK_ID, "network id")?;
        let encoded_data = optional(control::ENCODED_DATA, "encoded-data byte")?;
        Ok(Self {
            write: flag(control::WRITE),
            extend: flag(control::EXTEND),
            control2,
            counter,
            network_id,
            encoded_data,
            node_id: r.u8("node id")?,
            index: r.u16_be("object index")?,
            subindex: r.u8("subindex")?,
            start: r.u16_be("starting address")?,
            count: r.u16_be("number of data bytes")?,
        })
    }

    fn access(&self) -> &'static str {
        if self.write { "write" } else { "read" }
    }

    fn check_fits(&self, data: usize) -> Result<(), PduError> {
        if data <= self.max_data() {
            Ok(())
        } else {
            Err(PduError::CanopenTooLong {
                len: data,
                max: self.max_data(),
            })
        }
    }
}

/// An FC 43/0Dh request: read or write one object (or one fragment of it).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct CanopenRequest {
    pub header: CanopenHeader,
    /// The value to write (little-endian object bytes, NT-GEN); empty for a read.
    pub data: Vec<u8>,
}

impl CanopenRequest {
    /// Read `len` bytes of `index:subindex` on `node_id`. `len` must be the object's size.
    pub fn read(node_id: u8, index: u16, subindex: u8, len: u16) -> Self {
        Self {
            header: CanopenHeader {
                node_id,
                index,
                subindex,
                count: len,
                ..CanopenHeader::default()
            },
            data: Vec::new(),
        }
    }

    /// Write `data` (the object value, little-endian) to `index:subindex` on `node_id`.
    pub fn write(node_id: u8, index: u16, subindex: u8, data: Vec<u8>) -> Self {
        Self {
            header: CanopenHeader {
                write: true,
                node_id,
                index,
                subindex,
                count: saturating_u16(data.len()),
                ..CanopenHeader::default()
            },
            data,
        }
    }

    /// A read carries no data; a write carries exactly `count` bytes; all fits one PDU.
    pub fn validate(&self) -> Result<(), PduError> {
        let h = &self.header;
        if !h.write && !self.data.is_empty() {
            return Err(PduError::Trailing {
                function: fc::ENCAPSULATED,
                extra: self.data.len(),
                after: "read request header (a read carries no data)",
            });
        }
        if h.write && self.data.len() != usize::from(h.count) {
            return Err(PduError::CanopenDataLength {
                access: h.access(),
                count: h.count,
                actual: self.data.len(),
            });
        }
        h.check_fits(self.data.len())
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        self.header.encode_into(out);
        out.extend_from_slice(&self.data);
    }

    /// Decodes the rest of an FC 43 PDU after its MEI byte 0Dh.
    fn decode(r: &mut Reader<'_>) -> Result<Self, PduError> {
        let header = CanopenHeader::decode(r)?;
        if !header.write {
            r.finish("read request header (a read carries no data)")?;
            return Ok(Self {
                header,
                data: Vec::new(),
            });
        }
        let data = r.rest().to_vec();
        let request = Self { header, data };
        request.validate()?;
        Ok(request)
    }
}

/// An FC 43/0Dh response: the request's header echoed, and the object bytes for a read.
///
/// Whether the response to a **write** carries the written data is not documented. HAN's
/// master predicts every response length as header + number-of-data and rejects a write
/// response with fewer than 12 bytes after the function code, which only works if the drive
/// echoes the data; so
/// [`CanopenResponse::answering`] echoes it, and [`Response::decode`] accepts a write
/// response with the data or without it (protocol notes §5.20: tolerant where
/// the record is unclear).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct CanopenResponse {
    pub header: CanopenHeader,
    /// The object value read (little-endian object bytes), or the echo of the written value.
    pub data: Vec<u8>,
}

impl CanopenResponse {
    /// The answer a server gives to `request`: the header echoed; for a read, `data` with the
    /// number of data bytes set to its length; for a write, the written data echoed (`data`
    /// is ignored).
    pub fn answering(request: &CanopenRequest, data: Vec<u8>) -> Self {
        let mut header = request.header.clone();
        if header.write {
            return Self {
                header,
                data: request.data.clone(),
            };
        }
        header.count = saturating_u16(data.len());
        Self { header, data }
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        self.header.encode_into(out);
        out.extend_from_slice(&self.data);
    }

    fn decode(r: &mut Reader<'_>) -> Result<Self, PduError> {
        let header = CanopenHeader::decode(r)?;
        let data = r.rest().to_vec();
        let fits = data.len() == usize::from(header.count) || (header.write && data.is_empty());
        if !fits {
            return Err(PduError::CanopenDataLength {
                access: header.access(),
                count: header.count,
                actual: data.len(),
            });
        }
        Ok(Self { header, data })
    }

    /// The response must be about the object that was asked for.
    fn check_echo(&self, request: &CanopenRequest) -> Result<(), PduError> {
        let (asked, got) = (&request.header, &self.header);
        if (asked.index, asked.subindex) != (got.index, got.subindex) {
            return Err(PduError::Echo {
                function: fc::ENCAPSULATED,
                what: "object",
                expected: format!("{:04X}h:{:02X}", asked.index, asked.subindex),
                got: format!("{:04X}h:{:02X}", got.index, got.subindex),
            });
        }
        if asked.write != got.write {
            return Err(PduError::Echo {
                function: fc::ENCAPSULATED,
                what: "access",
                expected: asked.access().to_string(),
                got: got.access().to_string(),
            });
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// FC 101: read the complete object dictionary.

/// One "object dictionary frame" of an FC 101/102 response (NT-FC101):
/// `idxLo idxHi sub nbytes data…`, the one little-endian header in Modbus.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct DictionaryFrame {
    pub index: u16,
    pub subindex: u8,
    /// The object value, little-endian, `nbytes` long.
    pub data: Vec<u8>,
}

impl DictionaryFrame {
    fn encode_into(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.index.to_le_bytes());
        out.push(self.subindex);
        out.push(u8::try_from(self.data.len()).unwrap_or(u8::MAX));
        out.extend_from_slice(&self.data);
    }

    fn decode_all(function: u8, bytes: &[u8]) -> Result<Vec<Self>, PduError> {
        let mut r = Reader {
            function,
            bytes,
            pos: 0,
        };
        let mut frames = Vec::new();
        while r.remaining() > 0 {
            let index = r.take(2, "object frame index")?;
            let subindex = r.u8("object frame subindex")?;
            let len = r.u8("object frame length")?;
            let data = r.take(usize::from(len), "object frame data")?.to_vec();
            frames.push(Self {
                index: u16::from_le_bytes([index[0], index[1]]),
                subindex,
                data,
            });
        }
        Ok(frames)
    }
}

// ---------------------------------------------------------------------------------------------
// Requests.

/// A Modbus request PDU.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Request {
    /// FC 3.
    ReadHolding { address: u16, count: u16 },
    /// FC 4.
    ReadInput { address: u16, count: u16 },
    /// FC 6.
    WriteSingle { address: u16, value: u16 },
    /// FC 16.
    WriteMultiple { address: u16, values: Vec<u16> },
    /// FC 23: the write happens before the read (Modbus spec §6.17).
    ReadWrite {
        read_address: u16,
        read_count: u16,
        write_address: u16,
        values: Vec<u16>,
    },
    /// FC 43 with MEI 0Dh.
    Canopen(CanopenRequest),
    /// FC 101: `restart` sends sub-function 55h, otherwise AAh (next).
    ReadDictionary { restart: bool },
    /// Any other function code (FC 43 with another MEI included), so a server can answer
    /// exception 01. `data` is everything after the function code.
    Other { function: u8, data: Vec<u8> },
}

impl Request {
    /// The function code.
    pub fn function(&self) -> u8 {
        match self {
            Request::ReadHolding { .. } => fc::READ_HOLDING,
            Request::ReadInput { .. } => fc::READ_INPUT,
            Request::WriteSingle { .. } => fc::WRITE_SINGLE,
            Request::WriteMultiple { .. } => fc::WRITE_MULTIPLE,
            Request::ReadWrite { .. } => fc::READ_WRITE,
            Request::Canopen(_) => fc::ENCAPSULATED,
            Request::ReadDictionary { .. } => fc::READ_DICTIONARY,
            Request::Other { function, .. } => *function,
        }
    }

    /// The Modbus limits (quantities, byte counts, PDU size). [`Request::encode`] does not
    /// check them: call this first for anything built from user input.
    pub fn validate(&self) -> Result<(), PduError> {
        let function = self.function();
        match self {
            Request::ReadHolding { count, .. } | Request::ReadInput { count, .. } => {
                check_quantity(
                    function,
                    "register count",
                    usize::from(*count),
                    limits::READ_MAX,
                )
            }
            Request::WriteSingle { .. } | Request::ReadDictionary { .. } => Ok(()),
            Request::WriteMultiple { values, .. } => check_quantity(
                function,
                "register count",
                values.len(),
                limits::WRITE_MULTIPLE_MAX,
            ),
            Request::ReadWrite {
                read_count, values, ..
            } => {
                check_quantity(
                    function,
                    "read count",
                    usize::from(*read_count),
                    limits::READ_MAX,
                )?;
                check_quantity(
                    function,
                    "write count",
                    values.len(),
                    limits::READ_WRITE_WRITE_MAX,
                )
            }
            Request::Canopen(request) => request.validate(),
            Request::Other { data, .. } if data.len() >= MAX_PDU => Err(PduError::TooLong {
                function,
                len: data.len() + 1,
            }),
            Request::Other { .. } => Ok(()),
        }
    }

    /// The PDU bytes, function code first.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = vec![self.function()];
        match self {
            Request::ReadHolding { address, count } | Request::ReadInput { address, count } => {
                push_u16(&mut out, *address);
                push_u16(&mut out, *count);
            }
            Request::WriteSingle { address, value } => {
                push_u16(&mut out, *address);
                push_u16(&mut out, *value);
            }
            Request::WriteMultiple { address, values } => {
                push_u16(&mut out, *address);
                push_u16(&mut out, saturating_u16(values.len()));
                out.push(byte_count(values));
                push_registers(&mut out, values);
            }
            Request::ReadWrite {
                read_address,
                read_count,
                write_address,
                values,
            } => {
                push_u16(&mut out, *read_address);
                push_u16(&mut out, *read_count);
                push_u16(&mut out, *write_address);
                push_u16(&mut out, saturating_u16(values.len()));
                out.push(byte_count(values));
                push_registers(&mut out, values);
            }
            Request::Canopen(request) => {
                out.clear();
                request.encode_into(&mut out);
            }
            Request::ReadDictionary { restart } => {
                let sub = if *restart {
                    DICTIONARY_RESTART
                } else {
                    DICTIONARY_NEXT
                };
                out.extend_from_slice(&[sub, 0]);
            }
            Request::Other { data, .. } => out.extend_from_slice(data),
        }
        out
    }

    /// Decodes a request PDU and checks the Modbus limits. Unknown function codes, and FC 43
    /// with an MEI other than 0Dh, give [`Request::Other`].
    pub fn decode(pdu: &[u8]) -> Result<Request, PduError> {
        let (&function, _) = pdu.split_first().ok_or(PduError::Empty)?;
        let mut r = Reader::after_function(function, pdu);
        let request = match function {
            fc::READ_HOLDING | fc::READ_INPUT => decode_read(&mut r)?,
            fc::WRITE_SINGLE => Request::WriteSingle {
                address: r.u16_be("register address")?,
                value: r.u16_be("register value")?,
            },
            fc::WRITE_MULTIPLE => decode_write_multiple(&mut r)?,
            fc::READ_WRITE => decode_read_write(&mut r)?,
            fc::ENCAPSULATED if r.u8("MEI type")? == MEI_CANOPEN => {
                Request::Canopen(CanopenRequest::decode(&mut r)?)
            }
            fc::READ_DICTIONARY => decode_read_dictionary(&mut r)?,
            _ => Request::Other {
                function,
                data: r.rest_after_function().to_vec(),
            },
        };
        r.finish("request")?;
        request.validate()?;
        Ok(request)
    }

    /// A short description for error messages and the log, e.g.
    /// "FC 23 (read 4996-4999, write 5996-5999)".
    pub fn describe(&self) -> String {
        let function = self.function();
        let what = match self {
            Request::ReadHolding { address, count } | Request::ReadInput { address, count } => {
                format!("read {}", register_range(*address, usize::from(*count)))
            }
            Request::WriteSingle { address, value } => format!("write {address} = {value:04X}h"),
            Request::WriteMultiple { address, values } => {
                format!("write {}", register_range(*address, values.len()))
            }
            Request::ReadWrite {
                read_address,
                read_count,
                write_address,
                values,
            } => format!(
                "read {}, write {}",
                register_range(*read_address, usize::from(*read_count)),
                register_range(*write_address, values.len())
            ),
            Request::Canopen(CanopenRequest { header: h, .. }) => format!(
                "{} {:04X}h:{:02X}, node {}, {} bytes",
                h.access(),
                h.index,
                h.subindex,
                h.node_id,
                h.count
            ),
            Request::ReadDictionary { restart: true } => "restart".to_string(),
            Request::ReadDictionary { restart: false } => "next".to_string(),
            Request::Other { data, .. } => format!("{} data bytes", data.len()),
        };
        format!("FC {function} ({what})")
    }
}

fn decode_read(r: &mut Reader<'_>) -> Result<Request, PduError> {
    let function = r.function;
    let address = r.u16_be("starting address")?;
    let count = r.u16_be("register count")?;
    Ok(match function {
        fc::READ_INPUT => Request::ReadInput { address, count },
        _ => Request::ReadHolding { address, count },
    })
}

fn decode_write_multiple(r: &mut Reader<'_>) -> Result<Request, PduError> {
    let function = r.function;
    let address = r.u16_be("starting address")?;
    let count = usize::from(r.u16_be("register count")?);
    let byte_count = usize::from(r.u8("byte count")?);
    check_quantity(
        function,
        "register count",
        count,
        limits::WRITE_MULTIPLE_MAX,
    )?;
    check_byte_count(function, byte_count, count)?;
    let values = registers(r, count)?;
    Ok(Request::WriteMultiple { address, values })
}

fn decode_read_write(r: &mut Reader<'_>) -> Result<Request, PduError> {
    let function = r.function;
    let read_address = r.u16_be("read starting address")?;
    let read_count = r.u16_be("read count")?;
    let write_address = r.u16_be("write starting address")?;
    let write_count = usize::from(r.u16_be("write count")?);
    let byte_count = usize::from(r.u8("write byte count")?);
    check_quantity(
        function,
        "read count",
        usize::from(read_count),
        limits::READ_MAX,
    )?;
    check_quantity(
        function,
        "write count",
        write_count,
        limits::READ_WRITE_WRITE_MAX,
    )?;
    check_byte_count(function, byte_count, write_count)?;
    let values = registers(r, write_count)?;
    Ok(Request::ReadWrite {
        read_address,
        read_count,
        write_address,
        values,
    })
}

fn decode_read_dictionary(r: &mut Reader<'_>) -> Result<Request, PduError> {
    let sub = r.u8("sub-function")?;
    let restart = match sub {
        DICTIONARY_RESTART => true,
        DICTIONARY_NEXT => false,
        other => return Err(PduError::DictionarySubFunction(other)),
    };
    let declared = usize::from(r.u8("length of data")?);
    if declared != 0 || r.remaining() != 0 {
        return Err(PduError::LengthByte {
            function: fc::READ_DICTIONARY,
            declared,
            actual: r.remaining(),
        });
    }
    Ok(Request::ReadDictionary { restart })
}

// ---------------------------------------------------------------------------------------------
// Exceptions.

/// A device's refusal: a standard exception, or Nanotec's extended exception carrying a
/// CANopen abort code (FC 43/101/102, protocol notes §1.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Exception {
    /// `function | 80h, code`. `function` is the code as sent, without bit 7.
    Standard { function: u8, code: u8 },
    /// `function | 80h, FFh, 00 06, 0Dh, CEh, <4-byte abort code>`.
    ///
    /// Byte order of the abort code: the N5 manual's Modbus TCP example (manualslib.de,
    /// N5 technical manual v3.3.0, p. 127) answers a too-long read of 6061h with
    /// `FF 00 06 0D CE 12 00 07 06`, i.e. 06070012h little-endian, in line with NT-GEN's
    /// "CANopen data is little-endian". Decoding therefore reads little-endian, but if that
    /// reading is not a CiA 301 abort code and the big-endian one is, it takes the big-endian
    /// one (a firmware that sends it the other way round still shows the right text).
    /// Encoding writes little-endian.
    Extended { function: u8, abort: u32 },
}

impl Exception {
    /// The function code the exception answers (bit 7 clear).
    pub fn function(&self) -> u8 {
        match self {
            Exception::Standard { function, .. } | Exception::Extended { function, .. } => {
                *function
            }
        }
    }

    /// The CANopen abort code of an extended exception.
    pub fn abort(&self) -> Option<AbortCode> {
        match self {
            Exception::Extended { abort, .. } => Some(AbortCode(*abort)),
            Exception::Standard { .. } => None,
        }
    }

    /// What the exception means, in the words of the Modbus spec §7 or CiA 301.
    pub fn text(&self) -> &'static str {
        match self {
            Exception::Standard { code, .. } => standard_text(*code),
            Exception::Extended { abort, .. } => AbortCode(*abort)
                .text()
                .unwrap_or("not a CiA 301 abort code"),
        }
    }

    /// The PDU bytes.
    pub fn encode(&self) -> Vec<u8> {
        match self {
            Exception::Standard { function, code } => vec![function | 0x80, *code],
            Exception::Extended { function, abort } => {
                let mut out = vec![
                    function | 0x80,
                    exception::EXTENDED,
                    0x00,
                    0x06,
                    MEI_CANOPEN,
                    exception::CANOPEN_ERROR,
                ];
                out.extend_from_slice(&abort.to_le_bytes());
                out
            }
        }
    }

    /// Decodes an exception PDU (function code with bit 7 set). `FFh` after FC 43/101/102
    /// (ABh, E5h, E6h) is Nanotec's extended exception; anything else is standard.
    pub fn decode(pdu: &[u8]) -> Result<Exception, PduError> {
        let (&raw, _) = pdu.split_first().ok_or(PduError::Empty)?;
        if raw & 0x80 == 0 {
            return Err(PduError::NotException(raw));
        }
        let function = raw & 0x7F;
        let mut r = Reader::after_function(function, pdu);
        let code = r.u8("exception code")?;
        if code == exception::EXTENDED && has_extended_exception(function) {
            return decode_extended(function, &mut r);
        }
        r.finish("exception code")?;
        Ok(Exception::Standard { function, code })
    }
}

/// Whether `function` (bit 7 clear) answers errors with Nanotec's extended exception.
pub fn has_extended_exception(function: u8) -> bool {
    matches!(
        function,
        fc::ENCAPSULATED | fc::READ_DICTIONARY | fc::READ_ARRAY
    )
}

fn decode_extended(function: u8, r: &mut Reader<'_>) -> Result<Exception, PduError> {
    let rest = r.rest();
    let malformed = || PduError::ExtendedException {
        function,
        bytes: hex(rest),
    };
    let [
        0x00,
        0x06,
        MEI_CANOPEN,
        exception::CANOPEN_ERROR,
        b0,
        b1,
        b2,
        b3,
    ] = *rest
    else {
        return Err(malformed());
    };
    let le = u32::from_le_bytes([b0, b1, b2, b3]);
    let be = u32::from_be_bytes([b0, b1, b2, b3]);
    let known = |code: u32| AbortCode(code).text().is_some();
    let abort = if !known(le) && known(be) { be } else { le };
    Ok(Exception::Extended { function, abort })
}

fn standard_text(code: u8) -> &'static str {
    use exception as e;
    match code {
        e::ILLEGAL_FUNCTION => "illegal function",
        e::ILLEGAL_DATA_ADDRESS => "illegal data address",
        e::ILLEGAL_DATA_VALUE => "illegal data value",
        e::SERVER_DEVICE_FAILURE => "slave device failure",
        e::ACKNOWLEDGE => "acknowledge (request accepted, processing takes long)",
        e::SERVER_DEVICE_BUSY => "slave device busy",
        e::MEMORY_PARITY_ERROR => "memory parity error",
        e::GATEWAY_PATH_UNAVAILABLE => "gateway path unavailable",
        e::GATEWAY_TARGET_NO_RESPONSE => "gateway target device failed to respond",
        _ => "unknown exception code",
    }
}

impl fmt::Display for Exception {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Exception::Standard { function, code } => write!(
                f,
                "FC {function} refused: exception {code:02X}h, {}",
                self.text()
            ),
            Exception::Extended { function, abort } => {
                write!(f, "FC {function} refused: abort {}", AbortCode(*abort))
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Responses.

/// A normal (non-exception) Modbus response PDU.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Response {
    /// FC 3: the registers read.
    ReadHolding(Vec<u16>),
    /// FC 4.
    ReadInput(Vec<u16>),
    /// FC 6: the echo of the request.
    WriteSingle { address: u16, value: u16 },
    /// FC 16: starting address and quantity written.
    WriteMultiple { address: u16, count: u16 },
    /// FC 23: the registers read.
    ReadWrite(Vec<u16>),
    /// FC 43/0Dh.
    Canopen(CanopenResponse),
    /// FC 101: the sub-function echoed and the object frames of this part.
    Dictionary {
        sub: u8,
        frames: Vec<DictionaryFrame>,
    },
}

impl Response {
    /// The function code.
    pub fn function(&self) -> u8 {
        match self {
            Response::ReadHolding(_) => fc::READ_HOLDING,
            Response::ReadInput(_) => fc::READ_INPUT,
            Response::WriteSingle { .. } => fc::WRITE_SINGLE,
            Response::WriteMultiple { .. } => fc::WRITE_MULTIPLE,
            Response::ReadWrite(_) => fc::READ_WRITE,
            Response::Canopen(_) => fc::ENCAPSULATED,
            Response::Dictionary { .. } => fc::READ_DICTIONARY,
        }
    }

    /// The PDU bytes, function code first.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = vec![self.function()];
        match self {
            Response::ReadHolding(values)
            | Response::ReadInput(values)
            | Response::ReadWrite(values) => {
                out.push(byte_count(values));
                push_registers(&mut out, values);
            }
            Response::WriteSingle { address, value } => {
                push_u16(&mut out, *address);
                push_u16(&mut out, *value);
            }
            Response::WriteMultiple { address, count } => {
                push_u16(&mut out, *address);
                push_u16(&mut out, *count);
            }
            Response::Canopen(response) => {
                out.clear();
                response.encode_into(&mut out);
            }
            Response::Dictionary { sub, frames } => {
                let mut body = Vec::new();
                for frame in frames {
                    frame.encode_into(&mut body);
                }
                out.push(*sub);
                out.push(u8::try_from(body.len()).unwrap_or(u8::MAX));
                out.extend_from_slice(&body);
            }
        }
        out
    }

    /// Decodes the answer to `request`: `Ok(Ok(_))` for a normal response that matches what
    /// was asked, `Ok(Err(_))` for the device's refusal, `Err(_)` for a malformed or
    /// mismatched answer.
    ///
    /// FC 101's end-of-dictionary is an extended exception with abort 08000024h; Nanotec's
    /// FC 101/102 pages give its function code as 2Bh + 80h (ABh) rather than E5h/E6h, so
    /// both are accepted for FC 101 (NT-FC101).
    pub fn decode(request: &Request, pdu: &[u8]) -> Result<Result<Response, Exception>, PduError> {
        let (&function, _) = pdu.split_first().ok_or(PduError::Empty)?;
        let asked = request.function();
        let exception_codes = [asked | 0x80, fc::ENCAPSULATED | 0x80];
        let is_exception = function == asked | 0x80
            || (asked == fc::READ_DICTIONARY && exception_codes.contains(&function));
        if is_exception {
            return Exception::decode(pdu).map(Err);
        }
        if function != asked {
            return Err(PduError::FunctionMismatch {
                request: request.describe(),
                got: function,
            });
        }
        let mut r = Reader::after_function(function, pdu);
        let response = decode_normal(request, &mut r)?;
        r.finish("response")?;
        Ok(Ok(response))
    }
}

fn decode_normal(request: &Request, r: &mut Reader<'_>) -> Result<Response, PduError> {
    let function = r.function;
    match request {
        Request::ReadHolding { count, .. } => {
            decode_registers(r, usize::from(*count)).map(Response::ReadHolding)
        }
        Request::ReadInput { count, .. } => {
            decode_registers(r, usize::from(*count)).map(Response::ReadInput)
        }
        Request::ReadWrite { read_count, .. } => {
            decode_registers(r, usize::from(*read_count)).map(Response::ReadWrite)
        }
        Request::WriteSingle { address, value } => {
            let got_address = r.u16_be("register address")?;
            let got_value = r.u16_be("register value")?;
            check_echo(function, "address", *address, got_address)?;
            check_echo(function, "value", *value, got_value)?;
            Ok(Response::WriteSingle {
                address: got_address,
                value: got_value,
            })
        }
        Request::WriteMultiple { address, values } => {
            let got_address = r.u16_be("starting address")?;
            let count = r.u16_be("register count")?;
            check_echo(function, "address", *address, got_address)?;
            check_echo(function, "count", saturating_u16(values.len()), count)?;
            Ok(Response::WriteMultiple {
                address: got_address,
                count,
            })
        }
        Request::Canopen(asked) => {
            let mei = r.u8("MEI type")?;
            check_echo(function, "MEI type", MEI_CANOPEN, mei)?;
            let response = CanopenResponse::decode(r)?;
            response.check_echo(asked)?;
            Ok(Response::Canopen(response))
        }
        Request::ReadDictionary { .. } => {
            let sub = r.u8("sub-function")?;
            let declared = usize::from(r.u8("length of data")?);
            let body = r.rest();
            if declared != body.len() {
                return Err(PduError::LengthByte {
                    function,
                    declared,
                    actual: body.len(),
                });
            }
            let frames = DictionaryFrame::decode_all(function, body)?;
            Ok(Response::Dictionary { sub, frames })
        }
        Request::Other { .. } => Err(PduError::NoResponseDecoder { function }),
    }
}

fn decode_registers(r: &mut Reader<'_>, count: usize) -> Result<Vec<u16>, PduError> {
    let function = r.function;
    let byte_count = usize::from(r.u8("byte count")?);
    check_byte_count(function, byte_count, count)?;
    registers(r, count)
}

fn check_echo<T: PartialEq + fmt::Display>(
    function: u8,
    what: &'static str,
    expected: T,
    got: T,
) -> Result<(), PduError> {
    if expected == got {
        Ok(())
    } else {
        Err(PduError::Echo {
            function,
            what,
            expected: expected.to_string(),
            got: got.to_string(),
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use proptest::prelude::*;

    use super::*;

    fn bytes(hex: &str) -> Vec<u8> {
        hex.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).expect("test vector is hex"))
            .collect()
    }

    fn round_trip_request(request: &Request) {
        let pdu = request.encode();
        assert_eq!(Request::decode(&pdu).as_ref(), Ok(request), "{pdu:02X?}");
    }

    fn round_trip_response(request: &Request, response: &Response) {
        let pdu = response.encode();
        assert_eq!(
            Response::decode(request, &pdu),
            Ok(Ok(response.clone())),
            "{pdu:02X?}"
        );
    }

    // --- Golden vectors of protocol notes §1.2 ---------------------------------------------

    #[test]
    fn fc16_od_read_of_3320h_01_matches_the_spec_example() {
        let request = Request::WriteMultiple {
            address: 5996,
            values: vec![0x0000, 0x0000, 0x3320, 0x010E],
        };
        let wire = bytes("10 17 6C 00 04 08 00 00 00 00 33 20 01 0E");
        assert_eq!(request.encode(), wire);
        assert_eq!(Request::decode(&wire), Ok(request.clone()));
        assert_eq!(request.describe(), "FC 16 (write 5996-5999)");
        round_trip_response(
            &request,
            &Response::WriteMultiple {
                address: 5996,
                count: 4,
            },
        );
    }

    #[test]
    fn fc23_pdi_exchange_header_matches_the_register_map() {
        let request = Request::ReadWrite {
            read_address: 4996,
            read_count: 4,
            write_address: 5996,
            values: vec![0x0000, 0x0000, 0x3320, 0x018E],
        };
        let wire = request.encode();
        assert_eq!(wire[..10], bytes("17 13 84 00 04 17 6C 00 04 08")[..]);
        assert_eq!(wire[10..], bytes("00 00 00 00 33 20 01 8E")[..]);
        assert_eq!(
            request.describe(),
            "FC 23 (read 4996-4999, write 5996-5999)"
        );
        let reply = bytes("17 08 00 01 00 00 00 00 01 2C");
        assert_eq!(
            Response::decode(&request, &reply),
            Ok(Ok(Response::ReadWrite(vec![1, 0, 0, 300])))
        );
    }

    // --- FC 43 / MEI 0Dh ----------------------------------------------------------------

    #[test]
    fn fc43_read_is_what_public_code_sends() {
        // HAN MotorModbusMaster::sendReadRequest; the same bytes as the N5 manual's example.
        let request = Request::Canopen(CanopenRequest::read(1, 0x6060, 0x00, 2));
        let wire = bytes("2B 0D 00 00 01 60 60 00 00 00 00 02");
        assert_eq!(request.encode(), wire);
        assert_eq!(Request::decode(&wire), Ok(request.clone()));
        assert_eq!(request.describe(), "FC 43 (read 6060h:00, node 1, 2 bytes)");
    }

    #[test]
    fn fc43_write_is_what_public_code_sends() {
        // HAN MotorModbusMaster::sendWriteRequest: control 01h, then the data bytes.
        let request = Request::Canopen(CanopenRequest::write(5, 0x6040, 0x00, vec![0x06, 0x00]));
        let wire = bytes("2B 0D 01 00 05 60 40 00 00 00 00 02 06 00");
        assert_eq!(request.encode(), wire);
        assert_eq!(Request::decode(&wire), Ok(request));
    }

    #[test]
    fn fc43_read_response_carries_the_object_bytes() {
        let request = Request::Canopen(CanopenRequest::read(1, 0x6041, 0x00, 2));
        let wire = bytes("2B 0D 00 00 01 60 41 00 00 00 00 02 37 06");
        let Ok(Ok(Response::Canopen(response))) = Response::decode(&request, &wire) else {
            panic!("not a CANopen response");
        };
        assert_eq!(response.data, vec![0x37, 0x06]);
        assert_eq!(response.header.count, 2);
    }

    #[test]
    fn fc43_write_response_with_or_without_the_data_echo() {
        let asked = CanopenRequest::write(1, 0x6040, 0x00, vec![0x0F, 0x00]);
        let request = Request::Canopen(asked.clone());
        let echoed = bytes("2B 0D 01 00 01 60 40 00 00 00 00 02 0F 00");
        let bare = bytes("2B 0D 01 00 01 60 40 00 00 00 00 02");
        assert_eq!(
            Response::decode(&request, &echoed),
            Ok(Ok(Response::Canopen(CanopenResponse::answering(
                &asked,
                Vec::new()
            ))))
        );
        let Ok(Ok(Response::Canopen(response))) = Response::decode(&request, &bare) else {
            panic!("a write response without data must be accepted");
        };
        assert!(response.data.is_empty());
        // What we send as a server: the full echo.
        assert_eq!(
            Response::Canopen(CanopenResponse::answering(&asked, Vec::new())).encode(),
            echoed
        );
    }

    #[test]
    fn fc43_protocol_control_bits_follow_nanotec_numbering() {
        let header = CanopenHeader {
            write: true,
            extend: true,
            control2: Some(0x00),
            counter: Some(7),
            network_id: Some(1),
            encoded_data: Some(0),
            ..CanopenHeader::default()
        };
        // NT bit 0 (MSB) extend, 1 extended control, 2 counter, 5 network id, 6 encoded
        // data, 7 (LSB) access.
        assert_eq!(header.control(), 0b1110_0111);
        assert_eq!(header.encoded_len(), 2 + 2 + 1 + 3 + 8);
        let request = Request::Canopen(CanopenRequest {
            header: CanopenHeader { count: 1, ..header },
            data: vec![0xAA],
        });
        let wire = request.encode();
        assert_eq!(
            wire,
            bytes("2B 0D E7 00 00 07 01 00 00 00 00 00 00 00 00 01 AA")
        );
        round_trip_request(&request);
    }

    #[test]
    fn fc43_decoder_ignores_reserved_bits_and_byte() {
        let wire = bytes("2B 0D 18 55 01 60 41 00 00 00 00 02");
        assert_eq!(
            Request::decode(&wire),
            Ok(Request::Canopen(CanopenRequest::read(1, 0x6041, 0, 2)))
        );
    }

    #[test]
    fn fc43_with_another_mei_is_other() {
        let wire = bytes("2B 0E 01 00");
        assert_eq!(
            Request::decode(&wire),
            Ok(Request::Other {
                function: 0x2B,
                data: vec![0x0E, 0x01, 0x00]
            })
        );
    }

    #[test]
    fn fc43_errors_name_what_is_wrong() {
        let short_write = bytes("2B 0D 01 00 01 60 40 00 00 00 00 04 06 00");
        assert_eq!(
            Request::decode(&short_write).unwrap_err().to_string(),
            "FC 43 write: the number-of-data field says 4 bytes, but 2 data bytes follow"
        );
        let truncated = bytes("2B 0D 00 00 01 60");
        assert_eq!(
            Request::decode(&truncated).unwrap_err().to_string(),
            "FC 43: the PDU ends after 6 bytes, before the object index"
        );
        let request = Request::Canopen(CanopenRequest::read(1, 0x6041, 0, 2));
        let wrong_object = bytes("2B 0D 00 00 01 60 61 00 00 00 00 01 08");
        assert_eq!(
            Response::decode(&request, &wrong_object)
                .unwrap_err()
                .to_string(),
            "FC 43: the response gives object 6061h:00, the request sent 6041h:00"
        );
        let too_long = CanopenRequest::write(1, 0x2000, 0, vec![0; 250]);
        assert_eq!(
            too_long.validate().unwrap_err().to_string(),
            "FC 43: 250 data bytes do not fit one PDU (at most 241 with this header); split the transfer"
        );
    }

    // --- Exceptions ---------------------------------------------------------------------

    #[test]
    fn extended_exception_little_endian_as_in_the_n5_example() {
        // N5 manual: reading 2 bytes of a 1-byte object → 06070012h.
        let request = Request::Canopen(CanopenRequest::read(1, 0x6061, 0, 2));
        let wire = bytes("AB FF 00 06 0D CE 12 00 07 06");
        let refusal = Exception::Extended {
            function: 0x2B,
            abort: 0x0607_0012,
        };
        assert_eq!(Response::decode(&request, &wire), Ok(Err(refusal)));
        assert_eq!(refusal.encode(), wire);
        assert_eq!(
            refusal.text(),
            "Data type does not match, length of service parameter too high"
        );
        assert_eq!(
            refusal.to_string(),
            "FC 43 refused: abort 06070012h (Data type does not match, length of service parameter too high)"
        );
    }

    #[test]
    fn extended_exception_big_endian_is_recognised_when_only_it_is_known() {
        let wire = bytes("AB FF 00 06 0D CE 06 02 00 00");
        assert_eq!(
            Exception::decode(&wire),
            Ok(Exception::Extended {
                function: 0x2B,
                abort: 0x0602_0000
            })
        );
        // Neither reading known: little-endian, shown raw.
        let unknown = bytes("AB FF 00 06 0D CE 78 56 34 12");
        let refusal = Exception::decode(&unknown).expect("well-formed");
        assert_eq!(refusal.abort(), Some(AbortCode(0x1234_5678)));
        assert_eq!(refusal.text(), "not a CiA 301 abort code");
    }

    #[test]
    fn malformed_extended_exception_is_an_error_with_the_bytes() {
        let wire = bytes("AB FF 00 05 0D CE 12 00 07");
        assert_eq!(
            Exception::decode(&wire).unwrap_err().to_string(),
            "FC 43: extended exception not in Nanotec's layout (FF, length 0006h, 0Dh, CEh, 4-byte code): 00 05 0D CE 12 00 07"
        );
    }

    #[test]
    fn standard_exceptions_have_their_texts() {
        let request = Request::ReadHolding {
            address: 4996,
            count: 4,
        };
        let refusal = Exception::Standard {
            function: 3,
            code: 2,
        };
        assert_eq!(
            Response::decode(&request, &bytes("83 02")),
            Ok(Err(refusal))
        );
        assert_eq!(refusal.encode(), bytes("83 02"));
        assert_eq!(
            refusal.to_string(),
            "FC 3 refused: exception 02h, illegal data address"
        );
        let texts: Vec<_> = (1..=4)
            .map(|code| Exception::Standard { function: 3, code }.text())
            .collect();
        assert_eq!(
            texts,
            [
                "illegal function",
                "illegal data address",
                "illegal data value",
                "slave device failure"
            ]
        );
        assert_eq!(
            Exception::Standard {
                function: 3,
                code: 0x42
            }
            .text(),
            "unknown exception code"
        );
        assert_eq!(
            Exception::decode(&bytes("03 02")),
            Err(PduError::NotException(3))
        );
    }

    // --- FC 101 -------------------------------------------------------------------------

    #[test]
    fn fc101_reads_the_dictionary_frame_by_frame() {
        let restart = Request::ReadDictionary { restart: true };
        assert_eq!(restart.encode(), bytes("65 55 00"));
        assert_eq!(
            Request::ReadDictionary { restart: false }.encode(),
            bytes("65 AA 00")
        );
        assert_eq!(
            Request::decode(&bytes("65 AA 00")),
            Ok(Request::ReadDictionary { restart: false })
        );
        let wire = bytes("65 55 0E 00 10 00 04 92 01 02 00 41 60 00 02 37 06");
        let expected = Response::Dictionary {
            sub: 0x55,
            frames: vec![
                DictionaryFrame {
                    index: 0x1000,
                    subindex: 0,
                    data: vec![0x92, 0x01, 0x02, 0x00],
                },
                DictionaryFrame {
                    index: 0x6041,
                    subindex: 0,
                    data: vec![0x37, 0x06],
                },
            ],
        };
        assert_eq!(Response::decode(&restart, &wire), Ok(Ok(expected.clone())));
        assert_eq!(expected.encode(), wire);
    }

    #[test]
    fn fc101_ends_with_no_data_available_under_either_function_code() {
        let next = Request::ReadDictionary { restart: false };
        for first in ["E5", "AB"] {
            let wire = bytes(&format!("{first} FF 00 06 0D CE 24 00 00 08"));
            let Ok(Err(refusal)) = Response::decode(&next, &wire) else {
                panic!("end of dictionary not recognised after {first}");
            };
            assert_eq!(refusal.abort(), Some(AbortCode::NO_DATA));
        }
    }

    #[test]
    fn fc101_errors() {
        assert_eq!(
            Request::decode(&bytes("65 12 00")).unwrap_err().to_string(),
            "FC 101: sub-function 12h is neither 55h (restart) nor AAh (next)"
        );
        let next = Request::ReadDictionary { restart: false };
        assert_eq!(
            Response::decode(&next, &bytes("65 AA 05 00 10 00 04"))
                .unwrap_err()
                .to_string(),
            "FC 101: the length byte says 5 bytes follow, but 4 do"
        );
        assert_eq!(
            Response::decode(&next, &bytes("65 AA 05 00 10 00 04 92"))
                .unwrap_err()
                .to_string(),
            "FC 101: the PDU ends after 5 bytes, before the object frame data"
        );
    }

    // --- Limits and mismatches ----------------------------------------------------------

    #[test]
    fn quantity_limits_are_checked_both_ways() {
        let cases = [
            (
                Request::ReadHolding {
                    address: 0,
                    count: 126,
                },
                "FC 3: register count is 126, the Modbus limit is 1..=125",
            ),
            (
                Request::ReadInput {
                    address: 0,
                    count: 0,
                },
                "FC 4: register count is 0, the Modbus limit is 1..=125",
            ),
            (
                Request::WriteMultiple {
                    address: 0,
                    values: vec![0; 124],
                },
                "FC 16: register count is 124, the Modbus limit is 1..=123",
            ),
            (
                Request::ReadWrite {
                    read_address: 0,
                    read_count: 126,
                    write_address: 0,
                    values: vec![0],
                },
                "FC 23: read count is 126, the Modbus limit is 1..=125",
            ),
            (
                Request::ReadWrite {
                    read_address: 0,
                    read_count: 1,
                    write_address: 0,
                    values: vec![0; 122],
                },
                "FC 23: write count is 122, the Modbus limit is 1..=121",
            ),
        ];
        for (request, message) in cases {
            assert_eq!(request.validate().unwrap_err().to_string(), message);
            assert_eq!(
                Request::decode(&request.encode()).unwrap_err().to_string(),
                message
            );
        }
        let at_the_limits = [
            Request::ReadHolding {
                address: 0,
                count: 125,
            },
            Request::WriteMultiple {
                address: 0,
                values: vec![0; 123],
            },
            Request::ReadWrite {
                read_address: 0,
                read_count: 125,
                write_address: 0,
                values: vec![0; 121],
            },
        ];
        for request in at_the_limits {
            round_trip_request(&request);
        }
    }

    #[test]
    fn byte_counts_must_be_twice_the_count() {
        let wire = bytes("10 17 6C 00 02 03 00 00 00");
        assert_eq!(
            Request::decode(&wire).unwrap_err().to_string(),
            "FC 16: byte count 3 does not match 2 registers (must be 4)"
        );
        let request = Request::ReadHolding {
            address: 4996,
            count: 2,
        };
        assert_eq!(
            Response::decode(&request, &bytes("03 02 00 01"))
                .unwrap_err()
                .to_string(),
            "FC 3: byte count 2 does not match 2 registers (must be 4)"
        );
        assert_eq!(
            Response::decode(&request, &bytes("03 04 00 01 00"))
                .unwrap_err()
                .to_string(),
            "FC 3: the PDU ends after 5 bytes, before the register values"
        );
        assert_eq!(
            Response::decode(&request, &bytes("03 04 00 01 00 02 FF"))
                .unwrap_err()
                .to_string(),
            "FC 3: 1 unexpected bytes after the response"
        );
    }

    #[test]
    fn responses_must_answer_the_request() {
        let request = Request::ReadInput {
            address: 4996,
            count: 4,
        };
        assert_eq!(
            Response::decode(&request, &bytes("03 02 00 00"))
                .unwrap_err()
                .to_string(),
            "the response to FC 4 (read 4996-4999) has function code 3 (03h)"
        );
        let write = Request::WriteSingle {
            address: 5999,
            value: 0x010E,
        };
        assert_eq!(
            Response::decode(&write, &bytes("06 17 6F 01 0F"))
                .unwrap_err()
                .to_string(),
            "FC 6: the response gives value 271, the request sent 270"
        );
        assert_eq!(write.describe(), "FC 6 (write 5999 = 010Eh)");
        assert_eq!(
            Response::decode(
                &Request::Other {
                    function: 8,
                    data: vec![]
                },
                &bytes("08 00")
            )
            .unwrap_err()
            .to_string(),
            "FC 8: drivedeck has no decoder for the response to this function code"
        );
        assert_eq!(Response::decode(&write, &[]), Err(PduError::Empty));
        assert_eq!(Request::decode(&[]), Err(PduError::Empty));
    }

    #[test]
    fn describe_is_short() {
        let cases = [
            (
                Request::ReadHolding {
                    address: 4996,
                    count: 1,
                },
                "FC 3 (read 4996)",
            ),
            (
                Request::ReadDictionary { restart: true },
                "FC 101 (restart)",
            ),
            (
                Request::Other {
                    function: 0x2B,
                    data: vec![0x0E, 1, 0],
                },
                "FC 43 (3 data bytes)",
            ),
        ];
        for (request, text) in cases {
            assert_eq!(request.describe(), text);
        }
    }

    // --- Property tests -----------------------------------------------------------------

    fn any_header(write: bool) -> impl Strategy<Value = CanopenHeader> {
        (
            (any::<bool>(), proptest::option::of(any::<u8>())),
            proptest::option::of(any::<u8>()),
            proptest::option::of(any::<u8>()),
            proptest::option::of(any::<u8>()),
            (
                any::<u8>(),
                any::<u16>(),
                any::<u8>(),
                any::<u16>(),
                any::<u16>(),
            ),
        )
            .prop_map(
                move |(
                    (extend, control2),
                    counter,
                    network_id,
                    encoded_data,
                    (node_id, index, subindex, start, count),
                )| CanopenHeader {
                    write,
                    extend,
                    control2,
                    counter,
                    network_id,
                    encoded_data,
                    node_id,
                    index,
                    subindex,
                    start,
                    count,
                },
            )
    }

    fn any_canopen_request() -> impl Strategy<Value = CanopenRequest> {
        any::<bool>()
            .prop_flat_map(any_header)
            .prop_flat_map(|header| {
                let len = if header.write {
                    0..=header.max_data()
                } else {
                    0..=0
                };
                (Just(header), proptest::collection::vec(any::<u8>(), len))
            })
            .prop_map(|(mut header, data)| {
                if header.write {
                    header.count = saturating_u16(data.len());
                }
                CanopenRequest { header, data }
            })
    }

    fn registers_up_to(max: u16) -> impl Strategy<Value = Vec<u16>> {
        proptest::collection::vec(any::<u16>(), 1..=usize::from(max))
    }

    const KNOWN: [u8; 7] = [0x03, 0x04, 0x06, 0x10, 0x17, 0x2B, 0x65];

    /// Valid requests of every kind.
    pub(crate) fn any_request() -> impl Strategy<Value = Request> {
        prop_oneof![
            (any::<u16>(), 1..=limits::READ_MAX)
                .prop_map(|(address, count)| Request::ReadHolding { address, count }),
            (any::<u16>(), 1..=limits::READ_MAX)
                .prop_map(|(address, count)| Request::ReadInput { address, count }),
            (any::<u16>(), any::<u16>())
                .prop_map(|(address, value)| Request::WriteSingle { address, value }),
            (any::<u16>(), registers_up_to(limits::WRITE_MULTIPLE_MAX))
                .prop_map(|(address, values)| Request::WriteMultiple { address, values }),
            (
                any::<u16>(),
                1..=limits::READ_MAX,
                any::<u16>(),
                registers_up_to(limits::READ_WRITE_WRITE_MAX)
            )
                .prop_map(|(read_address, read_count, write_address, values)| {
                    Request::ReadWrite {
                        read_address,
                        read_count,
                        write_address,
                        values,
                    }
                }),
            any_canopen_request().prop_map(Request::Canopen),
            any::<bool>().prop_map(|restart| Request::ReadDictionary { restart }),
            (
                any::<u8>().prop_filter("unknown function", |f| !KNOWN.contains(f)),
                proptest::collection::vec(any::<u8>(), 0..MAX_PDU)
            )
                .prop_map(|(function, data)| Request::Other { function, data }),
            proptest::collection::vec(any::<u8>(), 0..8).prop_map(|mut data| {
                data.insert(0, MEI_DEVICE_ID);
                Request::Other {
                    function: fc::ENCAPSULATED,
                    data,
                }
            }),
        ]
    }

    fn any_frames() -> impl Strategy<Value = Vec<DictionaryFrame>> {
        proptest::collection::vec(
            (
                any::<u16>(),
                any::<u8>(),
                proptest::collection::vec(any::<u8>(), 0..=8),
            )
                .prop_map(|(index, subindex, data)| DictionaryFrame {
                    index,
                    subindex,
                    data,
                }),
            0..=20,
        )
    }

    /// A valid request with a valid normal response to it.
    pub(crate) fn any_exchange() -> impl Strategy<Value = (Request, Response)> {
        any_request()
            .prop_filter("has a response decoder", |r| {
                !matches!(r, Request::Other { .. })
            })
            .prop_flat_map(|request| {
                let response = match &request {
                    Request::ReadHolding { count, .. } => {
                        proptest::collection::vec(any::<u16>(), usize::from(*count))
                            .prop_map(Response::ReadHolding)
                            .boxed()
                    }
                    Request::ReadInput { count, .. } => {
                        proptest::collection::vec(any::<u16>(), usize::from(*count))
                            .prop_map(Response::ReadInput)
                            .boxed()
                    }
                    Request::ReadWrite { read_count, .. } => {
                        proptest::collection::vec(any::<u16>(), usize::from(*read_count))
                            .prop_map(Response::ReadWrite)
                            .boxed()
                    }
                    Request::WriteSingle { address, value } => Just(Response::WriteSingle {
                        address: *address,
                        value: *value,
                    })
                    .boxed(),
                    Request::WriteMultiple { address, values } => Just(Response::WriteMultiple {
                        address: *address,
                        count: saturating_u16(values.len()),
                    })
                    .boxed(),
                    Request::Canopen(asked) => {
                        let asked = asked.clone();
                        proptest::collection::vec(any::<u8>(), 0..=asked.header.max_data())
                            .prop_map(move |data| {
                                Response::Canopen(CanopenResponse::answering(&asked, data))
                            })
                            .boxed()
                    }
                    Request::ReadDictionary { restart } => {
                        let sub = if *restart {
                            DICTIONARY_RESTART
                        } else {
                            DICTIONARY_NEXT
                        };
                        any_frames()
                            .prop_map(move |frames| Response::Dictionary { sub, frames })
                            .boxed()
                    }
                    Request::Other { .. } => unreachable!("filtered out"),
                };
                (Just(request), response)
            })
    }

    pub(crate) fn any_exception() -> impl Strategy<Value = Exception> {
        prop_oneof![
            (0u8..0x80, 1u8..=0x0B)
                .prop_map(|(function, code)| Exception::Standard { function, code }),
            (
                prop_oneof![
                    Just(fc::ENCAPSULATED),
                    Just(fc::READ_DICTIONARY),
                    Just(fc::READ_ARRAY)
                ],
                prop_oneof![
                    Just(AbortCode::NO_OBJECT.0),
                    Just(AbortCode::NO_DATA.0),
                    Just(AbortCode::TYPE_LENGTH_TOO_HIGH.0)
                ]
            )
                .prop_map(|(function, abort)| Exception::Extended { function, abort }),
        ]
    }

    proptest! {
        #[test]
        fn request_decoder_is_total(pdu in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = Request::decode(&pdu);
            let _ = Exception::decode(&pdu);
        }

        #[test]
        fn response_decoder_is_total(
            request in any_request(),
            pdu in proptest::collection::vec(any::<u8>(), 0..300),
        ) {
            let _ = Response::decode(&request, &pdu);
        }

        #[test]
        fn response_decoder_is_total_on_near_misses(
            (request, response) in any_exchange(),
            flip in any::<(usize, u8)>(),
            cut in any::<usize>(),
        ) {
            let mut pdu = response.encode();
            let at = flip.0 % pdu.len();
            pdu[at] ^= flip.1;
            let _ = Response::decode(&request, &pdu);
            pdu.truncate(cut % (pdu.len() + 1));
            let _ = Response::decode(&request, &pdu);
        }

        #[test]
        fn requests_round_trip(request in any_request()) {
            prop_assert_eq!(request.validate(), Ok(()));
            prop_assert!(request.encode().len() <= MAX_PDU);
            round_trip_request(&request);
        }

        #[test]
        fn responses_round_trip((request, response) in any_exchange()) {
            prop_assert!(response.encode().len() <= MAX_PDU);
            round_trip_response(&request, &response);
        }

        #[test]
        fn exceptions_round_trip(refusal in any_exception()) {
            prop_assert_eq!(Exception::decode(&refusal.encode()), Ok(refusal));
        }
    }
}
