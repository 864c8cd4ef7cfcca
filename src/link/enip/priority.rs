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
