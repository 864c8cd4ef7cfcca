//! The simulated drive as a Modbus TCP and RTU server, with a Nanotec drive's register map
//! (PDI spec §3.2; protocol notes §1.2 to §1.5):
//!
//! | registers | content | access |
//! | --- | --- | --- |
//! | 4996–4999 | PDI TX: Status, 603Fh, ReturnValue hi/lo | read (FC 3, 4, 23) |
//! | 5000… | TX process image per 3602h | read |
//! | 5996–5999 | PDI RX: SetValue1 hi/lo, SetValue2, SetValue3·Cmd | read, write (FC 6, 16, 23) |
//! | 6000… | RX process image per 3502h | read, write |
//! | 2000–2063 | NanoJ outputs 2500h:01–20h | read |
//! | 3000–3063 | NanoJ inputs 2400h:01–20h | write, 32-bit aligned |
//!
//! FC 43 / MEI 0Dh reads and writes any object, with abort codes in the extended exception;
//! FC 101 streams the whole dictionary. Anything else: exception 01; addresses outside the
//! map: 02; bad values: 03. FC 23 writes before it reads. The RTU line is in `modbus_rtu`.

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

use super::SharedDrive;
use crate::cia::AbortCode;
use crate::od::{Address, DataType, Value};
use crate::proto::modbus::frame;
use crate::proto::modbus::pdu::{
    CanopenRequest, CanopenResponse, DictionaryFrame, Exception, MAX_PDU, Request, Response,
    exception,
};
use crate::proto::modbus::registers::{
    self, ImageLayout, NANOJ_INPUTS, NANOJ_OUTPUTS, NANOJ_REGISTERS, PDI_REGISTERS, PDI_RX, PDI_TX,
    WordOrder,
};
use crate::sim::Drive;
use crate::sim::wrap_integer;

/// Server settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServerOptions {
    /// Word order of 32-bit values in registers.
    pub order: WordOrder,
    /// Simultaneous TCP clients; a Nanotec drive allows one.
    pub max_clients: usize,
    /// Answer FC 23; off simulates a gateway without it (exception 01).
    pub fc23: bool,
    /// Answer FC 43 / MEI 0Dh; off simulates a device without object access over Modbus.
    pub fc43: bool,
}

impl Default for ServerOptions {
    fn default() -> Self {
        Self {
            order: WordOrder::High,
            max_clients: 1,
            fc23: true,
            fc43: true,
        }
    }
}

/// What one client connection remembers: the FC 101 cursor, and the layouts of the process
/// images.
#[derive(Debug, Default)]
pub struct Session {
    dictionary_cursor: usize,
    layouts: Layouts,
}

/// The layouts of the RX (3502h) and TX (3602h) process images as last built, each with
/// the drive's `od_changes` when it was built.
#[derive(Debug, Default)]
struct Layouts {
    rx: Option<(u64, ImageLayout)>,
    tx: Option<(u64, ImageLayout)>,
}

fn refuse(request: &Request, code: u8) -> Exception {
    Exception::Standard {
        function: request.function(),
        code,
    }
}

/// The mapping of a process image, from its mapping object (3502h or 3602h). Reading the
/// mapping and building its layout on every request was a third of what the server spent
/// per request, so the layout is kept until an object is set from outside (a master may
/// remap between two requests: then it is built again).
fn layout<'a>(
    drive: &Drive,
    mapping: u16,
    cached: &'a mut Option<(u64, ImageLayout)>,
) -> &'a ImageLayout {
    let changes = drive.od_changes();
    if cached.as_ref().is_some_and(|(built, _)| *built != changes) {
        *cached = None;
    }
    let (_, layout) = cached.get_or_insert_with(|| {
        let count = drive
            .read(Address::new(mapping, 0))
            .ok()
            .and_then(|v| v.as_i128())
            .unwrap_or(0)
            .clamp(0, 16) as u8;
        let entries: Vec<u32> = (1..=count)
            .map(|sub| {
                drive
                    .read(Address::new(mapping, sub))
                    .ok()
                    .and_then(|v| v.as_i128())
                    .unwrap_or(0) as u32
            })
            .collect();
        (changes, ImageLayout::from_entries(&entries))
    });
    layout
}

/// An object's raw bits for a process image.
fn raw_value(drive: &Drive, address: Address) -> u32 {
    match drive.read(address) {
        Ok(Value::Real(v)) => (v as f32).to_bits(),
        Ok(v) => v.as_i128().unwrap_or(0) as u32,
        Err(_) => 0,
    }
}

/// A register area that can be read, and its content.
fn read_area(
    drive: &Drive,
    layouts: &mut Layouts,
    address: u16,
    count: u16,
    order: WordOrder,
) -> Option<Vec<u16>> {
    let end = u32::from(address) + u32::from(count);
    let within = |start: u16, len: usize| {
        u32::from(address) >= u32::from(start) && end <= u32::from(start) + len as u32
    };
    let slice = |mut all: Vec<u16>, start: u16| -> Vec<u16> {
        let from = usize::from(address - start);
        all.truncate(from + usize::from(count));
        all.drain(..from);
        all
    };
    // PDI TX followed by the TX image: one contiguous area.
    let tx_layout = layout(drive, 0x3602, &mut layouts.tx);
    let tx_len = usize::from(PDI_REGISTERS) + tx_layout.register_len();
    if within(PDI_TX, tx_len) {
        let mut all = Vec::with_capacity(tx_len);
        all.extend_from_slice(&registers::tx_to_registers(&drive.tx_image(), order));
        tx_layout.pack_into(|a| raw_value(drive, a), order, &mut all);
        return Some(slice(all, PDI_TX));
    }
    let rx_layout = layout(drive, 0x3502, &mut layouts.rx);
    let rx_len = usize::from(PDI_REGISTERS) + rx_layout.register_len();
    if within(PDI_RX, rx_len) {
        let mut all = Vec::with_capacity(rx_len);
        all.extend_from_slice(&registers::rx_to_registers(&drive.rx_image(), order));
        rx_layout.pack_into(|a| raw_value(drive, a), order, &mut all);
        return Some(slice(all, PDI_RX));
    }
    if within(NANOJ_OUTPUTS, usize::from(NANOJ_REGISTERS)) {
        let all: Vec<u16> = (1..=32u8)
            .flat_map(|sub| {
                registers::u32_to_registers(raw_value(drive, Address::new(0x2500, sub)), order)
            })
            .collect();
        return Some(slice(all, NANOJ_OUTPUTS));
    }
    None
}

/// Write registers; `Err` is the exception to answer.
fn write_area(
    drive: &mut Drive,
    layouts: &mut Layouts,
    request: &Request,
    address: u16,
    values: &[u16],
    order: WordOrder,
) -> Result<(), Exception> {
    let end = usize::from(address) + values.len();
    // PDI RX and the RX image behind it.
    let rx_layout = layout(drive, 0x3502, &mut layouts.rx);
    let rx_end = usize::from(PDI_RX) + usize::from(PDI_REGISTERS) + rx_layout.register_len();
    if address >= PDI_RX && end <= rx_end {
        let offset = usize::from(address - PDI_RX);
        let pdi_part = values
            .iter()
            .enumerate()
            .take_while(|(i, _)| offset + i < usize::from(PDI_REGISTERS));
        let mut pdi = registers::rx_to_registers(&drive.rx_image(), order);
        let mut touched = false;
        for (i, value) in pdi_part {
            pdi[offset + i] = *value;
            touched = true;
        }
        if touched {
            drive.write_rx(&registers::registers_to_rx(pdi, order));
        }
        let image_first = offset.saturating_sub(usize::from(PDI_REGISTERS));
        let skip = usize::from(PDI_REGISTERS)
            .saturating_sub(offset)
            .min(values.len());
        for (entry, raw) in rx_layout.unpack(image_first, &values[skip..], order) {
            let Some(dtype) = drive.entry(entry.address).map(|e| e.dtype) else {
                continue;
            };
            let value = wrap_integer(dtype, sign_extend(raw, entry.bits, dtype));
            drive
                .write(entry.address, value)
                .map_err(|_| refuse(request, exception::ILLEGAL_DATA_VALUE))?;
        }
        return Ok(());
    }
    // NanoJ inputs: whole 32-bit values only.
    if address >= NANOJ_INPUTS && end <= usize::from(NANOJ_INPUTS + NANOJ_REGISTERS) {
        if !(address - NANOJ_INPUTS).is_multiple_of(2) || !values.len().is_multiple_of(2) {
            return Err(refuse(request, exception::ILLEGAL_DATA_ADDRESS));
        }
        let first = (address - NANOJ_INPUTS) / 2;
        for (i, pair) in values.chunks_exact(2).enumerate() {
            let raw = registers::registers_to_u32([pair[0], pair[1]], order);
            let sub = (first as usize + i + 1) as u8;
            drive
                .write(Address::new(0x2400, sub), Value::Int(i64::from(raw as i32)))
                .map_err(|_| refuse(request, exception::ILLEGAL_DATA_VALUE))?;
        }
        return Ok(());
    }
    Err(refuse(request, exception::ILLEGAL_DATA_ADDRESS))
}

fn sign_extend(raw: u32, bits: u8, dtype: DataType) -> i64 {
    if !dtype.is_signed() {
        return i64::from(raw);
    }
    match bits {
        8 => i64::from(raw as u8 as i8),
        16 => i64::from(raw as u16 as i16),
        _ => i64::from(raw as i32),
    }
}

fn canopen(drive: &mut Drive, request: &CanopenRequest) -> Result<Response, Exception> {
    let h = &request.header;
    let address = Address::new(h.index, h.subindex);
    let abort = |code: AbortCode| Exception::Extended {
        function: crate::proto::modbus::pdu::fc::ENCAPSULATED,
        abort: code.0,
    };
    if h.extend || h.start != 0 {
        // Multi-message transfers are not simulated.
        return Err(abort(AbortCode::UNSUPPORTED_ACCESS));
    }
    let entry = drive.entry(address).cloned();
    if h.write {
        let Some(entry) = entry else {
            return Err(abort(
                drive.read(address).err().unwrap_or(AbortCode::NO_OBJECT),
            ));
        };
        if let Some(size) = entry.dtype.size() {
            if request.data.len() > size {
                return Err(abort(AbortCode::TYPE_LENGTH_TOO_HIGH));
            }
            if request.data.len() < size {
                return Err(abort(AbortCode::TYPE_LENGTH_TOO_LOW));
            }
        }
        let value = Value::from_le_bytes(entry.dtype, &request.data)
            .map_err(|_| abort(AbortCode::TYPE_LENGTH_MISMATCH))?;
        drive.write(address, value).map_err(abort)?;
        return Ok(Response::Canopen(CanopenResponse::answering(
            request,
            vec![],
        )));
    }
    let value = drive.read(address).map_err(abort)?;
    let dtype = entry.map_or(DataType::Integer32, |e| e.dtype);
    let mut bytes = value
        .to_le_bytes(dtype)
        .map_err(|_| abort(AbortCode::GENERAL_ERROR))?;
    match dtype.size() {
        Some(size) if usize::from(h.count) > size => {
            return Err(abort(AbortCode::TYPE_LENGTH_TOO_HIGH));
        }
        Some(size) if usize::from(h.count) < size => {
            return Err(abort(AbortCode::TYPE_LENGTH_TOO_LOW));
        }
        _ => {}
    }
    bytes.truncate(h.max_data());
    Ok(Response::Canopen(CanopenResponse::answering(
        request, bytes,
    )))
}

fn dictionary(drive: &Drive, session: &mut Session, restart: bool) -> Result<Response, Exception> {
    if restart {
        session.dictionary_cursor = 0;
    }
    let addresses: Vec<Address> = drive.addresses().collect();
    let mut frames = vec![];
    // FC, sub-function and length byte come first.
    let mut room = MAX_PDU - 3;
    while let Some(address) = addresses.get(session.dictionary_cursor) {
        let Ok((value, dtype)) = drive.read_typed(*address) else {
            session.dictionary_cursor += 1;
            continue;
        };
        let mut data = value.to_le_bytes(dtype).unwrap_or_default();
        data.truncate(usize::from(u8::MAX).min(MAX_PDU - 7));
        let need = 4 + data.len();
        if need > room {
            break;
        }
        room -= need;
        frames.push(DictionaryFrame {
            index: address.index,
            subindex: address.sub,
            data,
        });
        session.dictionary_cursor += 1;
    }
    if frames.is_empty() {
        return Err(Exception::Extended {
            function: crate::proto::modbus::pdu::fc::READ_DICTIONARY,
            abort: AbortCode::NO_DATA.0,
        });
    }
    Ok(Response::Dictionary {
        sub: if restart {
            crate::proto::modbus::pdu::DICTIONARY_RESTART
        } else {
            crate::proto::modbus::pdu::DICTIONARY_NEXT
        },
        frames,
    })
}

/// Answer one request against the drive's register map.
pub fn answer(
    drive: &mut Drive,
    session: &mut Session,
    request: &Request,
    options: &ServerOptions,
) -> Result<Response, Exception> {
    let order = options.order;
    let missing = match request {
        Request::ReadWrite { .. } => !options.fc23,
        Request::Canopen(_) | Request::ReadDictionary { .. } => !options.fc43,
        _ => false,
    };
    if missing {
        return Err(refuse(request, exception::ILLEGAL_FUNCTION));
    }
    if request.validate().is_err() {
        return Err(refuse(request, exception::ILLEGAL_DATA_VALUE));
    }
    let read = |drive: &Drive, layouts: &mut Layouts, address: u16, count: u16| {
        read_area(drive, layouts, address, count, order)
            .ok_or_else(|| refuse(request, exception::ILLEGAL_DATA_ADDRESS))
    };
    let layouts = &mut session.layouts;
    match request {
        Request::ReadHolding { address, count } => {
            read(drive, layouts, *address, *count).map(Response::ReadHolding)
        }
        Request::ReadInput { address, count } => {
            read(drive, layouts, *address, *count).map(Response::ReadInput)
        }
        Request::WriteSingle { address, value } => {
            write_area(drive, layouts, request, *address, &[*value], order)?;
            Ok(Response::WriteSingle {
                address: *address,
                value: *value,
            })
        }
        Request::WriteMultiple { address, values } => {
            write_area(drive, layouts, request, *address, values, order)?;
            Ok(Response::WriteMultiple {
                address: *address,
                count: values.len() as u16,
            })
        }
        Request::ReadWrite {
            read_address,
            read_count,
            write_address,
            values,
        } => {
            // The write happens before the read (Modbus spec).
            write_area(drive, layouts, request, *write_address, values, order)?;
            read(drive, layouts, *read_address, *read_count).map(Response::ReadWrite)
        }
        Request::Canopen(c) => canopen(drive, c),
        Request::ReadDictionary { restart } => dictionary(drive, session, *restart),
        Request::Other { .. } => Err(refuse(request, exception::ILLEGAL_FUNCTION)),
    }
}

/// Answer a raw request PDU: the response PDU, or `None` for a PDU that cannot be
/// answered at all (no function code).
pub fn answer_pdu(
    shared: &SharedDrive,
    session: &mut Session,
    pdu: &[u8],
    options: &ServerOptions,
) -> Option<Vec<u8>> {
    let function = *pdu.first()?;
    let request = match Request::decode(pdu) {
        Ok(request) => request,
        Err(_) => {
            // A known function with malformed data: illegal data value.
            return Some(
                Exception::Standard {
                    function: function & 0x7F,
                    code: exception::ILLEGAL_DATA_VALUE,
                }
                .encode(),
            );
        }
    };
    let mut drive = shared.lock();
    if drive.rebooting() {
        // A drive that restarts answers nothing.
        return None;
    }
    Some(match answer(&mut drive, session, &request, options) {
        Ok(response) => response.encode(),
        Err(e) => e.encode(),
    })
}

/// A running server; dropping it does not stop it (the process does).
#[derive(Debug)]
pub struct TcpServer {
    pub local: SocketAddr,
}

/// Serve Modbus TCP on `listener` until the task is dropped.
pub async fn serve_tcp(
    listener: TcpListener,
    shared: SharedDrive,
    options: ServerOptions,
) -> io::Result<()> {
    let active = Arc::new(AtomicUsize::new(0));
    loop {
        let (stream, peer) = listener.accept().await?;
        if active.load(Ordering::SeqCst) >= options.max_clients {
            // Like the drive: its one connection is taken. Close at once.
            tracing::info!(
                "refused Modbus TCP client {peer}: {} client(s) already connected",
                options.max_clients
            );
            drop(stream);
            continue;
        }
        if shared.rebooting() {
            // Nothing listens while the drive restarts.
            drop(stream);
            continue;
        }
        active.fetch_add(1, Ordering::SeqCst);
        let shared = shared.clone();
        let active = active.clone();
        tokio::spawn(async move {
            if let Err(e) = serve_connection(stream, &shared, &options).await {
                tracing::debug!("Modbus TCP client {peer}: {e}");
            }
            active.fetch_sub(1, Ordering::SeqCst);
        });
    }
}

async fn serve_connection(
    mut stream: TcpStream,
    shared: &SharedDrive,
    options: &ServerOptions,
) -> io::Result<()> {
    let _ = stream.set_nodelay(true);
    let mut session = Session::default();
    let mut buffer = Vec::with_capacity(512);
    let mut chunk = [0u8; 512];
    loop {
        loop {
            match frame::decode_tcp(&buffer) {
                Ok(Some((frame, used))) => {
                    buffer.drain(..used);
                    if let Some(pdu) = answer_pdu(shared, &mut session, &frame.pdu, options) {
                        stream
                            .write_all(&frame::encode_tcp(frame.transaction, frame.unit, &pdu))
                            .await?;
                    } else if shared.rebooting() {
                        // Its network stack restarts with it: the connection is gone.
                        return Ok(());
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    // Not Modbus TCP: close, as a device would.
                    return Err(io::Error::new(io::ErrorKind::InvalidData, e.to_string()));
                }
            }
        }
        let n = stream.read(&mut chunk).await?;
        if n == 0 {
            return Ok(());
        }
        buffer.extend_from_slice(&chunk[..n]);
    }
}
