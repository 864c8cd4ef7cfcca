//! The worker: its own thread with a current-thread tokio runtime, the only owner of the
//! link. `Request`s go in through bounded channels (urgent ones through their own, so a
//! quick stop never waits behind a queue), `Event`s come out, and the UI is woken with a
//! callback when something new arrives.

mod clock;
mod commands;
mod cycle;
mod jobs;
mod limiter;
mod loss;
mod protocol;
mod requests;
mod session;
mod sink;
mod supervisor;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, sync_channel};
use std::thread::JoinHandle;
use std::time::Duration;

use tokio::sync::mpsc;

pub use loss::REOPEN_EVERY;
pub use protocol::{
    CommandProgress, Event, HALT_ON_LOSS_TIMEOUT, Health, JOG_KEEPALIVE, JOG_TIMEOUT, LOST_AFTER,
    LinkLossAction, MAX_LOST_AFTER, MAX_WATCHED, ObjectError, ObjectPath, Rejection, Request,
    RequestId, Sample, WORKER_ID,
};

use crate::pdi::Timing;

/// Called by the worker when new events wait (the UI passes `request_repaint_after`).
pub type Notify = Arc<dyn Fn() + Send + Sync>;

/// How many ordinary requests may wait for the worker before the UI is told it is busy.
pub const REQUEST_QUEUE: usize = 32;
/// Room for urgent requests (quick stop, switch off, halt).
pub const URGENT_QUEUE: usize = 8;
/// Events waiting for the UI before samples are dropped.
pub const EVENT_QUEUE: usize = 4096;

/// The worker's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Process-image exchanges per second.
    pub poll_rate: f64,
    pub timing: Timing,
    /// Reconnect with backoff after a link error.
    pub reconnect: bool,
    /// Report every frame (`Event::Frames`) from the start.
    pub trace: bool,
    /// What to do when the link fails during a move.
    pub on_link_loss: LinkLossAction,
    /// Exchanges that must fail in a row before the link counts as lost.
    pub lost_after: u32,
    /// Ride out a connection that closes or resets within the `lost_after` budget: open
    /// it again in place (one failed exchange per try, tried again every
    /// [`REOPEN_EVERY`]) and go on with the same session, so that the command that runs
    /// is neither ended nor replayed. The command line's way; the window (off) ends the
    /// session and reconnects with `reconnect`.
    pub reconnect_in_session: bool,
    /// Run on simulated time: the worker's runtime starts with tokio's clock paused, so
    /// whenever the worker only waits (for its next cycle) time jumps ahead, and a test of
    /// the in-process simulated drive waits no real time for a move. Only the in-process
    /// simulator (`LinkSpec::Sim`) may be opened so: a real link's timeouts would fire at
    /// once.
    pub simulated_time: bool,
    /// Time zero of the samples' clock. `None`: the worker's first connection. A window
    /// with several drives gives every worker its own start, so that the samples of all
    /// its drives lie on one time axis.
    pub epoch: Option<std::time::Instant>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            poll_rate: 100.0,
            timing: Timing::default(),
            reconnect: true,
            trace: false,
            on_link_loss: LinkLossAction::Halt,
            lost_after: LOST_AFTER,
            reconnect_in_session: false,
            simulated_time: false,
            epoch: None,
        }
    }
}

/// Why a request did not reach the worker.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    #[error(
        "the worker is busy: {0} requests are already waiting; try again when the link catches up"
    )]
    Busy(usize),
    #[error("the worker has stopped")]
    Stopped,
}

type Envelope = (RequestId, Request);

/// The handle the UI or a script holds. Dropping it stops the worker.
pub struct Worker {
    requests: Option<mpsc::Sender<Envelope>>,
    urgent: Option<mpsc::Sender<Envelope>>,
    events: Receiver<Event>,
    next_id: AtomicU64,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Start the worker thread. It waits for `Request::Connect`.
    pub fn spawn(config: Config, notify: Notify) -> std::io::Result<Worker> {
        let (request_tx, request_rx) = mpsc::channel(REQUEST_QUEUE);
        let (urgent_tx, urgent_rx) = mpsc::channel(URGENT_QUEUE);
        let (event_tx, event_rx) = sync_channel(EVENT_QUEUE);
        let thread = std::thread::Builder::new()
            .name("drivedeck-worker".into())
            .spawn(move || {
                let mut sink = sink::EventSink::new(event_tx, notify);
                let mut builder = tokio::runtime::Builder::new_current_thread();
                builder.enable_all().start_paused(config.simulated_time);
                match builder.build() {
                    Ok(runtime) => {
                        runtime.block_on(supervisor::run(config, request_rx, urgent_rx, &mut sink))
                    }
                    Err(e) => {
                        sink.emit(Event::Notice(crate::link::Notice::info(format!(
                            "the worker could not start its runtime: {e}"
                        ))));
                        sink.wake();
                    }
                }
            })?;
        Ok(Worker {
            requests: Some(request_tx),
            urgent: Some(urgent_tx),
            events: event_rx,
            next_id: AtomicU64::new(1),
            thread: Some(thread),
        })
    }

    /// Send a request without blocking. Urgent requests use their own queue.
    pub fn send(&self, request: Request) -> Result<RequestId, SendError> {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let channel = if request.is_urgent() {
            &self.urgent
        } else {
            &self.requests
        };
        let channel = channel.as_ref().ok_or(SendError::Stopped)?;
        channel.try_send((id, request)).map_err(|e| match e {
            mpsc::error::TrySendError::Full(_) => SendError::Busy(channel.max_capacity()),
            mpsc::error::TrySendError::Closed(_) => SendError::Stopped,
        })?;
        Ok(id)
    }

    /// The next event, if one waits.
    pub fn try_recv(&self) -> Option<Event> {
        self.events.try_recv().ok()
    }

    /// Wait up to `timeout` for the next event (scripts).
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Event, RecvTimeoutError> {
        self.events.recv_timeout(timeout)
    }

    /// Every event that waits now.
    pub fn drain(&self) -> Vec<Event> {
        self.events.try_iter().collect()
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing both channels ends the worker's loop; it closes the link on the way out.
        self.requests = None;
        self.urgent = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
