//! What a link sent and received, frame by frame, for the frame log, `--trace` and the
//! exports: the record of one frame, and the bounded ring every link keeps them in until
//! the worker takes them.

use std::collections::VecDeque;

/// Frames a link keeps between two takes: the oldest go first when nobody asks.
pub const TRACE_LIMIT: usize = 4096;

/// One frame a link sent or received, for the frame log and its export.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TraceRecord {
    /// When, as wall-clock time (for candump logs and timelines).
    pub at: std::time::SystemTime,
    pub sent: bool,
    /// The frame as the bus's tools write it: `601#4018100100000000` on CAN, hex on Modbus.
    pub raw: String,
    /// What it means: "SDO request node 1: upload 1018h:01h".
    pub text: String,
    /// The CAN frame and its interface name (`can0`, `slcan0`), for candump logs.
    pub can: Option<(crate::proto::canopen::CanFrame, String)>,
}

impl TraceRecord {
    /// Seconds since the Unix epoch.
    pub fn unix_seconds(&self) -> f64 {
        self.at
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0)
    }

    /// One line of a log file: candump's format for CAN frames, the same shape otherwise.
    pub fn log_line(&self) -> String {
        match &self.can {
            Some((frame, interface)) => {
                crate::proto::canopen::describe::candump_line(self.unix_seconds(), interface, frame)
            }
            None => format!(
                "({:.6}) {} {}  {}",
                self.unix_seconds(),
                if self.sent { "tx" } else { "rx" },
                self.raw,
                self.text
            ),
        }
    }
}

/// The frames not yet taken, at most [`TRACE_LIMIT`], oldest first.
#[derive(Clone, Debug, Default)]
pub struct TraceRing {
    records: VecDeque<TraceRecord>,
}

impl TraceRing {
    pub fn new() -> Self {
        Self::default()
    }

    /// Keep `record`, dropping the oldest when full.
    pub fn push(&mut self, record: TraceRecord) {
        if self.records.len() >= TRACE_LIMIT {
            self.records.pop_front();
        }
        self.records.push_back(record);
    }

    /// Keep a frame of bytes shown as `raw` with its meaning.
    pub fn record(&mut self, sent: bool, raw: String, text: String) {
        self.push(TraceRecord {
            at: std::time::SystemTime::now(),
            sent,
            raw,
            text,
            can: None,
        });
    }

    /// Every frame kept, oldest first; the ring is empty afterwards.
    pub fn take(&mut self) -> Vec<TraceRecord> {
        self.records.drain(..).collect()
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }
}

/// Frames kept as bytes, with what the link knew of each (`K`): written out as text only
/// when taken. An exchange is the hot path and the frame log is read far less often, so
/// the hex and the meaning are not worked out per frame. At most [`TRACE_LIMIT`] frames
/// and `keep` bytes of each are kept; the oldest frame's buffer is reused once full.
#[derive(Debug)]
pub struct RawFrames<K> {
    frames: VecDeque<RawFrame<K>>,
    keep: usize,
}

#[derive(Debug)]
struct RawFrame<K> {
    at: std::time::SystemTime,
    sent: bool,
    kind: K,
    bytes: Vec<u8>,
}

impl<K> RawFrames<K> {
    /// A ring keeping at most `keep` bytes of each frame.
    pub fn new(keep: usize) -> Self {
        RawFrames {
            frames: VecDeque::new(),
            keep,
        }
    }

    /// Keep `bytes` (sent or received), stamped now.
    pub fn record(&mut self, sent: bool, kind: K, bytes: &[u8]) {
        self.record_at(std::time::SystemTime::now(), sent, kind, bytes);
    }

    /// Keep `bytes` sent or received `at`.
    pub fn record_at(&mut self, at: std::time::SystemTime, sent: bool, kind: K, bytes: &[u8]) {
        let mut kept = if self.frames.len() >= TRACE_LIMIT {
            self.frames.pop_front().map(|f| f.bytes).unwrap_or_default()
        } else {
            Vec::new()
        };
        kept.clear();
        kept.extend_from_slice(&bytes[..bytes.len().min(self.keep)]);
        self.frames.push_back(RawFrame {
            at,
            sent,
            kind,
            bytes: kept,
        });
    }

    /// Every frame kept, oldest first, as records: `write` gives a frame's raw text and
    /// meaning from whether it was sent, its kind and the bytes kept (which may be cut).
    pub fn take(
        &mut self,
        mut write: impl FnMut(bool, &K, &[u8]) -> (String, String),
    ) -> Vec<TraceRecord> {
        self.frames
            .drain(..)
            .map(|f| {
                let (raw, text) = write(f.sent, &f.kind, &f.bytes);
                TraceRecord {
                    at: f.at,
                    sent: f.sent,
                    raw,
                    text,
                    can: None,
                }
            })
            .collect()
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ring_keeps_the_newest_and_empties_when_taken() {
        let mut ring = TraceRing::new();
        for i in 0..TRACE_LIMIT + 10 {
            ring.record(true, i.to_string(), String::new());
        }
        assert_eq!(ring.len(), TRACE_LIMIT);
        let taken = ring.take();
        assert_eq!(taken.first().map(|r| r.raw.as_str()), Some("10"));
        assert!(ring.is_empty());
    }

    #[test]
    fn raw_frames_keep_the_newest_cut_to_size_and_write_out_when_taken() {
        let mut ring = RawFrames::new(3);
        for i in 0..TRACE_LIMIT + 10 {
            ring.record(i % 2 == 0, i, &[1, 2, 3, 4, 5]);
        }
        assert_eq!(ring.len(), TRACE_LIMIT);
        let taken = ring.take(|sent, kind, bytes| (format!("{bytes:?}"), format!("{sent} {kind}")));
        assert_eq!(taken[0].raw, "[1, 2, 3]");
        assert_eq!(taken[0].text, "true 10");
        assert!(taken[0].sent);
        assert!(!taken[1].sent);
        assert!(ring.is_empty());
    }
}
