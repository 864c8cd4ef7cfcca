//! A drive's way to its worker: the worker thread (which owns the drive's link), the
//! worker settings last handed over, and the hand-over itself — every request with its
//! owner, urgent ones first, a full queue reported rather than waited for.
//!
//! No egui here.

use crate::ui::drive::Drive;
use crate::worker::{self, LinkLossAction, Request, Worker};

/// A drive's worker and the settings it was last given.
pub struct Channel {
    worker: Option<Worker>,
    poll_rate: f64,
    record_frames: bool,
    link_loss: Option<LinkLossAction>,
    lost_after: Option<u32>,
}

/// How the window's workers run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkerClock {
    /// On simulated time (tests of the in-process simulated drive: a move takes no real
    /// time). Only for `sim://` links; see `worker::Config::simulated_time`.
    pub simulated: bool,
}

impl Channel {
    /// Start a worker for `drive`; what went wrong goes in its log.
    pub fn spawn(
        drive: &mut Drive,
        notify: worker::Notify,
        epoch: std::time::Instant,
        clock: WorkerClock,
    ) -> Channel {
        let config = worker::Config {
            poll_rate: drive.settings.poll_rate,
            epoch: Some(epoch),
            simulated_time: clock.simulated,
            ..worker::Config::default()
        };
        let worker = match Worker::spawn(config, notify) {
            Ok(worker) => Some(worker),
            Err(e) => {
                drive.info(format!("the worker thread could not start: {e}"));
                None
            }
        };
        Channel {
            worker,
            poll_rate: drive.settings.poll_rate,
            record_frames: false,
            link_loss: None,
            lost_after: None,
        }
    }

    /// Every event the worker has for this drive, in order.
    pub fn drain(&self) -> Vec<worker::Event> {
        self.worker.as_ref().map(Worker::drain).unwrap_or_default()
    }

    /// The worker settings changed in the window, as requests at the end of the queue.
    pub fn sync_settings(&mut self, drive: &mut Drive) {
        let settings = &drive.settings;
        let mut wanted = Vec::new();
        if settings.record_frames != self.record_frames {
            self.record_frames = settings.record_frames;
            wanted.push(Request::SetTrace(self.record_frames));
        }
        if self.link_loss != Some(settings.on_link_loss) {
            self.link_loss = Some(settings.on_link_loss);
            wanted.push(Request::SetLinkLoss(settings.on_link_loss));
        }
        let lost_after = settings.lost_after.clamp(1, worker::MAX_LOST_AFTER);
        if self.lost_after != Some(lost_after) {
            self.lost_after = Some(lost_after);
            wanted.push(Request::SetLostAfter(lost_after));
        }
        if settings.poll_rate != self.poll_rate {
            self.poll_rate = settings.poll_rate;
            wanted.push(Request::SetPollRate(self.poll_rate));
        }
        for request in wanted {
            drive.ask(request);
        }
    }

    /// Hand `drive`'s requests to the worker: only the urgent ones (stops, halt) when
    /// `urgent`, everything waiting otherwise. Each owner hears of its request's id, or
    /// why it could not be sent.
    pub fn send(&mut self, drive: &mut Drive, urgent: bool) {
        for (owner, request) in drive.take_requests(urgent) {
            let sent = match &self.worker {
                Some(worker) => worker.send(request.clone()).map_err(|e| e.to_string()),
                None => Err("the worker is not running".to_owned()),
            };
            drive.handed(owner, &request, sent);
        }
    }
}
