//! The object dictionary browser: every known object in a filtered table with its value,
//! the rows on screen read by themselves (a few at a time, changes highlighted), one row,
//! the visible rows or all of them on request (with progress and cancel), edited in place
//! by type with range checks and a confirmation, read back after every write; and backups:
//! save, compare, restore and store to the device's memory. What a comparison or a restore
//! may touch is judged by the dictionary shown (`od::backup::skip_reason`): commands,
//! process data, read-only and unknown objects in a file are listed as skipped, with the
//! reason, and never written. Messages say how things went by their colour and belong to
//! the link they came from.

use std::collections::BTreeMap;

use crate::od::backup::{self, Backup, Comparison, Difference, Step};
use crate::od::{Address, Catalog, DataType, Entry, Value};
use crate::worker::{ObjectError, ObjectPath, Rejection, Request, RequestId};

mod backup_view;
mod edit;
mod editing;
mod message;
mod panel;
mod refresh;
mod table;

pub use editing::parse_edit;
pub use message::{Message, Tone};
pub use panel::{browser_ui, tone_color};
pub use refresh::{
    CHANGED_FOR, DictionarySettings, MOST_READS_PER_SECOND, REFRESH_AFTER, REFRESH_IN_FLIGHT,
    Refresh,
};
pub use table::Columns;

/// A value as last read.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub result: Result<Value, String>,
    /// `Drive::clock` when it arrived.
    pub at: f64,
    /// When a read last brought another value than the one before, and that value (the
    /// row is highlighted for [`CHANGED_FOR`] seconds).
    pub changed: Option<(f64, Value)>,
}

/// What a bulk read is for.
#[derive(Clone, Debug, PartialEq)]
pub enum Purpose {
    /// Filling the table.
    Browse,
    /// Saving a backup to `path`.
    Backup { path: String },
    /// Comparing the device with a file.
    Compare(Box<Backup>),
    /// Reading the device before a restore, to show what would change.
    Restore(Box<Backup>),
}

/// A running bulk read.
#[derive(Clone, Debug, PartialEq)]
pub struct Bulk {
    pub id: Option<RequestId>,
    pub total: usize,
    pub done: usize,
    pub failed: usize,
    pub purpose: Purpose,
    /// What this read brought (for backups and comparisons).
    pub reads: BTreeMap<Address, Result<Value, String>>,
    pub cancelled: bool,
}

/// A value being typed into a row.
#[derive(Clone, Debug, PartialEq)]
pub struct Edit {
    pub address: Address,
    pub text: String,
    /// Why the text is not a value the object takes (type, range, limits), as typed.
    pub error: Option<String>,
    /// The box takes the keyboard in the next frame.
    focus: bool,
}

/// A write waiting for the user's yes.
#[derive(Clone, Debug, PartialEq)]
pub struct Confirm {
    pub address: Address,
    pub name: String,
    pub dtype: DataType,
    pub value: Value,
    pub before: Option<Value>,
}

/// A restore being previewed or run.
#[derive(Clone, Debug, PartialEq)]
pub struct Restore {
    pub backup: Box<Backup>,
    pub steps: Vec<Step>,
    /// Each step's outcome once written.
    pub results: Vec<Option<Result<(), String>>>,
    pub running: bool,
    pub confirm: bool,
    /// Saved objects left alone, with the reason: not settings of the dictionary shown
    /// (commands, process data, read-only, unknown), or unreadable on the device.
    pub skipped: Vec<(Address, String)>,
    /// How the file's device differs from this one, as read before the preview.
    pub mismatch: Option<backup::Mismatch>,
    /// The user ticked "restore onto another kind of device anyway" (the CLI's --force).
    pub force: bool,
}

/// What a request the browser sent is for: it leaves with the request as its owner's
/// note, and comes back with every reply.
#[derive(Clone, Debug, PartialEq)]
pub enum Pending {
    /// The bulk read ([`Browser::bulk`]).
    Bulk,
    /// Reads outside the bulk one (a row's Read, the rows on screen, read-backs after a
    /// write or a restore): `left` answers still to come; `asked` by the user (a Read, a
    /// write, a restore), whose refusal is said, not by the table itself.
    Refresh {
        left: usize,
        asked: bool,
    },
    Write {
        address: Address,
    },
    RestoreStep(usize),
    Store,
    /// Sent over a link to another drive than the one shown now: its answers are dropped.
    Stale,
}

/// The browser's state.
#[derive(Clone, Debug, Default)]
pub struct Browser {
    pub filter: String,
    pub values: BTreeMap<Address, Cell>,
    pub bulk: Option<Bulk>,
    pub edit: Option<Edit>,
    pub confirm: Option<Confirm>,
    pub confirm_store: bool,
    /// The last write's outcome per object, shown inline.
    pub write_results: BTreeMap<Address, Result<(), String>>,
    /// The rows drawn in the last frame ("read visible", and read by themselves).
    pub visible: Vec<Address>,
    /// The row picked by a click (Enter edits it, the arrow keys move it).
    pub selected: Option<Address>,
    /// The scrolled columns' widths and how far they are scrolled sideways.
    pub columns: Columns,
    /// The reads the table makes by itself, rate-limited.
    pub refresh: Refresh,
    /// The backup and EDS files as typed.
    pub files: Files,
    /// What the browser says about the last thing done (read, saved, loaded, failed).
    pub message: Option<Message>,
    pub comparison: Option<(Box<Backup>, Vec<Difference>)>,
    pub restore: Option<Restore>,
    /// A dictionary loaded from an EDS instead of the built-in catalog.
    pub eds: Option<(String, Catalog)>,
    /// The link connected now and the one the values came from.
    pub source: Source,
    /// The window's clock as last seen.
    now: f64,
    /// Requests for the worker, each with what it is for.
    asks: Vec<(Pending, Request)>,
}

/// The files the browser's boxes name.
#[derive(Clone, Debug)]
pub struct Files {
    /// Where "Save backup" writes and "Load backup" reads.
    pub backup: String,
    /// The EDS to load instead of the built-in catalog.
    pub eds: String,
}

impl Default for Files {
    fn default() -> Self {
        Self {
            backup: "drive-backup.json".into(),
            eds: String::new(),
        }
    }
}

/// Whose values the browser shows: the link connected now, the one the values came from,
/// and how many connections were made (answers and messages of an earlier one are told
/// apart by it).
#[derive(Clone, Debug, Default)]
pub struct Source {
    /// The connection string, for backup files and to know whose values are shown ("" when
    /// not connected).
    pub text: String,
    /// The link the values came from: the last one connected.
    values_of: String,
    /// How many connections were made so far (see [`Browser::on_connected`]).
    connection: u64,
}

/// A value with the unit `catalog` gives its object (as it is, for an object it lacks).
pub(super) fn shown_in(catalog: &Catalog, address: Address, value: &Value) -> String {
    match catalog.get(address) {
        Some(entry) => backup::shown(value, entry),
        None => value.to_string(),
    }
}

impl Browser {
    pub fn new() -> Self {
        Self::default()
    }

    /// The dictionary shown: an EDS's, or the built-in catalog.
    pub fn catalog(&self) -> &Catalog {
        match &self.eds {
            Some((_, catalog)) => catalog,
            None => crate::od::builtin(),
        }
    }

    /// The entries that pass the filter (index `6064`, `1018:01`, or a name).
    pub fn rows(&self) -> Vec<&Entry> {
        self.catalog().filter(self.filter.trim()).collect()
    }

    /// A value as the browser shows it: with the unit the dictionary gives its object.
    pub fn shown(&self, address: Address, value: &Value) -> String {
        shown_in(self.catalog(), address, value)
    }

    pub(super) fn send(&mut self, request: Request, pending: Pending) {
        self.asks.push((pending, request));
    }

    /// The requests the browser wants sent, each with what it is for.
    pub fn take_asks(&mut self) -> Vec<(Pending, Request)> {
        std::mem::take(&mut self.asks)
    }

    /// The requests waiting to be sent.
    pub fn asks(&self) -> impl Iterator<Item = &Request> {
        self.asks.iter().map(|(_, r)| r)
    }

    /// The window's clock now (for the ages shown and the reads' pace).
    pub fn set_clock(&mut self, now: f64) {
        self.now = now;
    }

    /// Start a bulk read of `objects` (readable ones only).
    pub fn read_many(&mut self, objects: Vec<(Address, DataType)>, purpose: Purpose) {
        if objects.is_empty() {
            return;
        }
        self.bulk = Some(Bulk {
            id: None,
            total: objects.len(),
            done: 0,
            failed: 0,
            purpose,
            reads: BTreeMap::new(),
            cancelled: false,
        });
        self.send(
            Request::ReadMany {
                objects,
                path: ObjectPath::Auto,
            },
            Pending::Bulk,
        );
    }

    /// Drop what is still to be read of the bulk read `id`.
    pub(super) fn cancel_bulk(&mut self, id: RequestId) {
        self.send(Request::Cancel(id), Pending::Stale);
    }

    /// One object, read by itself.
    pub fn read_one(&mut self, address: Address, dtype: DataType) {
        self.read_back(vec![(address, dtype)], true);
    }

    fn readable(entries: &[&Entry]) -> Vec<(Address, DataType)> {
        entries
            .iter()
            .filter(|e| e.access.readable())
            .map(|e| (e.address, e.dtype))
            .collect()
    }

    /// The worker took a request of ours as `id`.
    pub fn sent(&mut self, id: RequestId, pending: &Pending) {
        if *pending == Pending::Bulk
            && let Some(bulk) = self.bulk.as_mut()
            && bulk.id.is_none()
        {
            bulk.id = Some(id);
        }
    }

    /// A request of ours that could not be sent at all.
    pub fn unsent(&mut self, pending: Pending, request: &Request, reason: &str) {
        match (pending, request) {
            (Pending::Refresh { asked, .. }, Request::ReadMany { objects, .. }) => {
                // The table tries again by itself; no message for what nobody asked for.
                self.refresh.forget(objects.iter().map(|(a, _)| *a));
                if asked {
                    self.say(Tone::Failed, reason);
                }
            }
            (Pending::Bulk, _) => {
                self.bulk = None;
                self.say(Tone::Failed, reason);
            }
            _ => self.say(Tone::Failed, reason),
        }
    }

    fn is_bulk(&self, id: RequestId) -> bool {
        self.bulk.as_ref().is_some_and(|b| b.id == Some(id))
    }

    /// A read result for request `id` (what it is for: `pending`); `true` when the
    /// request is over.
    pub fn on_read(
        &mut self,
        id: RequestId,
        pending: &mut Pending,
        address: Address,
        result: &Result<Value, ObjectError>,
        clock: f64,
    ) -> bool {
        self.now = clock;
        let mut over = false;
        match pending {
            Pending::Stale => return false,
            Pending::Refresh { left, .. } => {
                *left = left.saturating_sub(1);
                over = *left == 0;
                self.refresh.arrived(address);
            }
            _ => {}
        }
        // The table shows the refusal in words; the variant decided nothing here.
        let result = result.clone().map_err(|e| e.to_string());
        self.store_value(address, result.clone(), clock);
        if self.is_bulk(id) {
            if let Some(bulk) = self.bulk.as_mut() {
                bulk.done += 1;
                if result.is_err() {
                    bulk.failed += 1;
                }
                bulk.reads.insert(address, result);
            }
            over = self.bulk_progressed(id);
        }
        over
    }

    /// A value read: into its row, marked when it differs from the one read before.
    fn store_value(&mut self, address: Address, result: Result<Value, String>, clock: f64) {
        let old = self.values.get(&address);
        let changed = match (old.map(|c| &c.result), &result) {
            (Some(Ok(before)), Ok(now)) if before != now => Some((clock, before.clone())),
            _ => old.and_then(|c| c.changed.clone()),
        };
        self.values.insert(
            address,
            Cell {
                result,
                at: clock,
                changed,
            },
        );
    }

    /// A refusal of request `id` of ours (not connected, link lost…); `true` when the
    /// request is over.
    pub fn on_rejected(
        &mut self,
        id: RequestId,
        pending: &mut Pending,
        rejection: &Rejection,
    ) -> bool {
        let reason = rejection.to_string();
        match pending.clone() {
            Pending::Stale => false,
            Pending::Bulk => self.bulk_rejected(id, rejection),
            Pending::Refresh { asked, .. } => {
                // Which objects went unread is not said: the table reads them again once
                // they are due; later refusals of the same request are dropped.
                *pending = Pending::Stale;
                self.refresh.forget_all();
                if asked {
                    self.say(Tone::Failed, reason);
                }
                false
            }
            Pending::Write { address } => {
                self.write_results.insert(address, Err(reason));
                true
            }
            Pending::RestoreStep(step) => {
                self.restore_result(step, Err(reason));
                true
            }
            Pending::Store => {
                self.say(Tone::Failed, format!("store to device: {reason}"));
                true
            }
        }
    }

    /// The bulk read refused whole, or one of its objects dropped with the link; `true`
    /// when it is over.
    fn bulk_rejected(&mut self, id: RequestId, rejection: &Rejection) -> bool {
        if !self.is_bulk(id) {
            return false;
        }
        if let Some(bulk) = self.bulk.as_mut() {
            if bulk.done == 0 && *rejection == Rejection::NotConnected {
                bulk.done = bulk.total;
                bulk.failed = bulk.total;
            } else {
                bulk.done += 1;
                bulk.failed += 1;
            }
        }
        self.say(Tone::Failed, rejection.to_string());
        self.bulk_progressed(id)
    }

    /// The worker dropped what was left of a bulk read; `true` when it is over.
    pub fn on_cancelled(&mut self, id: RequestId, pending: &Pending, dropped: usize) -> bool {
        if *pending != Pending::Bulk || !self.is_bulk(id) {
            return false;
        }
        if let Some(bulk) = self.bulk.as_mut() {
            bulk.done += dropped;
            bulk.cancelled = true;
        }
        self.bulk_progressed(id)
    }

    /// A write result of a request of ours (what it was for: `pending`). The objects
    /// written are read back.
    pub fn on_written(
        &mut self,
        pending: Pending,
        address: Address,
        result: &Result<(), ObjectError>,
    ) {
        let result = &result.clone().map_err(|e| e.to_string());
        match pending {
            Pending::Write { .. } => {
                self.write_results.insert(address, result.clone());
                if let Some(entry) = self.catalog().get(address) {
                    let object = (address, entry.dtype);
                    self.read_back(vec![object], true);
                }
            }
            Pending::RestoreStep(step) => {
                if self.restore_result(step, result.clone()) {
                    self.read_back_restored();
                }
            }
            Pending::Store => {
                self.message = Some(match result {
                    Ok(()) => self.message_now(
                        Tone::Done,
                        "stored: the drive keeps these values after a restart",
                    ),
                    Err(e) => {
                        self.message_now(Tone::Failed, format!("store to device failed: {e}"))
                    }
                })
            }
            Pending::Refresh { .. } | Pending::Bulk | Pending::Stale => {}
        }
    }

    /// A restore step's outcome; `true` when it was the last one.
    fn restore_result(&mut self, step: usize, result: Result<(), String>) -> bool {
        let Some(restore) = self.restore.as_mut() else {
            return false;
        };
        if let Some(slot) = restore.results.get_mut(step) {
            *slot = Some(result);
        }
        if !restore.running || !restore.results.iter().all(Option::is_some) {
            return false;
        }
        restore.running = false;
        let total = restore.results.len();
        let failed = restore
            .results
            .iter()
            .filter(|r| matches!(r, Some(Err(_))))
            .count();
        if failed == 0 {
            self.say(
                Tone::Done,
                format!(
                    "restored: {total} writes done; \"Store to device\" keeps them after a restart"
                ),
            );
        } else {
            self.say(
                Tone::Failed,
                format!("restore finished with {failed} of {total} writes refused (see the list)"),
            );
        }
        true
    }

    /// A bulk read moved on; when complete, finish what it was for (`true`).
    fn bulk_progressed(&mut self, id: RequestId) -> bool {
        let Some(bulk) = self.bulk.as_ref().filter(|b| b.id == Some(id)) else {
            return false;
        };
        if bulk.done < bulk.total {
            return false;
        }
        let Some(bulk) = self.bulk.take() else {
            return false;
        };
        if bulk.cancelled {
            self.say(
                Tone::Warning,
                format!(
                    "cancelled after {} of {} objects",
                    bulk.reads.len(),
                    bulk.total
                ),
            );
            return true;
        }
        match bulk.purpose {
            Purpose::Browse => self.finish_browse(&bulk),
            Purpose::Backup { path } => self.finish_backup(&path, &bulk.reads),
            Purpose::Compare(file) => self.finish_compare(file, &bulk.reads),
            Purpose::Restore(file) => self.finish_restore(file, &bulk.reads),
        }
        true
    }

    /// The table filled: how many objects were read, how many refused.
    fn finish_browse(&mut self, bulk: &Bulk) {
        if bulk.failed == 0 {
            self.say(Tone::Done, format!("read {} objects", bulk.total));
        } else {
            self.say(
                Tone::Warning,
                format!(
                    "read {} objects, {} refused (see the rows)",
                    bulk.total, bulk.failed
                ),
            );
        }
    }

    /// The device against the file: where they differ, and what of the file is no setting.
    fn finish_compare(
        &mut self,
        file: Box<Backup>,
        reads: &BTreeMap<Address, Result<Value, String>>,
    ) {
        let differences = backup::compare(&file, self.catalog(), reads);
        let count =
            |f: fn(&Comparison) -> bool| differences.iter().filter(|d| f(&d.device)).count();
        let differing = count(|c| matches!(c, Comparison::Differs(_) | Comparison::Unreadable(_)));
        let skipped = count(|c| matches!(c, Comparison::Skipped(_)));
        let tone = if differing == 0 {
            Tone::Done
        } else {
            Tone::Warning
        };
        self.say(
            tone,
            format!(
                "compared {} objects with the file: {differing} differ or could not be read{}",
                differences.len() - skipped,
                if skipped > 0 {
                    format!("; {skipped} entries skipped (not settings, never restored)")
                } else {
                    String::new()
                }
            ),
        );
        self.comparison = Some((file, differences));
    }

    /// The restore's preview: the writes that make the device match the file, and what
    /// of the file it leaves alone, with the reason.
    fn finish_restore(
        &mut self,
        file: Box<Backup>,
        reads: &BTreeMap<Address, Result<Value, String>>,
    ) {
        let steps = backup::restore_plan(&file, self.catalog(), reads);
        let skipped: Vec<(Address, String)> = backup::compare(&file, self.catalog(), reads)
            .into_iter()
            .filter_map(|d| match d.device {
                Comparison::Skipped(reason) => Some((d.address, reason)),
                Comparison::Unreadable(reason) => Some((
                    d.address,
                    format!("cannot be read from the device: {reason}"),
                )),
                _ => None,
            })
            .collect();
        let tone = if steps.is_empty() {
            Tone::Done
        } else {
            Tone::Info
        };
        self.say(
            tone,
            format!(
                "{} writes would make the device match the file{}",
                steps.len(),
                if skipped.is_empty() {
                    String::new()
                } else {
                    format!("; {} entries left alone (see the list)", skipped.len())
                }
            ),
        );
        let mismatch = file
            .identity
            .mismatch(&backup::DeviceIdentity::from_reads(reads));
        self.restore = Some(Restore {
            mismatch,
            force: false,
            results: vec![None; steps.len()],
            backup: file,
            steps,
            running: false,
            confirm: false,
            skipped,
        });
    }

    fn finish_backup(&mut self, path: &str, reads: &BTreeMap<Address, Result<Value, String>>) {
        let saved_at = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let file = Backup::new(&self.source.text, self.catalog(), reads, saved_at);
        match crate::file::write_whole(std::path::Path::new(path), file.to_json()) {
            Ok(()) => {
                let unreadable = file.unreadable.len();
                let text = format!(
                    "saved {} objects of {} to {path}{}",
                    file.objects.len(),
                    file.identity.summary(),
                    if unreadable == 0 {
                        String::new()
                    } else {
                        format!(" ({unreadable} could not be read)")
                    }
                );
                let tone = if unreadable == 0 {
                    Tone::Done
                } else {
                    Tone::Warning
                };
                self.say(tone, text);
            }
            Err(e) => self.say(Tone::Failed, format!("cannot write {path}: {e}")),
        }
    }

    /// Load a backup file for a comparison or a restore.
    fn load(&mut self) -> Option<Box<Backup>> {
        let path = self.files.backup.trim().to_owned();
        // A FIFO or a device is refused at once: the window never waits on one.
        match Backup::load(std::path::Path::new(&path)) {
            Ok(file) => Some(Box::new(file)),
            Err(e @ crate::od::backup::BackupError::File(_)) => {
                self.say(Tone::Failed, e.to_string());
                None
            }
            Err(e) => {
                self.say(Tone::Failed, format!("{path}: {e}"));
                None
            }
        }
    }
}
