//! Log lines that may repeat at the cycle rate, at a bounded rate.

use std::time::{Duration, Instant};

use super::protocol::Event;
use super::sink::EventSink;
use crate::link::Notice;

/// Log lines that may repeat at the cycle rate (a noisy line): at most [`Limiter::BURST`]
/// in any [`Limiter::WINDOW`], then a count of the ones held back with the next one said.
#[derive(Default)]
pub(super) struct Limiter {
    window_start: Option<Instant>,
    said: u32,
    held: u32,
}

impl Limiter {
    const WINDOW: Duration = Duration::from_secs(5);
    const BURST: u32 = 5;

    pub(super) fn say(&mut self, text: String, sink: &mut EventSink) {
        let now = super::clock::now();
        if self
            .window_start
            .is_none_or(|start| now - start >= Self::WINDOW)
        {
            self.window_start = Some(now);
            self.said = 0;
        }
        if self.said >= Self::BURST {
            self.held += 1;
            return;
        }
        self.said += 1;
        let text = match std::mem::take(&mut self.held) {
            0 => text,
            held => format!("{text} (and {held} more like it before, not shown)"),
        };
        sink.emit(Event::Notice(Notice::info(text)));
    }
}
