//! The plot model, without a window: which signals there are, the bounded history they
//! go into, the command markers, the trigger and the recordings it makes. The plot panel
//! draws from it; `drivedeck record` records through it.

use std::collections::VecDeque;
use std::time::SystemTime;

use super::recording::{ChannelInfo, Marker, Metadata, Recording};
use super::ring::Ring;
use super::trigger::{Capture, CaptureEvent, CaptureState, Trigger};
use crate::od::Address;
use crate::od::backup::DeviceIdentity;
use crate::pdi::StatusBit;
use crate::signal::{MAX_WATCHED, Sample, Signal};

mod replay;

/// The default history: 10 minutes at 1 kHz.
pub const DEFAULT_HISTORY_ROWS: usize = 600_000;
/// Command markers kept (older ones go with the history they belong to anyway).
const MARKER_LIMIT: usize = 10_000;

/// How a signal is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A line on its own plot.
    Analog,
    /// An integer word drawn as one digital lane per bit.
    Bits,
}

/// The signals every link samples (where it can): the drive's own plot signals and what
/// the PDI's TX image carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    Position,
    Velocity,
    Torque,
    FollowingError,
    AnalogInput,
    ReturnValue,
    PdiStatus,
    DigitalInputs,
}

impl Builtin {
    pub const ALL: [Builtin; 8] = [
        Builtin::Position,
        Builtin::Velocity,
        Builtin::Torque,
        Builtin::FollowingError,
        Builtin::AnalogInput,
        Builtin::ReturnValue,
        Builtin::PdiStatus,
        Builtin::DigitalInputs,
    ];

    /// The short name used on the command line and in exported files.
    pub fn id(self) -> &'static str {
        match self {
            Builtin::Position => "position",
            Builtin::Velocity => "velocity",
            Builtin::Torque => "torque",
            Builtin::FollowingError => "following_error",
            Builtin::AnalogInput => "analog_input",
            Builtin::ReturnValue => "return_value",
            Builtin::PdiStatus => "pdi_status",
            Builtin::DigitalInputs => "digital_inputs",
        }
    }

    /// The drive's signal this is, where it is one (the others come from the PDI image).
    pub fn signal(self) -> Option<Signal> {
        match self {
            Builtin::Position => Some(Signal::Position),
            Builtin::Velocity => Some(Signal::Velocity),
            Builtin::Torque => Some(Signal::Torque),
            Builtin::FollowingError => Some(Signal::FollowingError),
            Builtin::AnalogInput => Some(Signal::AnalogInput),
            Builtin::DigitalInputs => Some(Signal::DigitalInputs),
            Builtin::ReturnValue | Builtin::PdiStatus => None,
        }
    }

    pub fn name(self) -> &'static str {
        match (self, self.signal()) {
            (_, Some(signal)) => signal.name(),
            (Builtin::ReturnValue, None) => "PDI ReturnValue",
            (_, None) => "PDI-Status",
        }
    }

    pub fn unit(self) -> &'static str {
        self.signal().map_or("", Signal::unit)
    }

    pub fn kind(self) -> Kind {
        match self {
            Builtin::PdiStatus | Builtin::DigitalInputs => Kind::Bits,
            _ => Kind::Analog,
        }
    }

    /// Shown before the user picks: the motion signals and the status lanes.
    pub fn shown_by_default(self) -> bool {
        matches!(
            self,
            Builtin::Position | Builtin::Velocity | Builtin::Torque | Builtin::PdiStatus
        )
    }

    /// The value this sample carries, if the link measured it this cycle.
    pub fn value(self, sample: &Sample) -> Option<f64> {
        match (self, self.signal()) {
            (_, Some(signal)) => sample.get(signal),
            (Builtin::ReturnValue, None) => Some(f64::from(sample.tx.return_value)),
            (_, None) => Some(f64::from(sample.tx.status.0)),
        }
    }

    pub fn from_id(id: &str) -> Option<Builtin> {
        Builtin::ALL.into_iter().find(|b| b.id() == id)
    }
}

/// The name of bit `bit` of a bit signal, for its lane.
pub fn bit_name(builtin: Option<Builtin>, bit: u8) -> String {
    match builtin {
        Some(Builtin::PdiStatus) => StatusBit::ALL
            .into_iter()
            .find(|b| b.bit() == bit)
            .map_or_else(|| format!("bit {bit}"), |b| b.label().to_owned()),
        Some(Builtin::DigitalInputs) => match bit {
            0 => "negative limit switch".into(),
            1 => "positive limit switch".into(),
            2 => "home switch".into(),
            3 => "interlock".into(),
            16..=31 => format!("input {}", bit - 15),
            _ => format!("bit {bit}"),
        },
        _ => format!("bit {bit}"),
    }
}

/// Where a signal's values come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    Builtin(Builtin),
    /// An object the user added; `slot` is its place in `Sample::watched`.
    Watched {
        slot: usize,
        address: Address,
    },
    /// A channel of a recording opened from a file that is none of the built-in signals.
    Recorded,
}

/// One signal: what it is, where it lives in the history, whether it is drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct SignalDef {
    pub source: Source,
    pub info: ChannelInfo,
    pub kind: Kind,
    /// Its column in the history.
    pub column: usize,
    pub shown: bool,
    /// Drawn once it has samples, until the user decides (following error and analog
    /// input: most links do not deliver them).
    pub auto: bool,
}

impl SignalDef {
    pub fn builtin(&self) -> Option<Builtin> {
        match self.source {
            Source::Builtin(b) => Some(b),
            Source::Watched { .. } | Source::Recorded => None,
        }
    }
}

/// An object to sample besides the built-in signals.
#[derive(Clone, Debug, PartialEq)]
pub struct WatchedObject {
    pub address: Address,
    pub name: String,
    pub unit: String,
}

/// A stretch of the history without samples: the link lost (or closed) after the sample
/// at `from`, and back with the sample at `to`. The plots draw no line across it and
/// shade it; exports mark both ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Gap {
    /// The time of the last sample before it.
    pub from: f64,
    /// The time of the first sample after it; `None` while the link is still down.
    pub to: Option<f64>,
    /// Lost, rather than closed by the user.
    pub lost: bool,
    /// Why, in words: "link lost: timed out", "disconnected".
    pub why: String,
}

impl Gap {
    /// Seconds without samples, up to `now` (on the samples' clock) while it is open.
    pub fn duration(&self, now: f64) -> f64 {
        (self.to.unwrap_or(now) - self.from).max(0.0)
    }

    /// Its label on the plots: "no link 12.3 s" (lost), "not connected 4.0 s" (closed).
    pub fn label(&self, now: f64) -> String {
        let what = if self.lost {
            "no link"
        } else {
            "not connected"
        };
        format!("{what} {:.1} s", self.duration(now))
    }
}

/// What the scope did with a sample that the window should hear of.
#[derive(Clone, Debug, PartialEq)]
pub enum ScopeEvent {
    /// The trigger fired at this time.
    Fired(f64),
    /// A triggered recording is complete and waits in `Scope::recording`.
    Recorded,
}

/// The plot model.
#[derive(Clone, Debug)]
pub struct Scope {
    ring: Ring,
    signals: Vec<SignalDef>,
    markers: VecDeque<Marker>,
    /// The stretches without samples (a lost link, a disconnect), oldest first.
    gaps: VecDeque<Gap>,
    /// Since when the samples are of the drive connected now, where another one came
    /// before it in this history.
    drive_since: Option<f64>,
    capture: Option<Capture>,
    /// The last triggered recording.
    recording: Option<Recording>,
    /// The device and link, for the exported files' header.
    pub meta: Metadata,
    row: Vec<f64>,
}

impl Default for Scope {
    fn default() -> Self {
        Scope::new(DEFAULT_HISTORY_ROWS)
    }
}

impl Scope {
    /// An empty scope keeping `rows` samples of every signal.
    pub fn new(rows: usize) -> Scope {
        let signals: Vec<SignalDef> = Builtin::ALL
            .into_iter()
            .enumerate()
            .map(|(column, b)| SignalDef {
                source: Source::Builtin(b),
                info: ChannelInfo {
                    id: b.id().into(),
                    name: b.name().into(),
                    unit: b.unit().into(),
                },
                kind: b.kind(),
                column,
                shown: b.shown_by_default(),
                auto: matches!(b, Builtin::FollowingError | Builtin::AnalogInput),
            })
            .collect();
        Scope {
            ring: Ring::new(rows, signals.len()),
            signals,
            markers: VecDeque::new(),
            gaps: VecDeque::new(),
            drive_since: None,
            capture: None,
            recording: None,
            meta: Metadata::default(),
            row: Vec::new(),
        }
    }

    pub fn ring(&self) -> &Ring {
        &self.ring
    }

    pub fn signals(&self) -> &[SignalDef] {
        &self.signals
    }

    pub fn signals_mut(&mut self) -> &mut [SignalDef] {
        &mut self.signals
    }

    /// The signal with this id.
    pub fn signal(&self, id: &str) -> Option<&SignalDef> {
        self.signals.iter().find(|s| s.info.id == id)
    }

    /// Whether the plots draw this signal: picked, or automatic and with samples.
    pub fn is_drawn(&self, signal: &SignalDef) -> bool {
        signal.shown || (signal.auto && self.ring.latest(signal.column).is_some())
    }

    /// Rows kept per signal.
    pub fn capacity(&self) -> usize {
        self.ring.capacity()
    }

    /// Keep `rows` samples from now on (the newest that fit stay).
    pub fn set_capacity(&mut self, rows: usize) {
        self.ring.set_capacity(rows);
    }

    /// Forget the history, markers and gaps (the user's "Clear plot", or samples whose
    /// clock started again).
    pub fn clear(&mut self) {
        self.ring.clear();
        self.markers.clear();
        self.gaps.clear();
        self.drive_since = None;
        if let Some(capture) = &mut self.capture
            && matches!(capture.state(), CaptureState::Fired { .. })
        {
            capture.arm();
        }
    }

    /// Take one sample into the history (and the trigger).
    pub fn push(&mut self, sample: &Sample) -> Option<ScopeEvent> {
        self.row.clear();
        self.row.resize(self.ring.channels(), f64::NAN);
        for signal in &self.signals {
            let value = match signal.source {
                Source::Builtin(b) => b.value(sample),
                Source::Watched { slot, .. } => sample.watched.get(slot).copied().flatten(),
                Source::Recorded => None,
            };
            self.row[signal.column] = value.unwrap_or(f64::NAN);
        }
        if self.ring.push(sample.t, &self.row).is_err() {
            // Time went backwards: another clock (the worker keeps one for its life).
            self.clear();
            self.ring.push(sample.t, &self.row).ok()?;
        }
        if let Some(gap) = self.gaps.back_mut()
            && gap.to.is_none()
        {
            gap.to = Some(sample.t);
        }
        let capture = self.capture.as_mut()?;
        match capture.feed(sample.t, &self.row) {
            CaptureEvent::Nothing => None,
            CaptureEvent::Fired { at } => Some(ScopeEvent::Fired(at)),
            CaptureEvent::Complete { from, at, to } => {
                let trigger = capture.trigger().clone();
                let mut meta = self.meta.clone();
                meta.trigger = Some(self.describe_trigger(&trigger));
                meta.trigger_time_s = Some(at);
                self.recording = Some(self.export(from, to, meta, false));
                Some(ScopeEvent::Recorded)
            }
        }
    }

    /// A command was sent at `t` (the samples' clock).
    pub fn mark(&mut self, t: f64, text: impl Into<String>) {
        if self.markers.len() >= MARKER_LIMIT {
            self.markers.pop_front();
        }
        self.markers.push_back(Marker {
            t,
            text: text.into(),
        });
    }

    /// The link went (`lost`) or was closed (`why` says which): a gap opens after the
    /// newest sample, closed by the next sample that comes. Nothing opens without history
    /// or while a gap is open already.
    pub fn link_down(&mut self, lost: bool, why: impl Into<String>) {
        let Some(from) = self.ring.last_time() else {
            return;
        };
        if self.open_gap().is_some() {
            return;
        }
        if self.gaps.len() >= MARKER_LIMIT {
            self.gaps.pop_front();
        }
        self.gaps.push_back(Gap {
            from,
            to: None,
            lost,
            why: why.into(),
        });
    }

    /// The gap the link is in now, if it is down.
    pub fn open_gap(&self) -> Option<&Gap> {
        self.gaps.back().filter(|g| g.to.is_none())
    }

    /// The gaps that reach into the history, oldest first.
    pub fn gaps(&self) -> impl Iterator<Item = &Gap> {
        let first = self.ring.first_time().unwrap_or(f64::INFINITY);
        self.gaps
            .iter()
            .filter(move |g| g.to.is_none_or(|to| to >= first))
    }

    /// Another drive from `t` on (another link or identity): marked with `text`, and an
    /// export reaching back before it says so.
    pub fn new_drive(&mut self, t: f64, text: impl Into<String>) {
        self.mark(t, text);
        self.drive_since = Some(t);
    }

    /// The markers still inside the history.
    pub fn markers(&self) -> impl Iterator<Item = &Marker> {
        let first = self.ring.first_time().unwrap_or(f64::INFINITY);
        self.markers.iter().filter(move |m| m.t >= first)
    }

    /// Sample these objects besides the built-in signals (at most [`MAX_WATCHED`]): an
    /// object already watched keeps its history, a new one gets a fresh column.
    pub fn set_watched(&mut self, objects: &[WatchedObject]) {
        let mut kept: Vec<SignalDef> = self
            .signals
            .iter()
            .filter(|s| matches!(s.source, Source::Builtin(_)))
            .cloned()
            .collect();
        for (slot, object) in objects.iter().take(MAX_WATCHED).enumerate() {
            let old = self.signals.iter().find(|s| {
                matches!(s.source, Source::Watched { address, .. } if address == object.address)
            });
            let (column, shown) = match old {
                Some(old) => (old.column, old.shown),
                None => (self.ring.add_channel(), true),
            };
            kept.push(SignalDef {
                source: Source::Watched {
                    slot,
                    address: object.address,
                },
                info: ChannelInfo {
                    id: format!("{:04X}h_{:02X}h", object.address.index, object.address.sub),
                    name: format!("{} {}", object.name, object.address),
                    unit: object.unit.clone(),
                },
                kind: Kind::Analog,
                column,
                shown,
                auto: false,
            });
        }
        self.signals = kept;
    }

    /// The objects sampled besides the built-in signals, in slot order.
    pub fn watched(&self) -> Vec<Address> {
        self.signals
            .iter()
            .filter_map(|s| match s.source {
                Source::Watched { address, .. } => Some(address),
                Source::Builtin(_) | Source::Recorded => None,
            })
            .collect()
    }

    /// Arm `trigger` (replacing any other).
    pub fn arm(&mut self, trigger: Trigger) {
        let mut capture = Capture::new(trigger);
        capture.arm();
        self.capture = Some(capture);
    }

    pub fn disarm(&mut self) {
        if let Some(capture) = &mut self.capture {
            capture.disarm();
        }
    }

    pub fn capture_state(&self) -> CaptureState {
        self.capture
            .as_ref()
            .map_or(CaptureState::Idle, Capture::state)
    }

    pub fn trigger(&self) -> Option<&Trigger> {
        self.capture.as_ref().map(Capture::trigger)
    }

    /// The last triggered recording.
    pub fn recording(&self) -> Option<&Recording> {
        self.recording.as_ref()
    }

    /// The trigger in words, with the signals' ids.
    pub fn describe_trigger(&self, trigger: &Trigger) -> String {
        let mut names = vec!["?"; self.ring.channels()];
        for s in &self.signals {
            if let Some(slot) = names.get_mut(s.column) {
                *slot = &s.info.id;
            }
        }
        format!(
            "{}, {} s before and {} s after",
            trigger.condition.describe(&names),
            trigger.pre_s,
            trigger.post_s
        )
    }

    /// The history between `from` and `to` as a recording, of the shown signals or all.
    pub fn export(&self, from: f64, to: f64, meta: Metadata, shown_only: bool) -> Recording {
        let columns: Vec<(usize, ChannelInfo)> = self
            .signals
            .iter()
            .filter(|s| !shown_only || self.is_drawn(s))
            .map(|s| (s.column, s.info.clone()))
            .collect();
        let mut recording = Recording::from_ring(&self.ring, &columns, from, to, meta);
        recording.markers = self
            .markers
            .iter()
            .cloned()
            .chain(self.gap_markers())
            .filter(|m| (from..=to).contains(&m.t))
            .collect();
        recording.markers.sort_by(|a, b| a.t.total_cmp(&b.t));
        if let Some(since) = self.drive_since
            && from < since
        {
            let note = format!(
                "the samples before t = {since:.3} s are of another drive (see the markers)"
            );
            recording.meta.note = Some(match recording.meta.note.take() {
                Some(text) => format!("{text}; {note}"),
                None => note,
            });
        }
        recording
    }

    /// Both ends of every gap, as markers for the exported files.
    fn gap_markers(&self) -> impl Iterator<Item = Marker> + '_ {
        self.gaps.iter().flat_map(|gap| {
            let back = gap.to.map(|to| Marker {
                t: to,
                text: format!("link back after {:.1} s without samples", to - gap.from),
            });
            std::iter::once(Marker {
                t: gap.from,
                text: gap.why.clone(),
            })
            .chain(back)
        })
    }
}

/// An object the user asks to plot, checked against the catalog: it must be a readable
/// number. `text` is an address (`2031:00`, `6064h`).
pub fn watchable(
    catalog: &crate::od::Catalog,
    text: &str,
) -> Result<(WatchedObject, crate::od::DataType), String> {
    let address: Address = text.parse().map_err(|e: crate::od::Error| e.to_string())?;
    let entry = catalog
        .get(address)
        .ok_or_else(|| format!("{address} is not in the object dictionary"))?;
    let numeric = entry.dtype.is_integer()
        || matches!(
            entry.dtype,
            crate::od::DataType::Boolean
                | crate::od::DataType::Real32
                | crate::od::DataType::Real64
        );
    if !numeric {
        return Err(format!(
            "{address} {} is a {}, not a number that can be plotted",
            entry.full_name(),
            entry.dtype.short_name()
        ));
    }
    if !entry.access.readable() {
        return Err(format!("{address} {} cannot be read", entry.full_name()));
    }
    Ok((
        WatchedObject {
            address,
            name: entry.full_name(),
            unit: entry.unit.clone().unwrap_or_default(),
        },
        entry.dtype,
    ))
}

/// The header of an exported file: the device's identity and the link.
pub fn metadata(identity: Option<&DeviceIdentity>, link: &str, rate_hz: f64) -> Metadata {
    let hex = |v: Option<u32>| v.map(|v| format!("{v:08X}h"));
    Metadata {
        vendor: identity.and_then(|i| hex(i.vendor)),
        product: identity.and_then(|i| hex(i.product)),
        revision: identity.and_then(|i| hex(i.revision)),
        serial: identity.and_then(|i| hex(i.serial)),
        device_name: identity.and_then(|i| i.name.clone()),
        link: Some(link.to_owned()),
        started: Some(utc_text(SystemTime::now())),
        rate_hz: Some(rate_hz),
        ..Metadata::default()
    }
}

/// A value for the read-out: integers as integers, others with up to four decimals.
pub fn format_number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        let text = format!("{v:.4}");
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

/// `2026-12-01T18:48:28Z`.
pub fn utc_text(at: SystemTime) -> String {
    let secs = at
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let days = (secs / 86_400) as i64;
    let rest = secs % 86_400;
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::{Status, TxImage};
    use crate::telemetry::trigger::{Condition, Edge};

    fn sample(t: f64, position: f64, status: u16) -> Sample {
        Sample {
            t,
            signals: crate::signal::Signals::default()
                .with(crate::signal::Signal::Position, position),
            tx: TxImage {
                status: Status(status),
                ..TxImage::default()
            },
            ..Sample::default()
        }
    }

    #[test]
    fn utc_text_is_iso_8601() {
        let at = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_796_150_908);
        assert_eq!(utc_text(at), "2026-12-01T18:48:28Z");
        assert_eq!(utc_text(SystemTime::UNIX_EPOCH), "1970-01-01T00:00:00Z");
    }

    #[test]
    fn samples_land_in_their_columns_and_a_clock_that_starts_again_starts_afresh() {
        let mut scope = Scope::new(100);
        for i in 0..10 {
            scope.push(&sample(f64::from(i) * 0.01, f64::from(i), 1));
        }
        let position = scope.signal("position").map(|s| s.column);
        assert_eq!(position, Some(0));
        assert_eq!(scope.ring().len(), 10);
        assert_eq!(scope.ring().value(9, 0), Some(9.0));
        let status = scope.signal("pdi_status").map(|s| s.column).unwrap_or(99);
        assert_eq!(scope.ring().value(9, status), Some(1.0));
        // Velocity was not measured: NaN, not a repeated value.
        assert!(scope.ring().value(9, 1).is_some_and(f64::is_nan));
        scope.mark(0.05, "Move absolute");
        assert_eq!(scope.markers().count(), 1);
        scope.push(&sample(0.0, 5.0, 0));
        assert_eq!(scope.ring().len(), 1);
        assert_eq!(scope.markers().count(), 0);
    }

    #[test]
    fn an_outage_is_a_gap_in_the_one_history_and_the_exports_mark_it() {
        let mut scope = Scope::new(1000);
        for i in 0..10 {
            scope.push(&sample(f64::from(i) * 0.1, f64::from(i), 1));
        }
        scope.mark(0.5, "Velocity");
        scope.link_down(true, "link lost: timed out");
        scope.link_down(false, "disconnected");
        let open = scope
            .open_gap()
            .cloned()
            .expect("a gap while the link is down");
        assert_eq!((open.from, open.to, open.lost), (0.9, None, true));
        assert_eq!(open.label(13.2), "no link 12.3 s");
        for i in 0..5 {
            scope.push(&sample(13.2 + f64::from(i) * 0.1, 100.0, 1));
        }
        assert_eq!(scope.ring().len(), 15, "nothing erased");
        assert_eq!(scope.markers().count(), 1);
        assert!(scope.open_gap().is_none());
        let gaps: Vec<Gap> = scope.gaps().cloned().collect();
        assert_eq!(gaps.len(), 1);
        assert_eq!(gaps[0].to, Some(13.2));
        let rec = scope.export(0.0, 20.0, Metadata::default(), false);
        let marks: Vec<(f64, &str)> = rec.markers.iter().map(|m| (m.t, m.text.as_str())).collect();
        assert_eq!(
            marks,
            [
                (0.5, "Velocity"),
                (0.9, "link lost: timed out"),
                (13.2, "link back after 12.3 s without samples")
            ]
        );
        assert_eq!(rec.meta.note, None);

        // Another drive from 13.5 s on: an export reaching back before it says so.
        scope.new_drive(13.5, "another drive: sim");
        let rec = scope.export(0.0, 20.0, Metadata::default(), false);
        let note = rec.meta.note.unwrap_or_default();
        assert!(
            note.contains("before t = 13.500 s are of another drive"),
            "{note}"
        );
        let rec = scope.export(13.5, 20.0, Metadata::default(), false);
        assert_eq!(rec.meta.note, None);
        // Clearing forgets the gaps with the history.
        scope.clear();
        assert_eq!(scope.gaps().count(), 0);
    }

    #[test]
    fn watched_objects_keep_their_history_and_new_ones_get_a_column() {
        let mut scope = Scope::new(100);
        let a = WatchedObject {
            address: Address::new(0x2031, 0),
            name: "Max current".into(),
            unit: "mA".into(),
        };
        let b = WatchedObject {
            address: Address::new(0x6065, 0),
            name: "Following error window".into(),
            unit: String::new(),
        };
        scope.set_watched(std::slice::from_ref(&a));
        let mut s = sample(0.0, 1.0, 0);
        s.watched[0] = Some(42.0);
        scope.push(&s);
        let column_a = scope.signal("2031h_00h").map(|s| s.column).unwrap_or(0);
        assert_eq!(scope.ring().value(0, column_a), Some(42.0));
        scope.set_watched(&[b, a]);
        assert_eq!(scope.signal("2031h_00h").map(|s| s.column), Some(column_a));
        assert_eq!(scope.watched().len(), 2);
        let mut s = sample(0.1, 1.0, 0);
        s.watched = [None; MAX_WATCHED];
        s.watched[1] = Some(43.0);
        scope.push(&s);
        assert_eq!(scope.ring().value(1, column_a), Some(43.0));
    }

    #[test]
    fn a_trigger_records_with_the_pre_trigger_history_and_the_markers() {
        let mut scope = Scope::new(10_000);
        scope.meta = metadata(None, "sim", 100.0);
        scope.arm(Trigger {
            condition: Condition::Bit {
                channel: scope.signal("pdi_status").map_or(0, |s| s.column),
                bit: StatusBit::TargetReached.bit(),
                edge: Edge::Rising,
            },
            pre_s: 0.5,
            post_s: 0.2,
        });
        let mut fired = None;
        let mut recorded = false;
        for i in 0..300 {
            let t = f64::from(i) * 0.01;
            let status = if i >= 150 {
                StatusBit::TargetReached.mask()
            } else {
                0
            };
            if i == 140 {
                scope.mark(t, "Move relative");
            }
            match scope.push(&sample(t, f64::from(i), status)) {
                Some(ScopeEvent::Fired(at)) => fired = Some(at),
                Some(ScopeEvent::Recorded) => recorded = true,
                None => {}
            }
        }
        assert_eq!(fired, Some(1.5));
        assert!(recorded);
        let rec = scope.recording().expect("a recording");
        let first = rec.times.first().copied().unwrap_or(0.0);
        let last = rec.times.last().copied().unwrap_or(0.0);
        assert!((first - 1.0).abs() < 1e-9, "starts 0.5 s before: {first}");
        assert!((last - 1.7).abs() < 1e-9, "ends 0.2 s after: {last}");
        assert_eq!(rec.markers.len(), 1);
        assert_eq!(rec.meta.trigger_time_s, Some(1.5));
        assert!(
            rec.meta
                .trigger
                .as_deref()
                .is_some_and(|t| t.contains("pdi_status"))
        );
        assert_eq!(rec.channels.len(), Builtin::ALL.len());
    }
}
