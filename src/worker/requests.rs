//! What the worker does with each request: a short dispatch to one function per kind,
//! grouped as the connection, the settings, the jog, the sampled objects, finding
//! devices, the queued jobs and the simulator's faults.

use super::cycle::WatchState;
use super::protocol::{
    Event, HALT_ON_LOSS_TIMEOUT, LinkLossAction, MAX_LOST_AFTER, MAX_WATCHED, Rejection, Request,
    RequestId,
};
use super::session::Session;
use super::sink::EventSink;
use super::supervisor::{BACKOFF_FIRST, Supervisor, new_ticker};
use crate::connect;
use crate::injection::Injection;
use crate::link::Notice;
use crate::link::{self, Link, LinkFailure, LinkSpec};
use crate::od::{Address, DataType};

impl Supervisor {
    pub(super) async fn handle(&mut self, id: RequestId, request: Request, sink: &mut EventSink) {
        match request {
            Request::Connect(spec) => self.connect_to(spec, sink).await,
            Request::Disconnect => self.disconnect(sink).await,
            Request::SetTrace(on) => self.set_trace(on),
            Request::SetLinkLoss(action) => self.set_link_loss(action),
            Request::SetLostAfter(n) => self.set_lost_after(id, &request, n, sink),
            Request::SetPollRate(rate) => self.set_poll_rate(id, &request, rate, sink),
            Request::Jog { speed } => {
                if let Some(s) = self.session_or_reject(id, &request, sink) {
                    s.jog(id, speed, sink);
                }
            }
            Request::JogKeepAlive => {
                if let Some(s) = self.session.as_mut() {
                    s.keep_jogging();
                }
            }
            Request::JogStop => {
                if let Some(s) = self.session_or_reject(id, &request, sink) {
                    s.jog_stop(id, sink);
                }
            }
            Request::Watch(ref objects) => self.set_watch(id, &request, objects, sink),
            Request::Scan(spec) => self.scan(id, spec, sink).await,
            Request::ListSerialPorts => sink.emit(Event::SerialPorts(link::serial_ports())),
            Request::ListInterfaces => {
                sink.emit(Event::Interfaces(link::enip::discovery::interfaces()))
            }
            Request::Discover {
                interface,
                host,
                port,
            } => discover(id, interface, host, port, sink).await,
            Request::ReadMany { ref objects, path } => {
                if let Some(s) = self.session_or_reject(id, &request, sink) {
                    s.queue_reads(id, &request, objects, path, sink);
                }
            }
            Request::Cancel(cancelled) => self.cancel(cancelled, sink),
            Request::Inject { injection, active } => {
                if let Some(s) = self.session_or_reject(id, &request, sink) {
                    inject(s, id, &request, injection, active, sink);
                }
            }
            _ => {
                if let Some(s) = self.session_or_reject(id, &request, sink) {
                    s.enqueue(id, request, sink);
                }
            }
        }
    }

    /// The session, or `None` with the request refused: not connected.
    fn session_or_reject(
        &mut self,
        id: RequestId,
        request: &Request,
        sink: &mut EventSink,
    ) -> Option<&mut Session> {
        if self.session.is_none() {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::NotConnected,
            });
        }
        self.session.as_mut()
    }

    async fn connect_to(&mut self, spec: LinkSpec, sink: &mut EventSink) {
        self.close(Some("the link was closed for a new connection"), sink)
            .await;
        self.wanted = Some(spec.clone());
        self.backoff = BACKOFF_FIRST;
        self.connect(&spec, sink).await;
    }

    async fn disconnect(&mut self, sink: &mut EventSink) {
        // A command just given (the halt or switch-off of leaving) reaches the drive
        // before the link closes.
        if let Some(s) = self.session.as_mut()
            && s.master.is_awaiting_ack()
        {
            let outgoing = s.master.outgoing();
            let _ = tokio::time::timeout(HALT_ON_LOSS_TIMEOUT, s.link.exchange(outgoing.as_ref()))
                .await;
        }
        self.close(Some("disconnected"), sink).await;
        self.wanted = None;
        self.retry_at = None;
        sink.emit(Event::Disconnected { reason: None });
    }

    fn set_trace(&mut self, on: bool) {
        self.config.trace = on;
        if let Some(s) = self.session.as_mut() {
            s.trace = on;
            // Start from now: older frames are not news.
            let _ = s.link.take_trace();
        }
    }

    fn set_link_loss(&mut self, action: LinkLossAction) {
        self.config.on_link_loss = action;
    }

    fn set_lost_after(&mut self, id: RequestId, request: &Request, n: u32, sink: &mut EventSink) {
        if (1..=MAX_LOST_AFTER).contains(&n) {
            self.config.lost_after = n;
        } else {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(format!(
                    "the link can count as lost after 1 to {MAX_LOST_AFTER} failed exchanges in a row, not {n}"
                )),
            });
        }
    }

    fn set_poll_rate(&mut self, id: RequestId, request: &Request, rate: f64, sink: &mut EventSink) {
        if rate.is_finite() && (1.0..=2000.0).contains(&rate) {
            self.config.poll_rate = rate;
            self.ticker = new_ticker(rate);
        } else {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(format!(
                    "a poll rate of {rate} Hz is outside 1 to 2000 Hz"
                )),
            });
        }
    }

    /// The objects to sample besides the built-in signals, kept across reconnects.
    fn set_watch(
        &mut self,
        id: RequestId,
        request: &Request,
        objects: &[(Address, DataType)],
        sink: &mut EventSink,
    ) {
        if objects.len() > MAX_WATCHED {
            sink.emit(Event::Rejected {
                id,
                request: request.to_string(),
                reason: Rejection::Refused(format!(
                    "at most {MAX_WATCHED} objects can be sampled besides the built-in signals"
                )),
            });
            return;
        }
        self.watch = objects.to_vec();
        if let Some(s) = self.session.as_mut() {
            s.watch = WatchState::new(objects);
            if !s.native_objects {
                sink.emit(Event::Notice(Notice::info(
                    "this link has no object access of its own: added objects are sampled only where its process image carries them",
                )));
            }
        }
    }

    /// Find the devices on a bus: through the open link where it is on that bus.
    async fn scan(&mut self, id: RequestId, spec: LinkSpec, sink: &mut EventSink) {
        let same_bus = self
            .session
            .as_ref()
            .is_some_and(|s| same_bus(&s.link.info().spec, &spec));
        let result = match self.session.as_mut() {
            Some(s) if same_bus => s.link.scan().await,
            _ => {
                let (result, frames) = connect::scan_traced(&spec, self.config.trace).await;
                if !frames.is_empty() {
                    sink.emit(Event::Frames(frames));
                }
                result
            }
        };
        sink.emit(Event::Scanned {
            id,
            result: result.map_err(LinkFailure::from),
        });
    }

    fn cancel(&mut self, cancelled: RequestId, sink: &mut EventSink) {
        let dropped = self.session.as_mut().map_or(0, |s| s.cancel(cancelled));
        sink.emit(Event::Cancelled {
            id: cancelled,
            dropped,
        });
    }
}

/// Whether two connection strings name the same physical bus (the node may differ).
fn same_bus(a: &LinkSpec, b: &LinkSpec) -> bool {
    match (a, b) {
        (LinkSpec::CanopenSlcan { path: x, .. }, LinkSpec::CanopenSlcan { path: y, .. }) => x == y,
        (
            LinkSpec::CanopenSocketcan { iface: x, .. },
            LinkSpec::CanopenSocketcan { iface: y, .. },
        ) => x == y,
        (LinkSpec::CanopenSim { .. }, LinkSpec::CanopenSim { .. }) => true,
        _ => false,
    }
}

/// Find EtherNet/IP adapters.
async fn discover(
    id: RequestId,
    interface: Option<String>,
    host: Option<String>,
    port: u16,
    sink: &mut EventSink,
) {
    let discovery = link::enip::discovery::Discovery {
        port,
        interface,
        unicast: host.into_iter().collect(),
        ..Default::default()
    };
    let result = link::enip::discovery::discover(&discovery).await;
    sink.emit(Event::Scanned {
        id,
        result: result.map_err(LinkFailure::from),
    });
}

/// Inject or withdraw a fault on the simulated drive.
fn inject(
    s: &mut Session,
    id: RequestId,
    request: &Request,
    injection: Injection,
    active: bool,
    sink: &mut EventSink,
) {
    match s.link.inject(injection, active) {
        Ok(()) => sink.emit(Event::Notice(Notice::info(format!(
            "{request}: {}",
            injection.describe()
        )))),
        Err(e) => sink.emit(Event::Rejected {
            id,
            request: request.to_string(),
            reason: Rejection::Refused(e.to_string()),
        }),
    }
}
