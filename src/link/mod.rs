//! The buses. A `Link` exchanges the PDI process images with a drive and reads and writes
//! its objects; the worker owns exactly one link at a time and drives it.
//!
//! A device's refusal is data, a broken link is an error: object access returns
//! `Result<Result<T, Refusal>, Error>` the way tokio-modbus does, so the UI shows a refusal
//! next to the object and a link error as a banner with a reconnect.

pub mod canopen;
mod error;
pub mod modbus;
mod open;
pub mod sim;
pub mod spec;

use std::fmt;

pub use error::{Error, Refusal, modbus_exception_text};
pub use open::{AnyLink, open};
pub use spec::{CanopenOptions, EnipIo, LinkSpec, Parity, SpecError};

use crate::od::{Address, DataType, Value};
use crate::pdi::{RxImage, TxImage};
use crate::sim::Injection;

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
}

impl fmt::Display for LinkInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.description)
    }
}

/// The plot and status signals besides the PDI, each `None` when the link cannot get it
/// cheaply (a link delivers what its process image or a direct read gives for free).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Signals {
    /// 6064h, user units (0.1°)
    pub position: Option<f64>,
    /// 606Ch, user units (rpm)
    pub velocity: Option<f64>,
    /// 6077h, ‰ of rated torque
    pub torque: Option<f64>,
    /// 60F4h
    pub following_error: Option<f64>,
    /// 6041h
    pub statusword: Option<u16>,
    /// 60FDh
    pub digital_inputs: Option<u32>,
    /// 6061h
    pub mode: Option<i8>,
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
    async fn read_object(
        &mut self,
        address: Address,
        dtype: DataType,
    ) -> Result<Result<Value, Refusal>, Error>;

    /// Write an object without the PDI, sized to `dtype`.
    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Result<Result<(), Refusal>, Error>;

    /// Inject or withdraw a simulated fault. Only the simulator can.
    async fn inject(&mut self, injection: Injection, active: bool) -> Result<(), Error> {
        let _ = (injection, active);
        Err(Error::Unsupported(
            "fault injection works only on the simulated drive".into(),
        ))
    }

    /// Things the link learned that the user should know (e.g. a missing function code
    /// and the fallback chosen). The worker logs them and refreshes the link's description.
    fn take_notices(&mut self) -> Vec<String> {
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

/// The serial ports this machine has (for Modbus RTU and slcan adapters), by name.
pub fn serial_ports() -> Vec<String> {
    let mut ports: Vec<String> = tokio_serial::available_ports()
        .map(|ports| ports.into_iter().map(|p| p.port_name).collect())
        .unwrap_or_default();
    ports.sort();
    ports
}
