//! The worker's loop: wait for a request or the next cycle, run the session's cycle,
//! connect, lose the link, reconnect with backoff.

use std::time::{Duration, Instant};

use tokio::sync::mpsc;
use tokio::time::MissedTickBehavior;

use super::cycle::OBJECT_SHARE_OF_CYCLE;
use super::protocol::Event;
use super::session::Session;
use super::sink::EventSink;
use super::{Config, Envelope};
use crate::connect::{self, AnyLink};
use crate::link::Notice;
use crate::link::{self, Link, LinkFailure, LinkSpec};
use crate::od::{Address, DataType};

/// Reconnect backoff.
pub(super) const BACKOFF_FIRST: Duration = Duration::from_millis(250);
const BACKOFF_MAX: Duration = Duration::from_secs(5);

/// The worker's state between requests: the settings, the link wanted, the session on
/// it (if one is open), the reconnect schedule.
pub(super) struct Supervisor {
    pub(super) config: Config,
    /// The link the user asked for; kept while reconnecting.
    pub(super) wanted: Option<LinkSpec>,
    pub(super) session: Option<Session>,
    /// A link that failed, kept so that reconnecting reaches the same device (and, for
    /// the simulator, the same simulated drive).
    broken: Option<AnyLink>,
    pub(super) retry_at: Option<Instant>,
    pub(super) backoff: Duration,
    pub(super) ticker: tokio::time::Interval,
    /// The objects sampled on request, kept across reconnects.
    pub(super) watch: Vec<(Address, DataType)>,
    /// Time zero of every sample and marker: the first connection's start, kept for the
    /// worker's whole life (not per connection), so the window's plots and fault
    /// timeline keep one time axis across reconnects and a new connection's samples come
    /// after the old ones.
    epoch: Option<Instant>,
}

/// The worker's whole life.
pub async fn run(
    config: Config,
    mut requests: mpsc::Receiver<Envelope>,
    mut urgent: mpsc::Receiver<Envelope>,
    sink: &mut EventSink,
) {
    let mut w = Supervisor {
        config,
        wanted: None,
        session: None,
        broken: None,
        retry_at: None,
        backoff: BACKOFF_FIRST,
        ticker: new_ticker(config.poll_rate),
        watch: Vec::new(),
        epoch: config.epoch,
    };
    loop {
        tokio::select! {
            biased;
            message = urgent.recv() => {
                let Some((id, request)) = message else { break };
                w.handle(id, request, sink).await;
            }
            message = requests.recv() => {
                let Some((id, request)) = message else { break };
                w.handle(id, request, sink).await;
            }
            _ = w.ticker.tick() => w.tick(sink).await,
        }
        sink.flush();
        sink.wake();
        if sink.closed {
            break;
        }
    }
    if let Some(mut s) = w.session.take() {
        close_link(&mut s.link, w.config.trace, sink).await;
        sink.flush();
    }
}

/// Close a link politely, and say what closing did (a mapping put back) or why it failed.
/// With `trace`, the frames closing took come first.
pub(super) async fn close_link(link: &mut AnyLink, trace: bool, sink: &mut EventSink) {
    let closed = link.close().await;
    if trace {
        let frames = link.take_trace();
        if !frames.is_empty() {
            sink.emit(Event::Frames(frames));
        }
    }
    for notice in link.take_notices() {
        sink.emit(Event::Notice(notice));
    }
    if let Err(e) = closed {
        sink.emit(Event::Notice(Notice::info(format!(
            "closing the link did not finish: {e}"
        ))));
    }
}

pub(super) fn new_ticker(rate: f64) -> tokio::time::Interval {
    let period = Duration::from_secs_f64(1.0 / rate.clamp(1.0, 2000.0));
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(MissedTickBehavior::Skip);
    ticker
}

impl Supervisor {
    /// One cycle of the session, or, without one, a reconnect when its time has come.
    async fn tick(&mut self, sink: &mut EventSink) {
        let Some(s) = self.session.as_mut() else {
            if let (Some(spec), Some(at)) = (self.wanted.clone(), self.retry_at)
                && super::clock::now() >= at
            {
                self.connect(&spec, sink).await;
            }
            return;
        };
        s.halt_stale_jog(sink);
        match s.reopen(sink).await {
            Ok(true) => {}
            Ok(false) => return,
            Err(error) => {
                if s.exchange_failed(&error, &self.config, sink) {
                    self.lose_session(error, sink).await;
                }
                return;
            }
        }
        let Some(s) = self.session.as_mut() else {
            return;
        };
        let budget = Duration::from_secs_f64(
            OBJECT_SHARE_OF_CYCLE / self.config.poll_rate.clamp(1.0, 2000.0),
        );
        let result = s.cycle(sink, budget).await;
        s.report_recovered(sink);
        match result {
            Ok(()) => s.exchange_succeeded(sink),
            Err(error) => {
                if s.exchange_failed(&error, &self.config, sink) {
                    self.lose_session(error, sink).await;
                }
            }
        }
    }

    /// The link counts as lost: end the session, and reconnect later where that may help.
    async fn lose_session(&mut self, error: link::Error, sink: &mut EventSink) {
        let Some(mut s) = self.session.take() else {
            return;
        };
        let spec = s.link.info().spec;
        let reason = s.lost(&error, self.config.on_link_loss, sink).await;
        s.abandon_all(&reason, sink);
        sink.emit(Event::Disconnected {
            reason: Some(reason.clone()),
        });
        if self.config.reconnect && error.is_transient() {
            self.broken = Some(s.link);
            self.backoff = BACKOFF_FIRST;
            self.retry_at = Some(super::clock::now() + self.backoff);
            sink.emit(Event::ConnectFailed {
                spec,
                error: LinkFailure::new(&error, reason),
                retry_in: Some(self.backoff),
            });
        } else {
            close_link(&mut s.link, self.config.trace, sink).await;
            self.wanted = None;
        }
    }

    /// Close the session and forget a broken link.
    pub(super) async fn close(&mut self, reason: Option<&str>, sink: &mut EventSink) {
        if let Some(mut s) = self.session.take() {
            close_link(&mut s.link, self.config.trace, sink).await;
            s.abandon_all(reason.unwrap_or("closed"), sink);
            if reason.is_some_and(|r| r != "disconnected") {
                sink.emit(Event::Disconnected { reason: None });
            }
        }
        if let Some(mut link) = self.broken.take() {
            close_link(&mut link, self.config.trace, sink).await;
        }
    }

    /// Open the wanted link, or bring a broken one back.
    pub(super) async fn connect(&mut self, spec: &LinkSpec, sink: &mut EventSink) {
        sink.emit(Event::Connecting(spec.clone()));
        if self.config.simulated_time && *spec != LinkSpec::Sim {
            let error = link::Error::Unsupported(format!(
                "{spec} cannot run on simulated time (only the in-process simulator can)"
            ));
            self.connect_failed(spec, error, sink);
            return;
        }
        match self.open(spec, sink).await {
            Ok(s) => self.adopt(s, sink),
            Err((error, frames)) => {
                // The frames of a connection that failed come before its message.
                if self.config.trace && !frames.is_empty() {
                    sink.emit(Event::Frames(frames));
                }
                self.connect_failed(spec, error, sink);
            }
        }
    }

    /// A session on the broken link brought back, or on a new one.
    async fn open(&mut self, spec: &LinkSpec, sink: &mut EventSink) -> link::Traced<Session> {
        match self.broken.take() {
            Some(mut link) => match link.reconnect().await {
                Ok(()) => Session::start(link, &self.config, &self.watch, self.epoch, sink).await,
                Err(e) => {
                    let trace = link.take_trace();
                    self.broken = Some(link);
                    Err((e, trace))
                }
            },
            None => match connect::open_traced(spec).await {
                Ok(link) => Session::start(link, &self.config, &self.watch, self.epoch, sink).await,
                Err(failed) => Err(failed),
            },
        }
    }

    /// Connected: tell the window, and run the session from the next tick.
    fn adopt(&mut self, mut s: Session, sink: &mut EventSink) {
        // What connecting took (PDO mapping, for one) comes before the news of it.
        s.trace_out(sink);
        sink.emit(Event::Connected(s.link.info()));
        sink.emit(Event::LinkOwnChanges(s.link.own_changes()));
        self.epoch.get_or_insert(s.epoch);
        // What the link learned.
        for notice in s.link.take_notices() {
            sink.emit(Event::Notice(notice));
        }
        self.session = Some(s);
        self.retry_at = None;
        self.backoff = BACKOFF_FIRST;
    }

    /// Connecting failed: tell the window, and try again after the backoff where that
    /// may help.
    fn connect_failed(&mut self, spec: &LinkSpec, error: link::Error, sink: &mut EventSink) {
        let retry_in = (self.config.reconnect && error.is_transient()).then_some(self.backoff);
        sink.emit(Event::ConnectFailed {
            spec: spec.clone(),
            error: LinkFailure::from(&error),
            retry_in,
        });
        self.retry_at = retry_in.map(|d| super::clock::now() + d);
        if retry_in.is_none() {
            self.broken = None;
        }
        self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
    }
}
