//! The Gains tab's model: the controller's gains and the limits that shape a response
//! (`od::gains`), each with its value as read from the drive, its unit, its type's range
//! and its factory value; an edit checked as it is typed, confirmed before it is written,
//! read again after; every write reaches the Changes tab (and its undo) like any other.
//!
//! A model: no egui here.

use crate::od::{Address, DataType, Entry, Value, builtin, gains};
use crate::ui::browser::parse_edit;
use crate::ui::panel::PanelModel;
use crate::worker::{Event, ObjectPath, Request};

/// The tag of the reading of every row.
const READ: u64 = 1;
/// The tag of a write (one at a time).
const WRITE: u64 = 2;
/// The tags of the housekeeping writes (`housekeeping.rs`).
pub(super) const STORE: u64 = 3;
pub(super) const DEFAULTS: u64 = 4;
pub(super) const REBOOT: u64 = 5;

/// One gain or limit.
#[derive(Clone, Debug, PartialEq)]
pub struct GainRow {
    pub address: Address,
    pub group: &'static str,
    /// The object's name where it has subindices ("Motor Drive Parameter Set"), else "".
    pub object: String,
    /// The subindex's name (or the object's, for one without subindices).
    pub name: String,
    pub unit: String,
    pub dtype: DataType,
    /// The value the drive gave when last read.
    pub value: Option<Value>,
    /// Why it could not be read (another firmware's parameter set: "not on this drive").
    pub refused: Option<String>,
    pub factory: Option<Value>,
    /// The type's range, in words.
    pub range: String,
}

/// An edit in hand: the text typed and, once it parses, the value.
#[derive(Clone, Debug, PartialEq)]
pub struct GainEdit {
    pub address: Address,
    pub text: String,
    /// Why the text is not a value for the object (shown as it is typed).
    pub error: Option<String>,
    /// The user pressed Enter: the write waits for the confirmation.
    pub confirming: Option<Value>,
    /// The box is to take the keyboard (once, when the edit starts).
    pub focus: bool,
}

/// The Gains tab of one drive.
#[derive(Debug)]
pub struct GainsPanel {
    pub rows: Vec<GainRow>,
    pub edit: Option<GainEdit>,
    /// Rows still to be answered in the reading under way.
    pub reading: usize,
    /// The last write's outcome, in words (`Err`: it failed).
    pub message: Option<Result<String, String>>,
    /// A write sent and not yet answered.
    pub writing: Option<Address>,
    /// Store, factory values or restart asked for, waiting for the user's yes.
    pub asking: Option<super::housekeeping::Housekeeping>,
    /// A restart under way (`housekeeping.rs`).
    pub(super) restart: Option<super::housekeeping::Restart>,
    /// The newest sample's time (the worker's clock, continuous across reconnects).
    pub(super) last_t: Option<f64>,
    pub(super) connected: bool,
    pub(super) requests: Vec<(u64, Request)>,
}

impl Default for GainsPanel {
    fn default() -> Self {
        let catalog = builtin();
        let rows = gains::addresses()
            .into_iter()
            .map(|address| {
                let entry = catalog.get(address);
                let dtype = entry.map_or(DataType::Unsigned32, |e| e.dtype);
                let full = entry.map_or_else(|| address.to_string(), Entry::full_name);
                let (object, name) = match full.split_once(" / ") {
                    Some((object, name)) => (object.to_owned(), name.to_owned()),
                    None => (String::new(), full),
                };
                GainRow {
                    address,
                    group: gains::group_of(address),
                    object,
                    name,
                    unit: entry.and_then(|e| e.unit.clone()).unwrap_or_default(),
                    dtype,
                    value: None,
                    refused: None,
                    factory: entry.and_then(|e| e.default.clone()),
                    range: dtype
                        .integer_range()
                        .map(|(min, max)| crate::number::range_text(min, max))
                        .unwrap_or_default(),
                }
            })
            .collect();
        GainsPanel {
            rows,
            edit: None,
            reading: 0,
            message: None,
            writing: None,
            asking: None,
            restart: None,
            last_t: None,
            connected: false,
            requests: Vec::new(),
        }
    }
}

impl PanelModel for GainsPanel {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => {
                self.connected = true;
                self.reading = 0;
                self.read_all();
                self.reconnected();
            }
            Event::Disconnected { .. } | Event::ConnectFailed { .. } => {
                self.connected = false;
                self.reading = 0;
                self.writing = None;
                self.link_gone();
            }
            Event::Samples(samples) => {
                if let Some(last) = samples.last() {
                    self.last_t = Some(last.t);
                    self.sample_after_restart(last.t);
                }
            }
            // A write from elsewhere (the dictionary, Changes' undo) shows here too.
            Event::Changed { address, after, .. } => {
                if let Some(row) = self.row_mut(*address) {
                    row.value = Some(after.clone());
                    row.refused = None;
                }
            }
            _ => {}
        }
    }

    fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        match (tag, event) {
            (
                READ,
                Event::ObjectRead {
                    address, result, ..
                },
            ) => {
                if let Some(row) = self.row_mut(*address) {
                    match result {
                        Ok(value) => {
                            row.value = Some(value.clone());
                            row.refused = None;
                        }
                        Err(e) => {
                            row.value = None;
                            row.refused = Some(e.to_string());
                        }
                    }
                }
                self.reading = self.reading.saturating_sub(1);
                if self.reading == 0 {
                    self.read_after_restart();
                }
                self.reading == 0
            }
            (
                WRITE,
                Event::ObjectWritten {
                    address,
                    value,
                    result,
                    ..
                },
            ) => {
                self.writing = None;
                let name = self.row(*address).map_or_else(
                    || address.to_string(),
                    |r| format!("{} {}", r.address, r.name),
                );
                self.message = Some(match result {
                    Ok(()) => {
                        if let Some(row) = self.row_mut(*address) {
                            row.value = Some(value.clone());
                        }
                        // What the drive holds now, not what was sent.
                        self.read_one(*address);
                        Ok(format!(
                            "{name} = {value} written; the Changes tab can undo it"
                        ))
                    }
                    Err(e) => Err(format!("{name}: the drive refused {value}: {e}")),
                });
                true
            }
            (STORE | DEFAULTS | REBOOT, _) => self.housekeeping_reply(tag, event),
            (_, Event::Rejected { reason, .. }) => {
                if tag == WRITE {
                    self.writing = None;
                    self.message = Some(Err(format!("not written: {reason}")));
                } else {
                    self.reading = 0;
                }
                true
            }
            (_, Event::Cancelled { .. }) => {
                self.reading = 0;
                true
            }
            _ => false,
        }
    }

    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        std::mem::take(&mut self.requests)
    }
}

impl GainsPanel {
    pub fn row(&self, address: Address) -> Option<&GainRow> {
        self.rows.iter().find(|r| r.address == address)
    }

    fn row_mut(&mut self, address: Address) -> Option<&mut GainRow> {
        self.rows.iter_mut().find(|r| r.address == address)
    }

    pub fn is_connected(&self) -> bool {
        self.connected
    }

    /// Read every row again.
    pub fn read_all(&mut self) {
        if !self.connected || self.reading > 0 {
            return;
        }
        let objects: Vec<(Address, DataType)> =
            self.rows.iter().map(|r| (r.address, r.dtype)).collect();
        self.reading = objects.len();
        self.requests.push((
            READ,
            Request::ReadMany {
                objects,
                path: ObjectPath::Auto,
            },
        ));
    }

    fn read_one(&mut self, address: Address) {
        if let Some(dtype) = self.row(address).map(|r| r.dtype) {
            self.reading += 1;
            self.requests.push((
                READ,
                Request::ReadMany {
                    objects: vec![(address, dtype)],
                    path: ObjectPath::Auto,
                },
            ));
        }
    }

    /// Start editing a row: the box starts with its value as read.
    pub fn start_edit(&mut self, address: Address) {
        let Some(row) = self.row(address) else {
            return;
        };
        let text = row
            .value
            .as_ref()
            .or(row.factory.as_ref())
            .map(Value::to_string)
            .unwrap_or_default();
        self.edit = Some(GainEdit {
            address,
            text,
            error: None,
            confirming: None,
            focus: true,
        });
    }

    /// The box took the keyboard.
    pub fn focused(&mut self) {
        if let Some(edit) = self.edit.as_mut() {
            edit.focus = false;
        }
    }

    /// What was typed, checked at once against the object's type and limits.
    pub fn typed(&mut self, text: String) {
        let Some(edit) = self.edit.as_mut() else {
            return;
        };
        edit.confirming = None;
        edit.error = if text.trim().is_empty() {
            None
        } else {
            builtin()
                .get(edit.address)
                .map_or(Ok(()), |entry| parse_edit(entry, &text).map(|_| ()))
                .err()
        };
        edit.text = text;
    }

    /// Enter: the value checked, and the confirmation asked for (or why not).
    pub fn submit(&mut self) {
        let Some(edit) = self.edit.as_mut() else {
            return;
        };
        let parsed = match builtin().get(edit.address) {
            Some(entry) => parse_edit(entry, &edit.text),
            None => Value::parse(DataType::Unsigned32, &edit.text).map_err(|e| e.to_string()),
        };
        match parsed {
            Ok(value) => {
                edit.error = None;
                edit.confirming = Some(value);
            }
            Err(why) => edit.error = Some(why),
        }
    }

    /// The confirmation given: the write is sent.
    pub fn confirm(&mut self) {
        let Some(edit) = self.edit.take() else {
            return;
        };
        let (Some(value), Some(dtype)) = (edit.confirming, self.row(edit.address).map(|r| r.dtype))
        else {
            return;
        };
        if !self.connected {
            self.message = Some(Err("not connected: nothing written".into()));
            return;
        }
        self.writing = Some(edit.address);
        self.requests.push((
            WRITE,
            Request::WriteObject {
                address: edit.address,
                dtype,
                value,
                path: ObjectPath::Auto,
            },
        ));
    }

    /// Esc or Cancel: the edit dropped, nothing written.
    pub fn cancel(&mut self) {
        self.edit = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{LinkInfo, LinkSpec};

    fn connected() -> GainsPanel {
        let mut panel = GainsPanel::default();
        panel.on_event(&Event::Connected(LinkInfo {
            spec: LinkSpec::Sim,
            description: String::new(),
            native_objects: true,
            can_inject: true,
            pdi: true,
            homing_methods: None,
            commands_refused: None,
        }));
        panel
    }

    const VELOCITY_P: Address = Address::new(0x3210, 3);

    #[test]
    fn connecting_reads_every_row_and_a_refusal_stays_with_its_row() {
        let mut panel = connected();
        let requests = panel.take_requests();
        let [(READ, Request::ReadMany { objects, .. })] = requests.as_slice() else {
            panic!("{requests:?}");
        };
        assert_eq!(objects.len(), panel.rows.len());
        let mut over = false;
        for (address, _) in objects {
            let result = if address.index == 0x321A {
                Err(crate::worker::ObjectError::Refused(
                    crate::link::Refusal::Abort(crate::cia::AbortCode::NO_OBJECT),
                ))
            } else {
                Ok(Value::Uint(7))
            };
            over = panel.on_reply(
                READ,
                &Event::ObjectRead {
                    id: 1,
                    address: *address,
                    result,
                },
            );
        }
        assert!(over, "the reading ends with its last answer");
        assert_eq!(panel.row(VELOCITY_P).unwrap().value, Some(Value::Uint(7)));
        let refused = panel.row(Address::new(0x321A, 1)).unwrap();
        assert!(refused.value.is_none() && refused.refused.is_some());
    }

    #[test]
    fn an_edit_is_checked_as_typed_confirmed_then_written_and_read_again() {
        let mut panel = connected();
        panel.take_requests();
        panel.start_edit(VELOCITY_P);
        panel.typed("-5".into());
        assert!(panel.edit.as_ref().unwrap().error.is_some(), "out of range");
        panel.submit();
        assert!(panel.edit.as_ref().unwrap().confirming.is_none());
        panel.typed("48000".into());
        panel.submit();
        assert_eq!(
            panel.edit.as_ref().unwrap().confirming,
            Some(Value::Uint(48000))
        );
        assert!(
            panel.take_requests().is_empty(),
            "nothing before the confirmation"
        );
        panel.confirm();
        let requests = panel.take_requests();
        let [(WRITE, Request::WriteObject { address, value, .. })] = requests.as_slice() else {
            panic!("{requests:?}");
        };
        assert_eq!((*address, value), (VELOCITY_P, &Value::Uint(48000)));
        let over = panel.on_reply(
            WRITE,
            &Event::ObjectWritten {
                id: 2,
                address: VELOCITY_P,
                value: Value::Uint(48000),
                result: Ok(()),
            },
        );
        assert!(over);
        assert!(matches!(&panel.message, Some(Ok(m)) if m.contains("Changes")));
        let requests = panel.take_requests();
        assert!(
            matches!(requests.as_slice(), [(READ, Request::ReadMany { objects, .. })] if objects[0].0 == VELOCITY_P),
            "read again: {requests:?}"
        );
    }

    #[test]
    fn cancel_writes_nothing_and_a_write_from_elsewhere_shows() {
        let mut panel = connected();
        panel.take_requests();
        panel.start_edit(VELOCITY_P);
        panel.typed("3000".into());
        panel.submit();
        panel.cancel();
        panel.confirm();
        assert!(panel.take_requests().is_empty());
        panel.on_event(&Event::Changed {
            address: VELOCITY_P,
            dtype: DataType::Unsigned32,
            before: Some(Value::Uint(12000)),
            after: Value::Uint(3000),
        });
        assert_eq!(
            panel.row(VELOCITY_P).unwrap().value,
            Some(Value::Uint(3000))
        );
    }
}
