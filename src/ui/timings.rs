//! The window's start, timed: with `DRIVEDECK_TIMINGS` set, the window says on stderr when
//! it drew its first frame and when it first showed the drive's status, each as
//! milliseconds since the process started and as a wall-clock time (Unix nanoseconds) that
//! a launcher can subtract its own spawn time from (`drivedeck bench --startup` does).
//! With `DRIVEDECK_TIMINGS=exit` the window closes itself once both are seen, so a script
//! can start it again and again.
//!
//! Lines, one per event:
//! `timing: first-frame ms=412.3 unix_ns=1764...`
//! `timing: first-status ms=530.9 unix_ns=1764... since_connect_ms=118.6`

use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// The environment variable that turns the timings on (`1`) or on and exit (`exit`).
pub const VARIABLE: &str = "DRIVEDECK_TIMINGS";

/// When the process's `main` started, as near as the window can know it: set by
/// [`mark_start`] before anything else runs.
static STARTED: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();

/// Note the process's start (call first thing in `main`).
pub fn mark_start() {
    let _ = STARTED.get_or_init(Instant::now);
}

/// What has been seen of the start so far.
#[derive(Debug)]
pub struct Timings {
    exit: bool,
    /// When the first drive's connection was asked for.
    connect_asked: Option<Instant>,
    first_frame: bool,
    first_status: bool,
}

impl Timings {
    /// The timings, when the environment asks for them.
    pub fn from_env() -> Option<Timings> {
        let value = std::env::var(VARIABLE).ok()?;
        if value.is_empty() || value == "0" {
            return None;
        }
        Some(Timings {
            exit: value == "exit",
            connect_asked: None,
            first_frame: false,
            first_status: false,
        })
    }

    /// The connection was asked for now.
    pub fn connect_asked(&mut self) {
        self.connect_asked.get_or_insert_with(Instant::now);
    }

    /// A frame was drawn; `status` when it showed a sample of the drive connected now.
    /// Whether the window should close now (`exit`, and both seen).
    pub fn frame_drawn(&mut self, status: bool) -> bool {
        if !self.first_frame {
            self.first_frame = true;
            eprintln!("timing: first-frame {}", stamp());
        }
        if status && !self.first_status {
            self.first_status = true;
            let since = self
                .connect_asked
                .map(|at| format!(" since_connect_ms={:.1}", ms(at.elapsed())))
                .unwrap_or_default();
            eprintln!("timing: first-status {}{since}", stamp());
        }
        self.exit && self.first_frame && self.first_status
    }
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// `ms=… unix_ns=…`: since the start, and the wall clock.
fn stamp() -> String {
    let since = STARTED.get().map_or(f64::NAN, |at| ms(at.elapsed()));
    let unix = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    format!("ms={since:.1} unix_ns={unix}")
}

/// A `timing:` line's fields, as the launcher reads them: (event, ms since start, unix ns,
/// ms since the connect request).
pub fn parse_line(line: &str) -> Option<(String, f64, u128, Option<f64>)> {
    let mut words = line.strip_prefix("timing: ")?.split_whitespace();
    let event = words.next()?.to_owned();
    let (mut ms, mut unix, mut since) = (None, None, None);
    for word in words {
        match word.split_once('=') {
            Some(("ms", v)) => ms = v.parse().ok(),
            Some(("unix_ns", v)) => unix = v.parse().ok(),
            Some(("since_connect_ms", v)) => since = v.parse().ok(),
            _ => {}
        }
    }
    Some((event, ms?, unix?, since))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_reads_back() {
        let line =
            "timing: first-status ms=530.9 unix_ns=1764000000000000000 since_connect_ms=118.6";
        assert_eq!(
            parse_line(line),
            Some((
                "first-status".into(),
                530.9,
                1_764_000_000_000_000_000,
                Some(118.6)
            ))
        );
        assert_eq!(parse_line("timing: first-frame ms=x unix_ns=1"), None);
        assert_eq!(parse_line("note: something else"), None);
    }

    #[test]
    fn the_window_closes_only_when_asked_and_both_are_seen() {
        let mut t = Timings {
            exit: true,
            connect_asked: None,
            first_frame: false,
            first_status: false,
        };
        t.connect_asked();
        assert!(!t.frame_drawn(false));
        assert!(t.frame_drawn(true));
        t.exit = false;
        assert!(!t.frame_drawn(true));
    }
}
