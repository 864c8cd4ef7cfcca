//! The drive's housekeeping from the Gains tab: Store ("save" to 1010h:01), Factory values
//! ("load" to 1011h:01, then a restart) and Restart ("boot" to 2800h:01), each asked with a
//! plain sentence first. After a restart the worker reconnects by itself; the tab says when
//! the drive is back and whether the gains and limits came back as they were before it.
//!
//! A model: no egui here.

use super::model::{DEFAULTS, GainsPanel, REBOOT, STORE};
use crate::od::{Address, DataType, Value};
use crate::worker::{Event, ObjectPath, Request};

/// "save", "load" and "boot" in ASCII, read as little-endian u32.
const SAVE: u64 = 0x6576_6173;
const LOAD: u64 = 0x6461_6F6C;
const BOOT: u64 = 0x746F_6F62;

/// What the user may ask of the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Housekeeping {
    Store,
    Defaults,
    Reboot,
}

impl Housekeeping {
    /// The plain sentence asked before it is done.
    pub fn question(self) -> &'static str {
        match self {
            Housekeeping::Store => {
                "Store every value as it is now? The drive keeps them through a power cycle \
                 (\"save\" to 1010h:01)."
            }
            Housekeeping::Defaults => {
                "Restore the factory values? Everything stored is replaced by the factory's \
                 and the drive restarts: it stops and is gone for a moment (\"load\" to \
                 1011h:01, then \"boot\" to 2800h:01)."
            }
            Housekeeping::Reboot => {
                "Restart the drive? Its power stage goes off (the motor coasts), it is gone \
                 for a moment and comes back with the stored values (\"boot\" to 2800h:01)."
            }
        }
    }

    pub fn button(self) -> &'static str {
        match self {
            Housekeeping::Store => "Store",
            Housekeeping::Defaults => "Restore factory values",
            Housekeeping::Reboot => "Restart drive",
        }
    }
}

/// A restart under way: the values before it, when it was sent, what happened since.
#[derive(Clone, Debug, PartialEq)]
pub struct Restart {
    /// Each row's value before the restart.
    before: Vec<(Address, Option<Value>)>,
    /// The worker's time when the restart was sent.
    sent_t: Option<f64>,
    /// The factory values were asked for.
    defaults: bool,
    /// The link went down (the drive did restart).
    lost: bool,
    /// Reconnected: waiting for the first sample, then for the reading.
    back: bool,
    back_t: Option<f64>,
}

fn write(address: Address, value: u64) -> Request {
    Request::WriteObject {
        address,
        dtype: DataType::Unsigned32,
        value: Value::Uint(value),
        path: ObjectPath::Auto,
    }
}

impl GainsPanel {
    /// Ask the user first.
    pub fn ask(&mut self, what: Housekeeping) {
        self.asking = Some(what);
    }

    /// The user said no.
    pub fn decline(&mut self) {
        self.asking = None;
    }

    /// The user said yes: the write is sent.
    pub fn agree(&mut self) {
        let Some(what) = self.asking.take() else {
            return;
        };
        if !self.connected {
            self.message = Some(Err("not connected: nothing sent".into()));
            return;
        }
        // The last outcome goes: what is said next is this one's.
        self.message = Some(Ok(match what {
            Housekeeping::Store => "storing…".into(),
            Housekeeping::Defaults => "restoring the factory values…".into(),
            Housekeeping::Reboot => "restarting the drive…".into(),
        }));
        match what {
            Housekeeping::Store => self
                .requests
                .push((STORE, write(Address::new(0x1010, 1), SAVE))),
            Housekeeping::Defaults => self
                .requests
                .push((DEFAULTS, write(Address::new(0x1011, 1), LOAD))),
            Housekeeping::Reboot => self.send_restart(false),
        }
    }

    /// Whether a restart is under way.
    pub fn restarting(&self) -> bool {
        self.restart.is_some()
    }

    fn send_restart(&mut self, defaults: bool) {
        self.restart = Some(Restart {
            before: self
                .rows
                .iter()
                .map(|r| (r.address, r.value.clone()))
                .collect(),
            sent_t: self.last_t,
            defaults,
            lost: false,
            back: false,
            back_t: None,
        });
        self.message = Some(Ok("restarting the drive…".into()));
        self.requests
            .push((REBOOT, write(Address::new(0x2800, 1), BOOT)));
    }

    /// A reply to a housekeeping write; `true`: the request is over.
    pub(super) fn housekeeping_reply(&mut self, tag: u64, event: &Event) -> bool {
        let result = match event {
            Event::ObjectWritten { result, .. } => result.as_ref().map_err(|e| e.to_string()),
            Event::Rejected { reason, .. } => Err(reason.to_string()),
            _ => return false,
        };
        match (tag, result) {
            (STORE, Ok(())) => {
                self.message = Some(Ok(
                    "stored: the values as they are now come back at the next power-on".into(),
                ));
            }
            (DEFAULTS, Ok(())) => self.send_restart(true),
            (REBOOT, Ok(())) => {}
            // The drive may restart before it answers: the link's loss says it did.
            (REBOOT, Err(_)) if self.restart.as_ref().is_some_and(|r| r.lost) => {}
            (_, Err(why)) => {
                if tag == REBOOT {
                    self.restart = None;
                }
                let what = match tag {
                    STORE => "store",
                    DEFAULTS => "restore the factory values",
                    _ => "restart",
                };
                self.message = Some(Err(format!("the drive did not {what}: {why}")));
            }
            _ => {}
        }
        true
    }

    pub(super) fn link_gone(&mut self) {
        if let Some(restart) = self.restart.as_mut() {
            restart.lost = true;
            self.message = Some(Ok(
                "the drive restarts: reconnecting when it answers again…".into(),
            ));
        }
    }

    pub(super) fn reconnected(&mut self) {
        if let Some(restart) = self.restart.as_mut().filter(|r| r.lost) {
            restart.back = true;
        }
    }

    pub(super) fn sample_after_restart(&mut self, t: f64) {
        if let Some(restart) = self
            .restart
            .as_mut()
            .filter(|r| r.back && r.back_t.is_none())
        {
            restart.back_t = Some(t);
        }
    }

    /// The reading after the reconnection is complete: say when the drive came back and
    /// whether its values did.
    pub(super) fn read_after_restart(&mut self) {
        let Some(restart) = self.restart.as_ref().filter(|r| r.back) else {
            return;
        };
        let Some(restart) = Some(restart.clone()).filter(|_| self.connected) else {
            return;
        };
        self.restart = None;
        let after = match (restart.sent_t, restart.back_t) {
            (Some(sent), Some(back)) if back >= sent => format!(" after {:.1} s", back - sent),
            _ => String::new(),
        };
        let changed: Vec<String> = restart
            .before
            .iter()
            .filter_map(|(address, before)| {
                let row = self.row(*address)?;
                (before.is_some() && row.value.is_some() && row.value != *before).then(|| {
                    format!(
                        "{address} is {} (was {})",
                        row.value.as_ref().map(Value::to_string).unwrap_or_default(),
                        before.as_ref().map(Value::to_string).unwrap_or_default()
                    )
                })
            })
            .collect();
        let shown = |list: &[String]| {
            let mut text = list.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
            if list.len() > 4 {
                text.push_str(&format!(" and {} more", list.len() - 4));
            }
            text
        };
        self.message = Some(match (restart.defaults, changed.is_empty()) {
            (false, true) => Ok(format!(
                "the drive is back{after}: every gain and limit came back as it was"
            )),
            (false, false) => Err(format!(
                "the drive is back{after}, but {} value(s) did not come back (not stored): {}",
                changed.len(),
                shown(&changed)
            )),
            (true, true) => Ok(format!(
                "the drive is back{after} with the factory values: no gain or limit differed from them"
            )),
            (true, false) => Ok(format!(
                "the drive is back{after} with the factory values: {} changed, {}",
                changed.len(),
                shown(&changed)
            )),
        });
    }
}
