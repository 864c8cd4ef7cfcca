//! The SDO server of a simulated node: expedited and segmented, upload and download.

use super::{Initiate, MAX_TRANSFER, Request, Response, Segment};
use crate::cia::AbortCode;
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::nmt::cob;

/// Object access for an SDO server: bytes little-endian, sized by the object.
pub trait ObjectAccess {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode>;
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum ServerState {
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
            Request::UploadSegment { toggle } => self.upload_segment(state, toggle),
            Request::InitiateDownload {
                index,
                sub,
                initiate,
            } => self.initiate_download(index, sub, initiate, od),
            Request::DownloadSegment(segment) => self.download_segment(state, &segment, od),
            Request::Unknown { index, sub, .. } => {
                self.abort(index, sub, AbortCode::INVALID_COMMAND_SPECIFIER)
            }
        }
    }

    /// The next segment of the upload `state` runs, asked for with `toggle`.
    fn upload_segment(&mut self, state: ServerState, toggle: bool) -> Option<Response> {
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

    /// A download's start: an expedited one writes at once, a segmented one waits for its
    /// segments.
    fn initiate_download(
        &mut self,
        index: u16,
        sub: u8,
        initiate: Initiate,
        od: &mut impl ObjectAccess,
    ) -> Option<Response> {
        match initiate {
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
        }
    }

    /// A segment of the download `state` runs; the last one writes the object.
    fn download_segment(
        &mut self,
        state: ServerState,
        segment: &Segment,
        od: &mut impl ObjectAccess,
    ) -> Option<Response> {
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
