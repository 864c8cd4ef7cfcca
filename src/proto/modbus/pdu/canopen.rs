//! FC 43 / MEI 0Dh: CANopen objects over Modbus (CiA 309-2), request and response.

use super::{MAX_PDU, MEI_CANOPEN, PduError, Reader, fc, push_u16, saturating_u16};

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

    pub(super) fn access(&self) -> &'static str {
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

    pub(super) fn encode_into(&self, out: &mut Vec<u8>) {
        self.header.encode_into(out);
        out.extend_from_slice(&self.data);
    }

    /// Decodes the rest of an FC 43 PDU after its MEI byte 0Dh.
    pub(super) fn decode(r: &mut Reader<'_>) -> Result<Self, PduError> {
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
/// [`CanopenResponse::answering`] echoes it, and
/// [`Response::decode`](super::Response::decode) accepts a write response with the data or
/// without it (protocol notes §5.20: tolerant where the record is unclear).
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

    pub(super) fn encode_into(&self, out: &mut Vec<u8>) {
        self.header.encode_into(out);
        out.extend_from_slice(&self.data);
    }

    pub(super) fn decode(r: &mut Reader<'_>) -> Result<Self, PduError> {
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
    pub(super) fn check_echo(&self, request: &CanopenRequest) -> Result<(), PduError> {
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
