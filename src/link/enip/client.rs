//! `EnipLink`: a Nanotec drive over EtherNet/IP.
//!
//! * Objects go over Nanotec's explicit services on class 64h: GetOD (32h), SetOD (33h),
//!   and GetOD Rockwell (34h) where the type is not known beforehand.
//! * The PDI runs through a class 1 I/O connection (the PDI set 105/104, or the Common set
//!   101/100 with position, velocity, inputs, torque, analog input and following error
//!   along), opened with Forward_Open and produced at the RPI by threads of their own (nothing on the worker delays them); and
//!   through explicit 2291h/2292h access when the user asks for that or the drive refuses
//!   the I/O connection (the link says why).
//! * Connecting replays nothing: the first O→T assembly is what the drive holds already.

use std::net::{IpAddr, Ipv4Addr, SocketAddr, SocketAddrV4};
use std::sync::atomic::{AtomicU16, Ordering};
use std::time::{Duration, SystemTime};

use std::net::UdpSocket;

use super::implicit::{IoConfig, IoHandle, IoTiming};
use super::session::Session;
use crate::link::spec::{EnipIo, EnipOptions};
use crate::link::{
    Answer, Error, Exchange, FoundDevice, Link, LinkInfo, LinkSpec, Refusal, Signal, Signals,
};
use crate::od::{Address, DataType, Value};
use crate::pdi::{ImageObject, RX_OBJECTS, RxImage, TX_OBJECTS, TxImage};
use crate::proto::enip::assembly::{self, AssemblySet, CmdOffset, CommonIn, CommonOut};
use crate::proto::enip::cip::{self, Path, Segment, class, service};
use crate::proto::enip::connection::{
    self, ForwardClose, ForwardOpen, ForwardOpenReply, NetworkParams, TRANSPORT_CLASS1_CYCLIC,
    Triad,
};
use crate::proto::enip::cpf::{Item, SockAddr};
use crate::proto::enip::encap::UDP_IO_PORT;
use crate::proto::enip::identity::{Identity, NANOTEC_VENDOR};
use crate::proto::enip::io;
use crate::proto::enip::nanotec::{self, Typed};

/// How long an explicit request may take.
pub const EXPLICIT_TIMEOUT: Duration = Duration::from_millis(1000);
/// drivedeck has no ODVA vendor id; adapters use the originator vendor only to tell
/// connections apart.
pub const ORIGINATOR_VENDOR: u16 = 0xFFFE;
/// The I/O connection's timeout is at least this long: a laptop's scheduler and Wi-Fi
/// hiccups must not drop a commissioning session.
const MIN_IO_TIMEOUT: Duration = Duration::from_millis(500);

static SERIAL: AtomicU16 = AtomicU16::new(0);

/// Numbers that differ between runs and processes (connection serials and ids).
fn entropy() -> u32 {
    let nanos = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map(|d| d.subsec_nanos() ^ (d.as_secs() as u32).rotate_left(13))
        .unwrap_or(0);
    nanos ^ std::process::id().rotate_left(7)
}

/// The dictionary type of a PDI image object.
fn image_type(o: ImageObject) -> DataType {
    DataType::integer(o.bits, o.signed).unwrap_or(DataType::Integer32)
}

/// The timeout multiplier that gives at least [`MIN_IO_TIMEOUT`] at this RPI.
fn multiplier_for(rpi_us: u32) -> u8 {
    (0..=7u8)
        .find(|m| connection::timeout(rpi_us, *m) >= MIN_IO_TIMEOUT)
        .unwrap_or(7)
}

/// An open class 1 connection and what closing it needs.
#[derive(Debug)]
struct Opened {
    set: AssemblySet,
    cmd: CmdOffset,
    triad: Triad,
    path: Vec<u8>,
    handle: IoHandle,
    /// The Common set's outputs besides the PDI (kept as read at connect).
    common_out: CommonOut,
}

/// A drive over EtherNet/IP.
#[derive(Debug)]
pub struct EnipLink {
    spec: LinkSpec,
    host: String,
    port: u16,
    options: EnipOptions,
    session: Session,
    identity: Option<Identity>,
    io: Option<Opened>,
    /// The device has the PDI objects (2291h/2292h).
    pdi: bool,
    /// The RX image last written over explicit messages.
    explicit_rx: Option<RxImage>,
    /// Why commands are refused: the device has no PDI (the refusal of GetOD 2292h), or
    /// another scanner owns the drive's I/O connection (its class 1 image would
    /// overwrite every SetOD 2291h from here).
    commands_refused: Option<String>,
    /// The last Forward_Open was refused for an ownership conflict (0106h).
    owned_elsewhere: bool,
    /// While reopening: how long our old I/O connection may live on in the adapter.
    linger: Option<Duration>,
    /// A class 1 connection was lost and is not yet open again: a reopen that gets no
    /// data is a failed try (the outage goes on), not a reason to poll over explicit
    /// messages for the rest of the session.
    io_lost: bool,
    notices: Vec<String>,
}

impl EnipLink {
    pub async fn connect(spec: &LinkSpec) -> Result<EnipLink, Error> {
        Self::connect_traced(spec).await.map_err(|(error, _)| error)
    }

    /// [`EnipLink::connect`], keeping the frames of a connection that failed.
    pub async fn connect_traced(spec: &LinkSpec) -> crate::link::Traced<EnipLink> {
        let LinkSpec::Enip { host, port, enip } = spec else {
            return Err((
                Error::Unsupported(format!("{spec} is not an EtherNet/IP connection string")),
                vec![],
            ));
        };
        let session = Session::open_traced(host, *port, EXPLICIT_TIMEOUT).await?;
        let mut link = EnipLink {
            spec: spec.clone(),
            host: host.clone(),
            port: *port,
            options: *enip,
            session,
            identity: None,
            io: None,
            pdi: false,
            explicit_rx: None,
            commands_refused: None,
            owned_elsewhere: false,
            linger: None,
            io_lost: false,
            notices: vec![],
        };
        match link.start().await {
            Ok(()) => Ok(link),
            Err(error) => Err((error, link.take_trace())),
        }
    }

    /// Learn the device and open the I/O connection the user asked for.
    async fn start(&mut self) -> Result<(), Error> {
        match self.session.list_identity().await {
            Ok(identity) => {
                if identity.vendor != NANOTEC_VENDOR {
                    self.notices.push(format!(
                        "the adapter at {} is not a Nanotec device (vendor {:04X}h, {}): its object services may differ",
                        self.session.peer(),
                        identity.vendor,
                        crate::text::shown(&identity.product_name)
                    ));
                }
                self.identity = Some(identity);
            }
            Err(e) => self
                .notices
                .push(format!("no identity from the adapter ({e})")),
        }
        self.pdi = match self
            .get(
                Address::new(TX_OBJECTS[0].index, TX_OBJECTS[0].sub),
                image_type(TX_OBJECTS[0]),
            )
            .await?
        {
            Ok(_) => true,
            Err(refusal) => {
                let why = format!(
                    "this device has no Plug & Drive interface: it refused GetOD {} \
                     ({refusal}); object access only",
                    Address::new(TX_OBJECTS[0].index, TX_OBJECTS[0].sub)
                );
                self.notices.push(why.clone());
                self.commands_refused = Some(why);
                false
            }
        };
        if self.pdi {
            let set = match self.options.io {
                EnipIo::Pdi => Some(AssemblySet::Pdi),
                EnipIo::Common => Some(AssemblySet::Common),
                EnipIo::Explicit => None,
            };
            if let Some(set) = set {
                let mut opened = self.open_io(set).await;
                // Reopening: our own old connection may live on in the adapter until its
                // timeout and refuse the new one as an ownership conflict. Wait it out once
                // before taking the refusal for another master's.
                if let (Err(Error::Refused(_)), Some(linger)) = (&opened, self.linger.take())
                    && self.owned_elsewhere
                {
                    tokio::time::sleep(linger).await;
                    opened = self.open_io(set).await;
                }
                self.commands_refused = None;
                match opened {
                    Ok(opened) => {
                        self.io = Some(opened);
                        self.io_lost = false;
                    }
                    // The connection ran before: the adapter (or the network between) is
                    // not producing yet. Polling instead would hide the outage and keep
                    // the session off class 1 for good; this try failed, the next one
                    // opens it again.
                    Err(Error::Refused(reason)) if self.io_lost && !self.owned_elsewhere => {
                        return Err(Error::Disconnected(format!(
                            "{}: the I/O connection could not be opened again yet: {reason}",
                            self.session.peer()
                        )));
                    }
                    Err(Error::Refused(reason)) if self.owned_elsewhere => {
                        let why = format!(
                            "another master owns the drive's I/O connection ({reason}): its \
                             image overwrites every command sent from here, so drivedeck only \
                             reads the drive; stop the other master (a PLC, Plug & Drive \
                             Studio, a second drivedeck) or command the drive from it"
                        );
                        self.notices.push(why.clone());
                        self.commands_refused = Some(why);
                    }
                    Err(Error::Refused(reason)) => self.notices.push(format!(
                        "{reason}: running the PDI over explicit messages (SetOD 2291h, GetOD 2292h) instead"
                    )),
                    Err(other) => return Err(other),
                }
            }
        }
        Ok(())
    }

    /// One explicit request; a CIP error status is the device's refusal of `what`.
    async fn explicit(
        &mut self,
        request: &cip::Request,
        what: impl FnOnce() -> String,
    ) -> Answer<cip::Reply> {
        let (reply, _) = self.session.request(request, vec![]).await?;
        if !reply.status.is_success() {
            return Ok(Err(Refusal::Cip {
                what: what(),
                status: reply.status.0,
                additional: reply.additional,
            }));
        }
        Ok(Ok(reply))
    }

    /// Read one entry with GetOD; a CIP error status is the device's refusal.
    async fn get(&mut self, address: Address, dtype: DataType) -> Answer<Value> {
        let request = nanotec::get_od(address);
        Ok(self
            .explicit(&request, || format!("GetOD {address}"))
            .await?
            .and_then(|reply| decode_value(address, dtype, &reply.data)))
    }

    /// Read one entry with GetOD Rockwell: its type comes with it.
    pub async fn get_typed(&mut self, address: Address) -> Answer<(DataType, Value)> {
        let request = nanotec::get_od_rockwell(address);
        let reply = match self
            .explicit(&request, || format!("GetOD Rockwell {address}"))
            .await?
        {
            Ok(reply) => reply,
            Err(refusal) => return Ok(Err(refusal)),
        };
        let typed = match Typed::decode(&reply.data) {
            Ok(t) => t,
            Err(e) => return Ok(Err(Refusal::Malformed(format!("{address}: {e}")))),
        };
        let Some(dtype) = DataType::from_code(typed.dtype_code) else {
            return Ok(Err(Refusal::Malformed(format!(
                "{address}: unknown data type {:04X}h",
                typed.dtype_code
            ))));
        };
        Ok(decode_value(address, dtype, &typed.data).map(|v| (dtype, v)))
    }

    async fn set(&mut self, address: Address, dtype: DataType, value: &Value) -> Answer<()> {
        let bytes = match value.to_le_bytes(dtype) {
            Ok(b) => b,
            Err(e) => return Ok(Err(Refusal::Malformed(format!("{address}: {e}")))),
        };
        let request = match nanotec::set_od(address, &bytes) {
            Ok(r) => r,
            // Wider than SetOD carries: nothing on EtherNet/IP can write it.
            Err(e) => return Ok(Err(Refusal::Malformed(e.to_string()))),
        };
        Ok(self
            .explicit(&request, || format!("SetOD {address}"))
            .await?
            .map(|_| ()))
    }

    /// A PDI object that must be there once the PDI was found.
    async fn get_int(&mut self, address: Address, dtype: DataType) -> Result<i128, Error> {
        match self.get(address, dtype).await? {
            Ok(value) => value
                .as_i128()
                .ok_or_else(|| Error::Protocol(format!("{address} is not a number"))),
            Err(refusal) => Err(Error::Answer(format!(
                "the drive stopped answering its PDI objects: {refusal}"
            ))),
        }
    }

    /// 2291h:01..04 as the drive holds them.
    async fn read_rx_explicit(&mut self) -> Result<RxImage, Error> {
        let mut values = [0i64; 4];
        for (slot, o) in values.iter_mut().zip(RX_OBJECTS) {
            *slot = self
                .get_int(Address::new(o.index, o.sub), image_type(o))
                .await? as i64;
        }
        let mut values = values.into_iter();
        Ok(RxImage::from_object_values(|_| values.next().unwrap_or(0)))
    }

    /// An object read for the Common set's outputs: 0 where the drive lacks it.
    async fn get_or_zero(&mut self, address: Address, dtype: DataType) -> Result<i128, Error> {
        Ok(self
            .get(address, dtype)
            .await?
            .ok()
            .and_then(|v| v.as_i128())
            .unwrap_or(0))
    }

    /// The local UDP socket for T→O packets, and the sockaddr item to announce it with.
    /// A plain socket: the I/O threads own it, not the worker's runtime.
    fn bind_udp(&mut self) -> Result<(UdpSocket, Option<Item>), Error> {
        let any = |port| SocketAddr::from((Ipv4Addr::UNSPECIFIED, port));
        let announce = |socket: &UdpSocket| {
            socket.local_addr().ok().map(|a| {
                Item::SockaddrTo(SockAddr::new(SocketAddrV4::new(
                    Ipv4Addr::UNSPECIFIED,
                    a.port(),
                )))
            })
        };
        let io_error = |port: u16, e: std::io::Error| Error::Io {
            context: format!("binding UDP port {port} for the drive's I/O packets"),
            source: e,
        };
        match self.options.udp {
            Some(0) => {
                let socket = UdpSocket::bind(any(0)).map_err(|e| io_error(0, e))?;
                let item = announce(&socket);
                Ok((socket, item))
            }
            Some(port) => {
                let socket = UdpSocket::bind(any(port)).map_err(|e| io_error(port, e))?;
                Ok((socket, None))
            }
            None => match UdpSocket::bind(any(UDP_IO_PORT)) {
                Ok(socket) => Ok((socket, None)),
                Err(_) => {
                    let socket = UdpSocket::bind(any(0)).map_err(|e| io_error(0, e))?;
                    let item = announce(&socket);
                    if let Ok(local) = socket.local_addr() {
                        self.notices.push(format!(
                            "UDP {UDP_IO_PORT} is taken on this computer (another scanner, or a simulated adapter): receiving I/O on UDP {} and asking the adapter to send there",
                            local.port()
                        ));
                    }
                    Ok((socket, item))
                }
            },
        }
    }

    /// Forward_Open for `set`, and the I/O task. `Error::Refused` when the adapter says no.
    async fn open_io(&mut self, set: AssemblySet) -> Result<Opened, Error> {
        let cmd = match self.options.cmd_at {
            8 => CmdOffset::Eight,
            _ => CmdOffset::Seven,
        };
        let common_out = self.outputs_now(set).await?;
        let output = match set {
            AssemblySet::Pdi => assembly::encode_pdi_ot(&common_out.rx, cmd),
            AssemblySet::Common => common_out.encode().to_vec(),
        };
        let (socket, announce) = self.bind_udp()?;
        let open = self.forward_open(set, output.len());
        let request = cip::Request::new(
            service::FORWARD_OPEN,
            &Path::object(class::CONNECTION_MANAGER, 1),
            open.encode(),
        );
        let (reply, items) = self
            .session
            .request(&request, announce.into_iter().collect())
            .await?;
        if !reply.status.is_success() {
            self.owned_elsewhere =
                reply.additional.first() == Some(&connection::extended::OWNERSHIP_CONFLICT);
            return Err(Error::Refused(refused_io(set, cmd, &reply)));
        }
        let accepted = ForwardOpenReply::decode(&reply.data)
            .map_err(|e| Error::Protocol(format!("Forward_Open reply: {e}")))?;
        let to_timeout = open.to_timeout();
        let config = IoConfig {
            ot_connection: accepted.ot_connection,
            to_connection: accepted.to_connection,
            target: self.io_target(&items),
            ot_rpi: Duration::from_micros(u64::from(open.ot_rpi_us.max(1000))),
            to_rpi: Duration::from_micros(u64::from(open.to_rpi_us)),
            timeout_factor: connection::timeout_factor(open.timeout_multiplier),
            to_timeout,
            ot_header: true,
            to_header: false,
            output,
            input_len: set.to_len(),
        };
        let handle = IoHandle::start(socket, config).map_err(|e| Error::Io {
            context: "starting the I/O threads".into(),
            source: e,
        })?;
        let opened = Opened {
            set,
            cmd,
            triad: open.triad(),
            path: open.path,
            handle,
            common_out,
        };
        self.first_input(opened, to_timeout).await
    }

    /// The outputs as the drive holds them now, so that the first packets change nothing:
    /// the PDI's RX image and, for the Common set, the digital and NanoJ outputs.
    async fn outputs_now(&mut self, set: AssemblySet) -> Result<CommonOut, Error> {
        let rx = self.read_rx_explicit().await?;
        let mut common_out = CommonOut {
            rx,
            ..CommonOut::default()
        };
        if set == AssemblySet::Common {
            common_out.digital_outputs = self
                .get_or_zero(Address::new(0x60FE, 1), DataType::Unsigned32)
                .await? as u32;
            for (i, slot) in common_out.nanoj_inputs.iter_mut().enumerate() {
                *slot = self
                    .get_or_zero(Address::new(0x2400, i as u8 + 1), DataType::Integer32)
                    .await? as i32;
            }
        }
        Ok(common_out)
    }

    /// The Forward_Open for `set` with `output_len` bytes O→T, at the RPI asked for, under
    /// a fresh connection serial and T→O id.
    fn forward_open(&self, set: AssemblySet, output_len: usize) -> ForwardOpen {
        let rpi_us = self.options.rpi_ms.saturating_mul(1000);
        let serial = SERIAL
            .fetch_add(1, Ordering::Relaxed)
            .wrapping_add(entropy() as u16);
        let to_connection = entropy() | 1;
        let path = Path(vec![
            Segment::Class(class::ASSEMBLY),
            Segment::Instance(self.options.config),
            Segment::ConnectionPoint(set.ot_instance()),
            Segment::ConnectionPoint(set.to_instance()),
        ])
        .encode();
        ForwardOpen {
            large: false,
            tick: 0x0A,
            timeout_ticks: 0x0E,
            ot_connection: 0,
            to_connection,
            serial,
            vendor: ORIGINATOR_VENDOR,
            originator_serial: entropy(),
            timeout_multiplier: multiplier_for(rpi_us),
            ot_rpi_us: rpi_us,
            ot_params: NetworkParams::point_to_point(io::connection_size(output_len as u16, true)),
            to_rpi_us: rpi_us,
            to_params: NetworkParams::point_to_point(io::connection_size(
                set.to_len() as u16,
                false,
            )),
            transport: TRANSPORT_CLASS1_CYCLIC,
            path,
        }
    }

    /// Where O→T packets go: the adapter's sockaddr item, else its IP and port 2222.
    fn io_target(&self, items: &[Item]) -> SocketAddr {
        let peer_ip = self
            .session
            .addresses()
            .1
            .map(|a| a.ip())
            .unwrap_or(IpAddr::V4(Ipv4Addr::LOCALHOST));
        items
            .iter()
            .find_map(|i| match i {
                Item::SockaddrOt(s) => Some(SocketAddr::new(
                    if s.ip.is_unspecified() {
                        peer_ip
                    } else {
                        IpAddr::V4(s.ip)
                    },
                    s.port,
                )),
                _ => None,
            })
            .unwrap_or(SocketAddr::new(peer_ip, UDP_IO_PORT))
    }

    /// The adapter must be producing before the link reports itself open: `opened` once
    /// its first packet came, else closed again and `Error::Refused`.
    async fn first_input(&mut self, opened: Opened, to_timeout: Duration) -> Result<Opened, Error> {
        let first = opened
            .handle
            .input_after(
                0,
                to_timeout.max(Duration::from_secs(1)) + Duration::from_millis(500),
            )
            .await;
        if let Err(reason) = first {
            let local = opened.handle.local;
            self.forward_close(&opened).await;
            return Err(Error::Refused(format!(
                "the adapter accepted the I/O connection but no data reached UDP {} here ({reason})",
                local.port()
            )));
        }
        Ok(opened)
    }

    async fn forward_close(&mut self, opened: &Opened) {
        if let Some(reply) = self.send_forward_close(opened).await
            && !reply.status.is_success()
        {
            self.notices.push(format!(
                "Forward_Close was refused: {}",
                reply.status_text()
            ));
        }
    }

    /// Stop producing and ask the adapter to close the connection (by its triad, from any
    /// session: protocol notes §3.4); its reply, if one came.
    async fn send_forward_close(&mut self, opened: &Opened) -> Option<cip::Reply> {
        opened.handle.stop();
        let close = ForwardClose {
            tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: opened.triad,
            path: opened.path.clone(),
        };
        let request = cip::Request::new(
            service::FORWARD_CLOSE,
            &Path::object(class::CONNECTION_MANAGER, 1),
            close.encode(),
        );
        self.session
            .request(&request, vec![])
            .await
            .ok()
            .map(|(reply, _)| reply)
    }

    /// The PDI over explicit messages: changed set values, the command last; then the TX
    /// image.
    async fn exchange_explicit(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        if let Some(rx) = rx
            && self.explicit_rx.as_ref() != Some(rx)
        {
            // The set values first, the command byte last: it starts the command. Only
            // what changed is written.
            let old = self.explicit_rx.map(|o| o.object_values());
            for (n, (o, value)) in rx.object_values().into_iter().enumerate() {
                if old.is_some_and(|old| old[n].1 == value) {
                    continue;
                }
                let address = Address::new(o.index, o.sub);
                if let Err(refusal) = self.set(address, image_type(o), &Value::Int(value)).await? {
                    return Err(Error::Answer(format!(
                        "the drive refused the PDI write of {address} ({}): {refusal}",
                        o.name
                    )));
                }
            }
            self.explicit_rx = Some(*rx);
        }
        let mut values = [0i64; 3];
        for (slot, o) in values.iter_mut().zip(TX_OBJECTS) {
            *slot = self
                .get_int(Address::new(o.index, o.sub), image_type(o))
                .await? as i64;
        }
        let mut values = values.into_iter();
        Ok(Exchange {
            tx: TxImage::from_object_values(|_| values.next().unwrap_or(0)),
            signals: Signals::default(),
        })
    }

    fn describe(&self) -> String {
        let device = self
            .identity
            .as_ref()
            .map(|i| crate::text::shown(&i.product_name).into_owned())
            .filter(|n| !n.is_empty())
            .unwrap_or_else(|| "adapter".into());
        let how = match (&self.io, self.pdi) {
            (_, false) => "objects only (no PDI)".to_owned(),
            (Some(o), true) => format!(
                "PDI on the {}, class 1 I/O at {} ms",
                o.set.name(),
                self.options.rpi_ms
            ),
            (None, true) => "PDI over explicit messages (2291h/2292h)".to_owned(),
        };
        format!("EtherNet/IP {device} at {}: {how}", self.session.peer())
    }

    /// The identity the adapter announced.
    pub fn identity(&self) -> Option<&Identity> {
        self.identity.as_ref()
    }

    /// (sent, received, stray) I/O packets, when an I/O connection is open.
    pub fn io_counts(&self) -> Option<(u64, u64, u64)> {
        self.io.as_ref().map(|o| o.handle.counts())
    }

    /// Start (afresh) or stop recording the I/O connection's production and arrival
    /// intervals; false when no I/O connection is open.
    pub fn record_io_timing(&self, on: bool) -> bool {
        self.io
            .as_ref()
            .map(|o| o.handle.record_timing(on))
            .is_some()
    }

    /// The intervals recorded since [`EnipLink::record_io_timing`], when an I/O
    /// connection is open.
    pub fn take_io_timing(&self) -> Option<IoTiming> {
        self.io.as_ref().map(|o| o.handle.take_timing())
    }

    /// The priority the I/O producer thread runs at, once it started.
    pub fn io_priority(&self) -> Option<super::priority::Priority> {
        self.io.as_ref().and_then(|o| o.handle.priority())
    }

    /// The local UDP address the I/O connection takes T→O packets on.
    pub fn io_local(&self) -> Option<std::net::SocketAddr> {
        self.io.as_ref().map(|o| o.handle.local)
    }

    /// The priority the I/O consumer thread runs at now.
    pub fn io_consumer_priority(&self) -> Option<super::priority::Priority> {
        self.io.as_ref().and_then(|o| o.handle.consumer_priority())
    }

    /// The RPI of the open I/O connection.
    pub fn io_rpi(&self) -> Option<Duration> {
        self.io.as_ref().map(|o| o.handle.config.ot_rpi)
    }
}

/// A value from the bytes GetOD returned, strictly sized.
/// Why the adapter refused the I/O connection for `set`, with a hint where one helps.
fn refused_io(set: AssemblySet, cmd: CmdOffset, reply: &cip::Reply) -> String {
    format!(
        "the adapter refused the I/O connection for the {}: {}{}",
        set.name(),
        reply.status_text(),
        match reply.additional.first() {
            Some(&connection::extended::OWNERSHIP_CONFLICT) =>
                " (another scanner, a PLC perhaps, owns the drive's I/O)",
            Some(&connection::extended::INVALID_OT_SIZE) if cmd == CmdOffset::Eight =>
                " (try cmd_at=7)",
            Some(&connection::extended::INVALID_OT_SIZE) => " (try cmd_at=8)",
            _ => "",
        }
    )
}

fn decode_value(address: Address, dtype: DataType, data: &[u8]) -> Result<Value, Refusal> {
    if let Some(size) = dtype.size()
        && size != data.len()
    {
        return Err(Refusal::Malformed(format!(
            "{address}: {} bytes for a {} ({size} expected)",
            data.len(),
            dtype.short_name()
        )));
    }
    Value::from_le_bytes(dtype, data).map_err(|e| Refusal::Malformed(format!("{address}: {e}")))
}

impl Link for EnipLink {
    fn info(&self) -> LinkInfo {
        LinkInfo {
            spec: self.spec.clone(),
            description: self.describe(),
            native_objects: true,
            can_inject: false,
            pdi: self.pdi,
            homing_methods: None,
            commands_refused: self.commands_refused.clone(),
        }
    }

    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        if !self.pdi {
            return Err(Error::Unsupported(
                "this device has no Plug & Drive interface".into(),
            ));
        }
        let Some(opened) = self.io.as_mut() else {
            return self.exchange_explicit(rx).await;
        };
        if let Some(rx) = rx {
            let output = match opened.set {
                AssemblySet::Pdi => assembly::encode_pdi_ot(rx, opened.cmd),
                AssemblySet::Common => {
                    opened.common_out.rx = *rx;
                    opened.common_out.encode().to_vec()
                }
            };
            opened.handle.set_output(output);
        }
        let after = opened.handle.received();
        let wait = opened.handle.config.to_timeout + opened.handle.config.ot_rpi;
        let input = opened
            .handle
            .input_after(after, wait)
            .await
            .map_err(|reason| Error::Disconnected(format!("{}: {reason}", self.session.peer())))?;
        match opened.set {
            AssemblySet::Pdi => {
                let tx = TxImage::from_bytes(&input.data)
                    .map_err(|e| Error::Protocol(format!("PDI T→O assembly: {e}")))?;
                Ok(Exchange {
                    tx,
                    signals: Signals::default(),
                })
            }
            AssemblySet::Common => {
                let common =
                    CommonIn::decode(&input.data).map_err(|e| Error::Protocol(e.to_string()))?;
                Ok(Exchange {
                    tx: common.tx,
                    signals: Signals::default()
                        .with(Signal::Position, f64::from(common.position))
                        .with(Signal::Velocity, f64::from(common.velocity))
                        .with(Signal::Torque, f64::from(common.torque))
                        .with(Signal::FollowingError, f64::from(common.following_error))
                        .with(Signal::DigitalInputs, f64::from(common.digital_inputs))
                        .with(Signal::AnalogInput, f64::from(common.analog_input)),
                })
            }
        }
    }

    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error> {
        if !self.pdi {
            return Ok(None);
        }
        Ok(Some(self.read_rx_explicit().await?))
    }

    async fn read_object(&mut self, address: Address, dtype: DataType) -> Answer<Value> {
        if dtype == DataType::Domain {
            return Ok(self.get_typed(address).await?.map(|(_, v)| v));
        }
        self.get(address, dtype).await
    }

    /// GetOD Rockwell brings the entry's type with its value.
    async fn read_object_of_unknown_type(&mut self, address: Address) -> Answer<Value> {
        Ok(self.get_typed(address).await?.map(|(_, v)| v))
    }

    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()> {
        self.set(address, dtype, value).await
    }

    async fn scan(&mut self) -> Result<Vec<FoundDevice>, Error> {
        super::discovery::discover(&super::discovery::Discovery {
            port: self.port,
            unicast: vec![self.host.clone()],
            ..super::discovery::Discovery::default()
        })
        .await
    }

    fn take_recovered(&mut self) -> Vec<String> {
        let mut all = self.session.take_recovered();
        if let Some(opened) = &self.io {
            all.extend(opened.handle.take_recovered());
        }
        all
    }

    fn take_trace(&mut self) -> Vec<crate::link::TraceRecord> {
        let mut all = self.session.take_trace();
        if let Some(opened) = &self.io {
            all.extend(opened.handle.take_trace());
            all.sort_by_key(|r| r.at);
        }
        all
    }

    fn take_notices(&mut self) -> Vec<crate::link::Notice> {
        if let Some(warning) = self.io.as_ref().and_then(|o| o.handle.take_timing_notice()) {
            self.notices.push(warning);
        }
        std::mem::take(&mut self.notices)
            .into_iter()
            .map(crate::link::Notice::info)
            .collect()
    }

    async fn reconnect(&mut self) -> Result<(), Error> {
        let old = self.io.take();
        if let Some(opened) = &old {
            opened.handle.stop();
            self.io_lost = true;
        }
        self.session = match Session::open(&self.host, self.port, EXPLICIT_TIMEOUT).await {
            Ok(session) => session,
            Err(e) => {
                // Kept, stopped, for the next try to close.
                self.io = old;
                return Err(e);
            }
        };
        self.explicit_rx = None;
        // The old I/O connection may live on in the adapter until its own timeout (our
        // O→T datagrams stopped only when it timed out here) and would refuse the new one
        // as an ownership conflict (protocol notes §3.5): close it first. The adapter may
        // have closed it already ("connection not found"), which is as good.
        if let Some(opened) = &old {
            let _ = self.send_forward_close(opened).await;
            self.linger = Some(opened.handle.config.to_timeout + opened.handle.config.ot_rpi * 2);
        }
        let started = self.start().await;
        self.linger = None;
        started
    }

    async fn close(&mut self) -> Result<(), Error> {
        if let Some(opened) = self.io.take() {
            self.forward_close(&opened).await;
        }
        self.session.close().await;
        Ok(())
    }
}
