//! The emergency (EMCY) message (CiA 301; protocol notes §2.2): COB-ID 80h + node (1014h), 8 bytes.
//!
//! ```text
//! | error code u16 LE (as 603Fh) | error register (1001h) | 5 manufacturer bytes |
//! ```
//!
//! An error code of 0000h is "error reset / no error": the node reports that its last error
//! has gone. Nanotec's layout of the manufacturer bytes is not confirmed (protocol notes
//! §2.2, \[L\]), so they are kept raw.

use super::CanFrame;
use super::nmt::{Cob, classify, cob, data_frame};
use crate::cia::ErrorCode;

/// One emergency message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Emcy {
    /// The error code, as in 603Fh (protocol notes §4.5).
    pub error_code: u16,
    /// The error register 1001h (protocol notes §4.5).
    pub error_register: u8,
    /// Manufacturer-specific bytes, raw.
    pub manufacturer: [u8; 5],
}

/// A frame that is not an EMCY message.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EmcyError {
    #[error("COB-ID {0:03X}h is not an EMCY message (81h..FFh)")]
    WrongCobId(u32),
    #[error("an EMCY message carries data; this one is empty")]
    Empty,
    #[error("an EMCY message carries at most 8 bytes, this one {0}")]
    TooLong(usize),
    #[error("a remote request on an EMCY COB-ID carries no message")]
    Remote,
}

impl Emcy {
    /// The message that clears a node's error ("error reset / no error").
    pub const RESET: Emcy = Emcy {
        error_code: 0,
        error_register: 0,
        manufacturer: [0; 5],
    };

    pub fn new(error_code: u16, error_register: u8) -> Self {
        Self {
            error_code,
            error_register,
            manufacturer: [0; 5],
        }
    }

    /// Whether this is an "error reset / no error" message (error code 0000h).
    pub fn is_reset(&self) -> bool {
        self.error_code == 0
    }

    /// The error code with its meaning.
    pub fn code(&self) -> ErrorCode {
        ErrorCode(self.error_code)
    }

    /// The 8 payload bytes, error code little-endian.
    pub fn to_bytes(&self) -> [u8; 8] {
        let [lo, hi] = self.error_code.to_le_bytes();
        let m = self.manufacturer;
        [lo, hi, self.error_register, m[0], m[1], m[2], m[3], m[4]]
    }

    /// Decode a payload. Shorter payloads are zero-filled (some nodes send only the error
    /// code and register); an empty or over-long one is an error.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, EmcyError> {
        if bytes.is_empty() {
            return Err(EmcyError::Empty);
        }
        if bytes.len() > 8 {
            return Err(EmcyError::TooLong(bytes.len()));
        }
        let mut b = [0u8; 8];
        b[..bytes.len()].copy_from_slice(bytes);
        Ok(Self {
            error_code: u16::from_le_bytes([b[0], b[1]]),
            error_register: b[2],
            manufacturer: [b[3], b[4], b[5], b[6], b[7]],
        })
    }

    /// The EMCY frame of a node: COB-ID 80h + node, 8 bytes.
    pub fn frame(&self, node: u8) -> CanFrame {
        data_frame(cob::emcy(node), &self.to_bytes())
    }

    /// Decode an EMCY frame into (node, message).
    pub fn decode(frame: &CanFrame) -> Result<(u8, Self), EmcyError> {
        let Some(Cob::Emcy { node }) = frame.cob_id().map(classify) else {
            return Err(EmcyError::WrongCobId(frame.id()));
        };
        if frame.is_remote() {
            return Err(EmcyError::Remote);
        }
        Ok((node, Self::from_bytes(frame.data())?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn error_code_is_little_endian() {
        let emcy = Emcy {
            error_code: 0x2300,
            error_register: 0x03,
            manufacturer: [1, 2, 3, 4, 5],
        };
        let frame = emcy.frame(1);
        assert_eq!(frame.to_string(), "081#0023030102030405");
        assert_eq!(Emcy::decode(&frame), Ok((1, emcy)));
        assert_eq!(emcy.code(), ErrorCode::OUTPUT_CURRENT);
        assert!(!emcy.is_reset());
    }

    #[test]
    fn zero_code_is_error_reset() {
        let frame = Emcy::RESET.frame(5);
        assert_eq!(frame.to_string(), "085#0000000000000000");
        let (node, emcy) = Emcy::decode(&frame).unwrap();
        assert_eq!(node, 5);
        assert!(emcy.is_reset());
    }

    #[test]
    fn short_frames_are_zero_filled_empty_and_long_ones_refused() {
        let short = CanFrame::new(0x081, &[0x10, 0x82, 0x11]).unwrap();
        assert_eq!(Emcy::decode(&short), Ok((1, Emcy::new(0x8210, 0x11))));
        let one = CanFrame::new(0x081, &[0x10]).unwrap();
        assert_eq!(Emcy::decode(&one), Ok((1, Emcy::new(0x0010, 0))));
        let empty = CanFrame::new(0x081, &[]).unwrap();
        assert_eq!(Emcy::decode(&empty), Err(EmcyError::Empty));
        assert_eq!(Emcy::from_bytes(&[0; 9]), Err(EmcyError::TooLong(9)));
        assert_eq!(
            Emcy::from_bytes(&[0; 9]).unwrap_err().to_string(),
            "an EMCY message carries at most 8 bytes, this one 9"
        );
        let sync = CanFrame::new(0x080, &[0; 8]).unwrap();
        assert_eq!(Emcy::decode(&sync), Err(EmcyError::WrongCobId(0x80)));
        let remote = CanFrame::remote(0x081, 8).unwrap();
        assert_eq!(Emcy::decode(&remote), Err(EmcyError::Remote));
    }

    proptest! {
        #[test]
        fn round_trip(code: u16, register: u8, m: [u8; 5], node in 1u8..=127) {
            let emcy = Emcy { error_code: code, error_register: register, manufacturer: m };
            prop_assert_eq!(Emcy::decode(&emcy.frame(node)), Ok((node, emcy)));
        }

        #[test]
        fn decoding_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..=12)) {
            let _ = Emcy::from_bytes(&bytes);
        }
    }
}
