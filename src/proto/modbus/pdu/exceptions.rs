//! Exceptions: the standard codes and Nanotec's extended one with its abort code.

use std::fmt;

use super::{MEI_CANOPEN, PduError, Reader, exception, fc};
use crate::cia::AbortCode;
use crate::number::hex;

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

pub(super) fn decode_extended(function: u8, r: &mut Reader<'_>) -> Result<Exception, PduError> {
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

pub(super) fn standard_text(code: u8) -> &'static str {
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
