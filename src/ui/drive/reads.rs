//! The reads the window makes on a drive by itself, not logged: its identity on
//! connecting (the exports' header, the project check, another-drive markers), 1001h and
//! 1003h for the fault timeline (on connecting and on every new fault), and the torque
//! slope 6087h. Each leaves with its own [`Owner`], so its answers come back here whoever
//! else reads the same objects.
//!
//! A model: no egui here.

use std::collections::BTreeMap;

use super::Drive;
use super::link::{device_text, same_device};
use super::motion::TORQUE_SLOPE;
use super::requests::Owner;
use crate::diagnostics::{Origin, Severity};
use crate::od::backup::DeviceIdentity;
use crate::od::{Address, DataType, Value};
use crate::worker::{ObjectError, ObjectPath, Request, RequestId};

/// The reads under way: which request is the current one of each kind (answers to an
/// older one, from before a reconnect, are dropped) and what came so far.
#[derive(Clone, Debug, Default)]
pub struct Reads {
    identity: Option<RequestId>,
    identity_reads: BTreeMap<Address, Result<Value, ObjectError>>,
    diagnosis: Option<RequestId>,
    diagnosis_reads: BTreeMap<Address, Result<Value, ObjectError>>,
    /// Another fault came while the diagnosis was read: read again after.
    diagnosis_again: bool,
}

/// 1001h, 1003h:00 and the first eight 1003h entries: read on connecting and on each new
/// fault or warning, for the timeline.
fn diagnosis_objects() -> Vec<(Address, DataType)> {
    let mut objects = vec![
        (Address::new(0x1001, 0), DataType::Unsigned8),
        (Address::new(0x1003, 0), DataType::Unsigned8),
    ];
    objects.extend((1..=8).map(|sub| (Address::new(0x1003, sub), DataType::Unsigned32)));
    objects
}

impl Drive {
    /// A link came up: read the identity, the diagnosis and the torque slope anew.
    pub(super) fn read_on_connecting(&mut self) {
        self.reads = Reads::default();
        self.requests.push(
            Owner::Identity,
            Request::ReadMany {
                objects: crate::od::backup::IDENTITY.to_vec(),
                path: ObjectPath::Auto,
            },
        );
        self.push_diagnosis();
        // Know the torque slope before anyone asks for torque.
        self.requests.push(
            Owner::TorqueSlope,
            Request::ReadObject {
                address: TORQUE_SLOPE,
                dtype: Some(DataType::Unsigned32),
                path: ObjectPath::Auto,
            },
        );
    }

    fn push_diagnosis(&mut self) {
        self.requests.push(
            Owner::Diagnosis,
            Request::ReadMany {
                objects: diagnosis_objects(),
                path: ObjectPath::Auto,
            },
        );
    }

    /// Read 1001h and 1003h for the timeline (again after the running read, if one runs).
    pub(super) fn want_diagnosis(&mut self) {
        if self.reads.diagnosis.is_some() || self.requests.waits_for(&Owner::Diagnosis) {
            self.reads.diagnosis_again = true;
        } else {
            self.push_diagnosis();
        }
    }

    /// A read of ours went to the worker as `id`: the current one of its kind.
    pub(super) fn read_sent(&mut self, id: RequestId, owner: &Owner) {
        match owner {
            Owner::Identity => {
                self.reads.identity = Some(id);
                self.reads.identity_reads.clear();
            }
            Owner::Diagnosis => {
                self.reads.diagnosis = Some(id);
                self.reads.diagnosis_reads.clear();
            }
            _ => {}
        }
    }

    /// An answer to the identity read `id`.
    pub(super) fn identity_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: Result<Value, ObjectError>,
    ) {
        if self.reads.identity != Some(id) {
            return;
        }
        self.reads.identity_reads.insert(address, result);
        if self.reads.identity_reads.len() < crate::od::backup::IDENTITY.len() {
            return;
        }
        let identity = DeviceIdentity::from_reads(&self.reads.identity_reads);
        self.reads.identity = None;
        self.reads.identity_reads.clear();
        self.requests.done(id);
        let link = self.scope.meta.link.clone().unwrap_or_default();
        self.describe_drive(Some(&identity), &link);
        self.note_drive(&identity);
        self.check_against_project(Ok(&identity));
        self.link.identity = Some(identity);
    }

    /// An answer to the diagnosis read `id`: once all are in, onto the timeline.
    pub(super) fn diagnosis_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: Result<Value, ObjectError>,
    ) {
        if self.reads.diagnosis != Some(id) {
            return;
        }
        self.reads.diagnosis_reads.insert(address, result);
        if self.reads.diagnosis_reads.len() < diagnosis_objects().len() {
            return;
        }
        let reads = std::mem::take(&mut self.reads.diagnosis_reads);
        self.reads.diagnosis = None;
        self.requests.done(id);
        let t = self.sample_time();
        let uint = |address: Address| match reads.get(&address) {
            Some(Ok(value)) => value.as_i128().and_then(|v| u32::try_from(v).ok()),
            _ => None,
        };
        if let Some(register) = uint(Address::new(0x1001, 0)) {
            self.timeline.error_register(t, register as u8);
        }
        let count = uint(Address::new(0x1003, 0)).unwrap_or(0).min(8) as u8;
        let entries: Vec<(u8, u32)> = (1..=count)
            .filter_map(|sub| uint(Address::new(0x1003, sub)).map(|raw| (sub, raw)))
            .collect();
        self.timeline.error_history(t, &entries);
        if std::mem::take(&mut self.reads.diagnosis_again) {
            self.want_diagnosis();
        }
    }

    /// The torque slope as read.
    pub(super) fn slope_read(&mut self, id: RequestId, result: Result<Value, ObjectError>) {
        self.requests.done(id);
        self.motion.torque_slope = result
            .as_ref()
            .ok()
            .and_then(Value::as_i128)
            .and_then(|v| i64::try_from(v).ok());
    }

    /// A read of ours refused whole (not connected, the link gone): not waited for.
    pub(super) fn read_refused(&mut self, id: RequestId, owner: &Owner) {
        match owner {
            Owner::Identity if self.reads.identity == Some(id) => {
                self.reads.identity = None;
                self.reads.identity_reads.clear();
            }
            Owner::Diagnosis if self.reads.diagnosis == Some(id) => {
                self.reads.diagnosis = None;
                self.reads.diagnosis_reads.clear();
            }
            _ => {}
        }
    }

    /// The exports' header: the drive (where its identity is known) and the link; the
    /// session's start stays that of its first connection (t = 0 of the samples' clock).
    pub(super) fn describe_drive(&mut self, identity: Option<&DeviceIdentity>, link: &str) {
        let started = self.scope.meta.started.take();
        self.scope.meta = crate::telemetry::metadata(identity, link, self.settings.poll_rate);
        if started.is_some() {
            self.scope.meta.started = started;
        }
    }

    /// The drive connected now, its identity read. Another link or another identity (1018h)
    /// than the drive before in this session is another drive: the history stays, and a
    /// marker on the plots and an entry on the timeline say from when the samples are of
    /// this one.
    fn note_drive(&mut self, identity: &DeviceIdentity) {
        let Some(spec) = self.link.info().map(|info| info.spec.clone()) else {
            return;
        };
        let Some((link, was)) = self.link.seen.replace((spec.clone(), identity.clone())) else {
            return;
        };
        if link == spec && same_device(&was, identity) {
            return;
        }
        let text = format!("another drive: {} on {spec}", device_text(identity));
        let t = self.link.connected_at.or(self.sample_time());
        if let Some(t) = t {
            self.scope.new_drive(t, text.clone());
        }
        self.timeline.add(
            t,
            Severity::Info,
            Origin::Link,
            format!(
                "{text}; before: {} on {link} (its history stays)",
                device_text(&was)
            ),
        );
        self.info(text);
    }
}
