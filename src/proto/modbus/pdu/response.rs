//! Responses: decoded against the request they answer.

use std::fmt;

use super::canopen::CanopenResponse;
use super::dictionary::DictionaryFrame;
use super::exceptions::Exception;
use super::request::Request;
use super::{
    MAX_PDU, MEI_CANOPEN, PduError, Reader, byte_count, check_byte_count, fc, push_registers,
    push_u16, registers, saturating_u16,
};

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
        // One allocation: a response PDU is at most MAX_PDU bytes.
        let mut out = Vec::with_capacity(MAX_PDU);
        out.push(self.function());
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

pub(super) fn decode_normal(request: &Request, r: &mut Reader<'_>) -> Result<Response, PduError> {
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

pub(super) fn decode_registers(r: &mut Reader<'_>, count: usize) -> Result<Vec<u16>, PduError> {
    let function = r.function;
    let byte_count = usize::from(r.u8("byte count")?);
    check_byte_count(function, byte_count, count)?;
    registers(r, count)
}

pub(super) fn check_echo<T: PartialEq + fmt::Display>(
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
