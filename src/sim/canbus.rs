//! `canopen+sim`: the built-in simulated drive as a CANopen node on an in-memory CAN bus,
//! so the whole CANopen path (NMT, SDO, PDO mapping, PDOs, EMCY) runs without hardware.
//!
//! The `canopen+sim` links of one process share one in-memory bus, each node id its own
//! simulated drive: `canopen+sim://?node=1` beside `canopen+sim://?node=2` are two drives
//! on one bus, as two axes on one CAN cable. A node is there while its link is open (and
//! fresh when opened again). A node id already open in the process gets a bus of its own,
//! so a second link to it never fights the first over its PDOs: every link opened alone
//! behaves as it always did.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::link::Error;
use crate::link::canopen::{CanBus, MemoryBus, MemoryPort, SharedCanPort};
use crate::proto::canopen::CanFrame;
use crate::sim::Drive;
use crate::sim::link::LINK_LOSS_TIME;
use crate::sim::server::SharedDrive;

/// One in-memory bus and the node ids simulated on it.
#[derive(Debug)]
struct Shared {
    /// Tells the bus apart from the others while it lives.
    id: u64,
    bus: MemoryBus,
    nodes: BTreeSet<u8>,
}

/// The simulated CAN buses of a process (one, unless a node id is opened twice).
#[derive(Debug, Default)]
pub struct SimBuses {
    buses: Mutex<Vec<Shared>>,
    next_id: std::sync::atomic::AtomicU64,
}

/// Where a simulated node sits: which bus, which node id (taken back when it goes).
#[derive(Debug)]
struct Seat {
    buses: &'static SimBuses,
    bus: u64,
    node: u8,
}

impl SimBuses {
    /// No buses yet.
    pub const fn new() -> SimBuses {
        SimBuses {
            buses: Mutex::new(Vec::new()),
            next_id: std::sync::atomic::AtomicU64::new(0),
        }
    }

    fn buses(&self) -> std::sync::MutexGuard<'_, Vec<Shared>> {
        self.buses.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn new_bus(&self, buses: &mut Vec<Shared>) -> usize {
        let id = self
            .next_id
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        buses.push(Shared {
            id,
            bus: MemoryBus::new(),
            nodes: BTreeSet::new(),
        });
        buses.len() - 1
    }

    /// Take node id `node` on the first bus where it is free (a new bus if none): the bus
    /// and the seat to give back.
    fn seat(&'static self, node: u8) -> (MemoryBus, Seat) {
        let mut buses = self.buses();
        let index = match buses.iter().position(|b| !b.nodes.contains(&node)) {
            Some(index) => index,
            None => self.new_bus(&mut buses),
        };
        let shared = &mut buses[index];
        shared.nodes.insert(node);
        let seat = Seat {
            buses: self,
            bus: shared.id,
            node,
        };
        (shared.bus.clone(), seat)
    }

    /// The first bus (the one links opened side by side share), made if there is none,
    /// with a seat for `node` unless it is already there.
    fn first(&'static self, node: u8) -> (MemoryBus, u64, Option<Seat>) {
        let mut buses = self.buses();
        if buses.is_empty() {
            self.new_bus(&mut buses);
        }
        let first = &mut buses[0];
        let seat = first.nodes.insert(node).then(|| Seat {
            buses: self,
            bus: first.id,
            node,
        });
        (first.bus.clone(), first.id, seat)
    }

    /// The node ids on each bus, in order (for tests and messages).
    pub fn nodes(&self) -> Vec<Vec<u8>> {
        self.buses()
            .iter()
            .map(|b| b.nodes.iter().copied().collect())
            .collect()
    }

    fn leave(&self, bus: u64, node: u8) {
        let mut buses = self.buses();
        if let Some(index) = buses.iter().position(|b| b.id == bus) {
            buses[index].nodes.remove(&node);
            if buses[index].nodes.is_empty() {
                buses.remove(index);
            }
        }
    }
}

impl Drop for Seat {
    fn drop(&mut self) {
        self.buses.leave(self.bus, self.node);
    }
}

/// The simulated CAN buses of this process.
pub static SIM_BUSES: SimBuses = SimBuses::new();

/// The master's port on the process's in-memory bus, with a simulated node on it. The node
/// runs as a task on the caller's runtime and stops (leaving the bus) when this is dropped.
/// The master side of the bus is shared like a real adapter's
/// ([`crate::link::canopen::shared`]): one reader of the bus for every link on it, each
/// link handed its own node's frames.
#[derive(Debug)]
pub struct SimCanBus {
    port: SharedCanPort,
    node: tokio::task::AbortHandle,
    drive: SharedDrive,
    /// The node's cable, pulled for [`LINK_LOSS_TIME`] by the link-loss injection.
    cable: Cable,
    /// The node id on its bus, given back when this goes (after the task is stopped).
    _seat: Seat,
}

impl SimCanBus {
    /// A fresh simulated drive as node `node` on the process's bus (on a bus of its own if
    /// `node` is already there). Call inside a tokio runtime.
    pub async fn start(node: u8) -> Result<SimCanBus, Error> {
        SimCanBus::start_on(&SIM_BUSES, node).await
    }

    /// [`SimCanBus::start`] among `buses`.
    pub async fn start_on(buses: &'static SimBuses, node: u8) -> Result<SimCanBus, Error> {
        let (bus, seat) = buses.seat(node);
        SimCanBus::with_node(&bus, Some(node), node, seat).await
    }

    /// A port on the process's first bus to scan it: every simulated node open in the
    /// process is found. If `node` is not among them, a fresh one is put there for as long
    /// as the returned guest lives, so a scan of a lone `canopen+sim` finds its node as it
    /// always did.
    pub async fn scanner(node: u8) -> Result<(SharedCanPort, Option<SimCanBus>), Error> {
        SimCanBus::scanner_on(&SIM_BUSES, node).await
    }

    /// [`SimCanBus::scanner`] among `buses`.
    pub async fn scanner_on(
        buses: &'static SimBuses,
        node: u8,
    ) -> Result<(SharedCanPort, Option<SimCanBus>), Error> {
        let (bus, id, seat) = buses.first(node);
        let guest = match seat {
            Some(seat) => Some(SimCanBus::with_node(&bus, Some(node), node, seat).await?),
            None => None,
        };
        let key = format!("memory:{:p}#{id}", buses);
        let port = join_memory(&key, &bus, None).await?;
        Ok((port, guest))
    }

    /// A simulated drive as `node` on `bus`, and the master's port for `master` (the node
    /// whose frames it hears; `None`: every frame).
    async fn with_node(
        bus: &MemoryBus,
        master: Option<u8>,
        node: u8,
        seat: Seat,
    ) -> Result<SimCanBus, Error> {
        let key = format!("memory:{:p}#{}", seat.buses, seat.bus);
        let port = join_memory(&key, bus, master).await?;
        let drive = SharedDrive::new(Drive::new());
        let served = drive.clone();
        let cable = Cable::default();
        let node_port = CabledPort {
            port: bus.port(),
            cable: cable.clone(),
        };
        let task = tokio::spawn(async move {
            let _ = crate::sim::server::canopen::run(node_port, node, served).await;
        });
        Ok(SimCanBus {
            port,
            node: task.abort_handle(),
            drive,
            cable,
            _seat: seat,
        })
    }

    /// Inject or withdraw a fault in the simulated node. A link loss pulls the node's
    /// cable for [`LINK_LOSS_TIME`]: it neither hears nor sends, the other nodes on the bus
    /// carry on.
    pub fn inject(&mut self, injection: crate::sim::Injection, active: bool) -> Result<(), Error> {
        if injection.is_link() {
            self.cable
                .pull(active.then(|| Instant::now() + LINK_LOSS_TIME));
            return Ok(());
        }
        let mut drive = self.drive.lock();
        if active {
            drive.inject(injection);
        } else {
            drive.withdraw(injection);
        }
        Ok(())
    }

    /// The simulated drive behind the node.
    pub fn drive(&self) -> &SharedDrive {
        &self.drive
    }
}

impl Drop for SimCanBus {
    fn drop(&mut self) {
        self.node.abort();
    }
}

impl CanBus for SimCanBus {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        self.port.send(frame).await
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        self.port.recv().await
    }

    fn describe(&self) -> String {
        "the simulated CAN bus".into()
    }

    fn take_troubles(&mut self) -> Vec<String> {
        self.port.take_troubles()
    }

    async fn listener(&self) -> Option<Result<SharedCanPort, Error>> {
        Some(self.port.listen_all().await)
    }

    fn take_trace(&mut self) -> Option<Vec<crate::link::TraceRecord>> {
        self.port.take_trace()
    }
}

/// A simulated node's cable: plugged, or pulled until some time.
#[derive(Clone, Debug, Default)]
struct Cable {
    pulled_until: Arc<Mutex<Option<Instant>>>,
}

impl Cable {
    fn pull(&self, until: Option<Instant>) {
        *self.pulled_until.lock().unwrap_or_else(|p| p.into_inner()) = until;
    }

    fn pulled(&self) -> bool {
        self.pulled_until
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some_and(|until| Instant::now() < until)
    }
}

/// A simulated node's port behind its cable: while the cable is pulled, what it sends is
/// lost and what comes is not heard.
#[derive(Debug)]
struct CabledPort {
    port: MemoryPort,
    cable: Cable,
}

impl CanBus for CabledPort {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        if self.cable.pulled() {
            return Ok(());
        }
        self.port.send(frame).await
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        loop {
            let frame = self.port.recv().await?;
            if !self.cable.pulled() {
                return Ok(frame);
            }
        }
    }

    fn describe(&self) -> String {
        self.port.describe()
    }
}

/// The master's port on the in-memory bus `key` names: the first link on it starts the
/// bus's one reader ([`crate::link::canopen::shared`]).
async fn join_memory(key: &str, bus: &MemoryBus, node: Option<u8>) -> Result<SharedCanPort, Error> {
    let bus = bus.clone();
    crate::link::canopen::shared::join(
        key,
        "",
        "vcan0",
        node,
        move || async move { Ok(bus.port()) },
    )
    .await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 603Fh of the drive behind a simulated node.
    fn error_code(bus: &SimCanBus) -> i128 {
        let drive = bus.drive().lock();
        let code = drive.read(crate::od::Address::new(0x603F, 0));
        code.ok().and_then(|v| v.as_i128()).unwrap_or(-1)
    }

    #[tokio::test(flavor = "current_thread")]
    async fn links_side_by_side_share_a_bus_and_a_node_id_opened_twice_gets_its_own() {
        static BUSES: SimBuses = SimBuses::new();
        let one = SimCanBus::start_on(&BUSES, 1).await.expect("node");
        let two = SimCanBus::start_on(&BUSES, 2).await.expect("node");
        assert_eq!(BUSES.nodes(), [vec![1, 2]]);
        // Two drives, not one.
        one.drive()
            .lock()
            .inject(crate::sim::Injection::OverCurrent);
        assert_eq!(error_code(&one), 0x2300);
        assert_eq!(error_code(&two), 0);
        let again = SimCanBus::start_on(&BUSES, 1).await.expect("node");
        assert_eq!(BUSES.nodes(), [vec![1, 2], vec![1]]);
        // A scan looks at the first bus; a node not there is put there while it runs.
        let (_, guest) = SimCanBus::scanner_on(&BUSES, 2).await.expect("scanner");
        assert!(guest.is_none());
        let (_, guest) = SimCanBus::scanner_on(&BUSES, 9).await.expect("scanner");
        assert_eq!(BUSES.nodes(), [vec![1, 2, 9], vec![1]]);
        drop(guest);
        // A node leaves with its link; a bus with nobody on it goes.
        drop(one);
        assert_eq!(BUSES.nodes(), [vec![2], vec![1]]);
        drop(again);
        assert_eq!(BUSES.nodes(), [vec![2]]);
        // The free id is taken on the first bus again, as a fresh drive.
        let fresh = SimCanBus::start_on(&BUSES, 1).await.expect("node");
        assert_eq!(BUSES.nodes(), [vec![1, 2]]);
        assert_eq!(error_code(&fresh), 0);
        drop((two, fresh));
        assert!(BUSES.nodes().is_empty());
    }
}
