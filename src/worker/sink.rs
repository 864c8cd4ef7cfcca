//! The worker's side of the event channel: bounded, never blocking the worker, never
//! losing a command's outcome.

use std::collections::VecDeque;
use std::sync::mpsc::{SyncSender, TrySendError};

use super::{Event, Notify};

/// Important events wait here while the channel is full; beyond this many the oldest go.
const BACKLOG_LIMIT: usize = 10_000;
/// Traced frames wait in the backlog too (a `--trace` shows every one), but only while it
/// is this short: beyond, the frames go and the outcomes stay.
const FRAMES_BACKLOG_LIMIT: usize = 1_000;

pub struct EventSink {
    tx: SyncSender<Event>,
    backlog: VecDeque<Event>,
    notify: Notify,
    pending_notify: bool,
    pub dropped_samples: u64,
    /// Traced frames dropped because the receiver fell far behind.
    pub dropped_frames: u64,
    /// The UI end is gone; the worker should stop.
    pub closed: bool,
}

impl EventSink {
    pub fn new(tx: SyncSender<Event>, notify: Notify) -> Self {
        Self {
            tx,
            backlog: VecDeque::new(),
            notify,
            pending_notify: false,
            dropped_samples: 0,
            dropped_frames: 0,
            closed: false,
        }
    }

    /// Queue an event. Samples are dropped (and counted) when the UI cannot keep up;
    /// everything else waits in a backlog.
    pub fn emit(&mut self, event: Event) {
        self.flush();
        if !self.backlog.is_empty() {
            self.hold(event);
            return;
        }
        match self.tx.try_send(event) {
            Ok(()) => self.pending_notify = true,
            Err(TrySendError::Full(event)) => self.hold(event),
            Err(TrySendError::Disconnected(_)) => self.closed = true,
        }
    }

    fn hold(&mut self, event: Event) {
        match &event {
            Event::Samples(samples) => {
                self.dropped_samples += samples.len() as u64;
                return;
            }
            Event::Frames(frames) if self.backlog.len() >= FRAMES_BACKLOG_LIMIT => {
                self.dropped_frames += frames.len() as u64;
                return;
            }
            _ => {}
        }
        if self.backlog.len() >= BACKLOG_LIMIT {
            self.backlog.pop_front();
        }
        self.backlog.push_back(event);
    }

    /// Send what waited, as far as the channel takes it.
    pub fn flush(&mut self) {
        while let Some(event) = self.backlog.pop_front() {
            match self.tx.try_send(event) {
                Ok(()) => self.pending_notify = true,
                Err(TrySendError::Full(event)) => {
                    self.backlog.push_front(event);
                    break;
                }
                Err(TrySendError::Disconnected(_)) => {
                    self.closed = true;
                    self.backlog.clear();
                    break;
                }
            }
        }
    }

    /// Wake the UI once for everything emitted since the last wake.
    pub fn wake(&mut self) {
        if self.pending_notify {
            self.pending_notify = false;
            (self.notify)();
        }
    }
}
