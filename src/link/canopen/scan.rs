//! Node scan: which CANopen nodes are on the bus, and what they are.
//!
//! Listening catches boot-ups and heartbeats; an SDO read of 1018h:01 to every node id at
//! once finds the silent ones (the answers are told apart by their COB-ID). Each node found
//! is then asked for its identity (1018h:02-04) and name (1008h).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use super::CanBus;
use crate::cia::AbortCode;
use crate::link::{Error, FoundDevice};
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::nmt::{self, NmtState};
use crate::proto::canopen::sdo::{SdoClient, SdoEvent};

/// How long the scan listens for the answers to its 127 identity reads.
pub const ANSWER_WINDOW: Duration = Duration::from_millis(300);
/// How long one of the follow-up reads may take.
const READ_TIMEOUT: Duration = Duration::from_millis(250);

fn u32_of(data: &[u8]) -> Option<u32> {
    (data.len() == 4).then(|| u32::from_le_bytes([data[0], data[1], data[2], data[3]]))
}

/// Run one SDO upload on `bus`, passing other frames to `other`.
async fn upload<B: CanBus>(
    bus: &mut B,
    node: u8,
    index: u16,
    sub: u8,
    other: &mut impl FnMut(&CanFrame),
) -> Result<Option<Vec<u8>>, Error> {
    let mut client = SdoClient::new(node);
    bus.send(&client.upload(index, sub)).await?;
    let deadline = Instant::now() + READ_TIMEOUT;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let frame = match tokio::time::timeout(left, bus.recv()).await {
            Err(_) => {
                if let Some(abort) = client.abort(crate::cia::AbortCode::SDO_TIMEOUT) {
                    bus.send(&abort).await?;
                }
                return Ok(None);
            }
            Ok(frame) => frame?,
        };
        match client.on_frame(&frame) {
            SdoEvent::Ignored => other(&frame),
            // A late answer to an earlier read: this one's may still come.
            SdoEvent::Stale(_) => {}
            SdoEvent::Send(next) => bus.send(&next).await?,
            SdoEvent::Uploaded(data) => return Ok(Some(data)),
            SdoEvent::Downloaded | SdoEvent::Aborted(_) | SdoEvent::Protocol(_) => {
                if let Some(abort) = client.take_abort() {
                    bus.send(&abort).await?;
                }
                return Ok(None);
            }
        }
    }
}

/// Find the nodes on `bus`.
pub async fn scan<B: CanBus>(bus: &mut B) -> Result<Vec<FoundDevice>, Error> {
    let (mut states, vendors, aborts) = listen(bus).await?;
    let mut found: Vec<u8> = vendors
        .keys()
        .chain(states.keys())
        .chain(aborts.keys())
        .copied()
        .collect();
    found.sort_unstable();
    found.dedup();
    let mut devices = vec![];
    for node in found {
        let mut note = |frame: &CanFrame| {
            if let Ok((n, state)) = nmt::decode_heartbeat(frame) {
                states.insert(n, state);
            }
        };
        let product = upload(bus, node, 0x1018, 2, &mut note)
            .await?
            .and_then(|d| u32_of(&d));
        let revision = upload(bus, node, 0x1018, 3, &mut note)
            .await?
            .and_then(|d| u32_of(&d));
        let serial = upload(bus, node, 0x1018, 4, &mut note)
            .await?
            .and_then(|d| u32_of(&d));
        let name = upload(bus, node, 0x1008, 0, &mut note).await?.map(|d| {
            let end = d.iter().position(|b| *b == 0).unwrap_or(d.len());
            String::from_utf8_lossy(&d[..end]).into_owned()
        });
        devices.push(FoundDevice {
            address: format!("node {node}"),
            node: Some(node),
            vendor: vendors.get(&node).copied(),
            product,
            revision,
            serial,
            name,
            state: states.get(&node).map(|s| s.name().to_owned()),
            refused: aborts
                .get(&node)
                .map(|code| format!("answered the identity read (1018h:01) with SDO abort {code}")),
        });
    }
    Ok(devices)
}

/// What the scan heard, by node: NMT states (boot-ups, heartbeats), vendor ids, and the
/// refusals of the identity read (a node is there even when it refuses).
type Heard = (
    BTreeMap<u8, NmtState>,
    BTreeMap<u8, u32>,
    BTreeMap<u8, AbortCode>,
);

/// Read 1018h:01 from every node id at once and listen for [`ANSWER_WINDOW`].
async fn listen<B: CanBus>(bus: &mut B) -> Result<Heard, Error> {
    let mut states: BTreeMap<u8, NmtState> = BTreeMap::new();
    let mut vendors: BTreeMap<u8, u32> = BTreeMap::new();
    let mut aborts: BTreeMap<u8, AbortCode> = BTreeMap::new();
    let mut clients: Vec<SdoClient> = (1..=127u8).map(SdoClient::new).collect();
    for client in clients.iter_mut() {
        bus.send(&client.upload(0x1018, 1)).await?;
    }
    let deadline = Instant::now() + ANSWER_WINDOW;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let frame = match tokio::time::timeout(left, bus.recv()).await {
            Err(_) => break,
            Ok(frame) => frame?,
        };
        if let Ok((node, state)) = nmt::decode_heartbeat(&frame) {
            states.insert(node, state);
            continue;
        }
        let Some(cob) = frame.cob_id() else { continue };
        if (0x581..=0x5FF).contains(&cob) {
            let node = (cob - 0x580) as u8;
            if let Some(client) = clients.get_mut(usize::from(node - 1)) {
                match client.on_frame(&frame) {
                    SdoEvent::Uploaded(data) => {
                        vendors.insert(node, u32_of(&data).unwrap_or(0));
                    }
                    SdoEvent::Aborted(code) => {
                        aborts.insert(node, code);
                    }
                    _ => {}
                }
            }
        }
    }
    Ok((states, vendors, aborts))
}

/// A bus whose frames are kept, for a scan under `--trace` (the frames go to the terminal
/// or the frame log as a link's do).
pub struct TracedBus<'b, B> {
    bus: &'b mut B,
    interface: String,
    /// Every frame sent and received, in order.
    pub records: Vec<crate::link::TraceRecord>,
}

impl<'b, B: CanBus> TracedBus<'b, B> {
    pub fn new(bus: &'b mut B) -> Self {
        let interface = bus.describe();
        TracedBus {
            bus,
            interface,
            records: Vec::new(),
        }
    }

    fn record(&mut self, sent: bool, frame: &CanFrame) {
        self.records.push(crate::link::TraceRecord {
            at: std::time::SystemTime::now(),
            sent,
            raw: frame.to_string(),
            text: crate::proto::canopen::describe::describe(frame),
            can: Some((*frame, self.interface.clone())),
        });
    }
}

impl<B: CanBus> CanBus for TracedBus<'_, B> {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        self.record(true, frame);
        self.bus.send(frame).await
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        let frame = self.bus.recv().await?;
        self.record(false, &frame);
        Ok(frame)
    }

    fn describe(&self) -> String {
        self.bus.describe()
    }
}

/// [`scan`], with every frame kept when `trace` is on: the devices found (or why not) and
/// the frames.
pub async fn scan_traced<B: CanBus>(
    bus: &mut B,
    trace: bool,
) -> (
    Result<Vec<FoundDevice>, Error>,
    Vec<crate::link::TraceRecord>,
) {
    if !trace {
        return (scan(bus).await, Vec::new());
    }
    let mut traced = TracedBus::new(bus);
    let found = scan(&mut traced).await;
    (found, traced.records)
}
