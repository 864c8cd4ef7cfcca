//! The buses. A `Link` exchanges the PDI process images with a drive and reads and writes
//! its objects; the worker owns exactly one link at a time and drives it.
//!
//! A device's refusal is data, a broken link is an error: object access returns
//! `Answer<T>` the way tokio-modbus does, so the UI shows a refusal
//! next to the object and a link error as a banner with a reconnect.

pub mod canopen;
pub mod enip;
mod error;
pub mod modbus;
mod notice;
pub(crate) mod owner;
pub mod serial;
pub mod spec;
mod trace;
pub(crate) mod tries;

use std::fmt;

pub use crate::signal::{Signal, Signals};
pub use error::{Error, ErrorKind, LinkFailure, Refusal, modbus_exception_text};
pub use notice::{Notice, NoticeKind};
pub use spec::{CanopenOptions, EnipIo, LinkSpec, Parity, SpecError};
pub use trace::{RawFrames, TRACE_LIMIT, TraceRecord, TraceRing};

use crate::cia::AbortCode;
use crate::od::{Address, DataType, Value};
use crate::pdi::{RxImage, TxImage};

/// An object access's outcome: the value (or `()` for a write), the device's refusal,
/// or a link that failed.
pub type Answer<T> = Result<Result<T, Refusal>, Error>;

/// What a link tells about itself, for the connection bar and the log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkInfo {
    /// The connection string it was opened with.
    pub spec: LinkSpec,
    /// One line for the status bar, e.g. "Simulated drive (in-process)".
    pub description: String,
    /// Whether objects can be read and written without the PDI (SDO, FC 43, CIP, direct).
    pub native_objects: bool,
    /// Whether the simulator's faults can be injected through this link.
    pub can_inject: bool,
    /// Whether the device has the Plug & Drive interface (2291h/2292h). Without it (a
    /// generic CANopen node, say) the link gives object access only.
    pub pdi: bool,
    /// The homing methods the device is known to support (the simulated drive's list);
    /// `None` when the link cannot tell, and any CiA 402 method may work.
    pub homing_methods: Option<Vec<i8>>,
    /// Why PDI commands are refused on this link while its status is still read (another
    /// scanner owns the drive's I/O connection, whose image would overwrite every command
    /// from here); `None` when commands may be sent.
    pub commands_refused: Option<String>,
}

impl fmt::Display for LinkInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.description)
    }
}

/// A connection that could not be made, with the frames exchanged on the way (so that
/// `--trace` and the frame log show what the device said before it failed).
pub type Traced<T> = Result<T, (Error, Vec<TraceRecord>)>;

/// A device found on a bus by a scan (CANopen) or a discovery (EtherNet/IP).
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FoundDevice {
    /// Where it is, for people: `node 5`, `192.168.2.100`.
    pub address: String,
    /// The CANopen node id, where there is one.
    pub node: Option<u8>,
    /// 1018h:01 (Nanotec: 26Ch)
    pub vendor: Option<u32>,
    pub product: Option<u32>,
    pub revision: Option<u32>,
    pub serial: Option<u32>,
    /// 1008h, the device name.
    pub name: Option<String>,
    /// NMT state or similar, as last heard.
    pub state: Option<String>,
    /// Why the device is listed without its identity: it answered the scan's read with a
    /// refusal (a CANopen SDO abort, say).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

impl FoundDevice {
    /// The vendor in words where drivedeck knows it.
    /// CANopen nodes carry CiA vendor ids (Nanotec 26Ch), EtherNet/IP adapters ODVA ones
    /// (Nanotec 558h): the same number means different companies in the two lists.
    pub fn vendor_name(&self) -> String {
        let odva = self.node.is_none();
        match (self.vendor, odva) {
            (Some(0x26C), false) => "Nanotec (26Ch)".into(),
            (Some(0x558), true) => "Nanotec (ODVA 558h)".into(),
            (Some(v), false) => format!("{v:08X}h"),
            (Some(v), true) => format!("ODVA {v:X}h"),
            (None, _) => "?".into(),
        }
    }
}

/// What one process-image exchange brought back.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Exchange {
    pub tx: TxImage,
    pub signals: Signals,
}

/// One bus connection to one drive. The worker runs links on a current-thread runtime, so
/// the futures need not be `Send`.
#[allow(async_fn_in_trait)]
pub trait Link {
    fn info(&self) -> LinkInfo;

    /// Write the RX image (when `Some`) and read the TX image, as one exchange where the
    /// bus allows (FC 23, a PDO pair, a Class 1 cycle), with whatever signals come along.
    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error>;

    /// The RX image the drive holds now (2291h), so that connecting replays nothing.
    /// `None` when the bus cannot read it back.
    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error>;

    /// Read an object without the PDI. `Refusal::NotSupported` when the link has no such
    /// path (the worker then uses PDI OD-Read).
    async fn read_object(&mut self, address: Address, dtype: DataType) -> Answer<Value>;

    /// Read an object whose type nobody here knows (it is not in the catalog): as the
    /// integer of the size the device accepts. Modbus FC 43 must ask for the object's exact
    /// size (a 1-byte object asked for 4 bytes answers abort 06070012h, "length too high"),
    /// so by default 32 bits are asked first, then 16 and 8 on "too high" or 64 on "too
    /// low". Links whose answer carries its size (an SDO upload) or its type (GetOD
    /// Rockwell) read once.
    async fn read_object_of_unknown_type(&mut self, address: Address) -> Answer<Value> {
        let first = self.read_object(address, DataType::Integer32).await?;
        let Err(Refusal::Abort(code)) = &first else {
            return Ok(first);
        };
        let others: &[DataType] = match *code {
            AbortCode::TYPE_LENGTH_TOO_HIGH | AbortCode::TYPE_LENGTH_MISMATCH => {
                &[DataType::Integer16, DataType::Integer8]
            }
            AbortCode::TYPE_LENGTH_TOO_LOW => &[DataType::Integer64],
            _ => return Ok(first),
        };
        let mut last = first;
        for &dtype in others {
            last = self.read_object(address, dtype).await?;
            match &last {
                Err(Refusal::Abort(
                    AbortCode::TYPE_LENGTH_TOO_HIGH | AbortCode::TYPE_LENGTH_MISMATCH,
                )) => continue,
                _ => return Ok(last),
            }
        }
        Ok(last)
    }

    /// Write an object without the PDI, sized to `dtype`.
    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()>;

    /// Find the devices on this link's bus (CANopen node scan).
    async fn scan(&mut self) -> Result<Vec<FoundDevice>, Error> {
        Err(Error::Unsupported("scanning works on CANopen buses".into()))
    }

    /// The frames sent and received since the last call, oldest first (bounded: the oldest
    /// are dropped when nobody asks).
    fn take_trace(&mut self) -> Vec<TraceRecord> {
        Vec::new()
    }

    /// Troubles the link got over by itself since the last call (a lost or corrupted reply
    /// answered on a second try), each named, for the log.
    fn take_recovered(&mut self) -> Vec<String> {
        Vec::new()
    }

    /// Things the link learned that the user should know (e.g. a missing function code
    /// and the fallback chosen). The worker logs them and refreshes the link's description.
    fn take_notices(&mut self) -> Vec<Notice> {
        Vec::new()
    }

    /// What the link itself changed on the device to run (a PDO mapping, …), each with
    /// its old value and what becomes of it when the link closes.
    fn own_changes(&self) -> Vec<String> {
        Vec::new()
    }

    /// Bring a failed link back to the same device (the worker calls this with backoff
    /// after a transient error).
    async fn reconnect(&mut self) -> Result<(), Error> {
        Ok(())
    }

    /// Close the connection politely (release the one TCP connection a drive allows).
    async fn close(&mut self) -> Result<(), Error> {
        Ok(())
    }
}

/// An IPv4 interface of this computer (for EtherNet/IP discovery).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NetworkInterface {
    pub name: String,
    pub ip: std::net::Ipv4Addr,
    pub broadcast: Option<std::net::Ipv4Addr>,
}

impl NetworkInterface {
    /// "eth0 192.168.2.10" for a picker.
    pub fn label(&self) -> String {
        format!("{} {}", self.name, self.ip)
    }
}

/// One name for one device file however it was written (`/dev/serial/by-id/…` and the
/// `/dev/ttyACM0` it points to), so that two links to one port find each other.
pub fn same_file(path: &str) -> String {
    std::fs::canonicalize(path)
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| path.to_owned())
}

/// The serial ports this machine has (for Modbus RTU and slcan adapters), by name.
pub fn serial_ports() -> Vec<String> {
    let mut ports: Vec<String> = tokio_serial::available_ports()
        .map(|ports| ports.into_iter().map(|p| p.port_name).collect())
        .unwrap_or_default();
    ports.sort();
    ports
}
