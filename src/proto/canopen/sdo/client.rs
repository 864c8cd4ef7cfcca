//! The SDO client: one transfer at a time for one node, expedited and segmented.

use super::{Initiate, MAX_TRANSFER, Request, Response, Segment, abort_frame};
use crate::cia::AbortCode;
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::nmt::cob;

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
    /// An initiate answer naming another object while this transfer waits for its own:
    /// most likely the late answer to an earlier request that was given up on. The
    /// transfer still waits (a retry would send a second request, whose answer would then
    /// arrive late in the next transfer, and so on); the text says what was skipped.
    Stale(String),
    /// The server broke the protocol (wrong toggle, unexpected command specifier, a
    /// segment that does not add up). The transfer is over; send [`SdoClient::take_abort`] to tell the server.
    Protocol(String),
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum ClientState {
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
/// [`SdoEvent::Send`] / [`SdoEvent::Ignored`] / [`SdoEvent::Stale`]. On a timeout, send
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
            ) => self.upload_initiated(index, sub, (echo_index, echo_sub), initiate),
            (
                ClientState::Uploading {
                    toggle, size, data, ..
                },
                Response::UploadSegment(segment),
            ) => self.upload_segment(index, sub, toggle, size, data, &segment),
            (
                ClientState::DownloadInitiate {
                    data, expedited, ..
                },
                Response::DownloadInitiated {
                    index: echo_index,
                    sub: echo_sub,
                },
            ) => self.download_initiated(index, sub, (echo_index, echo_sub), data, expedited),
            (
                ClientState::Downloading {
                    toggle, data, sent, ..
                },
                Response::DownloadSegment { toggle: echo },
            ) => self.download_segment(index, sub, (toggle, echo), data, sent),
            (state, response) => self.unexpected(index, sub, &state, &response),
        }
    }

    /// The upload initiate answer naming `echo`: skipped when that is not the running
    /// transfer's object; else the value itself (expedited), or the first segment request
    /// (segmented, when the announced size may come).
    fn upload_initiated(
        &mut self,
        index: u16,
        sub: u8,
        echo: (u16, u8),
        initiate: Initiate,
    ) -> SdoEvent {
        if echo != (index, sub) {
            self.state = ClientState::UploadInitiate { index, sub };
            return stale(index, sub, echo.0, echo.1);
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

    /// An upload segment, after `data` with the announced `size`, expected with `toggle`:
    /// the whole value on the last segment, else the request for the next one.
    fn upload_segment(
        &mut self,
        index: u16,
        sub: u8,
        toggle: bool,
        size: Option<u32>,
        mut data: Vec<u8>,
        segment: &Segment,
    ) -> SdoEvent {
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

    /// The download initiate answer naming `echo`: skipped when that is not the running
    /// transfer's object; else done (expedited) or the first segment.
    fn download_initiated(
        &mut self,
        index: u16,
        sub: u8,
        echo: (u16, u8),
        data: Vec<u8>,
        expedited: bool,
    ) -> SdoEvent {
        if echo != (index, sub) {
            self.state = ClientState::DownloadInitiate {
                index,
                sub,
                data,
                expedited,
            };
            return stale(index, sub, echo.0, echo.1);
        }
        if expedited {
            return SdoEvent::Downloaded;
        }
        self.next_segment(index, sub, false, data, 0)
    }

    /// A download segment's acknowledgement (`toggles`: the one sent, the one echoed):
    /// done when all `data` is `sent`, else the next segment.
    fn download_segment(
        &mut self,
        index: u16,
        sub: u8,
        toggles: (bool, bool),
        data: Vec<u8>,
        sent: usize,
    ) -> SdoEvent {
        let (toggle, echo) = toggles;
        if echo != toggle {
            return self.wrong_toggle(index, sub, toggle);
        }
        if sent >= data.len() {
            return SdoEvent::Downloaded;
        }
        self.next_segment(index, sub, !toggle, data, sent)
    }

    /// An answer the running transfer did not wait for: a protocol error.
    fn unexpected(
        &mut self,
        index: u16,
        sub: u8,
        state: &ClientState,
        response: &Response,
    ) -> SdoEvent {
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
}

/// An initiate answer whose multiplexer (protocol notes §2.4, bytes 1-3) is not the running
/// transfer's: skipped, the transfer keeps waiting.
fn stale(index: u16, sub: u8, echo_index: u16, echo_sub: u8) -> SdoEvent {
    SdoEvent::Stale(format!(
        "an answer for {echo_index:04X}h:{echo_sub:02X}h while waiting for {index:04X}h:{sub:02X}h (a late answer to an earlier request): skipped"
    ))
}
