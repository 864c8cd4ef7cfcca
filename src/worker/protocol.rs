//! What goes in and out of the worker: `Request`s from the UI or a script, `Event`s back.

use std::fmt;
use std::time::Duration;

use crate::injection::Injection;
use crate::link::{
    FoundDevice, LinkFailure, LinkInfo, LinkSpec, NetworkInterface, Notice, Refusal, TraceRecord,
};
use crate::od::{Address, DataType, Value};
use crate::pdi::{Action, Failure, RxImage, Waiting};
pub use crate::signal::{MAX_WATCHED, Sample};

/// Identifies a request in the events it causes.
pub type RequestId = u64;

/// The id of what the worker does on its own (the halt of a jog whose keep-alive
/// stopped, the halt tried when the link fails during a move).
pub const WORKER_ID: RequestId = u64::MAX;

/// How often the window sends `JogKeepAlive` while a jog button is held.
pub const JOG_KEEPALIVE: Duration = Duration::from_millis(100);
/// A jog without a keep-alive for this long is halted by the worker: five missed
/// keep-alives. The drive then brakes on its halt ramp.
pub const JOG_TIMEOUT: Duration = Duration::from_millis(500);
/// How long the worker tries to get a halt through when the link fails during a move.
pub const HALT_ON_LOSS_TIMEOUT: Duration = Duration::from_millis(300);
/// Exchanges that must fail in a row before the link counts as lost, unless set: one
/// lost, late or corrupted reply (after the bus's own retries) is not a lost link.
pub const LOST_AFTER: u32 = 3;
/// The most failed exchanges in a row the setting allows.
pub const MAX_LOST_AFTER: u32 = 100;

/// What the worker does when the link fails while the motor may be moving (a travel
/// command without the halt bit, or a jog).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LinkLossAction {
    /// One last try to set the halt bit: the drive brakes on its ramp, stays energised.
    #[default]
    Halt,
    /// One last try to switch the power stage off (the motor coasts).
    SwitchOff,
    /// Leave the drive alone (it carries on, or stops by its own watchdog).
    Nothing,
}

impl LinkLossAction {
    pub const ALL: [LinkLossAction; 3] = [
        LinkLossAction::Halt,
        LinkLossAction::SwitchOff,
        LinkLossAction::Nothing,
    ];

    pub fn name(self) -> &'static str {
        match self {
            LinkLossAction::Halt => "try to halt",
            LinkLossAction::SwitchOff => "try to switch off",
            LinkLossAction::Nothing => "leave the drive alone",
        }
    }
}

/// Which way an object access travels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ObjectPath {
    /// The link's own object access where it has one, the PDI otherwise.
    #[default]
    Auto,
    /// PDI OD-Read / OD-Write (works on every bus; 32-bit values only).
    Pdi,
    /// The link's own access only (SDO, FC 43, CIP 32h/33h, direct on the simulator).
    Native,
}

/// Something the worker is asked to do.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    Connect(LinkSpec),
    Disconnect,
    /// Send a PDI command.
    Command(Action),
    /// Set the halt bit on the running travel command.
    Halt,
    /// Jog: Profile Velocity at `speed` rpm for as long as `JogKeepAlive` keeps coming
    /// (at least every [`JOG_KEEPALIVE`]); the worker halts the drive when it stops
    /// coming for [`JOG_TIMEOUT`] (a frozen window, a lost focus, a closed lid).
    Jog {
        speed: i32,
    },
    /// The jog button is still held.
    JogKeepAlive,
    /// The jog button was released: halt.
    JogStop,
    /// Reset the halt bit: continue to the old target.
    Resume,
    ReadObject {
        address: Address,
        /// The object's type where the caller knows it (from the catalog).
        dtype: Option<DataType>,
        path: ObjectPath,
    },
    WriteObject {
        address: Address,
        dtype: DataType,
        value: Value,
        path: ObjectPath,
    },
    /// Inject or withdraw a fault on the simulated drive.
    Inject {
        injection: Injection,
        active: bool,
    },
    /// Change the poll rate (cycles per second).
    SetPollRate(f64),
    /// What to do when the link fails during a move.
    SetLinkLoss(LinkLossAction),
    /// How many exchanges in a row must fail before the link counts as lost (1 to
    /// [`MAX_LOST_AFTER`]); fewer are retried, each named in the log.
    SetLostAfter(u32),
    /// Report every frame the link sends and receives (`Event::Frames`), or stop.
    SetTrace(bool),
    /// Find the devices on a bus: through the open link when it is on that bus, otherwise
    /// by opening the bus for the scan.
    Scan(LinkSpec),
    /// Read many objects (the OD browser, backups): each result comes as an
    /// `ObjectRead` with this request's id, in order, a few per cycle so the PDI keeps
    /// running; `Cancel` drops the ones not read yet.
    ReadMany {
        objects: Vec<(Address, DataType)>,
        path: ObjectPath,
    },
    /// Sample these objects every cycle along with the plot signals (at most
    /// [`MAX_WATCHED`]; an empty list stops). Each comes by the cheapest path: from the
    /// exchange where the link's image carries it, otherwise by a cyclic object read, as
    /// many per cycle as fit in a share of the cycle (round robin). Kept across reconnects.
    Watch(Vec<(Address, DataType)>),
    /// Drop what is still queued of request `id` (a `ReadMany`); reported by `Cancelled`.
    Cancel(RequestId),
    /// List the serial ports of this machine (for Modbus RTU and slcan adapters):
    /// answered by `SerialPorts`.
    ListSerialPorts,
    /// List the IPv4 interfaces of this machine (for EtherNet/IP discovery): answered by
    /// `Interfaces`.
    ListInterfaces,
    /// Find EtherNet/IP adapters: ListIdentity broadcast on `interface` (a name or IPv4
    /// address; `None`: every interface) and asked directly at `host`.
    Discover {
        interface: Option<String>,
        host: Option<String>,
        port: u16,
    },
}

impl Request {
    /// Requests that go ahead of everything queued: the ones that stop the motor.
    pub fn is_urgent(&self) -> bool {
        matches!(
            self,
            Request::Halt
                | Request::JogStop
                | Request::Command(Action::Quickstop)
                | Request::Command(Action::SwitchOff)
        )
    }
}

impl fmt::Display for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Request::Connect(spec) => write!(f, "connect to {spec}"),
            Request::Disconnect => f.write_str("disconnect"),
            Request::Command(action) => write!(f, "{action}"),
            Request::Halt => f.write_str("Halt (set bit 6)"),
            Request::Jog { speed } => write!(f, "Jog at {speed} rpm (Profile Velocity while held)"),
            Request::JogKeepAlive => f.write_str("jog keep-alive"),
            Request::JogStop => f.write_str("Jog released: halt"),
            Request::Resume => f.write_str("Resume (reset bit 6)"),
            Request::ReadObject { address, .. } => write!(f, "read {address}"),
            Request::WriteObject { address, value, .. } => write!(f, "write {value} to {address}"),
            Request::Inject { injection, active } => {
                if *active {
                    write!(f, "inject {injection}")
                } else {
                    write!(f, "withdraw {injection}")
                }
            }
            Request::SetPollRate(hz) => write!(f, "poll at {hz} Hz"),
            Request::SetLinkLoss(action) => write!(f, "on link loss: {}", action.name()),
            Request::SetLostAfter(n) => write!(
                f,
                "count the link as lost after {n} failed exchanges in a row"
            ),
            Request::Scan(spec) => write!(f, "scan {}", spec.bus_name()),
            Request::ReadMany { objects, .. } => write!(f, "read {} objects", objects.len()),
            Request::Cancel(id) => write!(f, "cancel request {id}"),
            Request::Discover { interface, .. } => write!(
                f,
                "discover EtherNet/IP adapters on {}",
                interface.as_deref().unwrap_or("every interface")
            ),
            Request::ListSerialPorts => f.write_str("list the serial ports"),
            Request::ListInterfaces => f.write_str("list the network interfaces"),
            Request::SetTrace(on) => write!(f, "frame trace {}", if *on { "on" } else { "off" }),
            Request::Watch(objects) => write!(f, "sample {} object(s) cyclically", objects.len()),
        }
    }
}

/// Why the worker did not send a request, or dropped it before it ran.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Rejection {
    #[error("not connected to a drive")]
    NotConnected,
    /// It was queued when the link went away (the reason), and is not replayed.
    #[error("not sent: {0}")]
    LinkGone(String),
    /// The request itself cannot be carried out now or at all, in words (a value out of
    /// range, a queue that is full, a command the state does not allow).
    #[error("{0}")]
    Refused(String),
}

/// Why an object access gave no value. It stays typed from the link to the window and
/// the command line: callers tell a refusal from a failed PDI command by the variant.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ObjectError {
    /// The device's answer: an SDO abort, a Modbus exception, a CIP status, or an answer
    /// that does not fit the object's type.
    #[error("{0}")]
    Refused(Refusal),
    /// The access ran as a PDI OD Read/Write command and did not end well (refused with
    /// PdiStatusError, timed out, superseded, link lost).
    #[error("{0}")]
    Pdi(CommandProgress),
    /// The PDI's return value does not fit the type asked for.
    #[error("{0}")]
    Decode(String),
    /// The worker never sent it.
    #[error("{0}")]
    NotSent(Rejection),
}

impl ObjectError {
    /// The device's refusal, if that is what it was.
    pub fn refusal(&self) -> Option<&Refusal> {
        match self {
            ObjectError::Refused(refusal) => Some(refusal),
            _ => None,
        }
    }
}

/// How a command ended, or got on.
#[derive(Clone, Debug, PartialEq)]
pub enum CommandProgress {
    /// The drive detected the command.
    Accepted,
    /// The command finished (target reached, value read, …).
    Done { return_value: i32 },
    /// The drive refused it or a fault stopped it.
    Failed(Failure),
    TimedOut {
        waiting_for: Waiting,
        after: Duration,
    },
    /// A newer command replaced it.
    Superseded,
    /// The link was lost before the command finished: why, and what the worker did to
    /// the drive on the way out (a halt tried, and whether it reached the drive).
    LinkLost { reason: String },
}

impl CommandProgress {
    pub fn is_final(&self) -> bool {
        !matches!(self, CommandProgress::Accepted)
    }

    pub fn is_success(&self) -> bool {
        matches!(
            self,
            CommandProgress::Accepted | CommandProgress::Done { .. }
        )
    }
}

impl fmt::Display for CommandProgress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CommandProgress::Accepted => f.write_str("accepted"),
            CommandProgress::Done { return_value } => {
                write!(f, "done (ReturnValue {return_value})")
            }
            CommandProgress::Failed(failure) => write!(f, "failed: {failure}"),
            CommandProgress::TimedOut { waiting_for, after } => write!(
                f,
                "timed out after {:.1} s waiting for {waiting_for}",
                after.as_secs_f64()
            ),
            CommandProgress::Superseded => f.write_str("superseded by a newer command"),
            CommandProgress::LinkLost { reason } => {
                write!(f, "the link was lost before it finished: {reason}")
            }
        }
    }
}

/// The link's health, once a second.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Health {
    /// Process-image exchanges in the last second.
    pub cycles_per_second: f64,
    pub rtt_mean: Duration,
    pub rtt_max: Duration,
    /// Failed exchanges since connecting (each retried until the link counted as lost).
    pub errors: u64,
    /// Replies that were lost, late, corrupted or mismatched and got over by sending the
    /// request again, since connecting.
    pub recovered: u64,
    /// Samples the UI was too slow to take (dropped, never queued without bound).
    pub dropped_samples: u64,
    /// Traced frames dropped for the same reason (the outcomes they carried were not).
    pub dropped_frames: u64,
}

/// Something the worker reports.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    Connecting(LinkSpec),
    Connected(LinkInfo),
    /// The link learned something about the device and describes itself anew.
    LinkChanged(LinkInfo),
    /// Opening the link failed; `retrying` when the worker will try again.
    ConnectFailed {
        spec: LinkSpec,
        error: LinkFailure,
        retry_in: Option<Duration>,
    },
    /// The link is gone: `reason` is `None` when the user disconnected.
    Disconnected {
        reason: Option<String>,
    },
    /// A request was refused before anything was sent (not connected, bad values, …).
    Rejected {
        id: RequestId,
        request: String,
        reason: Rejection,
    },
    /// A PDI image carrying a command was written.
    Sent {
        id: RequestId,
        /// When, on the samples' clock (seconds since the worker first connected; it goes
        /// on across reconnects).
        t: f64,
        what: String,
        image: RxImage,
    },
    Progress {
        id: RequestId,
        progress: CommandProgress,
    },
    ObjectRead {
        id: RequestId,
        address: Address,
        result: Result<Value, ObjectError>,
    },
    ObjectWritten {
        id: RequestId,
        address: Address,
        value: Value,
        result: Result<(), ObjectError>,
    },
    /// The newest samples, in order; the last one is the current status.
    Samples(Vec<Sample>),
    Health(Health),
    /// The tool changed an object on the drive: `before` is its value before the tool
    /// first wrote it this session (`None` when it could not be read first), `after` the
    /// value now. Writing `before` back undoes the change.
    Changed {
        address: Address,
        dtype: DataType,
        before: Option<Value>,
        after: Value,
    },
    /// What the link itself changed on the device (see `Link::own_changes`), anew.
    LinkOwnChanges(Vec<String>),
    /// Something the user should know that is not tied to a request.
    Notice(Notice),
    /// Frames the link sent and received, when the trace is on (dropped, never queued
    /// without bound, when the UI is slow).
    Frames(Vec<TraceRecord>),
    /// What was left of request `id` was dropped before it reached the drive.
    Cancelled {
        id: RequestId,
        dropped: usize,
    },
    /// The serial ports of this machine, by name.
    SerialPorts(Vec<String>),
    /// The IPv4 interfaces of this machine, loopback last.
    Interfaces(Vec<NetworkInterface>),
    /// What a bus scan found.
    Scanned {
        id: RequestId,
        result: Result<Vec<FoundDevice>, LinkFailure>,
    },
}

impl Event {
    /// The request this event answers, if it is a reply to one.
    pub fn reply_id(&self) -> Option<RequestId> {
        match self {
            Event::Rejected { id, .. }
            | Event::Sent { id, .. }
            | Event::Progress { id, .. }
            | Event::ObjectRead { id, .. }
            | Event::ObjectWritten { id, .. }
            | Event::Cancelled { id, .. }
            | Event::Scanned { id, .. } => Some(*id),
            _ => None,
        }
    }
}
