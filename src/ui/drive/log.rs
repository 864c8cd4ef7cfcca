//! A drive's command log: every request the user made, with the image it wrote and how the
//! drive answered, and the notes the window adds (connections, notices).
//!
//! A model: no egui here.

use std::collections::VecDeque;

use crate::pdi::RxImage;
use crate::worker::RequestId;

/// Log entries kept per drive.
pub const LOG_LIMIT: usize = 2000;

/// One line of the command log.
#[derive(Clone, Debug, PartialEq)]
pub struct LogEntry {
    /// Seconds since the window opened.
    pub at: f64,
    pub id: Option<RequestId>,
    pub what: String,
    /// The RX image as written, once sent.
    pub image: Option<RxImage>,
    pub outcome: Outcome,
}

/// Where a logged request stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Queued,
    Sent,
    Accepted,
    Succeeded(String),
    Failed(String),
    /// A newer command took its place (a relative move followed by the next): not a
    /// fault, the drive did what it was told last.
    Superseded(String),
    /// Done, but not quite as asked (a halt the drive shows while the motor still
    /// brakes): drawn amber.
    Caution(String),
    /// Not tied to a request (connection changes, notices).
    Info,
}

impl Outcome {
    pub fn is_open(&self) -> bool {
        matches!(self, Outcome::Queued | Outcome::Sent | Outcome::Accepted)
    }
}

/// The log, oldest first, at most [`LOG_LIMIT`] entries.
#[derive(Clone, Debug, Default)]
pub struct Log {
    entries: VecDeque<LogEntry>,
}

impl Log {
    pub fn push(&mut self, entry: LogEntry) {
        if self.entries.len() >= LOG_LIMIT {
            self.entries.pop_front();
        }
        self.entries.push_back(entry);
    }

    /// A note not tied to a request, at `at`.
    pub fn info(&mut self, at: f64, text: impl Into<String>) {
        self.push(LogEntry {
            at,
            id: None,
            what: text.into(),
            image: None,
            outcome: Outcome::Info,
        });
    }

    /// The entry of request `id`.
    pub fn entry(&mut self, id: RequestId) -> Option<&mut LogEntry> {
        self.entries.iter_mut().rev().find(|e| e.id == Some(id))
    }

    pub fn iter(&self) -> impl DoubleEndedIterator<Item = &LogEntry> {
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
}

impl<'a> IntoIterator for &'a Log {
    type Item = &'a LogEntry;
    type IntoIter = std::collections::vec_deque::Iter<'a, LogEntry>;

    fn into_iter(self) -> Self::IntoIter {
        self.entries.iter()
    }
}
