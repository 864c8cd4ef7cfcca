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

/// What the client makes of a frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SdoEvent {
    /// Send this frame (the next segment request) and wait for the answer.
    Send(CanFrame),
    /// The upload is complete: the object's bytes, little-endian.
    Uploaded(Vec<u8>),
    /// The download is complete.
    Downloaded,
    /// The server refused or broke off the transfer. Nothing needs to be sent.
    Aborted(AbortCode),
    /// Not an answer to this client's transfer (another COB-ID, or no transfer running).
    Ignored,
    /// The server broke the protocol (wrong toggle, wrong index echo, unexpected command
    /// specifier). The transfer is over; send [`SdoClient::take_abort`] to tell the server.
    Protocol(String),
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum ClientState {
    Idle,
    UploadInitiate {
        index: u16,
        sub: u8,
    },
    Uploading {
        index: u16,
        sub: u8,
        toggle: bool,
        size: Option<u32>,
        data: Vec<u8>,
    },
    DownloadInitiate {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        expedited: bool,
    },
    Downloading {
        index: u16,
        sub: u8,
        /// The toggle of the segment sent last.
        toggle: bool,
        data: Vec<u8>,
        /// Bytes sent, including the segment in flight.
        sent: usize,
    },
    /// A protocol error ended the transfer; the abort to send is kept for `take_abort`.
    Failed {
        index: u16,
        sub: u8,
        code: AbortCode,
    },
}

/// A sans-IO SDO client for one node, one transfer at a time (protocol notes §2.4).
///
/// Start a transfer with [`upload`](Self::upload) or [`download`](Self::download) (which
/// replaces any transfer still running), send the frame, and feed every received frame to
/// [`on_frame`](Self::on_frame) until it returns something other than
/// [`SdoEvent::Send`] / [`SdoEvent::Ignored`]. On a timeout, send
/// [`abort`](Self::abort)`(AbortCode::SDO_TIMEOUT)`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SdoClient {
    node: u8,
    state: ClientState,
}

impl SdoClient {
    pub fn new(node: u8) -> Self {
        Self {
            node,
            state: ClientState::Idle,
        }
    }

    pub fn node(&self) -> u8 {
        self.node
    }

    /// Whether a transfer waits for an answer.
    pub fn is_busy(&self) -> bool {
        !matches!(self.state, ClientState::Idle | ClientState::Failed { .. })
    }

    /// The object of the running (or just failed) transfer.
    pub fn current(&self) -> Option<(u16, u8)> {
        match self.state {
            ClientState::Idle => None,
            ClientState::UploadInitiate { index, sub }
            | ClientState::Uploading { index, sub, .. }
            | ClientState::DownloadInitiate { index, sub, .. }
            | ClientState::Downloading { index, sub, .. }
            | ClientState::Failed { index, sub, .. } => Some((index, sub)),
        }
    }

    /// Start reading an object: `40 <index LE> <sub> 00 00 00 00`.
    pub fn upload(&mut self, index: u16, sub: u8) -> CanFrame {
        self.state = ClientState::UploadInitiate { index, sub };
        Request::InitiateUpload { index, sub }.frame(self.node)
    }

    /// Start writing an object: expedited with the size indicated for 1 to 4 bytes
    /// (2Fh/2Bh/27h/23h), otherwise segmented with the size indicated (21h), which includes
    /// an empty value (one empty last segment).
    pub fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> CanFrame {
        let (initiate, expedited) = match Initiate::expedited(data) {
            Some(initiate) => (initiate, true),
            None => (
                Initiate::Segmented {
                    size: Some(u32::try_from(data.len()).unwrap_or(u32::MAX)),
                },
                false,
            ),
        };
        self.state = ClientState::DownloadInitiate {
            index,
            sub,
            data: if expedited { Vec::new() } else { data.to_vec() },
            expedited,
        };
        Request::InitiateDownload {
            index,
            sub,
            initiate,
        }
        .frame(self.node)
    }

    /// End the running (or failed) transfer with an abort, e.g. 05040000h on the caller's
    /// timeout. `None` when no transfer runs.
    pub fn abort(&mut self, code: AbortCode) -> Option<CanFrame> {
        let (index, sub) = self.current()?;
        self.state = ClientState::Idle;
        Some(abort_frame(self.node, index, sub, code))
    }

    /// After [`SdoEvent::Protocol`]: the abort that tells the server why (05030000h for a
    /// wrong toggle, 05040001h for an unexpected command specifier, 08000000h otherwise).
    /// `None` when the last transfer did not fail that way.
    pub fn take_abort(&mut self) -> Option<CanFrame> {
        let ClientState::Failed { index, sub, code } = self.state else {
            return None;
        };
        self.state = ClientState::Idle;
        Some(abort_frame(self.node, index, sub, code))
    }

    /// Feed a received frame.
    pub fn on_frame(&mut self, frame: &CanFrame) -> SdoEvent {
        if frame.cob_id() != Some(cob::sdo_tx(self.node)) || frame.is_remote() || !self.is_busy() {
            return SdoEvent::Ignored;
        }
        let Some((index, sub)) = self.current() else {
            return SdoEvent::Ignored;
        };
        let response = match Response::decode(frame.data()) {
            Ok(response) => response,
            Err(e) => return self.fail(index, sub, AbortCode::GENERAL_ERROR, e.to_string()),
        };
        if let Response::Abort { code, .. } = response {
            self.state = ClientState::Idle;
            return SdoEvent::Aborted(code);
        }
        let state = std::mem::replace(&mut self.state, ClientState::Idle);
        match (state, response) {
            (
                ClientState::UploadInitiate { .. },
                Response::UploadInitiated {
                    index: echo_index,
                    sub: echo_sub,
                    initiate,
                },
            ) => {
                if (echo_index, echo_sub) != (index, sub) {
                    return self.wrong_echo(index, sub, echo_index, echo_sub);
                }
                match initiate {
                    Initiate::Expedited { .. } => {
                        SdoEvent::Uploaded(initiate.expedited_data().unwrap_or_default().to_vec())
                    }
                    Initiate::Segmented { size } => {
                        if let Some(size) = size
                            && usize::try_from(size).map_or(true, |s| s > MAX_TRANSFER)
                        {
                            return self.fail(
                                index,
                                sub,
                                AbortCode::OUT_OF_MEMORY,
                                format!(
                                    "the object has {size} bytes, more than the {MAX_TRANSFER} a transfer may bring"
                                ),
                            );
                        }
                        self.state = ClientState::Uploading {
                            index,
                            sub,
                            toggle: false,
                            size,
                            data: Vec::new(),
                        };
                        SdoEvent::Send(Request::UploadSegment { toggle: false }.frame(self.node))
                    }
                }
            }
            (
                ClientState::Uploading {
                    toggle,
                    size,
                    mut data,
                    ..
                },
                Response::UploadSegment(segment),
            ) => {
                if segment.toggle != toggle {
                    return self.wrong_toggle(index, sub, toggle);
                }
                data.extend_from_slice(segment.data());
                let expected = size.map(|s| usize::try_from(s).unwrap_or(usize::MAX));
                if let Some(expected) = expected
                    && data.len() > expected
                {
                    return self.fail(
                        index,
                        sub,
                        AbortCode::GENERAL_ERROR,
                        format!("the upload brings more than the {expected} bytes it announced"),
                    );
                }
                if data.len() > MAX_TRANSFER {
                    return self.fail(
                        index,
                        sub,
                        AbortCode::OUT_OF_MEMORY,
                        format!("the upload brings more than {MAX_TRANSFER} bytes"),
                    );
                }
                if segment.last {
                    if let Some(expected) = expected
                        && data.len() != expected
                    {
                        return self.fail(
                            index,
                            sub,
                            AbortCode::GENERAL_ERROR,
                            format!(
                                "the upload ended after {} bytes, {expected} were announced",
                                data.len()
                            ),
                        );
                    }
                    return SdoEvent::Uploaded(data);
                }
                self.state = ClientState::Uploading {
                    index,
                    sub,
                    toggle: !toggle,
                    size,
                    data,
                };
                SdoEvent::Send(Request::UploadSegment { toggle: !toggle }.frame(self.node))
            }
            (
                ClientState::DownloadInitiate {
                    data, expedited, ..
                },
                Response::DownloadInitiated {
                    index: echo_index,
                    sub: echo_sub,
                },
            ) => {
                if (echo_index, echo_sub) != (index, sub) {
                    return self.wrong_echo(index, sub, echo_index, echo_sub);
                }
                if expedited {
                    return SdoEvent::Downloaded;
                }
                self.next_segment(index, sub, false, data, 0)
            }
            (
                ClientState::Downloading {
                    toggle, data, sent, ..
                },
                Response::DownloadSegment { toggle: echo },
            ) => {
                if echo != toggle {
                    return self.wrong_toggle(index, sub, toggle);
                }
                if sent >= data.len() {
                    return SdoEvent::Downloaded;
                }
                self.next_segment(index, sub, !toggle, data, sent)
            }
            (state, response) => {
                let waiting = match state {
                    ClientState::UploadInitiate { .. } => "the upload initiate response",
                    ClientState::Uploading { .. } => "an upload segment",
                    ClientState::DownloadInitiate { .. } => "the download initiate response",
                    _ => "a download segment acknowledgement",
                };
                self.fail(
                    index,
                    sub,
                    AbortCode::INVALID_COMMAND_SPECIFIER,
                    format!(
                        "expected {waiting}, got command byte {:02X}h",
                        response.encode()[0]
                    ),
                )
            }
        }
    }

    fn next_segment(
        &mut self,
        index: u16,
        sub: u8,
        toggle: bool,
        data: Vec<u8>,
        offset: usize,
    ) -> SdoEvent {
        let end = data.len().min(offset.saturating_add(7));
        let chunk = data.get(offset..end).unwrap_or_default();
        let segment = Segment::new(toggle, chunk, end >= data.len());
        self.state = ClientState::Downloading {
            index,
            sub,
            toggle,
            data,
            sent: end,
        };
        SdoEvent::Send(Request::DownloadSegment(segment).frame(self.node))
    }

    fn fail(&mut self, index: u16, sub: u8, code: AbortCode, message: String) -> SdoEvent {
        self.state = ClientState::Failed { index, sub, code };
        SdoEvent::Protocol(format!(
            "SDO node {} {index:04X}h:{sub:02X}h: {message}",
            self.node
        ))
    }

    fn wrong_toggle(&mut self, index: u16, sub: u8, expected: bool) -> SdoEvent {
        self.fail(
            index,
            sub,
            AbortCode::TOGGLE_BIT_NOT_ALTERNATED,
            format!(
                "segment with toggle {}, expected {}",
                u8::from(!expected),
                u8::from(expected)
            ),
        )
    }

    fn wrong_echo(&mut self, index: u16, sub: u8, echo_index: u16, echo_sub: u8) -> SdoEvent {
        self.fail(
            index,
            sub,
            AbortCode::GENERAL_ERROR,
            format!("the response names {echo_index:04X}h:{echo_sub:02X}h"),
        )
    }
}

/// Object access for an SDO server: bytes little-endian, sized by the object.
pub trait ObjectAccess {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode>;
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum ServerState {
    Idle,
    Uploading {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        offset: usize,
        toggle: bool,
    },
    Downloading {
        index: u16,
        sub: u8,
        size: Option<usize>,
        data: Vec<u8>,
        toggle: bool,
    },
}

/// A sans-IO SDO server for a simulated node (protocol notes §2.4, §2.5): expedited and
/// segmented upload and download, one transfer at a time. A new initiate while a transfer
/// runs restarts; block transfer is answered with 05040001h.
///
/// Aborts it sends: the object's own code from [`ObjectAccess`]; 05030000h for a segment with
/// the wrong toggle; 05040001h for an unknown command specifier, block transfer, an empty
/// frame, or a segment without an initiated transfer (named 0000h:00h then); 06070012h /
/// 06070013h when a segmented download brings more / fewer bytes than its initiate announced;
/// 05040005h beyond [`MAX_TRANSFER`]. Values up to 4 bytes are uploaded expedited, longer and
/// empty ones segmented; an expedited download without the size (22h) writes all 4 bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SdoServer {
    node: u8,
    state: ServerState,
}

impl SdoServer {
    pub fn new(node: u8) -> Self {
        Self {
            node,
            state: ServerState::Idle,
        }
    }

    pub fn node(&self) -> u8 {
        self.node
    }

    /// Whether a segmented transfer is in progress.
    pub fn is_busy(&self) -> bool {
        self.state != ServerState::Idle
    }

    /// Forget any transfer (NMT reset communication).
    pub fn reset(&mut self) {
        self.state = ServerState::Idle;
    }

    /// Answer a frame addressed to this node (600h + node); `None` for any other frame and
    /// for an abort from the client.
    pub fn on_request(&mut self, frame: &CanFrame, od: &mut impl ObjectAccess) -> Option<CanFrame> {
        if frame.cob_id() != Some(cob::sdo_rx(self.node)) || frame.is_remote() {
            return None;
        }
        let response = match Request::decode(frame.data()) {
            Ok(request) => self.answer(request, od),
            Err(_) => self.abort(0, 0, AbortCode::INVALID_COMMAND_SPECIFIER),
        };
        response.map(|r| r.frame(self.node))
    }

    fn answer(&mut self, request: Request, od: &mut impl ObjectAccess) -> Option<Response> {
        let state = std::mem::replace(&mut self.state, ServerState::Idle);
        match request {
            Request::Abort { .. } => None,
            Request::InitiateUpload { index, sub } => Some(self.initiate_upload(index, sub, od)),
            Request::UploadSegment { toggle } => {
                let ServerState::Uploading {
                    index,
                    sub,
                    data,
                    offset,
                    toggle: expected,
                } = state
                else {
                    return self.abort_state(&state, AbortCode::INVALID_COMMAND_SPECIFIER);
                };
                if toggle != expected {
                    return self.abort(index, sub, AbortCode::TOGGLE_BIT_NOT_ALTERNATED);
                }
                let end = data.len().min(offset.saturating_add(7));
                let last = end >= data.len();
                let segment = Segment::new(toggle, data.get(offset..end).unwrap_or_default(), last);
                if !last {
                    self.state = ServerState::Uploading {
                        index,
                        sub,
                        data,
                        offset: end,
                        toggle: !toggle,
                    };
                }
                Some(Response::UploadSegment(segment))
            }
            Request::InitiateDownload {
                index,
                sub,
                initiate,
            } => match initiate {
                Initiate::Expedited { .. } => {
                    let data = initiate.expedited_data().unwrap_or_default();
                    match od.write(index, sub, data) {
                        Ok(()) => Some(Response::DownloadInitiated { index, sub }),
                        Err(code) => self.abort(index, sub, code),
                    }
                }
                Initiate::Segmented { size } => {
                    let size = size.map(|s| usize::try_from(s).unwrap_or(usize::MAX));
                    if size.is_some_and(|s| s > MAX_TRANSFER) {
                        return self.abort(index, sub, AbortCode::OUT_OF_MEMORY);
                    }
                    self.state = ServerState::Downloading {
                        index,
                        sub,
                        size,
                        data: Vec::new(),
                        toggle: false,
                    };
                    Some(Response::DownloadInitiated { index, sub })
                }
            },
            Request::DownloadSegment(segment) => {
                let ServerState::Downloading {
                    index,
                    sub,
                    size,
                    mut data,
                    toggle,
                } = state
                else {
                    return self.abort_state(&state, AbortCode::INVALID_COMMAND_SPECIFIER);
                };
                if segment.toggle != toggle {
                    return self.abort(index, sub, AbortCode::TOGGLE_BIT_NOT_ALTERNATED);
                }
                data.extend_from_slice(segment.data());
                if data.len() > size.unwrap_or(MAX_TRANSFER) {
                    let code = match size {
                        Some(_) => AbortCode::TYPE_LENGTH_TOO_HIGH,
                        None => AbortCode::OUT_OF_MEMORY,
                    };
                    return self.abort(index, sub, code);
                }
                if !segment.last {
                    self.state = ServerState::Downloading {
                        index,
                        sub,
                        size,
                        data,
                        toggle: !toggle,
                    };
                    return Some(Response::DownloadSegment { toggle });
                }
                if size.is_some_and(|s| data.len() < s) {
                    return self.abort(index, sub, AbortCode::TYPE_LENGTH_TOO_LOW);
                }
                match od.write(index, sub, &data) {
                    Ok(()) => Some(Response::DownloadSegment { toggle }),
                    Err(code) => self.abort(index, sub, code),
                }
            }
            Request::Unknown { index, sub, .. } => {
                self.abort(index, sub, AbortCode::INVALID_COMMAND_SPECIFIER)
            }
        }
    }

    fn initiate_upload(&mut self, index: u16, sub: u8, od: &mut impl ObjectAccess) -> Response {
        let data = match od.read(index, sub) {
            Ok(data) => data,
            Err(code) => return Response::Abort { index, sub, code },
        };
        if let Some(initiate) = Initiate::expedited(&data) {
            return Response::UploadInitiated {
                index,
                sub,
                initiate,
            };
        }
        let Ok(size) = u32::try_from(data.len()) else {
            return Response::Abort {
                index,
                sub,
                code: AbortCode::OUT_OF_MEMORY,
            };
        };
        self.state = ServerState::Uploading {
            index,
            sub,
            data,
            offset: 0,
            toggle: false,
        };
        Response::UploadInitiated {
            index,
            sub,
            initiate: Initiate::Segmented { size: Some(size) },
        }
    }

    fn abort(&mut self, index: u16, sub: u8, code: AbortCode) -> Option<Response> {
        self.state = ServerState::Idle;
        Some(Response::Abort { index, sub, code })
    }

    /// Abort naming the transfer that was running, or 0000h:00h when none was.
    fn abort_state(&mut self, state: &ServerState, code: AbortCode) -> Option<Response> {
        let (index, sub) = match *state {
            ServerState::Idle => (0, 0),
            ServerState::Uploading { index, sub, .. }
            | ServerState::Downloading { index, sub, .. } => (index, sub),
        };
        self.abort(index, sub, code)
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use proptest::prelude::*;

    use super::*;

    /// An object of the fake dictionary: value, fixed size (`None` = any), writable.
    type FakeObject = (Vec<u8>, Option<usize>, bool);

    /// A fake object dictionary: fixed-size objects check the length.
    #[derive(Default)]
    struct FakeOd {
        objects: BTreeMap<(u16, u8), FakeObject>,
        writes: Vec<(u16, u8, Vec<u8>)>,
    }

    impl FakeOd {
        fn new() -> Self {
            let mut od = FakeOd::default();
            od.add(0x1018, 0x01, &0x0000_026Cu32.to_le_bytes(), Some(4), false);
            od.add(0x1017, 0x00, &[0, 0], Some(2), true);
            od.add(0x6040, 0x00, &[0, 0], Some(2), true);
            od.add(0x1008, 0x00, b"PD4-C5918L4204-E-08 (CAN)", None, false);
            od.add(0x2400, 0x01, &[], None, true);
            od
        }

        fn add(&mut self, index: u16, sub: u8, data: &[u8], size: Option<usize>, rw: bool) {
            self.objects.insert((index, sub), (data.to_vec(), size, rw));
        }
    }

    impl ObjectAccess for FakeOd {
        fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
            match self.objects.get(&(index, sub)) {
                Some((data, _, _)) => Ok(data.clone()),
                None if self.objects.keys().any(|(i, _)| *i == index) => {
                    Err(AbortCode::NO_SUBINDEX)
                }
                None => Err(AbortCode::NO_OBJECT),
            }
        }

        fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
            let Some((value, size, rw)) = self.objects.get_mut(&(index, sub)) else {
                return Err(AbortCode::NO_OBJECT);
            };
            if !*rw {
                return Err(AbortCode::READ_ONLY);
            }
            if size.is_some_and(|s| s != data.len()) {
                return Err(AbortCode::TYPE_LENGTH_MISMATCH);
            }
            *value = data.to_vec();
            self.writes.push((index, sub, data.to_vec()));
            Ok(())
        }
    }

    fn req(bytes: [u8; 8]) -> CanFrame {
        CanFrame::new(0x601, &bytes).unwrap()
    }

    fn resp(bytes: [u8; 8]) -> CanFrame {
        CanFrame::new(0x581, &bytes).unwrap()
    }

    fn abort_bytes(index: u16, sub: u8, code: AbortCode) -> [u8; 8] {
        Response::Abort { index, sub, code }.encode()
    }

    /// Run a transfer between client and server until the client reports an outcome.
    fn run(
        client: &mut SdoClient,
        server: &mut SdoServer,
        od: &mut FakeOd,
        first: CanFrame,
    ) -> SdoEvent {
        let mut request = first;
        for _ in 0..10_000 {
            let Some(response) = server.on_request(&request, od) else {
                return SdoEvent::Ignored;
            };
            match client.on_frame(&response) {
                SdoEvent::Send(next) => request = next,
                outcome => return outcome,
            }
        }
        panic!("transfer did not end");
    }

    #[test]
    fn reading_1018_01_byte_for_byte() {
        let mut client = SdoClient::new(1);
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let request = client.upload(0x1018, 0x01);
        assert_eq!(request, req([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]));
        let response = server.on_request(&request, &mut od).unwrap();
        assert_eq!(
            response,
            resp([0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0x00, 0x00])
        );
        assert_eq!(
            client.on_frame(&response),
            SdoEvent::Uploaded(vec![0x6C, 0x02, 0, 0])
        );
        assert!(!client.is_busy());
    }

    #[test]
    fn expedited_sizes_and_unindicated_size() {
        for (byte0, len) in [(0x4F, 1), (0x4B, 2), (0x47, 3), (0x43, 4), (0x42, 4)] {
            let mut client = SdoClient::new(1);
            client.upload(0x2000, 0);
            let frame = resp([byte0, 0x00, 0x20, 0x00, 1, 2, 3, 4]);
            assert_eq!(
                client.on_frame(&frame),
                SdoEvent::Uploaded(vec![1, 2, 3, 4][..len].to_vec()),
                "{byte0:02X}"
            );
        }
        let mut od = FakeOd::new();
        od.add(0x2000, 1, &[7], Some(1), true);
        od.add(0x2000, 3, &[7, 8, 9], Some(3), true);
        let mut server = SdoServer::new(1);
        let r = server
            .on_request(&req([0x40, 0x00, 0x20, 1, 0, 0, 0, 0]), &mut od)
            .unwrap();
        assert_eq!(r, resp([0x4F, 0x00, 0x20, 1, 7, 0, 0, 0]));
        let r = server
            .on_request(&req([0x40, 0x00, 0x20, 3, 0, 0, 0, 0]), &mut od)
            .unwrap();
        assert_eq!(r, resp([0x47, 0x00, 0x20, 3, 7, 8, 9, 0]));
    }

    #[test]
    fn writing_a_u16_byte_for_byte() {
        let mut client = SdoClient::new(1);
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let request = client.download(0x6040, 0x00, &0x000Fu16.to_le_bytes());
        assert_eq!(request, req([0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0, 0]));
        let response = server.on_request(&request, &mut od).unwrap();
        assert_eq!(response, resp([0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0]));
        assert_eq!(client.on_frame(&response), SdoEvent::Downloaded);
        assert_eq!(od.writes, vec![(0x6040, 0, vec![0x0F, 0x00])]);
        // The other expedited sizes.
        assert_eq!(client.download(0x2000, 1, &[1]).data()[0], 0x2F);
        assert_eq!(client.download(0x2000, 1, &[1, 2, 3]).data()[0], 0x27);
        assert_eq!(
            client.download(0x2000, 1, &[1, 2, 3, 4]),
            req([0x23, 0x00, 0x20, 0x01, 1, 2, 3, 4])
        );
    }

    #[test]
    fn segmented_upload_of_25_bytes_in_4_segments() {
        let mut client = SdoClient::new(1);
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let name = b"PD4-C5918L4204-E-08 (CAN)";
        assert_eq!(name.len(), 25);

        let request = client.upload(0x1008, 0x00);
        let response = server.on_request(&request, &mut od).unwrap();
        assert_eq!(response, resp([0x41, 0x08, 0x10, 0x00, 25, 0, 0, 0]));
        let mut want_requests = vec![
            [0x60, 0, 0, 0, 0, 0, 0, 0],
            [0x70, 0, 0, 0, 0, 0, 0, 0],
            [0x60, 0, 0, 0, 0, 0, 0, 0],
            [0x70, 0, 0, 0, 0, 0, 0, 0],
        ]
        .into_iter();
        let mut want_responses = vec![
            [0x00, b'P', b'D', b'4', b'-', b'C', b'5', b'9'],
            [0x10, b'1', b'8', b'L', b'4', b'2', b'0', b'4'],
            [0x00, b'-', b'E', b'-', b'0', b'8', b' ', b'('],
            // t = 1, n = 3 unused, c = 1.
            [0x17, b'C', b'A', b'N', b')', 0, 0, 0],
        ]
        .into_iter();
        let mut event = client.on_frame(&response);
        while let SdoEvent::Send(request) = event {
            assert_eq!(request, req(want_requests.next().unwrap()));
            let response = server.on_request(&request, &mut od).unwrap();
            assert_eq!(response, resp(want_responses.next().unwrap()));
            event = client.on_frame(&response);
        }
        assert_eq!(event, SdoEvent::Uploaded(name.to_vec()));
        assert!(want_requests.next().is_none() && want_responses.next().is_none());
        assert!(!server.is_busy());
    }

    #[test]
    fn segmented_download_of_10_bytes() {
        let mut client = SdoClient::new(1);
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let data = b"0123456789";
        let request = client.download(0x2400, 0x01, data);
        assert_eq!(request, req([0x21, 0x00, 0x24, 0x01, 10, 0, 0, 0]));
        let response = server.on_request(&request, &mut od).unwrap();
        assert_eq!(response, resp([0x60, 0x00, 0x24, 0x01, 0, 0, 0, 0]));
        let SdoEvent::Send(first) = client.on_frame(&response) else {
            panic!("no first segment")
        };
        assert_eq!(first, req([0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']));
        let response = server.on_request(&first, &mut od).unwrap();
        assert_eq!(response, resp([0x20, 0, 0, 0, 0, 0, 0, 0]));
        let SdoEvent::Send(second) = client.on_frame(&response) else {
            panic!("no second segment")
        };
        // t = 1, n = 4 unused, c = 1.
        assert_eq!(second, req([0x19, b'7', b'8', b'9', 0, 0, 0, 0]));
        let response = server.on_request(&second, &mut od).unwrap();
        assert_eq!(response, resp([0x30, 0, 0, 0, 0, 0, 0, 0]));
        assert_eq!(client.on_frame(&response), SdoEvent::Downloaded);
        assert_eq!(od.writes, vec![(0x2400, 1, data.to_vec())]);
    }

    #[test]
    fn empty_values_go_segmented() {
        let mut client = SdoClient::new(1);
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let first = client.download(0x2400, 1, &[]);
        assert_eq!(first, req([0x21, 0x00, 0x24, 0x01, 0, 0, 0, 0]));
        assert_eq!(
            run(&mut client, &mut server, &mut od, first),
            SdoEvent::Downloaded
        );
        let first = client.upload(0x2400, 1);
        assert_eq!(
            run(&mut client, &mut server, &mut od, first),
            SdoEvent::Uploaded(vec![])
        );
    }

    #[test]
    fn server_abort_paths() {
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let mut ask = |bytes: [u8; 8]| server.on_request(&req(bytes), &mut od);
        // Object and sub-index that do not exist.
        assert_eq!(
            ask([0x40, 0x34, 0x12, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(0x1234, 0, AbortCode::NO_OBJECT)))
        );
        assert_eq!(
            ask([0x40, 0x18, 0x10, 9, 0, 0, 0, 0]),
            Some(resp([0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06]))
        );
        // Read-only, wrong length.
        assert_eq!(
            ask([0x23, 0x18, 0x10, 1, 1, 2, 3, 4]),
            Some(resp(abort_bytes(0x1018, 1, AbortCode::READ_ONLY)))
        );
        assert_eq!(
            ask([0x2F, 0x40, 0x60, 0, 1, 0, 0, 0]),
            Some(resp(abort_bytes(
                0x6040,
                0,
                AbortCode::TYPE_LENGTH_MISMATCH
            )))
        );
        // Segments without a transfer.
        assert_eq!(
            ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(
                0,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
        assert_eq!(
            ask([0x00, 1, 2, 3, 4, 5, 6, 7]),
            Some(resp(abort_bytes(
                0,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
        // Block upload, block download, ccs 7.
        for byte0 in [0xA0, 0xC0, 0xE0] {
            assert_eq!(
                ask([byte0, 0x08, 0x10, 0, 0, 0, 0, 0]),
                Some(resp(abort_bytes(
                    0x1008,
                    0,
                    AbortCode::INVALID_COMMAND_SPECIFIER
                )))
            );
        }
        // Wrong toggle in an upload: the first request must carry t = 0.
        assert_eq!(
            ask([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]).map(|f| f.data()[0]),
            Some(0x41)
        );
        assert_eq!(
            ask([0x70, 0, 0, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(
                0x1008,
                0,
                AbortCode::TOGGLE_BIT_NOT_ALTERNATED
            )))
        );
        // The abort ended the transfer.
        assert_eq!(
            ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(
                0,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
        // Wrong toggle in a download.
        assert!(ask([0x21, 0x00, 0x24, 1, 10, 0, 0, 0]).is_some());
        assert_eq!(
            ask([0x10, 1, 2, 3, 4, 5, 6, 7]),
            Some(resp(abort_bytes(
                0x2400,
                1,
                AbortCode::TOGGLE_BIT_NOT_ALTERNATED
            )))
        );
        // More and fewer bytes than announced.
        assert!(ask([0x21, 0x00, 0x24, 1, 3, 0, 0, 0]).is_some());
        assert_eq!(
            ask([0x01, 1, 2, 3, 4, 5, 6, 7]),
            Some(resp(abort_bytes(
                0x2400,
                1,
                AbortCode::TYPE_LENGTH_TOO_HIGH
            )))
        );
        assert!(ask([0x21, 0x00, 0x24, 1, 9, 0, 0, 0]).is_some());
        assert_eq!(
            ask([0x01, 1, 2, 3, 4, 5, 6, 7]),
            Some(resp(abort_bytes(0x2400, 1, AbortCode::TYPE_LENGTH_TOO_LOW)))
        );
        // Segmented download into a read-only object: aborted when the data is complete.
        assert!(ask([0x21, 0x08, 0x10, 0, 1, 0, 0, 0]).is_some());
        assert_eq!(
            ask([0x0D, b'x', 0, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(0x1008, 0, AbortCode::READ_ONLY)))
        );
        // A client abort ends a transfer without an answer.
        assert!(ask([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]).is_some());
        assert_eq!(
            ask(abort_frame(1, 0x1008, 0, AbortCode::SDO_TIMEOUT)
                .data()
                .try_into()
                .unwrap()),
            None
        );
        assert_eq!(
            ask([0x60, 0, 0, 0, 0, 0, 0, 0]),
            Some(resp(abort_bytes(
                0,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
        // An empty frame is answered with an abort too.
        assert_eq!(
            server.on_request(&CanFrame::new(0x601, &[]).unwrap(), &mut od),
            Some(resp(abort_bytes(
                0,
                0,
                AbortCode::INVALID_COMMAND_SPECIFIER
            )))
        );
        // Frames for other nodes and other services are not answered.
        assert_eq!(
            server.on_request(
                &CanFrame::new(0x602, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
                &mut od
            ),
            None
        );
        assert_eq!(
            server.on_request(
                &CanFrame::new(0x581, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
                &mut od
            ),
            None
        );
        assert_eq!(
            server.on_request(&CanFrame::remote(0x601, 8).unwrap(), &mut od),
            None
        );
    }

    #[test]
    fn a_new_initiate_restarts_the_server() {
        let mut server = SdoServer::new(1);
        let mut od = FakeOd::new();
        let upload = req([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]);
        server.on_request(&upload, &mut od).unwrap();
        server
            .on_request(&req([0x60, 0, 0, 0, 0, 0, 0, 0]), &mut od)
            .unwrap();
        // Restart: the toggle starts at 0 again and the data from the start.
        server.on_request(&upload, &mut od).unwrap();
        let r = server
            .on_request(&req([0x60, 0, 0, 0, 0, 0, 0, 0]), &mut od)
            .unwrap();
        assert_eq!(r, resp([0x00, b'P', b'D', b'4', b'-', b'C', b'5', b'9']));
        // An expedited read in between ends the segmented one.
        server
            .on_request(&req([0x40, 0x18, 0x10, 1, 0, 0, 0, 0]), &mut od)
            .unwrap();
        assert!(!server.is_busy());
    }

    #[test]
    fn client_abort_paths() {
        // The server's abort.
        let mut client = SdoClient::new(1);
        client.upload(0x1018, 9);
        let abort = resp(abort_bytes(0x1018, 9, AbortCode::NO_SUBINDEX));
        assert_eq!(
            client.on_frame(&abort),
            SdoEvent::Aborted(AbortCode::NO_SUBINDEX)
        );
        assert!(!client.is_busy());
        assert_eq!(client.take_abort(), None);
        // A late frame after the end is not ours.
        assert_eq!(client.on_frame(&abort), SdoEvent::Ignored);

        // Timeout: the caller aborts with 05040000h.
        client.upload(0x1018, 1);
        assert_eq!(
            client.abort(AbortCode::SDO_TIMEOUT),
            Some(req([0x80, 0x18, 0x10, 0x01, 0x00, 0x00, 0x04, 0x05]))
        );
        assert_eq!(client.abort(AbortCode::SDO_TIMEOUT), None);
        assert_eq!(
            abort_frame(1, 0x1018, 1, AbortCode::SDO_TIMEOUT),
            req([0x80, 0x18, 0x10, 0x01, 0x00, 0x00, 0x04, 0x05])
        );

        // Wrong index echo.
        client.upload(0x1018, 1);
        let wrong = resp([0x43, 0x18, 0x10, 0x02, 1, 0, 0, 0]);
        let SdoEvent::Protocol(message) = client.on_frame(&wrong) else {
            panic!("echo not checked")
        };
        assert!(message.contains("1018h:02h"), "{message}");
        assert_eq!(
            client.take_abort(),
            Some(req(with_multiplexer(
                0x80,
                0x1018,
                1,
                AbortCode::GENERAL_ERROR.0.to_le_bytes()
            )))
        );
        client.download(0x6040, 0, &[6, 0]);
        let wrong = resp([0x60, 0x41, 0x60, 0x00, 0, 0, 0, 0]);
        assert!(matches!(client.on_frame(&wrong), SdoEvent::Protocol(_)));

        // Wrong toggle in an upload segment.
        client.upload(0x1008, 0);
        let SdoEvent::Send(_) = client.on_frame(&resp([0x41, 0x08, 0x10, 0, 25, 0, 0, 0])) else {
            panic!()
        };
        let SdoEvent::Protocol(message) = client.on_frame(&resp([0x10, 1, 2, 3, 4, 5, 6, 7]))
        else {
            panic!("toggle not checked")
        };
        assert!(message.contains("toggle"), "{message}");
        assert_eq!(
            client.take_abort(),
            Some(req(with_multiplexer(
                0x80,
                0x1008,
                0,
                AbortCode::TOGGLE_BIT_NOT_ALTERNATED.0.to_le_bytes()
            )))
        );

        // Wrong toggle in a download segment acknowledgement.
        client.download(0x2400, 1, b"0123456789");
        let SdoEvent::Send(_) = client.on_frame(&resp([0x60, 0x00, 0x24, 1, 0, 0, 0, 0])) else {
            panic!()
        };
        assert!(matches!(
            client.on_frame(&resp([0x30, 0, 0, 0, 0, 0, 0, 0])),
            SdoEvent::Protocol(_)
        ));

        // Unexpected command specifier: a download answer to an upload.
        client.upload(0x1018, 1);
        assert!(matches!(
            client.on_frame(&resp([0x60, 0x18, 0x10, 1, 0, 0, 0, 0])),
            SdoEvent::Protocol(_)
        ));
        assert_eq!(
            client.take_abort().map(|f| f.data()[4..].to_vec()),
            Some(
                AbortCode::INVALID_COMMAND_SPECIFIER
                    .0
                    .to_le_bytes()
                    .to_vec()
            )
        );

        // More segment data than announced, and less.
        client.upload(0x1008, 0);
        client.on_frame(&resp([0x41, 0x08, 0x10, 0, 3, 0, 0, 0]));
        assert!(matches!(
            client.on_frame(&resp([0x00, 1, 2, 3, 4, 5, 6, 7])),
            SdoEvent::Protocol(_)
        ));
        client.upload(0x1008, 0);
        client.on_frame(&resp([0x41, 0x08, 0x10, 0, 9, 0, 0, 0]));
        assert!(matches!(
            client.on_frame(&resp([0x0B, 1, 2, 0, 0, 0, 0, 0])),
            SdoEvent::Protocol(_)
        ));

        // An announced size beyond the limit.
        client.upload(0x1008, 0);
        assert!(matches!(
            client.on_frame(&resp([0x41, 0x08, 0x10, 0, 0xFF, 0xFF, 0xFF, 0xFF])),
            SdoEvent::Protocol(_)
        ));
        assert_eq!(
            client.take_abort().map(|f| f.data()[4..].to_vec()),
            Some(AbortCode::OUT_OF_MEMORY.0.to_le_bytes().to_vec())
        );

        // An empty response.
        client.upload(0x1018, 1);
        assert!(matches!(
            client.on_frame(&CanFrame::new(0x581, &[]).unwrap()),
            SdoEvent::Protocol(_)
        ));

        // Frames of other nodes and services are not ours; the transfer goes on.
        client.upload(0x1018, 1);
        let answer = [0x43, 0x18, 0x10, 0x01, 0x6C, 0x02, 0x00, 0x00];
        assert_eq!(
            client.on_frame(&CanFrame::new(0x582, &answer).unwrap()),
            SdoEvent::Ignored
        );
        assert_eq!(
            client.on_frame(&CanFrame::new(0x601, &answer).unwrap()),
            SdoEvent::Ignored
        );
        assert_eq!(
            client.on_frame(&resp(answer)),
            SdoEvent::Uploaded(vec![0x6C, 0x02, 0, 0])
        );
    }

    #[test]
    fn segmented_upload_without_size_and_short_frames() {
        let mut client = SdoClient::new(1);
        client.upload(0x1008, 0);
        let SdoEvent::Send(r) = client.on_frame(&resp([0x40, 0x08, 0x10, 0, 0, 0, 0, 0])) else {
            panic!()
        };
        assert_eq!(r.data()[0], 0x60);
        // A last segment with DLC 3 (n = 5 unused).
        let short = CanFrame::new(0x581, &[0x0B, b'h', b'i']).unwrap();
        assert_eq!(client.on_frame(&short), SdoEvent::Uploaded(b"hi".to_vec()));
    }

    #[test]
    fn codec_round_trips() {
        let requests = [
            Request::InitiateUpload {
                index: 0x1018,
                sub: 1,
            },
            Request::UploadSegment { toggle: true },
            Request::DownloadSegment(Segment::new(true, &[1, 2, 3], true)),
            Request::InitiateDownload {
                index: 0x6040,
                sub: 0,
                initiate: Initiate::expedited(&[6, 0]).unwrap(),
            },
            Request::InitiateDownload {
                index: 0x6040,
                sub: 0,
                initiate: Initiate::Segmented { size: None },
            },
            Request::Abort {
                index: 1,
                sub: 2,
                code: AbortCode::GENERAL_ERROR,
            },
        ];
        for r in requests {
            assert_eq!(Request::decode(&r.encode()), Ok(r));
        }
        assert_eq!(Request::decode(&[]), Err(SdoError::Empty));
        assert_eq!(Response::decode(&[0; 9]), Err(SdoError::TooLong(9)));
    }

    proptest! {
        #[test]
        fn server_never_panics(
            frames in proptest::collection::vec(
                (prop_oneof![Just(0x601u16), 0u16..0x800], proptest::collection::vec(any::<u8>(), 0..=8)),
                1..40,
            )
        ) {
            let mut server = SdoServer::new(1);
            let mut od = FakeOd::new();
            for (id, data) in frames {
                let frame = CanFrame::new(id, &data).unwrap();
                if let Some(answer) = server.on_request(&frame, &mut od) {
                    prop_assert_eq!(answer.cob_id(), Some(0x581));
                    prop_assert_eq!(answer.len(), 8);
                }
            }
        }

        #[test]
        fn client_never_panics(
            start in 0u8..3,
            len in 0usize..40,
            frames in proptest::collection::vec(
                (prop_oneof![Just(0x581u16), 0u16..0x800], proptest::collection::vec(any::<u8>(), 0..=8)),
                1..40,
            )
        ) {
            let mut client = SdoClient::new(1);
            let data = vec![0xA5; len];
            for (id, bytes) in frames {
                if !client.is_busy() {
                    match start {
                        0 => { client.upload(0x1008, 0); }
                        1 => { client.download(0x2400, 1, &data); }
                        _ => { let _ = client.take_abort(); }
                    }
                }
                let frame = CanFrame::new(id, &bytes).unwrap();
                if let SdoEvent::Send(next) = client.on_frame(&frame) {
                    prop_assert_eq!(next.cob_id(), Some(0x601));
                    prop_assert_eq!(next.len(), 8);
                }
            }
        }

        #[test]
        fn client_and_server_round_trip(data in proptest::collection::vec(any::<u8>(), 0..=300)) {
            let mut client = SdoClient::new(5);
            let mut server = SdoServer::new(5);
            let mut od = FakeOd::new();
            od.add(0x2400, 1, &[], None, true);
            let first = client.download(0x2400, 1, &data);
            prop_assert_eq!(run(&mut client, &mut server, &mut od, first), SdoEvent::Downloaded);
            let first = client.upload(0x2400, 1);
            prop_assert_eq!(run(&mut client, &mut server, &mut od, first), SdoEvent::Uploaded(data));
            prop_assert!(!client.is_busy());
            prop_assert!(!server.is_busy());
        }
    }
}
