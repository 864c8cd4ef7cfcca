//! PDI commands: starting one (a motion command, a halt, an object access through the
//! PDI), reporting how the ones in flight progress, and the jog that runs while its
//! keep-alive comes.

use std::time::Instant;

use super::protocol::{
    CommandProgress, Event, JOG_TIMEOUT, ObjectError, Rejection, Request, RequestId, WORKER_ID,
};
use super::session::Session;
use super::sink::EventSink;
use crate::link::Notice;
use crate::od::{Address, DataType, Value};
use crate::pdi::{self, Action, Progress, RxImage};

/// What a PDI command in flight was for.
#[derive(Clone, Debug)]
pub(super) enum Purpose {
    Command,
    Read {
        address: Address,
        dtype: Option<DataType>,
    },
    Write {
        address: Address,
        dtype: DataType,
        value: Value,
    },
    /// The value an object has before a PDI write changes it (for undo).
    Before {
        address: Address,
        dtype: DataType,
    },
}

/// A PDI command the master started (or refused), and what it was for.
type Started = (Result<RxImage, pdi::Error>, Purpose);

impl Session {
    pub(super) fn start_pdi(&mut self, id: RequestId, request: Request, sink: &mut EventSink) {
        if let Some(why) = crate::link::Link::info(&self.link).commands_refused {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(why),
            });
            return;
        }
        if !self.pdi {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(
                    "this device has no Plug & Drive interface (2291h/2292h): object access only"
                        .into(),
                ),
            });
            return;
        }
        let now = super::clock::now();
        let described = request.to_string();
        if matches!(request, Request::Command(_) | Request::Resume) {
            // Another command takes over from a jog.
            self.jog_deadline = None;
        }
        let (result, purpose) = match self.start_master(id, &request, now) {
            Ok(started) => started,
            Err(reason) => {
                sink.emit(Event::Rejected {
                    id,
                    request: described,
                    reason: Rejection::Refused(reason),
                });
                return;
            }
        };
        // Commands superseded by this one report at once.
        self.report_progress(sink);
        match result {
            Ok(image) => {
                self.purposes.insert(id, purpose);
                sink.emit(Event::Sent {
                    id,
                    t: self.time(now),
                    what: described,
                    image,
                });
            }
            Err(e) => sink.emit(Event::Rejected {
                id,
                request: described,
                reason: Rejection::Refused(e.to_string()),
            }),
        }
    }

    /// Hand a request to the PDI master. `Err`: why it is no PDI command at all.
    fn start_master(
        &mut self,
        id: RequestId,
        request: &Request,
        now: Instant,
    ) -> Result<Started, String> {
        Ok(match request {
            Request::Command(action) => (self.master.start(id, *action, now), Purpose::Command),
            Request::Halt => (self.master.halt(id, now), Purpose::Command),
            Request::Resume => (self.master.resume(id, now), Purpose::Command),
            Request::ReadObject { address, dtype, .. } => (
                self.master.start(
                    id,
                    Action::OdRead {
                        index: address.index,
                        sub: address.sub,
                    },
                    now,
                ),
                Purpose::Read {
                    address: *address,
                    dtype: *dtype,
                },
            ),
            Request::WriteObject {
                address,
                dtype,
                value,
                ..
            } => {
                let raw = value.to_pdi(*dtype).map_err(|e| e.to_string())?;
                (
                    self.master.start(
                        id,
                        Action::OdWrite {
                            index: address.index,
                            sub: address.sub,
                            value: raw,
                        },
                        now,
                    ),
                    Purpose::Write {
                        address: *address,
                        dtype: *dtype,
                        value: value.clone(),
                    },
                )
            }
            _ => return Err("not a PDI request".into()),
        })
    }

    pub(super) fn report_progress(&mut self, sink: &mut EventSink) {
        for progress in self.master.drain_progress() {
            let id = progress.tag();
            let purpose = if progress.is_final() {
                self.purposes.remove(&id)
            } else {
                self.purposes.get(&id).cloned()
            };
            match purpose {
                Some(Purpose::Before { address, dtype }) => {
                    self.note_before(address, dtype, progress)
                }
                Some(Purpose::Read { address, dtype }) if progress.is_final() => {
                    report_read(id, address, dtype, progress, sink)
                }
                Some(Purpose::Write {
                    address,
                    dtype,
                    value,
                }) if progress.is_final() => {
                    self.report_write(id, address, dtype, value, progress, sink)
                }
                _ => report_command(id, progress, sink),
            }
        }
    }

    /// A PDI read of the value before a write (for undo): kept, or `None` if it failed.
    fn note_before(&mut self, address: Address, dtype: DataType, progress: Progress) {
        match progress {
            Progress::Done { return_value, .. } => {
                self.before
                    .insert(address, Value::from_pdi(dtype, return_value).ok());
            }
            p if p.is_final() => {
                self.before.insert(address, None);
            }
            _ => {}
        }
    }

    /// A PDI write is over: reported (and, done, remembered for undo).
    fn report_write(
        &mut self,
        id: RequestId,
        address: Address,
        dtype: DataType,
        value: Value,
        progress: Progress,
        sink: &mut EventSink,
    ) {
        if let Progress::Done { .. } = progress {
            sink.emit(Event::ObjectWritten {
                id,
                address,
                value: value.clone(),
                result: Ok(()),
            });
            let before = self.before.get(&address).cloned().flatten();
            self.record_change(address, dtype, before, value, sink);
        } else {
            sink.emit(Event::ObjectWritten {
                id,
                address,
                value,
                result: Err(ObjectError::Pdi(CommandProgress::from(progress))),
            });
        }
    }

    /// `Request::Jog`: Profile Velocity, halted unless keep-alives come.
    pub(super) fn jog(&mut self, id: RequestId, speed: i32, sink: &mut EventSink) {
        self.start_pdi(id, Request::Command(Action::Velocity { speed }), sink);
        if self.master.pending_tag() == Some(id) {
            self.jog_deadline = Some(super::clock::now() + JOG_TIMEOUT);
        }
    }

    /// `Request::JogKeepAlive`: the jog that runs goes on.
    pub(super) fn keep_jogging(&mut self) {
        if self.jog_deadline.is_some() {
            self.jog_deadline = Some(super::clock::now() + JOG_TIMEOUT);
        }
    }

    /// `Request::JogStop`: halt the travel that runs (done at once if none runs).
    pub(super) fn jog_stop(&mut self, id: RequestId, sink: &mut EventSink) {
        self.jog_deadline = None;
        if self.master.travel_running() {
            self.start_pdi(id, Request::Halt, sink);
        } else {
            sink.emit(Event::Progress {
                id,
                progress: CommandProgress::Done { return_value: 0 },
            });
        }
    }

    /// Halt a jog whose keep-alive stopped coming.
    pub(super) fn halt_stale_jog(&mut self, sink: &mut EventSink) {
        if self.jog_deadline.is_none_or(|d| super::clock::now() < d) {
            return;
        }
        self.jog_deadline = None;
        self.start_pdi(WORKER_ID, Request::Halt, sink);
        sink.emit(Event::Notice(Notice::motor_stopped(format!(
            "jog halted: no keep-alive from the window for {:.1} s (frozen, or the focus was lost)",
            JOG_TIMEOUT.as_secs_f64()
        ))));
    }
}

/// A PDI read is over: its value, or why there is none.
fn report_read(
    id: RequestId,
    address: Address,
    dtype: Option<DataType>,
    progress: Progress,
    sink: &mut EventSink,
) {
    let result = match progress {
        Progress::Done { return_value, .. } => {
            let dtype = dtype.unwrap_or(DataType::Integer32);
            Value::from_pdi(dtype, return_value).map_err(|e| ObjectError::Decode(e.to_string()))
        }
        p => Err(ObjectError::Pdi(CommandProgress::from(p))),
    };
    sink.emit(Event::ObjectRead {
        id,
        address,
        result,
    });
}

/// A command's progress (or an object access's that is not over yet).
fn report_command(id: RequestId, progress: Progress, sink: &mut EventSink) {
    match progress {
        Progress::Resent { .. } => sink.emit(Event::Notice(Notice::info(format!(
            "request {id}: no acknowledgement yet; sent again with ToggleCmd flipped"
        )))),
        p => sink.emit(Event::Progress {
            id,
            progress: CommandProgress::from(p),
        }),
    }
}

impl From<Progress> for CommandProgress {
    fn from(progress: Progress) -> Self {
        match progress {
            Progress::Accepted { .. } | Progress::Resent { .. } => CommandProgress::Accepted,
            Progress::Done { return_value, .. } => CommandProgress::Done { return_value },
            Progress::Failed { failure, .. } => CommandProgress::Failed(failure),
            Progress::TimedOut {
                waiting_for, after, ..
            } => CommandProgress::TimedOut { waiting_for, after },
            Progress::Superseded { .. } => CommandProgress::Superseded,
        }
    }
}
