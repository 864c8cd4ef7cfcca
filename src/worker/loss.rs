//! When exchanges fail: counting the failures in a row, naming them (and the troubles the
//! link got over by itself) in the log at a bounded rate, deciding when the link counts
//! as lost, and the last try to stop a move that runs when it is.

use super::Config;
use super::protocol::{
    CommandProgress, Event, HALT_ON_LOSS_TIMEOUT, LinkLossAction, MAX_LOST_AFTER, RequestId,
    WORKER_ID,
};
use super::session::Session;
use super::sink::EventSink;
use crate::link::Notice;
use crate::link::{self, Link};
use crate::pdi::{Action, RxImage, StatusBit};

/// How often a connection that closed or reset under a session is tried again
/// (`Config::reconnect_in_session`); each try that fails is one failed exchange.
pub const REOPEN_EVERY: std::time::Duration = std::time::Duration::from_millis(250);

/// How long the last stop on a lost link may take to open a dead connection again
/// before it is sent.
const REOPEN_FOR_LAST_STOP: std::time::Duration = std::time::Duration::from_secs(1);

impl Session {
    /// The connection closed or reset under the session and its time to be opened
    /// again has come: `Ok(true)` when it is open again (said in the log, with a fault
    /// the drive latched meanwhile), `Ok(false)` while it is not yet time, `Err` when
    /// opening failed (one failed exchange).
    pub(super) async fn reopen(&mut self, sink: &mut EventSink) -> Result<bool, link::Error> {
        let Some(at) = self.reopen_at else {
            return Ok(true);
        };
        if super::clock::now() < at {
            return Ok(false);
        }
        self.link.reconnect().await?;
        // The first exchange on the new connection says what the drive holds now.
        let exchange = self.link.exchange(self.master.outgoing().as_ref()).await?;
        self.reopen_at = None;
        let why = self.reopen_why.take().unwrap_or_default();
        let tx = exchange.tx;
        let latched = if tx.status.is_set(StatusBit::Fault) {
            format!(
                "; the drive latched a fault meanwhile: 603Fh = {} (clear its cause, then Clear Error)",
                crate::cia::ErrorCode(tx.error_code)
            )
        } else {
            String::new()
        };
        sink.emit(Event::Notice(Notice::info(format!(
            "the connection to the drive was opened again after {} failed exchange(s) ({why}); the session goes on{latched}",
            self.failures
        ))));
        self.master.on_tx(tx, super::clock::now());
        self.master.poll(super::clock::now());
        self.report_progress(sink);
        Ok(true)
    }

    /// An exchange went through: a run of failed ones before it is over (and said so).
    pub(super) fn exchange_succeeded(&mut self, sink: &mut EventSink) {
        if self.failures > 0 {
            self.failure_notices.say(
                format!(
                    "the link recovered after {} failed exchange(s) in a row",
                    self.failures
                ),
                sink,
            );
            self.failures = 0;
        }
    }

    /// An exchange failed: counted (its frames come before any message about it).
    /// Whether the link now counts as lost; if not, the next cycle tries again.
    pub(super) fn exchange_failed(
        &mut self,
        error: &link::Error,
        config: &Config,
        sink: &mut EventSink,
    ) -> bool {
        self.trace_out(sink);
        self.errors += 1;
        self.failures += 1;
        let lost_after = config.lost_after.clamp(1, MAX_LOST_AFTER);
        if config.reconnect_in_session
            && !error.is_momentary()
            && error.is_transient()
            && self.failures < lost_after
        {
            // The connection itself closed or reset: open it again in place, at once the
            // first time (a server reachable again at once costs one failed exchange).
            let first = self.reopen_at.is_none() && self.reopen_why.is_none();
            let now = super::clock::now();
            self.reopen_at = Some(if first { now } else { now + REOPEN_EVERY });
            if first {
                self.reopen_why = Some(error.to_string());
                self.failure_notices.say(
                    format!(
                        "the connection to the drive failed: {error}; opening it again (the link counts as lost after {lost_after} failures in a row)"
                    ),
                    sink,
                );
            }
            return false;
        }
        if error.is_momentary() && self.failures < lost_after {
            if self.failures == 1 {
                self.failure_notices.say(
                    format!(
                        "an exchange with the drive failed: {error}; trying again (the link counts as lost after {lost_after} failures in a row)"
                    ),
                    sink,
                );
            }
            return false;
        }
        true
    }

    /// The link is lost: why, in words, with what the last try to stop a move that runs
    /// (as `action` says) did.
    pub(super) async fn lost(
        &mut self,
        error: &link::Error,
        action: LinkLossAction,
        sink: &mut EventSink,
    ) -> String {
        let reason = if self.failures > 1 {
            format!(
                "{} exchanges failed in a row; the last: {error}",
                self.failures
            )
        } else {
            error.to_string()
        };
        if self.jog_deadline.is_some() || self.master.travel_running() {
            // What the technician must do first; the protocol's detail after it.
            let stop = self.stop_on_loss(&reason, action, sink).await;
            format!(
                "{}. Cause: {reason}{}",
                stop.headline,
                stop.detail_tail(&reason)
            )
        } else {
            reason
        }
    }

    /// Troubles the link got over by itself (a reply lost or corrupted, then answered on
    /// another try): counted for the health line, named in the log at a bounded rate.
    pub(super) fn report_recovered(&mut self, sink: &mut EventSink) {
        for trouble in self.link.take_recovered() {
            self.recovered += 1;
            self.recovery_notices.say(format!("link: {trouble}"), sink);
        }
    }

    /// The link failed during a move: one last try to halt (or switch off) the drive, as
    /// the setting says. Returns what was done, honestly (for the messages of the link
    /// loss and of the commands it ends); the commands that ran end here.
    async fn stop_on_loss(
        &mut self,
        reason: &str,
        action: LinkLossAction,
        sink: &mut EventSink,
    ) -> LastStop {
        self.jog_deadline = None;
        let running: Vec<RequestId> = [self.master.pending_tag(), self.master.background_tag()]
            .into_iter()
            .flatten()
            .collect();
        let made = match action {
            LinkLossAction::Halt => Some(self.master.halt(WORKER_ID, super::clock::now())),
            LinkLossAction::SwitchOff => Some(self.master.start(
                WORKER_ID,
                Action::SwitchOff,
                super::clock::now(),
            )),
            LinkLossAction::Nothing => None,
        };
        // The commands that ran end with the link, not "superseded" by this last try.
        let _ = self.master.drain_progress();
        let what = if action == LinkLossAction::Halt {
            "a halt"
        } else {
            "a switch-off"
        };
        let stop = match made {
            None => LastStop::moving("as set, the drive is left alone".to_owned(), None),
            Some(Err(e)) => {
                LastStop::moving(format!("no {what} could be made"), Some(e.to_string()))
            }
            Some(Ok(image)) => self.send_last_stop(&image, action, what).await,
        };
        // A travel command stopped at a limit switch is still running for the PDI, but
        // the motor stood: say so rather than "during a move".
        let at_limit = self
            .master
            .last_tx()
            .is_some_and(|tx| tx.status.is_set(StatusBit::LimitReached));
        let during = if at_limit {
            "while a travel command stood at a limit switch"
        } else {
            "during a move"
        };
        // The words a technician must act on lead; the protocol's detail comes last, so
        // that a line cut short by the window still says what to do.
        sink.emit(Event::Notice(Notice::motor_stopped(format!(
            "{}; the link failed {during}. Cause: {reason}{}",
            stop.headline,
            stop.detail_tail(reason)
        ))));
        let ended = format!(
            "{}. Cause: {reason}{}",
            stop.headline,
            stop.detail_tail(reason)
        );
        for id in running {
            self.purposes.remove(&id);
            sink.emit(Event::Progress {
                id,
                progress: CommandProgress::LinkLost {
                    reason: ended.clone(),
                },
            });
        }
        stop
    }

    /// Send the last halt or switch-off (`what`) once, within [`HALT_ON_LOSS_TIMEOUT`]:
    /// what came of it.
    async fn send_last_stop(
        &mut self,
        image: &RxImage,
        action: LinkLossAction,
        what: &str,
    ) -> LastStop {
        // A connection known dead (closed or reset) is opened again first: a stop written
        // to a dead socket never reaches the drive.
        let mut reopened = false;
        if self.reopen_at.is_some() || self.reopen_why.is_some() {
            reopened = matches!(
                tokio::time::timeout(REOPEN_FOR_LAST_STOP, self.link.reconnect()).await,
                Ok(Ok(()))
            );
        }
        let mut attempt =
            tokio::time::timeout(HALT_ON_LOSS_TIMEOUT, self.link.exchange(Some(image))).await;
        if !reopened
            && let Ok(Err(e)) = &attempt
            && !e.is_momentary()
            && e.is_transient()
            && matches!(
                tokio::time::timeout(REOPEN_FOR_LAST_STOP, self.link.reconnect()).await,
                Ok(Ok(()))
            )
        {
            reopened = true;
            attempt =
                tokio::time::timeout(HALT_ON_LOSS_TIMEOUT, self.link.exchange(Some(image))).await;
        }
        let over = if reopened {
            " over a new connection"
        } else {
            ""
        };
        match attempt {
            Ok(Ok(exchange)) => {
                let status = exchange.tx.status;
                let confirmed = match action {
                    LinkLossAction::Halt => status.is_set(StatusBit::QsHaltBit),
                    _ => !status.is_set(StatusBit::OperationEnabled),
                };
                if confirmed {
                    LastStop::done(format!("{what} was sent{over} and the drive confirmed it"))
                } else {
                    LastStop::done(format!(
                        "{what} was sent{over} and the drive answered, without showing it yet"
                    ))
                }
            }
            // A timeout or replies that made no sense: the request may have gone out, but
            // nothing confirmed it.
            Ok(Err(e)) if e.is_momentary() => LastStop::moving(
                format!("{what} was sent, but no answer confirmed it"),
                Some(e.to_string()),
            ),
            Ok(Err(e)) => LastStop::moving(
                format!("{what} did not reach the drive"),
                Some(e.to_string()),
            ),
            Err(_) => LastStop::moving(
                format!(
                    "{what} got no answer within {:.1} s",
                    HALT_ON_LOSS_TIMEOUT.as_secs_f64()
                ),
                None,
            ),
        }
    }
}

/// What the last try to stop a move did when the link failed: the words that lead (what
/// to do when the drive may still be moving), and the protocol's detail for the end.
#[derive(Debug)]
struct LastStop {
    headline: String,
    detail: Option<String>,
}

impl LastStop {
    /// Nothing confirmed a stop: the technician must stop the drive themselves.
    fn moving(outcome: String, detail: Option<String>) -> LastStop {
        LastStop {
            headline: format!("Stop the drive at the machine: it may still be moving ({outcome})"),
            detail,
        }
    }

    /// The drive answered the last try.
    fn done(outcome: String) -> LastStop {
        let mut chars = outcome.chars();
        let headline = match chars.next() {
            Some(first) => first.to_uppercase().chain(chars).collect(),
            None => outcome,
        };
        LastStop {
            headline,
            detail: None,
        }
    }

    /// The last try's own error, after the cause `reason` (unless it says the same).
    fn detail_tail(&self, reason: &str) -> String {
        self.detail
            .as_ref()
            .filter(|d| !reason.contains(d.as_str()))
            .map(|d| format!("; the last try: {d}"))
            .unwrap_or_default()
    }
}
