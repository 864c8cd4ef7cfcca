//! Progress of long one-shot commands on the terminal: a bar on stderr that redraws in
//! place when stderr is a terminal, and nothing in between when it is a file or a pipe
//! (scripts get only the summary line).

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

/// Bar width in characters.
const WIDTH: usize = 30;
/// Redraws at most this often.
const EVERY: Duration = Duration::from_millis(100);

/// A `progress(done, total)` callback drawing `what [#####     ] done/total` on stderr.
pub fn bar(what: &'static str) -> impl FnMut(usize, usize) {
    let terminal = std::io::stderr().is_terminal();
    let mut last: Option<Instant> = None;
    move |done, total| {
        if !terminal {
            return;
        }
        let finished = done >= total;
        if !finished && last.is_some_and(|t| t.elapsed() < EVERY) {
            return;
        }
        last = Some(Instant::now());
        let filled = (done * WIDTH)
            .checked_div(total)
            .unwrap_or(WIDTH)
            .min(WIDTH);
        let mut err = std::io::stderr().lock();
        let _ = write!(
            err,
            "\r{what} [{}{}] {done}/{total}",
            "#".repeat(filled),
            " ".repeat(WIDTH - filled)
        );
        if finished {
            let _ = writeln!(err);
        }
        let _ = err.flush();
    }
}

/// The summary of a bulk read: how many of how many, how long and how fast.
pub fn summary(asked: usize, read: usize, elapsed: Duration) -> String {
    let seconds = elapsed.as_secs_f64();
    let rate = if seconds > 0.0 {
        format!(", {:.0} objects/s", read as f64 / seconds)
    } else {
        String::new()
    };
    format!("read {read} of {asked} objects in {seconds:.2} s{rate}")
}

/// Add the summary to a command's notes.
pub fn done(asked: usize, read: usize, elapsed: Duration, notes: &mut Vec<String>) {
    notes.push(summary(asked, read, elapsed));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_gives_count_time_and_rate() {
        assert_eq!(
            summary(10, 8, Duration::from_millis(500)),
            "read 8 of 10 objects in 0.50 s, 16 objects/s"
        );
        assert_eq!(
            summary(0, 0, Duration::ZERO),
            "read 0 of 0 objects in 0.00 s"
        );
    }
}
