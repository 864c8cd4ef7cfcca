//! A drive's link as the window sees it: connecting, up (and how well), lost or failed;
//! the newest sample and when it came; the device on it.
//!
//! A model: no egui here.

use std::time::{Duration, SystemTime};

use crate::injection::Injection;
use crate::link::{LinkFailure, LinkInfo, LinkSpec, NetworkInterface};
use crate::od::backup::DeviceIdentity;
use crate::pdi::StatusBit;
use crate::worker::{Health, Sample};

/// With the link up, samples older than this make the status panel stale (a drive that
/// stopped answering before the link times out).
pub const STALE_AFTER: f64 = 1.0;

/// The link as the window sees it.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Connection {
    #[default]
    Disconnected,
    Connecting(LinkSpec),
    Connected(LinkInfo),
    Failed {
        spec: LinkSpec,
        error: LinkFailure,
        retry_in: Option<Duration>,
    },
}

/// A drive's link and what came over it last.
#[derive(Clone, Debug, Default)]
pub struct LinkState {
    pub connection: Connection,
    /// The newest known value of every signal (merged over recent samples). Kept when
    /// the link goes: the status panel shows it dimmed, as last seen.
    pub latest: Option<Sample>,
    /// When the last `Samples` event was taken (wall clock): "last seen at".
    pub last_sample_at: Option<SystemTime>,
    /// A sample came on the link connected now; until then `latest` is from before.
    pub sampled_since_connect: bool,
    /// The time of the first sample on the link connected now (the samples' clock goes
    /// on across connections).
    pub connected_at: Option<f64>,
    /// Why the link went, when it was lost rather than closed (cleared on connecting
    /// again and on the user's disconnect).
    pub lost: Option<String>,
    pub health: Option<Health>,
    /// What the link itself changed on the device (a PDO mapping) and its fate.
    pub own_changes: Vec<String>,
    /// The identity of the device connected now, once read (the exports' header).
    pub identity: Option<DeviceIdentity>,
    /// The drive of the last connection whose identity was read, and its link: another
    /// one is marked on the plots and the timeline.
    pub seen: Option<(LinkSpec, DeviceIdentity)>,
    /// Faults injected into the simulated drive.
    pub injected: Vec<Injection>,
    /// This machine's serial ports and network interfaces, as the worker listed them.
    pub machine: Machine,
}

/// What the machine offers to connect through, asked of the worker once until it answers.
#[derive(Clone, Debug, Default)]
pub struct Machine {
    /// Serial ports found by the last look (for Modbus RTU and slcan).
    pub serial_ports: Option<Vec<String>>,
    /// The IPv4 interfaces, for EtherNet/IP discovery.
    pub interfaces: Option<Vec<NetworkInterface>>,
    pub(super) ports_asked: bool,
    pub(super) interfaces_asked: bool,
}

impl LinkState {
    pub fn is_connected(&self) -> bool {
        matches!(self.connection, Connection::Connected(_))
    }

    pub fn info(&self) -> Option<&LinkInfo> {
        match &self.connection {
            Connection::Connected(info) => Some(info),
            _ => None,
        }
    }

    /// The link it is (or is being) connected to.
    pub fn spec(&self) -> Option<&LinkSpec> {
        match &self.connection {
            Connection::Connected(info) => Some(&info.spec),
            Connection::Connecting(spec) | Connection::Failed { spec, .. } => Some(spec),
            Connection::Disconnected => None,
        }
    }

    /// Whether a status bit is set in the newest sample.
    pub fn bit(&self, bit: StatusBit) -> bool {
        self.latest.is_some_and(|s| s.tx.status.is_set(bit))
    }

    /// Why nothing can be sent to the drive now, in words for a disabled button's tooltip
    /// and the panels; `None` while connected.
    pub fn offline_reason(&self) -> Option<String> {
        let lost = self.lost.as_deref();
        match (&self.connection, lost) {
            (Connection::Connected(_), _) => None,
            (Connection::Connecting(_), None) => Some("connecting…".into()),
            (Connection::Connecting(_), Some(reason)) => {
                Some(format!("reconnecting…: the link was lost ({reason})"))
            }
            (Connection::Disconnected, None) => Some("not connected".into()),
            (Connection::Disconnected, Some(reason)) => {
                Some(format!("not connected: the link was lost ({reason})"))
            }
            (
                Connection::Failed {
                    error, retry_in, ..
                },
                lost,
            ) => {
                // What happens next first, the link's (often long) error text after it.
                let retry = match retry_in {
                    Some(d) => format!(", retrying in {:.1} s", d.as_secs_f64()),
                    None => String::new(),
                };
                Some(match lost {
                    // Right after the loss the worker reports the same error again.
                    Some(reason) if *reason == error.text => {
                        format!("not connected: the link was lost{retry} ({reason})")
                    }
                    Some(reason) => format!(
                        "not connected: the link was lost{retry} ({reason}; reconnecting failed: {error})"
                    ),
                    None => format!("not connected: connecting failed{retry} ({error})"),
                })
            }
        }
    }

    /// Whether what the status panel shows is the drive now: connected, a sample taken on
    /// this link, and the last one no older than `STALE_AFTER` (or three cycles at a slow
    /// `poll_rate`) at `now`.
    pub fn is_live(&self, now: SystemTime, poll_rate: f64) -> bool {
        self.is_connected() && self.sampled_since_connect && !self.is_silent(now, poll_rate)
    }

    /// Connected, but no samples came for longer than they should.
    fn is_silent(&self, now: SystemTime, poll_rate: f64) -> bool {
        let limit = STALE_AFTER.max(3.0 / poll_rate.max(0.1));
        self.sample_age(now).is_some_and(|age| age > limit)
    }

    /// Seconds since the last sample came, at `now`.
    pub fn sample_age(&self, now: SystemTime) -> Option<f64> {
        self.last_sample_at
            .map(|at| now.duration_since(at).map_or(0.0, |d| d.as_secs_f64()))
    }

    /// The status panel's headline while it does not show the drive live: "NO LINK — last
    /// seen at 14:02:11 UTC (3.2 s ago)"; `None` while live.
    pub fn stale_line(&self, now: SystemTime, poll_rate: f64) -> Option<String> {
        if self.is_live(now, poll_rate) {
            return None;
        }
        let seen = match (self.last_sample_at, self.sample_age(now)) {
            (Some(at), Some(age)) => {
                format!("last seen at {} ({})", clock_text(at), age_text(age))
            }
            _ => "never connected".to_owned(),
        };
        Some(match &self.connection {
            Connection::Connected(_) if !self.sampled_since_connect => {
                if self.latest.is_some() {
                    format!("WAITING FOR DATA — connected; {seen}")
                } else {
                    "WAITING FOR DATA — connected, no sample yet".to_owned()
                }
            }
            Connection::Connected(_) => format!("NO DATA — the drive stopped answering; {seen}"),
            // Disconnected on purpose after a session: nothing is wrong.
            Connection::Disconnected if self.lost.is_none() && self.latest.is_some() => {
                format!("DISCONNECTED — {seen}")
            }
            _ => format!("NO LINK — {seen}"),
        })
    }
}

/// A wall-clock time as `14:02:11 UTC`: the clock the fault timeline writes (no time
/// zone database, so UTC, said so).
pub fn clock_text(at: SystemTime) -> String {
    let text = crate::telemetry::utc_text(at);
    // `2026-12-01T18:48:28Z`: the time of day is characters 11 to 19.
    match text.get(11..19) {
        Some(time) => format!("{time} UTC"),
        None => text,
    }
}

/// How long ago, for the stale status: "3.2 s ago", "4 min 10 s ago".
pub fn age_text(seconds: f64) -> String {
    if seconds < 60.0 {
        format!("{seconds:.1} s ago")
    } else if seconds < 3600.0 {
        let whole = seconds as u64;
        format!("{} min {} s ago", whole / 60, whole % 60)
    } else {
        let whole = seconds as u64;
        format!("{} h {} min ago", whole / 3600, whole / 60 % 60)
    }
}

/// Whether two identities are of the same device: vendor, product, revision and serial
/// number (1018h) alike.
pub(super) fn same_device(a: &DeviceIdentity, b: &DeviceIdentity) -> bool {
    (a.vendor, a.product, a.revision, a.serial) == (b.vendor, b.product, b.revision, b.serial)
}

/// A device in a few words: its name (1008h) and serial number.
pub(super) fn device_text(identity: &DeviceIdentity) -> String {
    // The device's own words: control characters shown, a huge name shortened.
    let name = identity
        .name
        .as_deref()
        .map_or("a device".into(), crate::text::shown);
    match identity.serial {
        Some(serial) => format!("{name} serial {serial:08X}h"),
        None => name.into_owned(),
    }
}
