//! Opening any link from its connection string: the one place that knows every back end,
//! the simulated drive's included. It sits above both `link` (the buses) and `sim` (the
//! simulated drive and its in-process link and CAN bus), so neither imports the other.

use crate::injection::Injection;
use crate::link::canopen::SharedCanPort;
use crate::link::canopen::client::CanopenLink;
use crate::link::canopen::slcan::SlcanBus;
use crate::link::enip::client::EnipLink;
use crate::link::modbus::client::{DEFAULT_TIMEOUT, ModbusLink};
use crate::link::{self as super_link, Answer, Error, Exchange, Link, LinkInfo, LinkSpec, Traced};
use crate::od::{Address, DataType, Value};
use crate::pdi::RxImage;
use crate::sim::{SimCanBus, SimLink};

/// Every link the tool can open, so the worker can hold whichever the user picked.
#[derive(Debug)]
pub enum AnyLink {
    Sim(Box<SimLink>),
    Modbus(Box<ModbusLink>),
    Enip(Box<EnipLink>),
    CanopenSim(Box<CanopenLink<SimCanBus>>),
    CanopenSlcan(Box<CanopenLink<SharedCanPort>>),
    #[cfg(target_os = "linux")]
    CanopenSocketcan(Box<CanopenLink<SharedCanPort>>),
}

/// Open the link a connection string names.
pub async fn open(spec: &LinkSpec) -> Result<AnyLink, Error> {
    open_traced(spec).await.map_err(|(error, _)| error)
}

/// [`open`], keeping the frames exchanged before a connection failed.
pub async fn open_traced(spec: &LinkSpec) -> Traced<AnyLink> {
    let bare = |e: Error| (e, Vec::new());
    match spec {
        LinkSpec::Sim => Ok(AnyLink::Sim(Box::default())),
        LinkSpec::ModbusTcp { .. } | LinkSpec::ModbusRtu { .. } => Ok(AnyLink::Modbus(Box::new(
            ModbusLink::connect_traced(spec, DEFAULT_TIMEOUT).await?,
        ))),
        LinkSpec::CanopenSim { can } => {
            let bus = SimCanBus::start(can.node).await.map_err(bare)?;
            Ok(AnyLink::CanopenSim(Box::new(
                CanopenLink::connect_traced(spec.clone(), bus, *can).await?,
            )))
        }
        LinkSpec::CanopenSlcan { path, bitrate, can } => {
            let bus = join_slcan(path, *bitrate, Some(can.node))
                .await
                .map_err(bare)?;
            Ok(AnyLink::CanopenSlcan(Box::new(
                CanopenLink::connect_traced(spec.clone(), bus, *can).await?,
            )))
        }
        #[cfg(target_os = "linux")]
        LinkSpec::CanopenSocketcan { iface, can } => {
            let bus = join_socketcan(iface, Some(can.node)).await.map_err(bare)?;
            Ok(AnyLink::CanopenSocketcan(Box::new(
                CanopenLink::connect_traced(spec.clone(), bus, *can).await?,
            )))
        }
        #[cfg(not(target_os = "linux"))]
        LinkSpec::CanopenSocketcan { .. } => Err(bare(Error::Unsupported(
            "SocketCAN exists only on Linux: use an slcan adapter (canopen+slcan://COM5?node=1)"
                .into(),
        ))),
        LinkSpec::Enip { .. } => Ok(AnyLink::Enip(Box::new(
            EnipLink::connect_traced(spec).await?,
        ))),
    }
}

/// A port for `node` (`None`: every frame, for a scan) on the slcan adapter at `path`,
/// shared with every other link on it: the adapter is opened by the first.
async fn join_slcan(path: &str, bitrate: u32, node: Option<u8>) -> Result<SharedCanPort, Error> {
    let owned = path.to_owned();
    let key = format!("slcan:{}", super_link::same_file(path));
    let settings = format!("{bitrate} bit/s");
    crate::link::canopen::shared::join(&key, &settings, "slcan0", node, move || async move {
        SlcanBus::open(&owned, bitrate).await
    })
    .await
}

/// A port for `node` (`None`: every frame) on the SocketCAN interface `iface`, shared with
/// every other link on it.
#[cfg(target_os = "linux")]
async fn join_socketcan(iface: &str, node: Option<u8>) -> Result<SharedCanPort, Error> {
    let owned = iface.to_owned();
    let key = format!("socketcan:{iface}");
    crate::link::canopen::shared::join(&key, "", iface, node, move || async move {
        crate::link::canopen::socketcan::SocketCanBus::open(&owned)
    })
    .await
}

impl From<SimLink> for AnyLink {
    fn from(link: SimLink) -> Self {
        AnyLink::Sim(Box::new(link))
    }
}

/// Scan the bus a connection string names, without connecting to a node.
pub async fn scan(spec: &LinkSpec) -> Result<Vec<super_link::FoundDevice>, Error> {
    scan_traced(spec, false).await.0
}

/// [`scan`], with the CAN frames of the scan when `trace` is on (`--trace scan`).
pub async fn scan_traced(
    spec: &LinkSpec,
    trace: bool,
) -> (
    Result<Vec<super_link::FoundDevice>, Error>,
    Vec<super_link::TraceRecord>,
) {
    use crate::link::canopen::scan::scan_traced as can_scan;
    let found = match spec {
        LinkSpec::CanopenSim { can } => {
            // Every simulated node open in the process, and the spec's own.
            let (mut port, _guest) = match SimCanBus::scanner(can.node).await {
                Ok(opened) => opened,
                Err(e) => return (Err(e), Vec::new()),
            };
            // Let a node put there for the scan boot.
            tokio::time::sleep(std::time::Duration::from_millis(20)).await;
            return can_scan(&mut port, trace).await;
        }
        LinkSpec::CanopenSlcan { path, bitrate, .. } => {
            match join_slcan(path, *bitrate, None).await {
                Ok(mut bus) => return can_scan(&mut bus, trace).await,
                Err(e) => Err(e),
            }
        }
        #[cfg(target_os = "linux")]
        LinkSpec::CanopenSocketcan { iface, .. } => match join_socketcan(iface, None).await {
            Ok(mut bus) => return can_scan(&mut bus, trace).await,
            Err(e) => Err(e),
        },
        LinkSpec::Enip { host, port, .. } => {
            crate::link::enip::discovery::discover(&crate::link::enip::discovery::Discovery {
                port: *port,
                unicast: vec![host.clone()],
                ..Default::default()
            })
            .await
        }
        _ => Err(Error::Unsupported(format!(
            "{} has no bus scan: scanning works on CANopen buses and EtherNet/IP networks",
            spec.bus_name()
        ))),
    };
    (found, Vec::new())
}

impl AnyLink {
    /// Inject or withdraw a simulated fault. Only the simulated drive takes them.
    pub fn inject(&mut self, injection: Injection, active: bool) -> Result<(), Error> {
        match self {
            AnyLink::Sim(l) => l.inject(injection, active),
            AnyLink::CanopenSim(l) => l.bus_mut().inject(injection, active),
            _ => Err(Error::Unsupported(
                "fault injection works only on the simulated drive".into(),
            )),
        }
    }
}

/// `$body` with `$l` bound to the link inside `$link`, whichever kind it is.
macro_rules! each_link {
    ($link:expr, $l:ident => $body:expr) => {
        match $link {
            AnyLink::Sim($l) => $body,
            AnyLink::Modbus($l) => $body,
            AnyLink::Enip($l) => $body,
            AnyLink::CanopenSim($l) => $body,
            AnyLink::CanopenSlcan($l) => $body,
            #[cfg(target_os = "linux")]
            AnyLink::CanopenSocketcan($l) => $body,
        }
    };
}

impl Link for AnyLink {
    fn info(&self) -> LinkInfo {
        match self {
            // The node on the simulated bus is the simulated drive: its methods are known.
            AnyLink::CanopenSim(l) => LinkInfo {
                homing_methods: Some(crate::sim::SUPPORTED_METHODS.to_vec()),
                commands_refused: None,
                ..l.info()
            },
            other => each_link!(other, l => l.info()),
        }
    }

    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        each_link!(self, l => l.exchange(rx).await)
    }

    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error> {
        each_link!(self, l => l.read_rx().await)
    }

    async fn read_object(&mut self, address: Address, dtype: DataType) -> Answer<Value> {
        each_link!(self, l => l.read_object(address, dtype).await)
    }

    async fn read_object_of_unknown_type(&mut self, address: Address) -> Answer<Value> {
        each_link!(self, l => l.read_object_of_unknown_type(address).await)
    }

    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()> {
        each_link!(self, l => l.write_object(address, dtype, value).await)
    }

    async fn scan(&mut self) -> Result<Vec<super_link::FoundDevice>, Error> {
        each_link!(self, l => l.scan().await)
    }

    fn take_trace(&mut self) -> Vec<super_link::TraceRecord> {
        each_link!(self, l => l.take_trace())
    }

    fn take_recovered(&mut self) -> Vec<String> {
        each_link!(self, l => l.take_recovered())
    }

    fn take_notices(&mut self) -> Vec<super_link::Notice> {
        each_link!(self, l => l.take_notices())
    }

    fn own_changes(&self) -> Vec<String> {
        each_link!(self, l => l.own_changes())
    }

    async fn reconnect(&mut self) -> Result<(), Error> {
        each_link!(self, l => l.reconnect().await)
    }

    async fn close(&mut self) -> Result<(), Error> {
        each_link!(self, l => l.close().await)
    }
}
