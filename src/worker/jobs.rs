//! The queued object jobs: reads and writes by the link's own object access (as many as
//! fit in a share of the cycle) or through the PDI (one at a time), with the value each
//! object had before its first write this session (for undo).

use std::time::Duration;

use super::commands::Purpose;
use super::protocol::{Event, ObjectError, ObjectPath, Rejection, Request, RequestId};
use super::session::Session;
use super::sink::EventSink;
use crate::link::{self, Link, Refusal};
use crate::od::{Address, DataType, Value};
use crate::pdi::Action;

/// Jobs waiting for the PDI beyond this many are refused (the request channel bounds the
/// rest).
const JOB_QUEUE: usize = 256;
/// Room in the queue for bulk reads (a whole dictionary, an EDS's worth).
const BULK_QUEUE: usize = 8192;

impl Session {
    /// Queue a job, or start it now if it stops the motor.
    pub(super) fn enqueue(&mut self, id: RequestId, request: Request, sink: &mut EventSink) {
        if request.is_urgent() {
            // Stops go out now, ahead of everything queued.
            self.start_pdi(id, request, sink);
        } else if self.queue.len() >= JOB_QUEUE {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(format!(
                    "{JOB_QUEUE} requests are already waiting for the drive"
                )),
            });
        } else {
            self.queue.push_back((id, request));
        }
    }

    /// `Request::ReadMany`: one queued read an object, all under the request's id.
    pub(super) fn queue_reads(
        &mut self,
        id: RequestId,
        request: &Request,
        objects: &[(Address, DataType)],
        path: ObjectPath,
        sink: &mut EventSink,
    ) {
        if self.queue.len() + objects.len() > BULK_QUEUE {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(format!(
                    "{} objects at once is more than the {BULK_QUEUE} the worker queues; read them in parts",
                    objects.len()
                )),
            });
            return;
        }
        for &(address, dtype) in objects {
            self.queue.push_back((
                id,
                Request::ReadObject {
                    address,
                    dtype: Some(dtype),
                    path,
                },
            ));
        }
    }

    /// Drop the queued jobs of request `cancelled`; how many were dropped.
    pub(super) fn cancel(&mut self, cancelled: RequestId) -> usize {
        let before = self.queue.len();
        self.queue.retain(|(queued, _)| *queued != cancelled);
        before - self.queue.len()
    }

    /// Start queued jobs: object accesses without the PDI right away (as many as fit in
    /// `budget`, at least one), one PDI command once the previous one was acknowledged.
    pub(super) async fn run_jobs(
        &mut self,
        sink: &mut EventSink,
        budget: Duration,
    ) -> Result<(), link::Error> {
        let started = super::clock::now();
        let mut native_done = 0;
        while let Some((id, request)) = self.queue.front().cloned() {
            let native = match &request {
                Request::ReadObject { path, .. } | Request::WriteObject { path, .. } => {
                    *path == ObjectPath::Native
                        || (*path == ObjectPath::Auto && self.native_objects)
                }
                _ => false,
            };
            if native {
                if native_done > 0 && started.elapsed() >= budget {
                    break;
                }
                self.queue.pop_front();
                if let Err(e) = self.native_job(id, request.clone(), sink).await {
                    // Tried again next cycle, or refused with the reason once the link
                    // counts as lost.
                    self.queue.push_front((id, request));
                    return Err(e);
                }
                native_done += 1;
                continue;
            }
            if self.master.is_awaiting_ack() || self.awaiting_before() {
                break;
            }
            if self.pre_read(&request, sink) {
                break;
            }
            self.queue.pop_front();
            self.start_pdi(id, request, sink);
            break;
        }
        Ok(())
    }

    async fn native_job(
        &mut self,
        id: RequestId,
        request: Request,
        sink: &mut EventSink,
    ) -> Result<(), link::Error> {
        let refusal = match &request {
            Request::ReadObject { address, dtype, .. } => {
                self.native_read(id, *address, *dtype, sink).await?
            }
            Request::WriteObject {
                address,
                dtype,
                value,
                ..
            } => self.native_write(id, *address, *dtype, value, sink).await?,
            other => {
                sink.emit(Event::Rejected {
                    id,
                    request: other.to_string(),
                    reason: Rejection::Refused("not an object access".into()),
                });
                return Ok(());
            }
        };
        if let Some(refusal) = refusal {
            self.native_refused(id, request, refusal, sink);
        }
        Ok(())
    }

    /// A read by the link's own object access: reported, or the device's refusal.
    async fn native_read(
        &mut self,
        id: RequestId,
        address: Address,
        dtype: Option<DataType>,
        sink: &mut EventSink,
    ) -> Result<Option<Refusal>, link::Error> {
        let dtype = dtype.or_else(|| crate::od::builtin().get(address).map(|e| e.dtype));
        let result = match dtype {
            Some(dtype) => self.link.read_object(address, dtype).await?,
            None => self.link.read_object_of_unknown_type(address).await?,
        };
        self.trace_out(sink);
        match result {
            Ok(value) => {
                sink.emit(Event::ObjectRead {
                    id,
                    address,
                    result: Ok(value),
                });
                Ok(None)
            }
            Err(refusal) => Ok(Some(refusal)),
        }
    }

    /// A write by the link's own object access, the value before it read first (for
    /// undo): reported, or the device's refusal.
    async fn native_write(
        &mut self,
        id: RequestId,
        address: Address,
        dtype: DataType,
        value: &Value,
        sink: &mut EventSink,
    ) -> Result<Option<Refusal>, link::Error> {
        // The value before the first write, for undo.
        let before = match self.before.get(&address) {
            Some(known) => known.clone(),
            None => {
                let before = self.link.read_object(address, dtype).await?.ok();
                // Kept at once: a write tried again must not take its own value
                // for the one before.
                self.before.insert(address, before.clone());
                before
            }
        };
        let written = self.link.write_object(address, dtype, value).await?;
        self.trace_out(sink);
        match written {
            Ok(()) => {
                sink.emit(Event::ObjectWritten {
                    id,
                    address,
                    value: value.clone(),
                    result: Ok(()),
                });
                self.record_change(address, dtype, before, value.clone(), sink);
                Ok(None)
            }
            Err(refusal) => Ok(Some(refusal)),
        }
    }

    /// The device refused an object access by the link's own: tell the window.
    fn native_refused(
        &mut self,
        id: RequestId,
        request: Request,
        refusal: Refusal,
        sink: &mut EventSink,
    ) {
        // The link has no object access of its own after all (e.g. a Modbus device without
        // FC 43): an automatic request goes through the PDI instead.
        if refusal == Refusal::NotSupported
            && let Some(request) = via_pdi(&request)
        {
            self.native_objects = false;
            self.queue.push_front((id, request));
            return;
        }
        match request {
            Request::ReadObject { address, .. } => sink.emit(Event::ObjectRead {
                id,
                address,
                result: Err(ObjectError::Refused(refusal.clone())),
            }),
            Request::WriteObject { address, value, .. } => sink.emit(Event::ObjectWritten {
                id,
                address,
                value,
                result: Err(ObjectError::Refused(refusal.clone())),
            }),
            _ => {}
        }
    }

    /// Whether a PDI read of a value before a write still runs.
    fn awaiting_before(&self) -> bool {
        self.purposes
            .values()
            .any(|p| matches!(p, Purpose::Before { .. }))
    }

    /// Remember a write for undo and tell the window.
    pub(super) fn record_change(
        &mut self,
        address: Address,
        dtype: DataType,
        before: Option<Value>,
        after: Value,
        sink: &mut EventSink,
    ) {
        let before = self.before.entry(address).or_insert(before).clone();
        sink.emit(Event::Changed {
            address,
            dtype,
            before,
            after,
        });
    }

    /// Before a PDI write of an object not written yet this session, read its value
    /// through the PDI (for undo). `true` when such a read was started: the write waits.
    fn pre_read(&mut self, request: &Request, sink: &mut EventSink) -> bool {
        let Request::WriteObject { address, dtype, .. } = request else {
            return false;
        };
        if self.before.contains_key(address) {
            return false;
        }
        let id = self.next_internal;
        self.next_internal -= 1;
        let started = self.master.start(
            id,
            Action::OdRead {
                index: address.index,
                sub: address.sub,
            },
            super::clock::now(),
        );
        match started {
            Ok(_) => {
                self.purposes.insert(
                    id,
                    Purpose::Before {
                        address: *address,
                        dtype: *dtype,
                    },
                );
                self.report_progress(sink);
                true
            }
            Err(_) => {
                self.before.insert(*address, None);
                false
            }
        }
    }
}

/// An automatic object access, redirected to the PDI.
fn via_pdi(request: &Request) -> Option<Request> {
    match request {
        Request::ReadObject {
            address,
            dtype,
            path: ObjectPath::Auto,
        } => Some(Request::ReadObject {
            address: *address,
            dtype: *dtype,
            path: ObjectPath::Pdi,
        }),
        Request::WriteObject {
            address,
            dtype,
            value,
            path: ObjectPath::Auto,
        } => Some(Request::WriteObject {
            address: *address,
            dtype: *dtype,
            value: value.clone(),
            path: ObjectPath::Pdi,
        }),
        _ => None,
    }
}
