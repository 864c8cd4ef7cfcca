//! `ModbusLink`: a Nanotec drive over Modbus TCP or RTU.
//!
//! * The PDI runs in one FC 23 transaction per cycle: write 5996–5999, read 4996–4999 and,
//!   where the drive maps it, the TX process image behind it (6041h, 6061h, 6064h, 60FDh in
//!   the factory mapping), so status and position come without extra requests.
//! * A device or gateway that answers FC 23 with exception 01 gets FC 16 then FC 4 from then
//!   on; the link says so once.
//! * Objects go through FC 43 / MEI 0Dh (CiA 309-2); a device that answers it with
//!   exception 01 is marked as without it, and the worker falls back to PDI OD-Read/Write.
//! * FC 101 reads the whole object dictionary where the device supports it.

use std::time::Duration;

use super::transport::Transport;
use crate::link::{Answer, Error, Exchange, Link, LinkInfo, LinkSpec, Refusal, Signal, Signals};
use crate::od::{Address, DataType, Value};
use crate::pdi::RxImage;
use crate::proto::modbus::pdu::{CanopenRequest, Exception, Request, Response, exception};
use crate::proto::modbus::registers::{
    self, ImageLayout, Mapped, PDI_REGISTERS, PDI_RX, PDI_TX, WordOrder,
};

/// How long a Modbus request may take before the link reports a timeout.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(500);

/// The factory TX process image (3602h defaults, NT-3602; protocol notes §1.3).
pub use crate::proto::modbus::registers::FACTORY_TX_MAP;

/// Whether the device does something, as far as we know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Support {
    Unknown,
    Yes,
    No,
}

/// A drive over Modbus.
#[derive(Debug)]
pub struct ModbusLink {
    spec: LinkSpec,
    transport: Transport,
    order: WordOrder,
    fc23: Support,
    fc43: Support,
    /// The TX process image read along with the PDI; `None` when the device has none.
    tx_image: Option<ImageLayout>,
    notices: Vec<String>,
}

impl ModbusLink {
    /// Connect and learn what the device supports.
    pub async fn connect(spec: &LinkSpec, timeout: Duration) -> Result<ModbusLink, Error> {
        Self::connect_traced(spec, timeout)
            .await
            .map_err(|(error, _)| error)
    }

    /// [`ModbusLink::connect`], keeping the frames of a connection that failed.
    pub async fn connect_traced(
        spec: &LinkSpec,
        timeout: Duration,
    ) -> crate::link::Traced<ModbusLink> {
        let order = match spec {
            LinkSpec::ModbusTcp { words, .. } | LinkSpec::ModbusRtu { words, .. } => *words,
            _ => {
                return Err((
                    Error::Unsupported(format!("{spec} is not a Modbus connection string")),
                    vec![],
                ));
            }
        };
        let transport = Transport::connect(spec, timeout)
            .await
            .map_err(|e| (e, vec![]))?;
        let mut link = ModbusLink {
            spec: spec.clone(),
            transport,
            order,
            fc23: Support::Unknown,
            fc43: Support::Unknown,
            tx_image: None,
            notices: vec![],
        };
        match link.learn_tx_image().await {
            Ok(()) => Ok(link),
            Err(error) => Err((error, link.transport.take_trace())),
        }
    }

    /// Connect to a device whose TX process image mapping (3602h entries) is known, without
    /// asking for it over FC 43: for a server that does not know FC 43 / MEI 0Dh and closes
    /// the connection on it instead of answering exception 01, as a tokio-modbus register
    /// server does (the anchor server of `benches/anchors.rs`).
    pub async fn connect_with_tx_map(
        spec: &LinkSpec,
        timeout: Duration,
        tx_map: &[u32],
    ) -> Result<ModbusLink, Error> {
        let order = match spec {
            LinkSpec::ModbusTcp { words, .. } | LinkSpec::ModbusRtu { words, .. } => *words,
            _ => {
                return Err(Error::Unsupported(format!(
                    "{spec} is not a Modbus connection string"
                )));
            }
        };
        let transport = Transport::connect(spec, timeout).await?;
        let mut link = ModbusLink {
            spec: spec.clone(),
            transport,
            order,
            fc23: Support::Unknown,
            fc43: Support::Unknown,
            tx_image: None,
            notices: vec![],
        };
        link.use_tx_map(tx_map);
        Ok(link)
    }

    /// Where the TX process image is and what it holds: 3602h over FC 43 where the device
    /// answers it, the factory mapping otherwise.
    async fn learn_tx_image(&mut self) -> Result<(), Error> {
        let mut entries = None;
        if let Ok(Value::Uint(count)) = self
            .read_object(Address::new(0x3602, 0), DataType::Unsigned8)
            .await?
        {
            let mut read = vec![];
            for sub in 1..=count.min(16) as u8 {
                match self
                    .read_object(Address::new(0x3602, sub), DataType::Unsigned32)
                    .await?
                {
                    Ok(Value::Uint(entry)) => read.push(entry as u32),
                    _ => break,
                }
            }
            entries = Some(read);
        }
        let entries = entries.unwrap_or_else(|| FACTORY_TX_MAP.to_vec());
        self.use_tx_map(&entries);
        Ok(())
    }

    /// Read the TX process image of this mapping along with the PDI, if it is worth it.
    fn use_tx_map(&mut self, entries: &[u32]) {
        let layout = ImageLayout::from_entries(entries);
        // Only worth reading if it carries something we show.
        let useful = layout
            .entries
            .iter()
            .any(|e| Signal::of_address(e.address).is_some());
        self.tx_image =
            (useful && layout.register_len() > 0 && layout.register_len() <= 100).then_some(layout);
    }

    /// Read the whole object dictionary with FC 101 (restart, then next until "no data").
    /// `None` when the device does not support FC 101.
    pub async fn read_dictionary(&mut self) -> Result<Option<Vec<(Address, Vec<u8>)>>, Error> {
        let mut out = vec![];
        let mut restart = true;
        loop {
            let request = Request::ReadDictionary { restart };
            restart = false;
            match self.transport.transact(&request).await? {
                Ok(Response::Dictionary { frames, .. }) => {
                    if frames.is_empty() {
                        return Ok(Some(out));
                    }
                    out.extend(
                        frames
                            .into_iter()
                            .map(|f| (Address::new(f.index, f.subindex), f.data)),
                    );
                }
                Ok(other) => {
                    return Err(Error::Protocol(format!(
                        "FC 101 answered with FC {:02X}h",
                        other.function()
                    )));
                }
                Err(e)
                    if e.abort()
                        .is_some_and(|a| a == crate::cia::AbortCode::NO_DATA) =>
                {
                    return Ok(Some(out));
                }
                Err(Exception::Standard {
                    code: exception::ILLEGAL_FUNCTION,
                    ..
                }) => return Ok(None),
                Err(e) => {
                    return Err(Error::Protocol(format!(
                        "FC 101 (read the object dictionary): {e}"
                    )));
                }
            }
        }
    }

    /// The registers read with the PDI: its 4, plus the TX image behind it.
    fn read_count(&self) -> u16 {
        PDI_REGISTERS
            + self
                .tx_image
                .as_ref()
                .map_or(0, |l| l.register_len() as u16)
    }

    fn decode(&self, registers: &[u16]) -> Result<Exchange, Error> {
        let pdi: [u16; 4] = registers
            .get(..4)
            .and_then(|r| r.try_into().ok())
            .ok_or_else(|| {
                Error::Protocol(format!(
                    "{} registers instead of at least 4",
                    registers.len()
                ))
            })?;
        let tx = registers::registers_to_tx(pdi, self.order);
        let mut signals = Signals::default();
        if let Some(layout) = &self.tx_image {
            let image = &registers[4..];
            for (entry, raw) in layout.unpack(0, image, self.order) {
                apply_signal(&mut signals, entry, raw);
            }
        }
        Ok(Exchange { tx, signals })
    }

    /// One exchange with FC 23 (or FC 16 + FC 4 where FC 23 is missing).
    async fn cycle(&mut self, rx: Option<&RxImage>) -> Result<Result<Vec<u16>, Exception>, Error> {
        let count = self.read_count();
        let read = Request::ReadInput {
            address: PDI_TX,
            count,
        };
        let Some(rx) = rx else {
            return self.transact_registers(&read).await;
        };
        let values = registers::rx_to_registers(rx, self.order).to_vec();
        if self.fc23 != Support::No {
            let request = Request::ReadWrite {
                read_address: PDI_TX,
                read_count: count,
                write_address: PDI_RX,
                values: values.clone(),
            };
            match self.transact_registers(&request).await? {
                Err(Exception::Standard {
                    code: exception::ILLEGAL_FUNCTION,
                    ..
                }) => {
                    self.fc23 = Support::No;
                    self.notices.push(format!(
                        "{} does not support FC 23 (Read/Write Multiple Registers): using FC 16 then FC 4, two transactions per cycle",
                        self.transport.describe()
                    ));
                }
                result => {
                    if result.is_ok() {
                        self.fc23 = Support::Yes;
                    }
                    return Ok(result);
                }
            }
        }
        let write = Request::WriteMultiple {
            address: PDI_RX,
            values,
        };
        match self.transport.transact(&write).await? {
            Ok(_) => {}
            Err(e) => return Ok(Err(e)),
        }
        self.transact_registers(&read).await
    }

    async fn transact_registers(
        &mut self,
        request: &Request,
    ) -> Result<Result<Vec<u16>, Exception>, Error> {
        Ok(match self.transport.transact(request).await? {
            Ok(Response::ReadInput(r) | Response::ReadHolding(r) | Response::ReadWrite(r)) => Ok(r),
            Ok(other) => {
                return Err(Error::Protocol(format!(
                    "{} answered with FC {:02X}h",
                    request.describe(),
                    other.function()
                )));
            }
            Err(e) => Err(e),
        })
    }
}

/// Put one mapped object's raw value into the signal it feeds.
fn apply_signal(signals: &mut Signals, entry: Mapped, raw: u32) {
    if let Some(signal) = Signal::of_address(entry.address) {
        signals.set(signal, signal.from_raw(raw, entry.bits));
    }
}

/// The drive's exception to a process-image exchange: its answer, named with its code
/// and meaning, not a broken frame.
fn exception_error(request: &Request, e: &Exception) -> Error {
    let answer = match e {
        Exception::Standard { code, .. } => format!("exception {code:02X}h ({})", e.text()),
        Exception::Extended { abort, .. } => {
            format!(
                "the extended exception abort {}",
                crate::cia::AbortCode(*abort)
            )
        }
    };
    Error::Answer(format!(
        "{}: the drive refused it with {answer}",
        request.describe()
    ))
}

/// The bytes to ask for when reading an object of `dtype`: its size; strings and domains
/// as much as one message carries.
fn read_len(dtype: DataType) -> u16 {
    dtype.size().map_or(240, |s| s as u16)
}

impl Link for ModbusLink {
    fn info(&self) -> LinkInfo {
        let bus = match self.spec {
            LinkSpec::ModbusRtu { .. } => "Modbus RTU",
            _ => "Modbus TCP",
        };
        let mut features = vec![];
        features.push(match self.fc23 {
            Support::No => "FC 16 + FC 4",
            _ => "FC 23",
        });
        if self.fc43 != Support::No {
            features.push("FC 43");
        } else {
            features.push("objects via PDI");
        }
        if self.order == WordOrder::Low {
            features.push("low word first");
        }
        LinkInfo {
            spec: self.spec.clone(),
            description: format!(
                "{bus} {} ({})",
                self.transport.describe(),
                features.join(", ")
            ),
            native_objects: self.fc43 != Support::No,
            can_inject: false,
            pdi: true,
            homing_methods: None,
            commands_refused: None,
        }
    }

    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        match self.cycle(rx).await? {
            Ok(registers) => self.decode(&registers),
            Err(Exception::Standard {
                code: exception::ILLEGAL_DATA_ADDRESS,
                ..
            }) if self.tx_image.is_some() => {
                // The device has no TX image behind the PDI: read the PDI alone from now on.
                self.tx_image = None;
                self.notices.push(
                    "the drive has no process image at register 5000; reading the PDI registers alone".into(),
                );
                match self.cycle(rx).await? {
                    Ok(registers) => self.decode(&registers),
                    Err(e) => Err(exception_error(&pdi_request(rx.is_some()), &e)),
                }
            }
            Err(e) => Err(exception_error(&pdi_request(rx.is_some()), &e)),
        }
    }

    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error> {
        let request = Request::ReadHolding {
            address: PDI_RX,
            count: PDI_REGISTERS,
        };
        Ok(match self.transact_registers(&request).await? {
            Ok(r) if r.len() == 4 => Some(registers::registers_to_rx(
                [r[0], r[1], r[2], r[3]],
                self.order,
            )),
            _ => None,
        })
    }

    async fn read_object(&mut self, address: Address, dtype: DataType) -> Answer<Value> {
        if self.fc43 == Support::No {
            return Ok(Err(Refusal::NotSupported));
        }
        let request = Request::Canopen(CanopenRequest::read(
            0,
            address.index,
            address.sub,
            read_len(dtype),
        ));
        match self.transport.transact(&request).await? {
            Ok(Response::Canopen(response)) => {
                self.fc43 = Support::Yes;
                Ok(Value::from_le_bytes(dtype, &response.data)
                    .map_err(|e| Refusal::Malformed(e.to_string())))
            }
            Ok(other) => Err(Error::Protocol(format!(
                "FC 43 read of {address} answered with FC {:02X}h",
                other.function()
            ))),
            Err(e) => Ok(Err(self.refusal(e))),
        }
    }

    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()> {
        if self.fc43 == Support::No {
            return Ok(Err(Refusal::NotSupported));
        }
        let data = match value.to_le_bytes(dtype) {
            Ok(data) => data,
            Err(e) => return Ok(Err(Refusal::Malformed(e.to_string()))),
        };
        let request = Request::Canopen(CanopenRequest::write(0, address.index, address.sub, data));
        match self.transport.transact(&request).await? {
            Ok(Response::Canopen(_)) => {
                self.fc43 = Support::Yes;
                Ok(Ok(()))
            }
            Ok(other) => Err(Error::Protocol(format!(
                "FC 43 write of {address} answered with FC {:02X}h",
                other.function()
            ))),
            Err(e) => Ok(Err(self.refusal(e))),
        }
    }

    fn take_notices(&mut self) -> Vec<crate::link::Notice> {
        std::mem::take(&mut self.notices)
            .into_iter()
            .map(crate::link::Notice::info)
            .collect()
    }

    fn take_trace(&mut self) -> Vec<crate::link::TraceRecord> {
        self.transport.take_trace()
    }

    fn take_recovered(&mut self) -> Vec<String> {
        self.transport.take_recovered()
    }

    async fn reconnect(&mut self) -> Result<(), Error> {
        self.transport.reconnect().await
    }

    async fn close(&mut self) -> Result<(), Error> {
        self.transport.close().await;
        Ok(())
    }
}

impl ModbusLink {
    /// A device's exception to an FC 43 access as a refusal; exception 01 means the device
    /// has no FC 43 at all.
    fn refusal(&mut self, e: Exception) -> Refusal {
        match e {
            Exception::Standard {
                code: exception::ILLEGAL_FUNCTION,
                ..
            } if self.fc43 != Support::Yes => {
                self.fc43 = Support::No;
                self.notices.push(format!(
                    "{} does not support FC 43 (CANopen objects over Modbus): objects go through PDI OD-Read/OD-Write, 32 bits at most",
                    self.transport.describe()
                ));
                Refusal::NotSupported
            }
            Exception::Extended { abort, .. } => Refusal::Abort(crate::cia::AbortCode(abort)),
            Exception::Standard { function, code } => Refusal::Modbus { function, code },
        }
    }
}

/// The request a PDI exchange uses, for error messages.
fn pdi_request(writes: bool) -> Request {
    if writes {
        Request::ReadWrite {
            read_address: PDI_TX,
            read_count: PDI_REGISTERS,
            write_address: PDI_RX,
            values: vec![0; 4],
        }
    } else {
        Request::ReadInput {
            address: PDI_TX,
            count: PDI_REGISTERS,
        }
    }
}
