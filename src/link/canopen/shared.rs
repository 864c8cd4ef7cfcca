//! One CAN adapter shared by every drive on it.
//!
//! Two drives on one CAN cable are two nodes behind one adapter. Each drive keeps its own
//! worker thread and its own [`CanopenLink`](super::client::CanopenLink), but the adapter
//! is opened once: the first link to name it ([`join`], keyed by the adapter: `slcan:` and
//! its path, `socketcan:` and its interface, `memory:` and the simulated bus) starts the
//! bus's owner, a thread of its own that is the bus's only reader and writer. Every link
//! gets a [`SharedCanPort`] on it:
//!
//! * a frame received is handed to the port of the node it comes from (the node id in its
//!   COB-ID: SDO answers 580h+n, TPDOs, EMCY 80h+n, heartbeat 700h+n), so each link sees its
//!   own drive's frames and SDO transfers to different nodes run side by side; frames of no
//!   node (SYNC, TIME, LSS, extended ids) go to every port;
//! * a port opened without a node (a scan) hears every frame;
//! * every frame sent and received on the bus goes, in wire order, into the trace of
//!   every port ([`CanBus::take_trace`]): each drive's frame log is the bus's one log,
//!   every node's frames in it, as candump on the adapter shows them;
//! * NMT commands stay per node: a link starts its own node only. A command to every node
//!   (node id 0) from one port would stop or reset the other drives' nodes as well, so the
//!   owner refuses it while other nodes share the bus, and sends it (once) when the port
//!   is alone;
//! * a second link for a node already open on the bus is refused, naming the node;
//! * the bus closes when its last port goes. A bus that fails (the adapter unplugged) tells
//!   every port its error and ends; the next link to name the adapter opens it afresh.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

use tokio::sync::{mpsc, oneshot};

use super::CanBus;
use crate::link::{Error, TraceRecord, TraceRing};
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::nmt;

/// Frames a port may have waiting before the owner drops (and counts) more.
const PORT_QUEUE: usize = 4096;
/// Commands waiting for the owner.
const COMMAND_QUEUE: usize = 256;

/// The node a received frame comes from, by its COB-ID (CiA 301's predefined connection
/// set): `None` for the frames of no single node (NMT, SYNC, TIME, LSS, extended ids).
pub fn node_of(frame: &CanFrame) -> Option<u8> {
    let cob = frame.cob_id()?;
    let node = (cob & 0x7F) as u8;
    let function = cob >> 7;
    // Function 0 is NMT, 0Fh (780h-7FFh) holds LSS; node 0 is SYNC and TIME.
    (node != 0 && function != 0 && function != 0x0F).then_some(node)
}

/// What the owner thread hands a port: a frame, or the bus's failure.
type Delivery = Result<CanFrame, Error>;

enum Command {
    Join {
        node: Option<u8>,
        reply: oneshot::Sender<Result<Member, Error>>,
    },
    Send {
        from: u64,
        frame: CanFrame,
        reply: oneshot::Sender<Result<(), Error>>,
    },
    Leave {
        id: u64,
    },
}

/// A port's place on the owner's list.
struct Member {
    id: u64,
    frames: mpsc::Receiver<Delivery>,
}

/// The owner's record of a port.
struct Listener {
    id: u64,
    node: Option<u8>,
    frames: mpsc::Sender<Delivery>,
}

/// What a port has not taken yet: the bus's frames, and how many frames it lost.
#[derive(Debug, Default)]
struct Unread {
    trace: TraceRing,
    lost: u64,
}

/// What the owner and its ports share.
#[derive(Debug)]
struct Shared {
    key: String,
    /// What a second link must agree with (the slcan bit rate).
    settings: String,
    /// The bus's own words (`slcan /dev/ttyACM0 at 1 Mbit/s`), once open.
    describe: OnceLock<String>,
    /// What each port (by id) has not taken yet.
    unread: Mutex<BTreeMap<u64, Unread>>,
    /// Troubles the bus got over, for whichever port asks first.
    troubles: Mutex<Vec<String>>,
    /// The CAN interface name candump logs use.
    interface: String,
}

impl Shared {
    fn describe(&self) -> String {
        self.describe
            .get()
            .cloned()
            .unwrap_or_else(|| self.key.clone())
    }

    fn record(&self, sent: bool, frame: &CanFrame) {
        let record = TraceRecord {
            at: std::time::SystemTime::now(),
            sent,
            raw: frame.to_string(),
            text: crate::proto::canopen::describe::describe(frame),
            can: Some((*frame, self.interface.clone())),
        };
        for unread in lock(&self.unread).values_mut() {
            unread.trace.push(record.clone());
        }
    }
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|p| p.into_inner())
}

/// The buses open in this process, by key. The entries hold weak senders: a bus lives as
/// long as a port holds it.
/// A bus opened again waits for its last owner to let go of the adapter.
type Registry = BTreeMap<String, (mpsc::WeakSender<Command>, Arc<Shared>, Thread)>;

use crate::link::owner::Thread;

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    static BUSES: Mutex<Registry> = Mutex::new(BTreeMap::new());
    lock(&BUSES)
}

/// The buses open now, by key (for tests and messages).
pub fn open_buses() -> Vec<String> {
    registry()
        .iter()
        .filter(|(_, (sender, _, _))| sender.upgrade().is_some_and(|s| !s.is_closed()))
        .map(|(key, _)| key.clone())
        .collect()
}

/// One link's port on a shared CAN bus.
pub struct SharedCanPort {
    owner: mpsc::Sender<Command>,
    id: u64,
    node: Option<u8>,
    frames: mpsc::Receiver<Delivery>,
    shared: Arc<Shared>,
}

impl std::fmt::Debug for SharedCanPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SharedCanPort")
            .field("bus", &self.shared.key)
            .field("node", &self.node)
            .finish_non_exhaustive()
    }
}

/// Join the bus `key` names as `node` (`None`: hear every frame, for a scan), opening it
/// with `open` on an owner thread of its own when nobody has it open. `settings` must be
/// those the bus was opened with (a second link at another bit rate is refused), and
/// `interface` is the name candump logs give it.
pub async fn join<B, F, Fut>(
    key: &str,
    settings: &str,
    interface: &str,
    node: Option<u8>,
    open: F,
) -> Result<SharedCanPort, Error>
where
    B: CanBus + 'static,
    F: FnOnce() -> Fut + Send + 'static,
    Fut: std::future::Future<Output = Result<B, Error>> + 'static,
{
    let (owner, shared, opened) = {
        let mut buses = registry();
        let running = buses.get(key).and_then(|(weak, shared, _)| {
            let owner = weak.upgrade().filter(|s| !s.is_closed())?;
            Some((owner, shared.clone()))
        });
        match running {
            Some((owner, shared)) => {
                if shared.settings != settings {
                    return Err(Error::Refused(format!(
                        "{} is already open by another drive with {}, not {settings}: open every node on it with the same settings",
                        shared.describe(),
                        shared.settings
                    )));
                }
                (owner, shared, None)
            }
            None => {
                let shared = Arc::new(Shared {
                    key: key.to_owned(),
                    settings: settings.to_owned(),
                    describe: OnceLock::new(),
                    unread: Mutex::new(BTreeMap::new()),
                    troubles: Mutex::new(Vec::new()),
                    interface: interface.to_owned(),
                });
                let (owner, commands) = mpsc::channel(COMMAND_QUEUE);
                let (opened_tx, opened_rx) = oneshot::channel();
                let last = buses.remove(key).and_then(|(_, _, thread)| thread);
                let thread = spawn_owner(shared.clone(), commands, open, opened_tx, last)?;
                buses.insert(
                    key.to_owned(),
                    (owner.downgrade(), shared.clone(), Some(thread)),
                );
                (owner, shared, Some(opened_rx))
            }
        }
    };
    if let Some(opened) = opened {
        match opened.await {
            Ok(Ok(())) => {}
            Ok(Err(error)) => return Err(error),
            Err(_) => {
                return Err(Error::Disconnected(format!(
                    "the owner of {key} stopped while opening it"
                )));
            }
        }
    }
    let (reply, joined) = oneshot::channel();
    let gone = || {
        Error::Disconnected(format!(
            "{} closed before this link joined it (it failed for another drive on it)",
            shared.describe()
        ))
    };
    owner
        .send(Command::Join { node, reply })
        .await
        .map_err(|_| gone())?;
    let member = joined.await.map_err(|_| gone())??;
    Ok(SharedCanPort {
        owner,
        id: member.id,
        node,
        frames: member.frames,
        shared,
    })
}

/// Start the owner thread of a bus: it waits for the `last` owner of the adapter to close
/// it, opens the bus with `open` (a serial port or a socket belongs to the runtime that
/// opened it), says how that went on `opened`, then serves.
fn spawn_owner<B, F, Fut>(
    shared: Arc<Shared>,
    commands: mpsc::Receiver<Command>,
    open: F,
    opened: oneshot::Sender<Result<(), Error>>,
    last: Thread,
) -> Result<std::thread::JoinHandle<()>, Error>
where
    B: CanBus + 'static,
    F: FnOnce() -> Fut + Send + 'static,
    Fut: std::future::Future<Output = Result<B, Error>> + 'static,
{
    let key = shared.key.to_string();
    crate::link::owner::spawn_owner(
        format!("drivedeck-can {key}"),
        key,
        "the CAN bus",
        last,
        opened,
        move |opened| async move {
            match open().await {
                Ok(bus) => {
                    let _ = shared.describe.set(bus.describe());
                    let _ = opened.send(Ok(()));
                    serve(bus, commands, &shared).await;
                }
                Err(error) => {
                    let _ = opened.send(Err(error));
                }
            }
        },
    )
}

/// The owner's loop: commands from the ports, frames from the bus, until the last port
/// goes or the bus fails.
async fn serve<B: CanBus>(mut bus: B, mut commands: mpsc::Receiver<Command>, shared: &Shared) {
    let mut listeners: Vec<Listener> = Vec::new();
    let mut next_id = 1u64;
    loop {
        tokio::select! {
            command = commands.recv() => match command {
                None => break,
                Some(Command::Join { node, reply }) => {
                    let _ = reply.send(admit(&mut listeners, &mut next_id, node, shared));
                }
                Some(Command::Send { from, frame, reply }) => {
                    let sent = match refuse_broadcast(&listeners, from, &frame, shared) {
                        Some(refusal) => Err(refusal),
                        None => {
                            shared.record(true, &frame);
                            bus.send(&frame).await
                        }
                    };
                    let _ = reply.send(sent);
                }
                Some(Command::Leave { id }) => {
                    listeners.retain(|l| l.id != id);
                    lock(&shared.unread).remove(&id);
                }
            },
            frame = bus.recv() => match frame {
                Ok(frame) => {
                    shared.record(false, &frame);
                    dispatch(&mut listeners, frame, shared);
                }
                Err(error) => {
                    let fatal = matches!(error, Error::Disconnected(_) | Error::Io { .. });
                    for listener in &listeners {
                        let _ = listener.frames.try_send(Err(copy(&error)));
                    }
                    if fatal {
                        break;
                    }
                }
            },
        }
        let troubles = bus.take_troubles();
        if !troubles.is_empty() {
            lock(&shared.troubles).extend(troubles);
        }
    }
}

/// A new port on the bus, unless its node already has one.
fn admit(
    listeners: &mut Vec<Listener>,
    next_id: &mut u64,
    node: Option<u8>,
    shared: &Shared,
) -> Result<Member, Error> {
    if let Some(n) = node
        && listeners.iter().any(|l| l.node == Some(n))
    {
        return Err(Error::Refused(format!(
            "node {n} on {} is already open by another drive in this drivedeck: one link per node",
            shared.describe()
        )));
    }
    let id = *next_id;
    *next_id += 1;
    let (frames, receiver) = mpsc::channel(PORT_QUEUE);
    lock(&shared.unread).insert(id, Unread::default());
    listeners.push(Listener { id, node, frames });
    Ok(Member {
        id,
        frames: receiver,
    })
}

/// The refusal of an NMT command to every node from a port while other drives' nodes
/// share the bus; `None` for every other frame.
fn refuse_broadcast(
    listeners: &[Listener],
    from: u64,
    frame: &CanFrame,
    shared: &Shared,
) -> Option<Error> {
    let (command, 0) = nmt::decode_command(frame).ok()? else {
        return None;
    };
    let others: Vec<String> = listeners
        .iter()
        .filter(|l| l.id != from)
        .filter_map(|l| l.node)
        .map(|n| n.to_string())
        .collect();
    (!others.is_empty()).then(|| {
        Error::Refused(format!(
            "NMT {command} to every node on {} would reach node(s) {} of other drives too: address one node",
            shared.describe(),
            others.join(", ")
        ))
    })
}

/// Hand a received frame to the port of its node, and to every port that hears all.
fn dispatch(listeners: &mut Vec<Listener>, frame: CanFrame, shared: &Shared) {
    let node = node_of(&frame);
    listeners.retain(|l| {
        let wanted = l.node.is_none() || node.is_none() || l.node == node;
        if !wanted {
            return true;
        }
        match l.frames.try_send(Ok(frame)) {
            Ok(()) => true,
            Err(mpsc::error::TrySendError::Full(_)) => {
                if let Some(unread) = lock(&shared.unread).get_mut(&l.id) {
                    unread.lost += 1;
                }
                true
            }
            Err(mpsc::error::TrySendError::Closed(_)) => {
                lock(&shared.unread).remove(&l.id);
                false
            }
        }
    });
}

/// The same error again, for each port (an I/O error keeps its kind and words).
fn copy(error: &Error) -> Error {
    match error {
        Error::Io { context, source } => Error::Io {
            context: context.clone(),
            source: std::io::Error::new(source.kind(), source.to_string()),
        },
        Error::Timeout { what, after } => Error::Timeout {
            what: what.clone(),
            after: *after,
        },
        Error::Disconnected(s) => Error::Disconnected(s.clone()),
        Error::Refused(s) => Error::Refused(s.clone()),
        Error::Unsupported(s) => Error::Unsupported(s.clone()),
        Error::Protocol(s) => Error::Protocol(s.clone()),
        Error::Answer(s) => Error::Answer(s.clone()),
        Error::NoValidReply {
            what,
            tries,
            troubles,
        } => Error::NoValidReply {
            what: what.clone(),
            tries: *tries,
            troubles: troubles.clone(),
        },
    }
}

impl SharedCanPort {
    /// The node this port is for (`None`: it hears every frame).
    pub fn node(&self) -> Option<u8> {
        self.node
    }

    /// A second port on the same bus that hears every frame, for a scan while nodes are
    /// open on it.
    pub async fn listen_all(&self) -> Result<SharedCanPort, Error> {
        let (reply, joined) = oneshot::channel();
        let gone = || Error::Disconnected(format!("{} is closed", self.shared.describe()));
        self.owner
            .send(Command::Join { node: None, reply })
            .await
            .map_err(|_| gone())?;
        let member = joined.await.map_err(|_| gone())??;
        Ok(SharedCanPort {
            owner: self.owner.clone(),
            id: member.id,
            node: None,
            frames: member.frames,
            shared: self.shared.clone(),
        })
    }
}

impl CanBus for SharedCanPort {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        let (reply, sent) = oneshot::channel();
        let gone = || Error::Disconnected(format!("{} is closed", self.shared.describe()));
        self.owner
            .send(Command::Send {
                from: self.id,
                frame: *frame,
                reply,
            })
            .await
            .map_err(|_| gone())?;
        sent.await.map_err(|_| gone())?
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        match self.frames.recv().await {
            Some(delivery) => delivery,
            None => Err(Error::Disconnected(format!(
                "{} is closed",
                self.shared.describe()
            ))),
        }
    }

    fn describe(&self) -> String {
        self.shared.describe()
    }

    async fn listener(&self) -> Option<Result<SharedCanPort, Error>> {
        Some(self.listen_all().await)
    }

    /// Every frame on the bus since the last call, whichever link sent it or node it came
    /// from, in wire order.
    fn take_trace(&mut self) -> Option<Vec<TraceRecord>> {
        Some(
            lock(&self.shared.unread)
                .get_mut(&self.id)
                .map(|u| u.trace.take())
                .unwrap_or_default(),
        )
    }

    fn take_troubles(&mut self) -> Vec<String> {
        let mut troubles = std::mem::take(&mut *lock(&self.shared.troubles));
        let lost = lock(&self.shared.unread)
            .get_mut(&self.id)
            .map_or(0, |u| std::mem::take(&mut u.lost));
        if lost > 0 {
            troubles.push(format!(
                "{}: {lost} frame(s) lost, this link read too slowly",
                self.shared.describe()
            ));
        }
        troubles
    }
}

impl Drop for SharedCanPort {
    fn drop(&mut self) {
        // A full queue or a gone owner: the owner drops the port when its queue closes.
        let _ = self.owner.try_send(Command::Leave { id: self.id });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::canopen::MemoryBus;

    fn frame(cob: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(cob, data).expect("frame")
    }

    #[test]
    fn frames_go_to_the_node_in_their_cob_id() {
        assert_eq!(
            node_of(&frame(0x585, &[0x60, 0, 0, 0, 0, 0, 0, 0])),
            Some(5)
        );
        assert_eq!(node_of(&frame(0x186, &[0; 8])), Some(6));
        assert_eq!(node_of(&frame(0x87, &[0; 8])), Some(7));
        assert_eq!(node_of(&frame(0x77F, &[5])), Some(127));
        assert_eq!(node_of(&frame(0x000, &[1, 0])), None);
        assert_eq!(node_of(&frame(0x080, &[])), None);
        assert_eq!(node_of(&frame(0x7E5, &[0; 8])), None);
    }

    #[tokio::test(flavor = "current_thread")]
    async fn two_nodes_share_one_reader_and_each_hears_its_own() {
        let bus = MemoryBus::new();
        let mut far = bus.port();
        let key = "memory:test-two-nodes";
        let opener = |bus: MemoryBus| move || async move { Ok(bus.port()) };
        let mut five = join(key, "", "vcan0", Some(5), opener(bus.clone()))
            .await
            .expect("node 5");
        let mut six = join(key, "", "vcan0", Some(6), opener(bus.clone()))
            .await
            .expect("node 6");
        assert_eq!(open_buses().iter().filter(|k| *k == key).count(), 1);
        let e = join(key, "", "vcan0", Some(5), opener(bus.clone()))
            .await
            .expect_err("node 5 twice");
        assert!(e.to_string().contains("node 5"), "{e}");
        let e = join(key, "250000", "vcan0", Some(7), opener(bus.clone()))
            .await
            .expect_err("other settings");
        assert!(e.to_string().contains("same settings"), "{e}");
        // The far end answers node 6 first, then node 5, then a SYNC for all.
        far.send(&frame(0x586, &[6])).await.expect("send");
        far.send(&frame(0x585, &[5])).await.expect("send");
        far.send(&frame(0x080, &[])).await.expect("send");
        assert_eq!(five.recv().await.expect("5").data(), &[5]);
        assert_eq!(five.recv().await.expect("sync").cob_id(), Some(0x080));
        assert_eq!(six.recv().await.expect("6").data(), &[6]);
        assert_eq!(six.recv().await.expect("sync").cob_id(), Some(0x080));
        // A start of every node is refused while another node shares the bus.
        let all = nmt::command_frame(nmt::NmtCommand::Start, 0);
        let e = five.send(&all).await.expect_err("start all");
        assert!(e.to_string().contains("node(s) 6"), "{e}");
        five.send(&frame(0x605, &[1])).await.expect("send");
        assert_eq!(far.recv().await.expect("far").cob_id(), Some(0x605));
        // One log holds every node's frames, for each port.
        let trace: Vec<String> = five
            .take_trace()
            .unwrap_or_default()
            .into_iter()
            .map(|r| r.raw)
            .collect();
        assert_eq!(trace.len(), 4, "{trace:?}");
        assert!(trace[0].starts_with("586"), "{trace:?}");
        assert!(trace[3].starts_with("605"), "{trace:?}");
        let six_saw = six.take_trace().unwrap_or_default();
        assert_eq!(six_saw.len(), 4, "{six_saw:?}");
        // The last port closes the bus; alone, a start of every node goes out.
        drop(six);
        five.send(&all).await.expect("alone");
        drop(five);
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while open_buses().iter().any(|k| k == key) {
            assert!(std::time::Instant::now() < deadline, "the bus stays open");
            tokio::time::sleep(std::time::Duration::from_millis(5)).await;
        }
    }
}
