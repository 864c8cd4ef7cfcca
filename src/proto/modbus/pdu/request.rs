//! Requests: every function code drivedeck sends, encoded and decoded.

use super::canopen::CanopenRequest;
use super::{
    DICTIONARY_NEXT, DICTIONARY_RESTART, MAX_PDU, MEI_CANOPEN, PduError, Reader, byte_count,
    check_byte_count, check_quantity, fc, limits, push_registers, push_u16, register_range,
    registers, saturating_u16,
};

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

pub(super) fn decode_read(r: &mut Reader<'_>) -> Result<Request, PduError> {
    let function = r.function;
    let address = r.u16_be("starting address")?;
    let count = r.u16_be("register count")?;
    Ok(match function {
        fc::READ_INPUT => Request::ReadInput { address, count },
        _ => Request::ReadHolding { address, count },
    })
}

pub(super) fn decode_write_multiple(r: &mut Reader<'_>) -> Result<Request, PduError> {
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

pub(super) fn decode_read_write(r: &mut Reader<'_>) -> Result<Request, PduError> {
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

pub(super) fn decode_read_dictionary(r: &mut Reader<'_>) -> Result<Request, PduError> {
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
