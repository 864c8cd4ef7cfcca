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

    #[error(
        "FC {function}: {what} is {value}, the Modbus limit is {}",
        crate::number::range_text(min, max)
    )]
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

mod canopen;
mod dictionary;
mod exceptions;
mod request;
mod response;

pub use canopen::{CanopenHeader, CanopenRequest, CanopenResponse, control};
pub use dictionary::DictionaryFrame;
pub use exceptions::{Exception, has_extended_exception};
pub use request::Request;
pub use response::Response;

#[cfg(test)]
pub(crate) mod tests;
