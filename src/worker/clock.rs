//! The worker's clock: the wall clock, or, for tests of the in-process simulated drive,
//! tokio's paused clock, which jumps ahead whenever the worker only waits (see
//! [`super::Config::simulated_time`]). Every time the worker reads goes through [`now`].

use std::time::Instant;

/// Now, on the clock of the runtime the worker runs on (the wall clock unless it was
/// started paused).
pub(super) fn now() -> Instant {
    tokio::time::Instant::now().into_std()
}
