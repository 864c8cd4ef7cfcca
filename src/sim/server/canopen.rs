//! The simulated drive as a CANopen node (CiA 301): boot-up, NMT states, heartbeat, an SDO
//! server (expedited and segmented), PDOs that follow whatever mapping a master writes, and
//! EMCY on faults.
//!
//! `Node` is sans-IO (frames in, frames out, time passed in); `run` drives it on any
//! `CanBus`: the in-memory bus, an slcan pseudo-terminal, SocketCAN.

use std::time::{Duration, Instant};

use super::SharedDrive;
use crate::cia::AbortCode;
use crate::link::canopen::CanBus;
use crate::od::{Address, Value};
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::emcy::Emcy;
use crate::proto::canopen::nmt::{self, NmtCommand, NmtState};
use crate::proto::canopen::pdo::MappedObject;
use crate::proto::canopen::sdo::{ObjectAccess, SdoServer};
use crate::sim::{Drive, wrap_integer};

/// Bit 31 of a PDO COB-ID: the PDO is invalid (off).
const INVALID: u32 = 1 << 31;

/// One TPDO's transmit bookkeeping.
#[derive(Clone, Debug, Default)]
struct TpdoState {
    last_payload: Option<Vec<u8>>,
    last_sent: Option<Instant>,
    sync_count: u32,
}

/// A simulated CANopen node in front of a drive.
#[derive(Debug)]
pub struct Node {
    id: u8,
    state: NmtState,
    sdo: SdoServer,
    tpdo: [TpdoState; 4],
    last_heartbeat: Option<Instant>,
    last_error_code: u16,
    booted: bool,
    /// Refuse PDO mapping changes, like a device with fixed mappings.
    fixed_mapping: bool,
    /// The drive's restarts seen (a new one: the node boots again).
    reboots: u32,
}

/// The drive's object dictionary as seen by the SDO server: bytes in the objects' types.
struct DriveAccess<'a> {
    drive: &'a mut Drive,
    fixed_mapping: bool,
}

impl ObjectAccess for DriveAccess<'_> {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        let (value, dtype) = self.drive.read_typed(Address::new(index, sub))?;
        value
            .to_le_bytes(dtype)
            .map_err(|_| AbortCode::GENERAL_ERROR)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let address = Address::new(index, sub);
        if self.fixed_mapping
            && ((0x1600..0x1800).contains(&index) || (0x1A00..0x1C00).contains(&index))
        {
            return Err(AbortCode::READ_ONLY);
        }
        let Some(entry) = self.drive.entry(address).cloned() else {
            // Let the drive say whether the object or only the subindex is missing.
            return Err(self
                .drive
                .read(address)
                .err()
                .unwrap_or(AbortCode::NO_OBJECT));
        };
        if let Some(size) = entry.dtype.size() {
            if data.len() > size {
                return Err(AbortCode::TYPE_LENGTH_TOO_HIGH);
            }
            if data.len() < size {
                return Err(AbortCode::TYPE_LENGTH_TOO_LOW);
            }
        }
        let value =
            Value::from_le_bytes(entry.dtype, data).map_err(|_| AbortCode::TYPE_LENGTH_MISMATCH)?;
        self.drive.write(address, value)
    }
}

fn u32_of(drive: &Drive, index: u16, sub: u8) -> u32 {
    drive
        .read(Address::new(index, sub))
        .ok()
        .and_then(|v| v.as_i128())
        .unwrap_or(0) as u32
}

/// The entries of a mapping object (1600h+ or 1A00h+); entries that are not whole bytes
/// end it.
fn mapping(drive: &Drive, index: u16) -> Vec<MappedObject> {
    let count = u32_of(drive, index, 0).min(8) as u8;
    (1..=count)
        .map(|sub| MappedObject::from_u32(u32_of(drive, index, sub)))
        .take_while(|e| e.bits > 0 && e.bits % 8 == 0 && e.bits <= 32)
        .collect()
}

impl Node {
    /// A node with `id` in front of `drive`: sets the predefined connection set's COB-IDs
    /// (PDOs invalid until a master validates them) and the EMCY COB-ID.
    pub fn new(id: u8, drive: &mut Drive) -> Node {
        let set = |drive: &mut Drive, index: u16, sub: u8, value: u32| {
            drive.set_raw(Address::new(index, sub), Value::Uint(u64::from(value)));
        };
        for n in 0..4u16 {
            set(
                drive,
                0x1400 + n,
                1,
                INVALID | (0x200 + 0x100 * u32::from(n) + u32::from(id)),
            );
            set(
                drive,
                0x1800 + n,
                1,
                INVALID | (0x180 + 0x100 * u32::from(n) + u32::from(id)),
            );
        }
        set(drive, 0x1014, 0, 0x80 + u32::from(id));
        Node {
            id,
            state: NmtState::BootUp,
            sdo: SdoServer::new(id),
            tpdo: Default::default(),
            last_heartbeat: None,
            last_error_code: 0,
            booted: false,
            fixed_mapping: false,
            reboots: drive.reboots(),
        }
    }

    /// Whether the node is silent because its drive restarts; once the drive has
    /// restarted, the node starts again as at power-on (predefined connection set, boot-up
    /// message at its next turn).
    fn silent_for_restart(&mut self, drive: &mut Drive) -> bool {
        if drive.rebooting() {
            return true;
        }
        if drive.reboots() != self.reboots {
            let fixed = self.fixed_mapping;
            *self = Node::new(self.id, drive).with_fixed_mapping(fixed);
        }
        false
    }

    /// A node whose PDO mappings cannot be changed (writes to 1600h-17FFh and 1A00h-1BFFh
    /// are refused with 06010002h), so a master must run the PDI over SDO.
    pub fn with_fixed_mapping(mut self, fixed: bool) -> Node {
        self.fixed_mapping = fixed;
        self
    }

    pub fn id(&self) -> u8 {
        self.id
    }

    pub fn state(&self) -> NmtState {
        self.state
    }

    /// Handle one frame from the bus; returns the frames to send in answer.
    pub fn on_frame(&mut self, frame: &CanFrame, drive: &mut Drive, now: Instant) -> Vec<CanFrame> {
        if self.silent_for_restart(drive) {
            return vec![];
        }
        let mut out = vec![];
        if !self.booted {
            // Power-on comes before anything the bus says: a frame that arrives before the
            // first tick (an NMT start on a busy machine) must not be undone by the boot-up.
            self.boot(drive, now, &mut out);
        }
        let Some(cob) = frame.cob_id() else {
            return out;
        };
        if cob == 0 {
            if let Ok((command, node)) = nmt::decode_command(frame)
                && (node == 0 || node == self.id)
            {
                self.nmt(command, drive, now, &mut out);
            }
            return out;
        }
        if cob == 0x600 + u16::from(self.id) {
            if self.state != NmtState::Stopped {
                let mut access = DriveAccess {
                    drive,
                    fixed_mapping: self.fixed_mapping,
                };
                if let Some(answer) = self.sdo.on_request(frame, &mut access) {
                    out.push(answer);
                }
            }
            return out;
        }
        if cob == 0x080 {
            // SYNC: synchronous TPDOs count it.
            if self.state == NmtState::Operational {
                self.on_sync(drive, now, &mut out);
            }
            return out;
        }
        if self.state == NmtState::Operational {
            for n in 0..4u16 {
                let comm = u32_of(drive, 0x1400 + n, 1);
                if comm & INVALID == 0 && (comm & 0x7FF) as u16 == cob {
                    self.receive_pdo(n, frame, drive);
                }
            }
        }
        out
    }

    fn nmt(
        &mut self,
        command: NmtCommand,
        drive: &mut Drive,
        now: Instant,
        out: &mut Vec<CanFrame>,
    ) {
        match command {
            NmtCommand::Start => self.state = NmtState::Operational,
            NmtCommand::Stop => self.state = NmtState::Stopped,
            NmtCommand::EnterPreOperational => self.state = NmtState::PreOperational,
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                // Communication objects back to the predefined set, then boot-up again.
                *self = Node::new(self.id, drive);
                self.boot(drive, now, out);
            }
        }
    }

    fn boot(&mut self, drive: &Drive, now: Instant, out: &mut Vec<CanFrame>) {
        self.booted = true;
        out.push(nmt::boot_up_frame(self.id));
        // 1F80h bit 3: start by itself, for masters without NMT (spec 3.1).
        self.state = if u32_of(drive, 0x1F80, 0) & 0x08 != 0 {
            NmtState::Operational
        } else {
            NmtState::PreOperational
        };
        self.last_heartbeat = Some(now);
    }

    fn receive_pdo(&mut self, n: u16, frame: &CanFrame, drive: &mut Drive) {
        let entries = mapping(drive, 0x1600 + n);
        let needed: usize = entries.iter().map(|e| usize::from(e.bits / 8)).sum();
        if frame.len() < needed {
            // CiA 301: a too-short PDO is not processed (the drive would send EMCY 8210h).
            return;
        }
        let mut offset = 0;
        for entry in entries {
            let bytes = usize::from(entry.bits / 8);
            let data = &frame.data()[offset..offset + bytes];
            offset += bytes;
            let address = Address::new(entry.index, entry.sub);
            let Some(dtype) = drive.entry(address).map(|e| e.dtype) else {
                continue;
            };
            let mut raw = [0u8; 8];
            raw[..bytes].copy_from_slice(data);
            let raw = i64::from_le_bytes(raw);
            let value = if dtype.is_signed() {
                match bytes {
                    1 => i64::from(raw as i8),
                    2 => i64::from(raw as i16),
                    _ => i64::from(raw as i32),
                }
            } else {
                raw
            };
            // Object by object, in mapping order: 2291h:04 (the command) comes last.
            let _ = drive.write(address, wrap_integer(dtype, value));
        }
    }

    fn tpdo_payload(drive: &Drive, n: u16) -> Option<Vec<u8>> {
        let entries = mapping(drive, 0x1A00 + n);
        if entries.is_empty() {
            return None;
        }
        let mut payload = vec![];
        for entry in entries {
            let bytes = usize::from(entry.bits / 8);
            let raw = u32_of(drive, entry.index, entry.sub).to_le_bytes();
            payload.extend_from_slice(&raw[..bytes.min(4)]);
        }
        payload.truncate(8);
        Some(payload)
    }

    fn send_tpdo(
        &mut self,
        n: u16,
        payload: Vec<u8>,
        cob: u16,
        now: Instant,
        out: &mut Vec<CanFrame>,
    ) {
        if let Ok(frame) = CanFrame::new(cob, &payload) {
            out.push(frame);
        }
        let state = &mut self.tpdo[usize::from(n)];
        state.last_payload = Some(payload);
        state.last_sent = Some(now);
    }

    fn on_sync(&mut self, drive: &Drive, now: Instant, out: &mut Vec<CanFrame>) {
        for n in 0..4u16 {
            let comm = u32_of(drive, 0x1800 + n, 1);
            let kind = u32_of(drive, 0x1800 + n, 2);
            if comm & INVALID != 0 || !(1..=240).contains(&kind) {
                continue;
            }
            let state = &mut self.tpdo[usize::from(n)];
            state.sync_count += 1;
            if state.sync_count >= kind {
                state.sync_count = 0;
                if let Some(payload) = Self::tpdo_payload(drive, n) {
                    self.send_tpdo(n, payload, (comm & 0x7FF) as u16, now, out);
                }
            }
        }
    }

    /// Time passes: boot-up, heartbeat, event-driven TPDOs, EMCY on fault changes.
    pub fn tick(&mut self, drive: &mut Drive, now: Instant) -> Vec<CanFrame> {
        if self.silent_for_restart(drive) {
            return vec![];
        }
        let mut out = vec![];
        if !self.booted {
            self.boot(drive, now, &mut out);
        }
        let heartbeat = u32_of(drive, 0x1017, 0);
        if heartbeat > 0
            && self.last_heartbeat.is_none_or(|t| {
                now.duration_since(t) >= Duration::from_millis(u64::from(heartbeat))
            })
        {
            out.push(nmt::heartbeat_frame(self.id, self.state));
            self.last_heartbeat = Some(now);
        }
        // EMCY when 603Fh changes (a new fault or warning, or its reset).
        let code = u32_of(drive, 0x603F, 0) as u16;
        if code != self.last_error_code && self.state != NmtState::Stopped {
            self.last_error_code = code;
            let emcy = Emcy {
                error_code: code,
                error_register: u32_of(drive, 0x1001, 0) as u8,
                manufacturer: [0; 5],
            };
            out.push(emcy.frame(self.id));
        }
        if self.state != NmtState::Operational {
            return out;
        }
        for n in 0..4u16 {
            let comm = u32_of(drive, 0x1800 + n, 1);
            let kind = u32_of(drive, 0x1800 + n, 2);
            if comm & INVALID != 0 || kind < 254 {
                continue;
            }
            let Some(payload) = Self::tpdo_payload(drive, n) else {
                continue;
            };
            let inhibit = Duration::from_micros(100 * u64::from(u32_of(drive, 0x1800 + n, 3)));
            let event = Duration::from_millis(u64::from(u32_of(drive, 0x1800 + n, 5)));
            let state = &self.tpdo[usize::from(n)];
            let since = state.last_sent.map(|t| now.duration_since(t));
            let changed = state.last_payload.as_ref() != Some(&payload);
            let inhibited = since.is_some_and(|s| s < inhibit);
            let due = !event.is_zero() && since.is_none_or(|s| s >= event);
            if (changed || due) && !inhibited {
                self.send_tpdo(n, payload, (comm & 0x7FF) as u16, now, &mut out);
            }
        }
        out
    }
}

/// Serve the shared drive as node `id` on `bus` until the bus fails.
pub async fn run<B: CanBus>(bus: B, id: u8, shared: SharedDrive) -> Result<(), crate::link::Error> {
    run_many(bus, vec![(id, shared)]).await
}

/// Serve several drives on one `bus`, each as its own node id (`drivedeck sim --node 5
/// --node 6`).
pub async fn run_many<B: CanBus>(
    bus: B,
    drives: Vec<(u8, SharedDrive)>,
) -> Result<(), crate::link::Error> {
    let nodes = drives
        .into_iter()
        .map(|(id, shared)| {
            let node = {
                let mut drive = shared.lock();
                Node::new(id, &mut drive)
            };
            (node, shared)
        })
        .collect();
    run_nodes(bus, nodes).await
}

/// Serve `node` (built by the caller, e.g. with a fixed mapping) on `bus`.
pub async fn run_node<B: CanBus>(
    bus: B,
    node: Node,
    shared: SharedDrive,
) -> Result<(), crate::link::Error> {
    run_nodes(bus, vec![(node, shared)]).await
}

/// Serve `nodes`, each in front of its own drive, on one `bus` until the bus fails. One
/// reader of the bus hands every frame to every node, and each takes what its COB-IDs say
/// is for it (NMT to it or to all, its SDO requests, SYNC, its RPDOs); what one node sends,
/// the others hear too, as they would on the wire.
pub async fn run_nodes<B: CanBus>(
    mut bus: B,
    mut nodes: Vec<(Node, SharedDrive)>,
) -> Result<(), crate::link::Error> {
    let mut ticker = tokio::time::interval(Duration::from_millis(1));
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        let out = tokio::select! {
            frame = bus.recv() => deliver(&mut nodes, &frame?, None),
            _ = ticker.tick() => {
                let now = Instant::now();
                let mut out = vec![];
                for (from, (node, shared)) in nodes.iter_mut().enumerate() {
                    let mut drive = shared.lock();
                    out.extend(node.tick(&mut drive, now).into_iter().map(|f| (from, f)));
                }
                out
            }
        };
        for (from, frame) in out {
            bus.send(&frame).await?;
            if nodes.len() > 1 {
                // The node's neighbours hear it; what they answer goes on the bus (and is
                // not handed round again: nodes answer masters, not each other).
                for (_, answer) in deliver(&mut nodes, &frame, Some(from)) {
                    bus.send(&answer).await?;
                }
            }
        }
    }
}

/// Hand `frame` to every node but `except` (the one that sent it); the frames they answer
/// with, each with the index of the node that sends it.
fn deliver(
    nodes: &mut [(Node, SharedDrive)],
    frame: &CanFrame,
    except: Option<usize>,
) -> Vec<(usize, CanFrame)> {
    let now = Instant::now();
    let mut out = vec![];
    for (index, (node, shared)) in nodes.iter_mut().enumerate() {
        if Some(index) == except {
            continue;
        }
        let mut drive = shared.lock();
        out.extend(
            node.on_frame(frame, &mut drive, now)
                .into_iter()
                .map(|f| (index, f)),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_nmt_start_before_the_first_tick_is_not_undone_by_the_boot_up() {
        let mut drive = Drive::new();
        let mut node = Node::new(5, &mut drive);
        let now = Instant::now();
        let start = nmt::command_frame(NmtCommand::Start, 5);
        let out = node.on_frame(&start, &mut drive, now);
        assert_eq!(out, vec![nmt::boot_up_frame(5)], "boot-up first");
        node.tick(&mut drive, now);
        assert_eq!(node.state(), NmtState::Operational);
    }

    #[test]
    fn nodes_on_one_bus_take_only_what_is_for_them() {
        let nodes = [5u8, 6].map(|id| {
            let mut drive = Drive::new();
            let node = Node::new(id, &mut drive);
            (node, SharedDrive::new(drive))
        });
        let mut nodes = Vec::from(nodes);
        // An NMT command to all reaches both; one to node 6 only node 6.
        let out = deliver(&mut nodes, &nmt::command_frame(NmtCommand::Start, 0), None);
        assert_eq!(
            out,
            vec![(0, nmt::boot_up_frame(5)), (1, nmt::boot_up_frame(6))]
        );
        deliver(&mut nodes, &nmt::command_frame(NmtCommand::Stop, 6), None);
        assert_eq!(nodes[0].0.state(), NmtState::Operational);
        assert_eq!(nodes[1].0.state(), NmtState::Stopped);
        deliver(&mut nodes, &nmt::command_frame(NmtCommand::Start, 6), None);
        // An SDO request to node 6 is answered by node 6 alone, on its own COB-ID.
        let mut client = crate::proto::canopen::sdo::SdoClient::new(6);
        let out = deliver(&mut nodes, &client.upload(0x1014, 0), None);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].0, 1);
        assert_eq!(out[0].1.cob_id(), Some(0x586));
        assert_eq!(
            client.on_frame(&out[0].1),
            crate::proto::canopen::sdo::SdoEvent::Uploaded(0x86u32.to_le_bytes().to_vec())
        );
        // A frame a node sends is not handed back to it.
        let heard = deliver(
            &mut nodes,
            &nmt::command_frame(NmtCommand::ResetNode, 5),
            Some(0),
        );
        assert!(heard.is_empty(), "{heard:?}");
        assert_eq!(nodes[0].0.state(), NmtState::Operational);
    }
}
