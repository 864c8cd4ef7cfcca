//! The fault timeline: every fault and warning the tool sees, in order, with its meaning —
//! PDI-Status edges, 603Fh codes, the 1001h error register, the 1003h error history,
//! CANopen EMCY, failed commands, link drops. Pure: the window feeds it samples, read
//! results and events.

use std::collections::VecDeque;
use std::time::SystemTime;

use crate::cia::{ErrorCode, HistoryEntry, error_register_text};
use crate::pdi::{Status, StatusBit};
use crate::signal::Sample;

/// Entries kept (the oldest go first).
pub const TIMELINE_LIMIT: usize = 5000;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    Info,
    Warning,
    Fault,
}

impl Severity {
    pub fn name(self) -> &'static str {
        match self {
            Severity::Fault => "fault",
            Severity::Warning => "warning",
            Severity::Info => "info",
        }
    }
}

/// Where an entry came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    PdiStatus,
    ErrorCode,
    ErrorRegister,
    ErrorHistory,
    Emcy,
    Command,
    Link,
}

impl Origin {
    pub fn name(self) -> &'static str {
        match self {
            Origin::PdiStatus => "PDI-Status",
            Origin::ErrorCode => "603Fh",
            Origin::ErrorRegister => "1001h",
            Origin::ErrorHistory => "1003h",
            Origin::Emcy => "EMCY",
            Origin::Command => "command",
            Origin::Link => "link",
        }
    }
}

/// One thing that happened.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// On the samples' clock (seconds since the worker first connected, one axis across
    /// reconnects), where known: the plot cursor jumps there.
    pub t: Option<f64>,
    /// Wall-clock time, `2026-12-01T18:48:28Z`.
    pub wall: String,
    pub severity: Severity,
    pub origin: Origin,
    pub text: String,
}

/// The PDI-Status bits that go on the timeline, and how bad setting them is.
const STATUS_BITS: [(StatusBit, Severity); 5] = [
    (StatusBit::Fault, Severity::Fault),
    (StatusBit::FollowingError, Severity::Fault),
    (StatusBit::Warning, Severity::Warning),
    (StatusBit::LimitReached, Severity::Warning),
    (StatusBit::Error, Severity::Warning),
];

/// The timeline and what it remembers to find edges.
#[derive(Clone, Debug, Default)]
pub struct Timeline {
    entries: VecDeque<Entry>,
    status: Option<Status>,
    error_code: Option<u16>,
    register: Option<u8>,
    /// 1003h entries already reported (raw values), so a re-read adds only new ones.
    history_seen: Vec<u32>,
}

impl Timeline {
    pub fn entries(&self) -> impl DoubleEndedIterator<Item = &Entry> + ExactSizeIterator {
        self.entries.iter()
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// A new connection: the edges start afresh (the entries stay).
    pub fn reconnected(&mut self) {
        self.status = None;
        self.error_code = None;
        self.register = None;
        self.history_seen.clear();
    }

    pub fn add(&mut self, t: Option<f64>, severity: Severity, origin: Origin, text: String) {
        if self.entries.len() >= TIMELINE_LIMIT {
            self.entries.pop_front();
        }
        self.entries.push_back(Entry {
            t,
            wall: crate::telemetry::utc_text(SystemTime::now()),
            severity,
            origin,
            text,
        });
    }

    /// Look at one sample: status-bit edges and 603Fh changes go on the timeline.
    /// `true` when a fault or warning newly appeared (time to read 1001h and 1003h).
    pub fn observe(&mut self, sample: &Sample) -> bool {
        let mut appeared = false;
        let status = sample.tx.status;
        if let Some(before) = self.status {
            for (bit, severity) in STATUS_BITS {
                match (before.is_set(bit), status.is_set(bit)) {
                    (false, true) => {
                        appeared |= severity >= Severity::Warning && bit != StatusBit::Error;
                        self.add(
                            Some(sample.t),
                            severity,
                            Origin::PdiStatus,
                            format!("{} set: {}", bit.label(), bit.meaning()),
                        );
                    }
                    (true, false) => self.add(
                        Some(sample.t),
                        Severity::Info,
                        Origin::PdiStatus,
                        format!("{} cleared", bit.label()),
                    ),
                    _ => {}
                }
            }
        } else {
            // The first sample: what is already active.
            for (bit, severity) in STATUS_BITS {
                if status.is_set(bit) && bit != StatusBit::Error {
                    appeared = true;
                    self.add(
                        Some(sample.t),
                        severity,
                        Origin::PdiStatus,
                        format!("{} active on connecting: {}", bit.label(), bit.meaning()),
                    );
                }
            }
        }
        self.status = Some(status);

        let code = sample.tx.error_code;
        if self.error_code != Some(code) {
            if code != 0 {
                let severity = if status.is_set(StatusBit::Fault) {
                    Severity::Fault
                } else {
                    Severity::Warning
                };
                self.add(
                    Some(sample.t),
                    severity,
                    Origin::ErrorCode,
                    format!("{code:04X}h: {}", ErrorCode(code).meaning()),
                );
                appeared = true;
            } else if self.error_code.is_some() {
                self.add(
                    Some(sample.t),
                    Severity::Info,
                    Origin::ErrorCode,
                    "0000h: no error any more".into(),
                );
            }
            self.error_code = Some(code);
        }
        appeared
    }

    /// The error register 1001h as read.
    pub fn error_register(&mut self, t: Option<f64>, value: u8) {
        if self.register == Some(value) {
            return;
        }
        let before = self.register.replace(value);
        if value == 0 {
            if before.is_some_and(|b| b != 0) {
                self.add(
                    t,
                    Severity::Info,
                    Origin::ErrorRegister,
                    "00h: no error".into(),
                );
            }
            return;
        }
        self.add(
            t,
            Severity::Warning,
            Origin::ErrorRegister,
            format!("{value:02X}h: {}", error_register_text(value).join(", ")),
        );
    }

    /// The error history 1003h as read: `(subindex, raw value)` for sub 1 (newest) on;
    /// entries not reported before go on the timeline, oldest first.
    pub fn error_history(&mut self, t: Option<f64>, entries: &[(u8, u32)]) {
        let mut new: Vec<(u8, u32)> = entries
            .iter()
            .copied()
            .filter(|(_, raw)| *raw != 0 && !self.history_seen.contains(raw))
            .collect();
        new.sort_by_key(|(sub, _)| std::cmp::Reverse(*sub));
        for (sub, raw) in new {
            self.history_seen.push(raw);
            let entry = HistoryEntry::from_raw(raw);
            self.add(
                t,
                Severity::Fault,
                Origin::ErrorHistory,
                format!(
                    "1003h:{sub:02X}h error #{} {}: {:04X}h {}; class {:02X}h ({})",
                    entry.number,
                    entry.number_text(),
                    entry.code.0,
                    entry.code.meaning(),
                    entry.class,
                    error_register_text(entry.class).join(", ")
                ),
            );
        }
    }

    /// The timeline as CSV: `time_s,wall_clock,severity,origin,text`.
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time_s,wall_clock,severity,origin,text\n");
        for e in &self.entries {
            let t = e.t.map(|t| format!("{t:.3}")).unwrap_or_default();
            out.push_str(&format!(
                "{t},{},{},{},{}\n",
                e.wall,
                e.severity.name(),
                quote(e.origin.name()),
                quote(&e.text)
            ));
        }
        out
    }
}

/// A CSV cell, quoted when it needs to be (RFC 4180).
fn quote(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdi::TxImage;

    fn sample(t: f64, status: u16, error_code: u16) -> Sample {
        Sample {
            t,
            tx: TxImage {
                status: Status(status),
                error_code,
                return_value: 0,
            },
            ..Sample::default()
        }
    }

    #[test]
    fn edges_and_codes_go_on_in_order_with_their_meaning() {
        let mut timeline = Timeline::default();
        assert!(!timeline.observe(&sample(0.0, 0x0001, 0)));
        assert!(timeline.is_empty());
        let fault = StatusBit::Fault.mask() | StatusBit::FollowingError.mask();
        assert!(timeline.observe(&sample(1.25, fault, 0x8611)));
        assert!(
            !timeline.observe(&sample(1.26, fault, 0x8611)),
            "no edge, no entry"
        );
        timeline.observe(&sample(2.0, 0x0001, 0));
        let texts: Vec<String> = timeline
            .entries()
            .map(|e| {
                format!(
                    "{} {} {:?} {}",
                    e.t.unwrap_or(-1.0),
                    e.origin.name(),
                    e.severity,
                    e.text
                )
            })
            .collect();
        assert_eq!(texts.len(), 6, "{texts:#?}");
        assert!(
            texts[0].starts_with("1.25 PDI-Status Fault Fault set"),
            "{texts:#?}"
        );
        assert!(texts[1].starts_with("1.25 PDI-Status Fault Following error set"));
        assert!(texts[2].contains("603Fh Fault 8611h"), "{texts:#?}");
        assert!(
            texts[2].to_lowercase().contains("following error"),
            "{texts:#?}"
        );
        assert!(texts[3].contains("Fault cleared"));
        assert!(texts[5].contains("0000h: no error any more"));
        let csv = timeline.to_csv();
        assert!(
            csv.starts_with("time_s,wall_clock,severity,origin,text\n1.250,"),
            "{csv}"
        );
        assert_eq!(csv.lines().count(), 7);
    }

    #[test]
    fn the_error_history_is_decoded_and_reported_once() {
        let mut timeline = Timeline::default();
        let raw = HistoryEntry {
            number: 1,
            class: 0x20,
            code: ErrorCode::FOLLOWING_ERROR,
        }
        .to_raw();
        timeline.error_history(Some(3.0), &[(1, raw), (2, 0)]);
        timeline.error_history(Some(4.0), &[(1, raw)]);
        assert_eq!(timeline.len(), 1);
        let entry = timeline
            .entries()
            .next()
            .map(|e| e.text.clone())
            .unwrap_or_default();
        assert!(entry.starts_with("1003h:01h error #1"), "{entry}");
        assert!(entry.contains("8611h"), "{entry}");
        timeline.error_register(Some(3.0), 0x21);
        timeline.error_register(Some(3.1), 0x21);
        assert_eq!(timeline.len(), 2);
        assert!(
            timeline
                .entries()
                .last()
                .is_some_and(|e| e.text.starts_with("21h: generic error"))
        );
    }
}
