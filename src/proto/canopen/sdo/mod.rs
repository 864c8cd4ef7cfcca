//! SDO (CiA 301): the frame codec, a sans-IO client for one transfer at a time, and a sans-IO
//! server for the simulated node. No sockets, no clocks: the caller moves the frames and owns
//! the timeout (abort code 05040000h, protocol notes §2.5).
//!
//! Frames (protocol notes §2.4): requests on 600h + node, responses on 580h + node, always 8 bytes,
//! index little-endian. Byte 0 is the command specifier: ccs/scs in bits 7-5, then
//!
//! ```text
//! initiate   | cs | 0 | n n | e | s |   index LE | sub | data or size u32 LE
//! segment    | cs | t | n n n   | c |   7 data bytes (n unused at the end)
//! abort      | 1 0 0 0 0 0 0 0     |   index LE | sub | abort code u32 LE
//! ```
//!
//! | ccs (client → server)       | scs (server → client)             |
//! |-----------------------------|-----------------------------------|
//! | 0 download segment          | 0 upload segment                  |
//! | 1 initiate download         | 1 download segment acknowledged   |
//! | 2 initiate upload           | 2 initiate upload (data or size)  |
//! | 3 upload segment request    | 3 initiate download acknowledged  |
//! | 4 abort                     | 4 abort                           |
//! | 5, 6 block transfer (unsupported here), 7 invalid                |
//!
//! The toggle bit starts at 0 on every transfer, even after an abort (NT-SDO, protocol notes §2.4).
//! Every decoder is total: frames shorter than 8 bytes are zero-filled, an empty one is an
//! error, and nothing panics on any input.

use super::CanFrame;
use super::nmt::{cob, data_frame};
use crate::cia::AbortCode;

/// The largest transfer either side accepts (the simulated node's biggest objects are a few
/// kilobytes; a NanoJ program through 1F50h stays far below). A transfer that grows beyond it
/// is aborted with 05040005h (out of memory) instead of exhausting memory.
pub const MAX_TRANSFER: usize = 16 << 20;

/// How an initiate frame carries its data (protocol notes §2.4: bits e, s and n of byte 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Initiate {
    /// e = 1: the data is in bytes 4-7. `size` = `Some(1..=4)` when indicated (s = 1; e.g.
    /// 43h/4Fh, 23h/2Fh), `None` when not (42h/22h: all 4 bytes count).
    Expedited { data: [u8; 4], size: Option<u8> },
    /// e = 0: segments follow; bytes 4-7 give the total size when s = 1 (41h/21h).
    Segmented { size: Option<u32> },
}

impl Initiate {
    /// An expedited initiate with the size indicated, for 1 to 4 bytes; `None` otherwise.
    pub fn expedited(data: &[u8]) -> Option<Self> {
        if !(1..=4).contains(&data.len()) {
            return None;
        }
        let mut bytes = [0u8; 4];
        bytes[..data.len()].copy_from_slice(data);
        Some(Initiate::Expedited {
            data: bytes,
            size: Some(data.len() as u8),
        })
    }

    /// The data of an expedited initiate: the indicated size, or all 4 bytes.
    pub fn expedited_data(&self) -> Option<&[u8]> {
        match self {
            Initiate::Expedited { data, size } => {
                let len = usize::from(size.unwrap_or(4).clamp(1, 4));
                Some(&data[..len])
            }
            Initiate::Segmented { .. } => None,
        }
    }

    /// Bits 3-0 of byte 0 and bytes 4-7. An expedited size outside 1..=4 is clamped.
    fn encode(&self) -> (u8, [u8; 4]) {
        match *self {
            Initiate::Expedited { data, size: None } => (0b10, data),
            Initiate::Expedited {
                data,
                size: Some(size),
            } => {
                let size = size.clamp(1, 4);
                (((4 - size) << 2) | 0b11, data)
            }
            Initiate::Segmented { size: None } => (0b00, [0; 4]),
            Initiate::Segmented { size: Some(size) } => (0b01, size.to_le_bytes()),
        }
    }

    fn decode(b: &[u8; 8]) -> Self {
        let data = [b[4], b[5], b[6], b[7]];
        let expedited = b[0] & 0b10 != 0;
        let indicated = b[0] & 0b01 != 0;
        match (expedited, indicated) {
            (true, true) => Initiate::Expedited {
                data,
                size: Some(4 - ((b[0] >> 2) & 0b11)),
            },
            (true, false) => Initiate::Expedited { data, size: None },
            (false, true) => Initiate::Segmented {
                size: Some(u32::from_le_bytes(data)),
            },
            (false, false) => Initiate::Segmented { size: None },
        }
    }
}

/// One segment: up to 7 data bytes, the toggle bit and the last-segment flag c
/// (`000t nnnc`, protocol notes §2.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Segment {
    pub toggle: bool,
    /// c: no more segments follow.
    pub last: bool,
    len: u8,
    data: [u8; 7],
}

impl Segment {
    /// A segment of up to 7 bytes (more are cut off).
    pub fn new(toggle: bool, data: &[u8], last: bool) -> Self {
        let len = data.len().min(7);
        let mut bytes = [0u8; 7];
        bytes[..len].copy_from_slice(&data[..len]);
        Self {
            toggle,
            last,
            len: len as u8,
            data: bytes,
        }
    }

    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }

    /// Byte 0 without the command specifier (always 0 for these segments) and bytes 1-7.
    fn encode(&self) -> [u8; 8] {
        let unused = 7 - self.len.min(7);
        let mut out = [0u8; 8];
        out[0] = (u8::from(self.toggle) << 4) | (unused << 1) | u8::from(self.last);
        out[1..].copy_from_slice(&self.data);
        out
    }

    fn decode(b: &[u8; 8]) -> Self {
        let unused = usize::from((b[0] >> 1) & 0b111);
        Self::new(b[0] & 0x10 != 0, &b[1..8 - unused], b[0] & 1 != 0)
    }
}

/// What a client sends (ccs in bits 7-5 of byte 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Request {
    /// ccs 1: 2Fh/2Bh/27h/23h expedited, 21h segmented with size.
    InitiateDownload {
        index: u16,
        sub: u8,
        initiate: Initiate,
    },
    /// ccs 0.
    DownloadSegment(Segment),
    /// ccs 2: 40h.
    InitiateUpload { index: u16, sub: u8 },
    /// ccs 3: 60h / 70h.
    UploadSegment { toggle: bool },
    /// 80h.
    Abort {
        index: u16,
        sub: u8,
        code: AbortCode,
    },
    /// ccs 5 and 6 (block upload / download) and 7 (undefined): byte 0 and bytes 1-3 as sent.
    Unknown { byte0: u8, index: u16, sub: u8 },
}

/// What a server answers (scs in bits 7-5 of byte 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Response {
    /// scs 2: 4Fh/4Bh/47h/43h/42h expedited, 41h segmented with size.
    UploadInitiated {
        index: u16,
        sub: u8,
        initiate: Initiate,
    },
    /// scs 0.
    UploadSegment(Segment),
    /// scs 3: 60h.
    DownloadInitiated { index: u16, sub: u8 },
    /// scs 1: 20h / 30h.
    DownloadSegment { toggle: bool },
    /// 80h.
    Abort {
        index: u16,
        sub: u8,
        code: AbortCode,
    },
    /// scs 5, 6 and 7: byte 0 and bytes 1-3 as sent.
    Unknown { byte0: u8, index: u16, sub: u8 },
}

/// An SDO payload that cannot be decoded at all.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SdoError {
    #[error("an SDO frame carries 8 bytes; this one is empty")]
    Empty,
    #[error("an SDO frame carries 8 bytes, this one {0}")]
    TooLong(usize),
}

/// The 8 bytes of an SDO frame, shorter payloads zero-filled.
fn pad(bytes: &[u8]) -> Result<[u8; 8], SdoError> {
    if bytes.is_empty() {
        return Err(SdoError::Empty);
    }
    if bytes.len() > 8 {
        return Err(SdoError::TooLong(bytes.len()));
    }
    let mut b = [0u8; 8];
    b[..bytes.len()].copy_from_slice(bytes);
    Ok(b)
}

fn multiplexer(b: &[u8; 8]) -> (u16, u8) {
    (u16::from_le_bytes([b[1], b[2]]), b[3])
}

fn with_multiplexer(byte0: u8, index: u16, sub: u8, rest: [u8; 4]) -> [u8; 8] {
    let [lo, hi] = index.to_le_bytes();
    [byte0, lo, hi, sub, rest[0], rest[1], rest[2], rest[3]]
}

impl Request {
    pub fn encode(&self) -> [u8; 8] {
        match *self {
            Request::InitiateDownload {
                index,
                sub,
                initiate,
            } => {
                let (flags, rest) = initiate.encode();
                with_multiplexer(0x20 | flags, index, sub, rest)
            }
            Request::DownloadSegment(segment) => segment.encode(),
            Request::InitiateUpload { index, sub } => with_multiplexer(0x40, index, sub, [0; 4]),
            Request::UploadSegment { toggle } => {
                [0x60 | (u8::from(toggle) << 4), 0, 0, 0, 0, 0, 0, 0]
            }
            Request::Abort { index, sub, code } => {
                with_multiplexer(0x80, index, sub, code.0.to_le_bytes())
            }
            Request::Unknown { byte0, index, sub } => with_multiplexer(byte0, index, sub, [0; 4]),
        }
    }

    /// Decode a request payload (protocol notes §2.4).
    pub fn decode(bytes: &[u8]) -> Result<Self, SdoError> {
        let b = pad(bytes)?;
        let (index, sub) = multiplexer(&b);
        Ok(match b[0] >> 5 {
            0 => Request::DownloadSegment(Segment::decode(&b)),
            1 => Request::InitiateDownload {
                index,
                sub,
                initiate: Initiate::decode(&b),
            },
            2 => Request::InitiateUpload { index, sub },
            3 => Request::UploadSegment {
                toggle: b[0] & 0x10 != 0,
            },
            4 => Request::Abort {
                index,
                sub,
                code: AbortCode(u32::from_le_bytes([b[4], b[5], b[6], b[7]])),
            },
            _ => Request::Unknown {
                byte0: b[0],
                index,
                sub,
            },
        })
    }

    /// The request frame to a node (600h + node).
    pub fn frame(&self, node: u8) -> CanFrame {
        data_frame(cob::sdo_rx(node), &self.encode())
    }
}

impl Response {
    pub fn encode(&self) -> [u8; 8] {
        match *self {
            Response::UploadInitiated {
                index,
                sub,
                initiate,
            } => {
                let (flags, rest) = initiate.encode();
                with_multiplexer(0x40 | flags, index, sub, rest)
            }
            Response::UploadSegment(segment) => segment.encode(),
            Response::DownloadInitiated { index, sub } => {
                with_multiplexer(0x60, index, sub, [0; 4])
            }
            Response::DownloadSegment { toggle } => {
                [0x20 | (u8::from(toggle) << 4), 0, 0, 0, 0, 0, 0, 0]
            }
            Response::Abort { index, sub, code } => {
                with_multiplexer(0x80, index, sub, code.0.to_le_bytes())
            }
            Response::Unknown { byte0, index, sub } => with_multiplexer(byte0, index, sub, [0; 4]),
        }
    }

    /// Decode a response payload (protocol notes §2.4).
    pub fn decode(bytes: &[u8]) -> Result<Self, SdoError> {
        let b = pad(bytes)?;
        let (index, sub) = multiplexer(&b);
        Ok(match b[0] >> 5 {
            0 => Response::UploadSegment(Segment::decode(&b)),
            1 => Response::DownloadSegment {
                toggle: b[0] & 0x10 != 0,
            },
            2 => Response::UploadInitiated {
                index,
                sub,
                initiate: Initiate::decode(&b),
            },
            3 => Response::DownloadInitiated { index, sub },
            4 => Response::Abort {
                index,
                sub,
                code: AbortCode(u32::from_le_bytes([b[4], b[5], b[6], b[7]])),
            },
            _ => Response::Unknown {
                byte0: b[0],
                index,
                sub,
            },
        })
    }

    /// The response frame of a node (580h + node).
    pub fn frame(&self, node: u8) -> CanFrame {
        data_frame(cob::sdo_tx(node), &self.encode())
    }
}

/// The abort a client sends to a node (600h + node): for its own timeout (05040000h) or
/// after a protocol error (protocol notes §2.4, §2.5).
pub fn abort_frame(node: u8, index: u16, sub: u8, code: AbortCode) -> CanFrame {
    Request::Abort { index, sub, code }.frame(node)
}

mod client;
mod server;

pub use client::{SdoClient, SdoEvent};
pub use server::{ObjectAccess, SdoServer};
#[cfg(test)]
mod tests;
