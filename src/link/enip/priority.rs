//! The scheduling priority of the class 1 producer threads: a thread that sleeps to a
//! deadline and sends one datagram gains most from being run first when it wakes on a
//! loaded computer.

/// The real-time priority asked for: low among real-time threads (audio servers use
/// 50 to 95), above every ordinary thread.
pub const REALTIME_PRIORITY: i32 = 10;

/// Set to `normal` (or `0`, `off`), the producer threads keep the ordinary priority.
pub const PRIORITY_ENV: &str = "DRIVEDECK_IO_PRIORITY";

/// The priority a producer thread runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Priority {
    /// Real-time (Linux SCHED_FIFO) at this priority.
    Realtime(i32),
    /// The ordinary priority: the OS refused (no CAP_SYS_NICE, RLIMIT_RTPRIO 0), the
    /// platform has no such call here, or [`PRIORITY_ENV`] said so.
    Normal,
}

impl std::fmt::Display for Priority {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Priority::Realtime(p) => write!(f, "real-time (SCHED_FIFO {p})"),
            Priority::Normal => write!(f, "ordinary"),
        }
    }
}

fn wanted() -> bool {
    !matches!(
        std::env::var(PRIORITY_ENV).as_deref().map(str::trim),
        Ok("normal" | "0" | "off")
    )
}

/// Ask for real-time priority for the calling thread, where the OS grants it: the
/// priority it runs at afterwards. Never an error: a refusal leaves it as it was.
pub fn raise_current_thread() -> Priority {
    if !wanted() {
        return Priority::Normal;
    }
    raise()
}

#[cfg(target_os = "linux")]
fn raise() -> Priority {
    // The highest the rlimit allows up to REALTIME_PRIORITY (rtkit-style desktops grant
    // audio users some), else what CAP_SYS_NICE allows.
    for priority in [REALTIME_PRIORITY, 1] {
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: pthread_self() is the calling thread, alive for the call; `param` is a
        // valid sched_param for the duration of the call.
        let refused =
            unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
        if refused == 0 {
            return Priority::Realtime(priority);
        }
    }
    Priority::Normal
}

#[cfg(not(target_os = "linux"))]
fn raise() -> Priority {
    Priority::Normal
}

/// Back to the ordinary priority for the calling thread (a consumer that met a flood).
/// Never an error: what the OS says is what the thread runs at afterwards.
pub fn lower_current_thread() -> Priority {
    lower()
}

#[cfg(target_os = "linux")]
fn lower() -> Priority {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: as in `raise`: the calling thread and a valid sched_param.
    let failed =
        unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_OTHER, &param) };
    if failed == 0 {
        Priority::Normal
    } else {
        // Still where it was; only a thread that was raised calls this.
        Priority::Realtime(REALTIME_PRIORITY)
    }
}

#[cfg(not(target_os = "linux"))]
fn lower() -> Priority {
    Priority::Normal
}

/// Keeps a real-time consumer from being turned into a denial of service: a consumer does
/// work for every datagram that reaches its socket, so at real-time priority a flood of UDP
/// would take a core from everything else. Counted per [`FloodGuard::WINDOW`]: more than
/// four times the datagrams the RPI gives (and at least 16), and the consumer goes back to
/// ordinary priority for the rest of the connection.
#[derive(Clone, Debug)]
pub struct FloodGuard {
    allowed: u32,
    window_start: Option<std::time::Instant>,
    in_window: u32,
    tripped: bool,
}

impl FloodGuard {
    pub const WINDOW: std::time::Duration = std::time::Duration::from_millis(100);

    /// A guard for a connection whose adapter produces every `rpi`.
    pub fn new(rpi: std::time::Duration) -> FloodGuard {
        let per_window = Self::WINDOW.as_secs_f64() / rpi.as_secs_f64().max(1e-6);
        FloodGuard {
            allowed: ((4.0 * per_window).ceil() as u32).max(16),
            window_start: None,
            in_window: 0,
            tripped: false,
        }
    }

    /// A datagram arrived at `now`: `Some(count)` once, when the window's count passes
    /// what is allowed (the caller lowers its priority and says so).
    pub fn arrived(&mut self, now: std::time::Instant) -> Option<u32> {
        if self.tripped {
            return None;
        }
        match self.window_start {
            Some(start) if now.saturating_duration_since(start) < Self::WINDOW => {}
            _ => {
                self.window_start = Some(now);
                self.in_window = 0;
            }
        }
        self.in_window += 1;
        if self.in_window > self.allowed {
            self.tripped = true;
            return Some(self.in_window);
        }
        None
    }

    /// The most datagrams a window may bring.
    pub fn allowed(&self) -> u32 {
        self.allowed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    #[test]
    fn the_flood_guard_lets_the_rpi_through_and_trips_once_on_a_flood() {
        let rpi = Duration::from_millis(1);
        let mut guard = FloodGuard::new(rpi);
        assert_eq!(guard.allowed(), 400);
        let t0 = Instant::now();
        // Ten seconds at the RPI, with a copy of every packet: never trips.
        for k in 0..20_000u32 {
            assert_eq!(guard.arrived(t0 + rpi * (k / 2)), None, "packet {k}");
        }
        // A flood: 1000 datagrams within a millisecond.
        let t1 = t0 + Duration::from_secs(11);
        let tripped: Vec<_> = (0..1000u32)
            .filter_map(|k| guard.arrived(t1 + Duration::from_nanos(u64::from(k))))
            .collect();
        assert_eq!(tripped, vec![401]);
        assert_eq!(FloodGuard::new(Duration::from_millis(100)).allowed(), 16);
    }
}
