//! `CanopenLink`: a drive on a CAN bus. The PDI runs through an RPDO/TPDO pair mapped as
//! spec section 3 prescribes; objects go over SDO (expedited and segmented), one transfer
//! at a time. If the drive refuses the mapping, the PDI runs over SDO instead, and the link
//! says so.

use std::time::{Duration, Instant};

mod mapping;
mod sdo;

use super::CanBus;
use crate::cia::{AbortCode, ErrorCode};
use crate::link::tries::TRIES;
use crate::link::{
    Answer, CanopenOptions, Error, Exchange, Link, LinkInfo, LinkSpec, Notice, NoticeKind, Refusal,
    Signals, TraceRecord, TraceRing,
};
use crate::od::{Address, DataType, Value};
use crate::pdi::{PDI_OUTPUT, RX_OBJECTS, RxImage, TX_OBJECTS, TxImage};
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::emcy::Emcy;
use crate::proto::canopen::nmt::{self, NmtCommand};
use crate::proto::canopen::pdo::SdoWrite;
use crate::proto::canopen::sdo::SdoClient;

/// How long one SDO request may wait for its answer, all its tries together.
///
/// A request goes out up to [`TRIES`] times. Each try waits [`SDO_TRY`] (a third of this)
/// for every answer it expects (the initiate's, then each segment's, protocol notes §2.4),
/// so a request nobody answers takes this long in all. A lost or garbled answer, or one
/// that breaks the protocol (a wrong toggle, an unexpected command specifier), ends the
/// try: the drive is sent the abort for the abandoned transfer (05040000h on a timeout,
/// the protocol error's own code otherwise, protocol notes §2.5), so its server is free,
/// and the transfer starts again from its initiate. An initiate answer naming another
/// object is a late answer to an earlier request: skipped, the try goes on waiting (sending
/// again would leave a second answer to arrive late in the next transfer, and so on). An
/// abort from the drive is its answer, a refusal: never sent again.
pub const SDO_TIMEOUT: Duration = Duration::from_millis(500);
/// How long one try of an SDO request waits for each answer.
pub const SDO_TRY: Duration =
    Duration::from_micros((SDO_TIMEOUT.as_micros() / TRIES as u128) as u64);
/// TPDO event timer: the drive sends its image at least this often, which is also how the
/// link knows the drive is alive.
const EVENT_TIMER_MS: u16 = 100;
const EVENT_TIMER: Duration = Duration::from_millis(EVENT_TIMER_MS as u64);
/// Inhibit time of the PDI TPDO: 2 ms (20 × 100 µs) keeps a busy drive from flooding the bus.
const INHIBIT_100US: u16 = 20;
/// The RPDO is repeated at least this often while it does not change.
const RPDO_REFRESH: Duration = Duration::from_millis(50);
/// No TPDO for this long is one failed exchange; each further [`EVENT_TIMER`] without one
/// is one more (see [`CanopenLink::check_tpdo_silence`]).
const SILENCE: Duration = Duration::from_millis(3 * EVENT_TIMER_MS as u64 + 200);
/// Troubles got over kept for `take_recovered` when nobody takes them; more are counted.
const RECOVERED_KEPT: usize = 64;

/// How the PDI travels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PdiPath {
    Pdo,
    Sdo,
    /// The node has no 2291h/2292h: object access only.
    Absent,
}

/// What drivedeck changed on the drive, to put back on disconnect.
#[derive(Clone, Debug, Default)]
struct Saved {
    writes: Vec<SdoWrite>,
}

/// A drive on a CAN bus.
pub struct CanopenLink<B: CanBus> {
    spec: LinkSpec,
    /// The interface name candump logs use.
    interface: String,
    bus: B,
    options: CanopenOptions,
    path: PdiPath,
    sdo: SdoClient,
    tx: Option<TxImage>,
    /// The last TPDO, or the NMT start until the first one comes: a node that never sends
    /// one (not operational) is noticed as well as one that falls silent.
    last_tpdo: Option<Instant>,
    tpdo_seen: bool,
    /// Event-timer periods past [`SILENCE`] reported as failed exchanges since the last
    /// TPDO.
    missed: u32,
    last_rx: Option<RxImage>,
    last_rpdo: Option<Instant>,
    saved: Saved,
    notices: Vec<Notice>,
    trace: TraceRing,
    /// SDO troubles got over by sending again, not yet reported (at most
    /// [`RECOVERED_KEPT`]; `recovered_dropped` counts the rest).
    recovered: Vec<String>,
    recovered_dropped: u64,
}

impl<B: CanBus> std::fmt::Debug for CanopenLink<B> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CanopenLink")
            .field("spec", &self.spec)
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl<B: CanBus> CanopenLink<B> {
    /// Connect to node `options.node` on `bus`: check it answers, map the PDI PDOs (or fall
    /// back to SDO), start it.
    pub async fn connect(spec: LinkSpec, bus: B, options: CanopenOptions) -> Result<Self, Error> {
        Self::connect_traced(spec, bus, options)
            .await
            .map_err(|(error, _)| error)
    }

    /// [`CanopenLink::connect`], keeping the frames of a connection that failed.
    pub async fn connect_traced(
        spec: LinkSpec,
        bus: B,
        options: CanopenOptions,
    ) -> crate::link::Traced<Self> {
        let interface = match &spec {
            LinkSpec::CanopenSocketcan { iface, .. } => iface.clone(),
            LinkSpec::CanopenSlcan { .. } => "slcan0".into(),
            _ => "vcan0".into(),
        };
        let mut link = CanopenLink {
            interface,
            spec,
            sdo: SdoClient::new(options.node),
            bus,
            options,
            path: PdiPath::Sdo,
            tx: None,
            last_tpdo: None,
            tpdo_seen: false,
            missed: 0,
            last_rx: None,
            last_rpdo: None,
            saved: Saved::default(),
            notices: vec![],
            trace: TraceRing::new(),
            recovered: vec![],
            recovered_dropped: 0,
        };
        match link.start().await {
            Ok(()) => Ok(link),
            Err(error) => Err((error, link.take_trace())),
        }
    }

    /// Learn the node and set the PDI up on it.
    async fn start(&mut self) -> Result<(), Error> {
        let link = self;
        let options = link.options;
        // Is anybody there?
        match link.sdo_upload(0x1018, 1).await? {
            Ok(_) => {}
            Err(code) => {
                return Err(Error::Answer(format!(
                    "node {} answered the identity read with abort {code}",
                    options.node
                )));
            }
        }
        // A node without the Plug & Drive interface (any CANopen device) still gets
        // object access.
        if let Err(code) = link.sdo_upload(PDI_OUTPUT, TX_OBJECTS[0].sub).await? {
            link.path = PdiPath::Absent;
            link.notices.push(Notice::info(format!(
                "node {} has no Plug & Drive interface (reading {}: {code}): object access only",
                options.node,
                Address::new(PDI_OUTPUT, TX_OBJECTS[0].sub)
            )));
            return Ok(());
        }
        match link.map_pdi().await? {
            Ok(()) => link.path = PdiPath::Pdo,
            Err(reason) => {
                let refused = link.restore().await?;
                let left = if refused.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; putting the old mapping back, it refused {}",
                        refused.join("; ")
                    )
                };
                link.notices.push(Notice::info(format!(
                    "node {} refused the PDI mapping ({reason}): the PDI runs over SDO (2291h/2292h), slower{left}",
                    options.node
                )));
            }
        }
        if options.self_start {
            link.start_by_itself().await?;
        }
        link.send(&nmt::command_frame(NmtCommand::Start, options.node))
            .await?;
        if link.path == PdiPath::Pdo {
            link.last_tpdo = Some(Instant::now());
        }
        // The image as it is now, before the first TPDO arrives.
        link.tx = Some(link.read_tx_by_sdo().await?);
        Ok(())
    }

    /// The bus under the link (the simulated one takes fault injections).
    pub fn bus_mut(&mut self) -> &mut B {
        &mut self.bus
    }

    fn trace(&mut self, sent: bool, frame: &CanFrame) {
        self.trace.push(TraceRecord {
            at: std::time::SystemTime::now(),
            sent,
            raw: frame.to_string(),
            text: crate::proto::canopen::describe::describe(frame),
            can: Some((*frame, self.interface.clone())),
        });
    }

    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        self.trace(true, frame);
        self.bus.send(frame).await
    }

    /// Handle a frame that is not the answer being waited for: TPDOs, EMCY, heartbeat.
    fn unsolicited(&mut self, frame: &CanFrame) {
        let node = u16::from(self.options.node);
        let Some(cob) = frame.cob_id() else {
            return;
        };
        let tpdo = 0x180 + 0x100 * u16::from(self.options.pdo - 1) + node;
        if self.path == PdiPath::Pdo && cob == tpdo && frame.len() == 8 {
            if let Ok(tx) = TxImage::from_bytes(frame.data()) {
                self.tx = Some(tx);
                self.last_tpdo = Some(Instant::now());
                self.tpdo_seen = true;
                self.missed = 0;
            }
        } else if cob == 0x80 + node
            && let Ok((_, emcy)) = Emcy::decode(frame)
        {
            let code = ErrorCode(emcy.error_code);
            let text = if emcy.error_code == 0 {
                format!("EMCY node {node}: error reset")
            } else {
                format!(
                    "EMCY node {node}: {code}, error register {:02X}h",
                    emcy.error_register
                )
            };
            self.notices.push(Notice {
                kind: NoticeKind::Emcy {
                    node: self.options.node,
                    error_code: emcy.error_code,
                    error_register: emcy.error_register,
                },
                text,
            });
        }
    }

    async fn read_tx_by_sdo(&mut self) -> Result<TxImage, Error> {
        let read = |data: Result<Vec<u8>, AbortCode>| -> Result<Vec<u8>, Error> {
            data.map_err(|code| {
                Error::Answer(format!(
                    "the drive refused to give its PDI status over SDO: abort {code}"
                ))
            })
        };
        let mut bytes = [0u8; 8];
        for o in TX_OBJECTS {
            let data = read(self.sdo_upload(o.index, o.sub).await?)?;
            let range = o.bytes();
            if let Some(data) = data.get(..range.len()) {
                bytes[range].copy_from_slice(data);
            }
        }
        TxImage::from_bytes(&bytes).map_err(|e| Error::Protocol(e.to_string()))
    }

    /// Whether the drive still speaks on the PDO path. Its TPDO comes at least every
    /// [`EVENT_TIMER`] (the event timer, 1800h:05, protocol notes §2.3). No TPDO for
    /// [`SILENCE`] fails the exchange once; from then on each further event-timer period
    /// without one fails it once more: the exchange waits out the period (a TPDO that comes
    /// meanwhile ends the wait, and the exchange goes through). So the worker's "lost after
    /// N failed exchanges" means SILENCE + (N - 1) event-timer periods without a TPDO, at any
    /// poll rate, as N unanswered requests would on the other buses. (Returning the last
    /// image between those failures would count as a good exchange and start the count
    /// afresh: a node that answers SDO but sends no PDOs, pre-operational, would never be
    /// called lost; and the last halt on a loss would seem answered.)
    async fn check_tpdo_silence(&mut self) -> Result<(), Error> {
        let Some(last) = self.last_tpdo else {
            return Err(self.tpdo_missing(SILENCE));
        };
        if last.elapsed() <= SILENCE {
            return Ok(());
        }
        let allowed = SILENCE + EVENT_TIMER * self.missed;
        let until = last + allowed;
        if Instant::now() < until {
            self.drain_until(until, |link| link.last_tpdo != Some(last))
                .await?;
            if self.last_tpdo != Some(last) {
                return Ok(());
            }
        }
        self.missed = self.missed.saturating_add(1);
        Err(self.tpdo_missing(allowed))
    }

    /// The error for a TPDO that has not come for `after`.
    fn tpdo_missing(&self, after: Duration) -> Error {
        let (pdo, node) = (self.options.pdo, self.options.node);
        Error::Timeout {
            what: if self.tpdo_seen {
                format!("TPDO{pdo} from node {node} (it comes every {EVENT_TIMER_MS} ms at least)")
            } else {
                format!(
                    "the first TPDO{pdo} from node {node} after its NMT start (is the node operational?)"
                )
            },
            after,
        }
    }

    /// Take what arrives until `deadline`, or until `done` says so after a frame.
    async fn drain_until(
        &mut self,
        deadline: Instant,
        done: impl Fn(&Self) -> bool,
    ) -> Result<(), Error> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(());
            }
            let Ok(frame) = tokio::time::timeout(left, self.bus.recv()).await else {
                return Ok(());
            };
            let frame = frame?;
            self.trace(false, &frame);
            self.unsolicited(&frame);
            if done(self) {
                return Ok(());
            }
        }
    }

    /// Take what arrives within `window` (zero: only what has arrived already).
    async fn drain(&mut self, window: Duration) -> Result<(), Error> {
        let deadline = Instant::now() + window;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let frame = if left.is_zero() {
                // Without a timer: a zero timeout still waits for the timer wheel's next
                // tick (about 1 ms), which would cap SDO traffic near 900 transfers/s.
                tokio::select! {
                    biased;
                    frame = self.bus.recv() => Some(frame),
                    _ = std::future::ready(()) => None,
                }
            } else {
                tokio::time::timeout(left, self.bus.recv()).await.ok()
            };
            match frame {
                None => return Ok(()),
                Some(frame) => {
                    let frame = frame?;
                    self.trace(false, &frame);
                    self.unsolicited(&frame);
                }
            }
        }
    }
}

impl<B: CanBus> Link for CanopenLink<B> {
    fn info(&self) -> LinkInfo {
        let path = match self.path {
            PdiPath::Pdo => format!("PDI on RPDO{0}/TPDO{0}", self.options.pdo),
            PdiPath::Sdo => "PDI over SDO".to_owned(),
            PdiPath::Absent => "objects only: no PDI".to_owned(),
        };
        LinkInfo {
            spec: self.spec.clone(),
            description: format!(
                "CANopen node {} on {} ({path})",
                self.options.node,
                self.bus.describe()
            ),
            native_objects: true,
            can_inject: false,
            pdi: self.path != PdiPath::Absent,
            homing_methods: None,
            commands_refused: None,
        }
    }

    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        match self.path {
            PdiPath::Pdo => {
                // The RPDO goes out when the image changes, and every RPDO_REFRESH anyway (a
                // drive may watch its arrival); not every cycle, to spare the bus.
                let due = self.last_rpdo.is_none_or(|t| t.elapsed() >= RPDO_REFRESH);
                if let Some(rx) = rx.filter(|rx| due || self.last_rx != Some(**rx)) {
                    self.last_rpdo = Some(Instant::now());
                    let cob = 0x200
                        + 0x100 * u16::from(self.options.pdo - 1)
                        + u16::from(self.options.node);
                    let frame = CanFrame::new(cob, &rx.to_bytes())
                        .map_err(|e| Error::Protocol(e.to_string()))?;
                    self.send(&frame).await?;
                    self.last_rx = Some(*rx);
                }
                self.drain(Duration::from_millis(1)).await?;
                self.check_tpdo_silence().await?;
            }
            PdiPath::Absent => {
                // Nothing to exchange; keep the bus read so EMCY and heartbeats are seen.
                self.drain(Duration::from_millis(1)).await?;
            }
            PdiPath::Sdo => {
                if let Some(rx) = rx
                    && self.last_rx != Some(*rx)
                {
                    // Set values first, the command byte last: it starts the command.
                    let bytes = rx.to_bytes();
                    for o in RX_OBJECTS {
                        if let Err(code) =
                            self.sdo_download(o.index, o.sub, &bytes[o.bytes()]).await?
                        {
                            return Err(Error::Answer(format!(
                                "the drive refused the PDI write of {} ({}) over SDO: abort {code}",
                                Address::new(o.index, o.sub),
                                o.name
                            )));
                        }
                    }
                    self.last_rx = Some(*rx);
                }
                self.drain(Duration::ZERO).await?;
                self.tx = Some(self.read_tx_by_sdo().await?);
            }
        }
        let tx = self.tx.unwrap_or_default();
        Ok(Exchange {
            tx,
            signals: Signals::default(),
        })
    }

    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error> {
        if self.path == PdiPath::Absent {
            return Ok(None);
        }
        let mut bytes = [0u8; 8];
        for o in RX_OBJECTS {
            let range = o.bytes();
            match self.sdo_upload(o.index, o.sub).await? {
                Ok(data) if data.len() == range.len() => bytes[range].copy_from_slice(&data),
                _ => return Ok(None),
            }
        }
        Ok(RxImage::from_bytes(&bytes).ok())
    }

    async fn read_object(&mut self, address: Address, dtype: DataType) -> Answer<Value> {
        Ok(match self.sdo_upload(address.index, address.sub).await? {
            Ok(data) => {
                Value::from_le_bytes(dtype, &data).map_err(|e| Refusal::Malformed(e.to_string()))
            }
            Err(code) => Err(Refusal::Abort(code)),
        })
    }

    /// The upload says how many bytes the object has: the integer of that size (bytes of
    /// any other length as they are).
    async fn read_object_of_unknown_type(&mut self, address: Address) -> Answer<Value> {
        Ok(match self.sdo_upload(address.index, address.sub).await? {
            Ok(data) => {
                let dtype = DataType::integer((data.len() * 8).min(255) as u8, true)
                    .unwrap_or(DataType::OctetString);
                Value::from_le_bytes(dtype, &data).map_err(|e| Refusal::Malformed(e.to_string()))
            }
            Err(code) => Err(Refusal::Abort(code)),
        })
    }

    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()> {
        let data = match value.to_le_bytes(dtype) {
            Ok(data) => data,
            Err(e) => return Ok(Err(Refusal::Malformed(e.to_string()))),
        };
        Ok(self
            .sdo_download(address.index, address.sub, &data)
            .await?
            .map_err(Refusal::Abort))
    }

    fn take_notices(&mut self) -> Vec<Notice> {
        std::mem::take(&mut self.notices)
    }

    /// SDO requests answered on a later try, and what the bus got over (garbled slcan
    /// lines skipped, lines the adapter refused).
    fn take_recovered(&mut self) -> Vec<String> {
        let mut troubles = std::mem::take(&mut self.recovered);
        match std::mem::take(&mut self.recovered_dropped) {
            0 => {}
            n => troubles.push(format!(
                "{n} more SDO request(s) answered on a later try, not kept"
            )),
        }
        troubles.extend(self.bus.take_troubles());
        troubles
    }

    fn own_changes(&self) -> Vec<String> {
        let fate = if self.options.keep_pdo {
            "kept when disconnecting (keep_pdo=1)"
        } else {
            "put back by the link when disconnecting"
        };
        let mut writes = self.saved.writes.clone();
        writes.sort_by_key(|w| (w.index, w.sub));
        writes
            .iter()
            .map(|w| {
                let hex: String = w.data.iter().rev().map(|b| format!("{b:02X}")).collect();
                format!(
                    "{}: PDO setting of node {}, was {hex}h; {fate}",
                    Address::new(w.index, w.sub),
                    self.options.node
                )
            })
            .collect()
    }

    /// The link's own frames, or where the bus is shared by several links, the bus's one
    /// log (every node's frames, in wire order).
    fn take_trace(&mut self) -> Vec<TraceRecord> {
        let own = self.trace.take();
        self.bus.take_trace().unwrap_or(own)
    }

    async fn scan(&mut self) -> Result<Vec<crate::link::FoundDevice>, Error> {
        match self.bus.listener().await {
            Some(port) => super::scan::scan(&mut port?).await,
            None => super::scan::scan(&mut self.bus).await,
        }
    }

    async fn close(&mut self) -> Result<(), Error> {
        if !self.options.keep_pdo && !self.saved.writes.is_empty() {
            let refused = self.restore().await?;
            self.notices.push(Notice::info(if refused.is_empty() {
                format!("restored the PDO mapping of node {}", self.options.node)
            } else {
                format!(
                    "restored the PDO mapping of node {} except what it refused: {}",
                    self.options.node,
                    refused.join("; ")
                )
            }));
        }
        Ok(())
    }
}
