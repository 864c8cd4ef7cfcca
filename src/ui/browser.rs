//! The object dictionary browser: every known object in a filtered table with its value,
//! read one at a time, the visible rows or all of them (with progress and cancel), edited
//! by type with range checks and a confirmation; and backups: save, compare, restore and
//! store to the device's memory. What a comparison or a restore may touch is judged by the
//! dictionary shown (`od::backup::skip_reason`): commands, process data, read-only and
//! unknown objects in a file are listed as skipped, with the reason, and never written.

use std::collections::{BTreeMap, HashMap};

use eframe::egui::{self, RichText, Ui};
use egui_extras::{Column, TableBuilder};

use super::state::AppState;
use super::widgets::{AMBER, GREEN, RED};
use crate::od::backup::{self, Backup, Comparison, Difference, Step, Why};
use crate::od::eds::Eds;
use crate::od::{Address, Catalog, DataType, Entry, Value};
use crate::worker::{ObjectPath, Request, RequestId};

/// A value as last read.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub result: Result<Value, String>,
    /// `AppState::clock` when it arrived.
    pub at: f64,
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
    pub error: Option<String>,
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
}

/// What a request the browser sent is for.
#[derive(Clone, Debug, PartialEq)]
enum Pending {
    Read,
    Write { address: Address },
    RestoreStep(usize),
    Store,
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
    /// The rows drawn in the last frame ("read visible").
    pub visible: Vec<Address>,
    pub backup_path: String,
    /// What the backup section says (saved to, loaded, failed).
    pub message: Option<Result<String, String>>,
    pub comparison: Option<(Box<Backup>, Vec<Difference>)>,
    pub restore: Option<Restore>,
    /// A dictionary loaded from an EDS instead of the built-in catalog.
    pub eds: Option<(String, Catalog)>,
    pub eds_path: String,
    /// An object the user asked to plot (the app takes it after the panel is drawn).
    pub plot_request: Option<Address>,
    /// The connection string, for backup files.
    pub link_text: String,
    unsent: Vec<(Request, Pending)>,
    ids: HashMap<RequestId, Pending>,
}

impl Browser {
    pub fn new() -> Self {
        Self {
            backup_path: "drive-backup.json".into(),
            ..Default::default()
        }
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

    fn send(&mut self, outbox: &mut Vec<Request>, request: Request, pending: Pending) {
        self.unsent.push((request.clone(), pending));
        outbox.push(request);
    }

    /// Start a bulk read of `objects` (readable ones only).
    pub fn read_many(
        &mut self,
        outbox: &mut Vec<Request>,
        objects: Vec<(Address, DataType)>,
        purpose: Purpose,
    ) {
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
            outbox,
            Request::ReadMany {
                objects,
                path: ObjectPath::Auto,
            },
            Pending::Read,
        );
    }

    /// One object, read by itself.
    pub fn read_one(&mut self, outbox: &mut Vec<Request>, address: Address, dtype: DataType) {
        self.send(
            outbox,
            Request::ReadMany {
                objects: vec![(address, dtype)],
                path: ObjectPath::Auto,
            },
            Pending::Read,
        );
    }

    fn readable(entries: &[&Entry]) -> Vec<(Address, DataType)> {
        entries
            .iter()
            .filter(|e| e.access.readable())
            .map(|e| (e.address, e.dtype))
            .collect()
    }

    /// The app learned the id of a request: keep it if it is ours.
    pub fn note_queued(&mut self, id: RequestId, request: &Request) -> bool {
        let Some(at) = self.unsent.iter().position(|(r, _)| r == request) else {
            return false;
        };
        let (_, pending) = self.unsent.remove(at);
        if let (Pending::Read, Some(bulk)) = (&pending, self.bulk.as_mut())
            && bulk.id.is_none()
            && matches!(request, Request::ReadMany { objects, .. } if objects.len() == bulk.total)
        {
            bulk.id = Some(id);
        }
        self.ids.insert(id, pending);
        true
    }

    /// A request of ours that could not be sent at all.
    pub fn note_unsent(&mut self, request: &Request, reason: &str) -> bool {
        let Some(at) = self.unsent.iter().position(|(r, _)| r == request) else {
            return false;
        };
        self.unsent.remove(at);
        if matches!(request, Request::ReadMany { .. }) {
            self.bulk = None;
        }
        self.message = Some(Err(reason.to_owned()));
        true
    }

    fn is_bulk(&self, id: RequestId) -> bool {
        self.bulk.as_ref().is_some_and(|b| b.id == Some(id))
    }

    /// A read result; `true` when it was ours.
    pub fn on_read(
        &mut self,
        id: RequestId,
        address: Address,
        result: &Result<Value, String>,
        clock: f64,
    ) -> bool {
        if !self.ids.contains_key(&id) {
            return false;
        }
        self.values.insert(
            address,
            Cell {
                result: result.clone(),
                at: clock,
            },
        );
        if self.is_bulk(id) {
            if let Some(bulk) = self.bulk.as_mut() {
                bulk.done += 1;
                if result.is_err() {
                    bulk.failed += 1;
                }
                bulk.reads.insert(address, result.clone());
            }
            self.bulk_progressed(id);
        }
        true
    }

    /// A refusal of a request of ours (not connected, link lost…).
    pub fn on_rejected(&mut self, id: RequestId, reason: &str) -> bool {
        let Some(pending) = self.ids.get(&id).cloned() else {
            return false;
        };
        match pending {
            Pending::Read if self.is_bulk(id) => {
                if let Some(bulk) = self.bulk.as_mut() {
                    // A whole ReadMany refused, or one of its objects dropped with the link.
                    if bulk.done == 0 && reason.contains("not connected") {
                        bulk.done = bulk.total;
                        bulk.failed = bulk.total;
                    } else {
                        bulk.done += 1;
                        bulk.failed += 1;
                    }
                }
                self.message = Some(Err(reason.to_owned()));
                self.bulk_progressed(id);
            }
            Pending::Read => self.message = Some(Err(reason.to_owned())),
            Pending::Write { address } => {
                self.write_results.insert(address, Err(reason.to_owned()));
            }
            Pending::RestoreStep(step) => self.restore_result(step, Err(reason.to_owned())),
            Pending::Store => self.message = Some(Err(format!("store to device: {reason}"))),
        }
        true
    }

    /// The worker dropped what was left of a bulk read.
    pub fn on_cancelled(&mut self, id: RequestId, dropped: usize) -> bool {
        if !self.is_bulk(id) {
            return false;
        }
        if let Some(bulk) = self.bulk.as_mut() {
            bulk.done += dropped;
            bulk.cancelled = true;
        }
        self.bulk_progressed(id);
        true
    }

    /// A write result; `true` when it was ours. Writes read the object back.
    pub fn on_written(
        &mut self,
        id: RequestId,
        address: Address,
        result: &Result<(), String>,
        outbox: &mut Vec<Request>,
    ) -> bool {
        let Some(pending) = self.ids.remove(&id) else {
            return false;
        };
        let dtype = self.catalog().get(address).map(|e| e.dtype);
        match pending {
            Pending::Write { .. } => {
                self.write_results.insert(address, result.clone());
                if let Some(dtype) = dtype {
                    self.read_one(outbox, address, dtype);
                }
            }
            Pending::RestoreStep(step) => self.restore_result(step, result.clone()),
            Pending::Store => {
                self.message = Some(match result {
                    Ok(()) => Ok("stored: the drive keeps these values after a restart".into()),
                    Err(e) => Err(format!("store to device failed: {e}")),
                })
            }
            Pending::Read => {}
        }
        true
    }

    fn restore_result(&mut self, step: usize, result: Result<(), String>) {
        if let Some(restore) = self.restore.as_mut() {
            if let Some(slot) = restore.results.get_mut(step) {
                *slot = Some(result);
            }
            if restore.results.iter().all(Option::is_some) {
                restore.running = false;
                let failed = restore
                    .results
                    .iter()
                    .filter(|r| matches!(r, Some(Err(_))))
                    .count();
                self.message = Some(if failed == 0 {
                    Ok(format!(
                        "restored: {} writes done; \"Store to device\" keeps them after a restart",
                        restore.results.len()
                    ))
                } else {
                    Err(format!(
                        "restore finished with {failed} of {} writes refused (see the list)",
                        restore.results.len()
                    ))
                });
            }
        }
    }

    /// A bulk read moved on; when complete, finish what it was for.
    fn bulk_progressed(&mut self, id: RequestId) {
        let Some(bulk) = self.bulk.as_ref() else {
            return;
        };
        if bulk.done < bulk.total {
            return;
        }
        self.ids.remove(&id);
        let Some(bulk) = self.bulk.take() else {
            return;
        };
        if bulk.cancelled {
            self.message = Some(Err(format!(
                "cancelled after {} of {} objects",
                bulk.reads.len(),
                bulk.total
            )));
            return;
        }
        match bulk.purpose {
            Purpose::Browse => {
                self.message = Some(Ok(format!(
                    "read {} objects{}",
                    bulk.total,
                    if bulk.failed > 0 {
                        format!(", {} refused (see the rows)", bulk.failed)
                    } else {
                        String::new()
                    }
                )));
            }
            Purpose::Backup { path } => self.finish_backup(&path, &bulk.reads),
            Purpose::Compare(file) => {
                let differences = backup::compare(&file, self.catalog(), &bulk.reads);
                let count = |f: fn(&Comparison) -> bool| {
                    differences.iter().filter(|d| f(&d.device)).count()
                };
                let differing =
                    count(|c| matches!(c, Comparison::Differs(_) | Comparison::Unreadable(_)));
                let skipped = count(|c| matches!(c, Comparison::Skipped(_)));
                self.message = Some(Ok(format!(
                    "compared {} objects with the file: {differing} differ or could not be read{}",
                    differences.len() - skipped,
                    if skipped > 0 {
                        format!("; {skipped} entries skipped (not settings, never restored)")
                    } else {
                        String::new()
                    }
                )));
                self.comparison = Some((file, differences));
            }
            Purpose::Restore(file) => {
                let steps = backup::restore_plan(&file, self.catalog(), &bulk.reads);
                let skipped = backup::compare(&file, self.catalog(), &bulk.reads)
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
                self.message = Some(Ok(format!(
                    "{} writes would make the device match the file",
                    steps.len()
                )));
                self.restore = Some(Restore {
                    results: vec![None; steps.len()],
                    backup: file,
                    steps,
                    running: false,
                    confirm: false,
                    skipped,
                });
            }
        }
    }

    fn finish_backup(&mut self, path: &str, reads: &BTreeMap<Address, Result<Value, String>>) {
        let saved_at = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let file = Backup::new(&self.link_text, self.catalog(), reads, saved_at);
        self.message = Some(match std::fs::write(path, file.to_json()) {
            Ok(()) => Ok(format!(
                "saved {} objects of {} to {path}{}",
                file.objects.len(),
                file.identity.summary(),
                if file.unreadable.is_empty() {
                    String::new()
                } else {
                    format!(" ({} could not be read)", file.unreadable.len())
                }
            )),
            Err(e) => Err(format!("cannot write {path}: {e}")),
        });
    }

    /// Load a backup file for a comparison or a restore.
    fn load(&mut self) -> Option<Box<Backup>> {
        let path = self.backup_path.trim().to_owned();
        match std::fs::read_to_string(&path) {
            Err(e) => {
                self.message = Some(Err(format!("cannot read {path}: {e}")));
                None
            }
            Ok(text) => match Backup::from_json(&text) {
                Ok(file) => Some(Box::new(file)),
                Err(e) => {
                    self.message = Some(Err(format!("{path}: {e}")));
                    None
                }
            },
        }
    }
}

fn value_text(value: &Value, entry: &Entry) -> String {
    backup::shown(value, entry)
}

fn limits_text(entry: &Entry) -> String {
    match (&entry.min, &entry.max) {
        (Some(min), Some(max)) => format!("{min} … {max}"),
        (Some(min), None) => format!(">= {min}"),
        (None, Some(max)) => format!("<= {max}"),
        (None, None) => String::new(),
    }
}

fn age_text(clock: f64, at: f64) -> String {
    let age = (clock - at).max(0.0);
    if age < 1.0 {
        "now".into()
    } else if age < 120.0 {
        format!("{age:.0} s ago")
    } else {
        format!("{:.0} min ago", age / 60.0)
    }
}

/// Check what the user typed for `entry`: its type, its range and its limits.
pub fn parse_edit(entry: &Entry, text: &str) -> Result<Value, String> {
    let value = Value::parse(entry.dtype, text).map_err(|e| e.to_string())?;
    entry.check(&value).map_err(|e| e.to_string())?;
    Ok(value)
}

pub fn browser_ui(ui: &mut Ui, state: &mut AppState) {
    let connected = state.is_connected();
    let clock = state.clock;
    let link = state
        .link_info()
        .map(|i| i.spec.to_string())
        .unwrap_or_default();
    let b = &mut state.browser;
    b.link_text = link;
    let outbox = &mut state.outbox;

    ui.horizontal_wrapped(|ui| {
        ui.heading("Object dictionary");
        ui.label("Filter");
        super::widgets::named_text_edit(ui, &mut b.filter, 160.0, "Object filter");
        let rows = b.rows();
        let count = rows.len();
        let readable = Browser::readable(&rows);
        ui.weak(format!("{count} of {} objects", b.catalog().len()));
        let busy = b.bulk.is_some();
        if ui
            .add_enabled(connected && !busy, egui::Button::new("Read visible"))
            .on_hover_text("Read the rows on screen")
            .clicked()
        {
            let visible: Vec<(Address, DataType)> = b
                .visible
                .iter()
                .filter_map(|a| b.catalog().get(*a))
                .filter(|e| e.access.readable())
                .map(|e| (e.address, e.dtype))
                .collect();
            b.read_many(outbox, visible, Purpose::Browse);
        }
        if ui
            .add_enabled(connected && !busy, egui::Button::new("Read all"))
            .on_hover_text(
                "Read every object that passes the filter, with progress; the motor keeps running",
            )
            .clicked()
        {
            b.read_many(outbox, readable, Purpose::Browse);
        }
        match &b.eds {
            Some((path, _)) => {
                ui.weak(format!("dictionary: {path}"));
                if ui.small_button("Built-in").clicked() {
                    b.eds = None;
                }
            }
            None => {
                ui.weak("dictionary: built-in Nanotec catalog");
            }
        }
    });
    ui.horizontal(|ui| {
        ui.label("EDS");
        super::widgets::named_text_edit(ui, &mut b.eds_path, 220.0, "EDS path");
        if ui
            .button("Load EDS")
            .on_hover_text("Use a device's EDS file (CiA 306) instead of the built-in catalog")
            .clicked()
        {
            load_eds(b);
        }
    });

    bulk_ui(ui, b, outbox);
    backup_ui(ui, b, outbox, connected);
    if let Some(message) = &b.message {
        match message {
            Ok(text) => ui.colored_label(GREEN, text),
            Err(text) => ui.colored_label(RED, text),
        };
    }
    comparison_ui(ui, b);
    restore_ui(ui, b, outbox, connected);
    confirm_ui(ui, b, outbox);
    table_ui(ui, b, outbox, connected, clock);
    if let Some(address) = state.browser.plot_request.take() {
        state.watch_object(&address.to_string());
        state.browser.message = state
            .plot
            .message
            .clone()
            .map(|m| m.map(|text| format!("{text}: see the Plots tab")));
    }
}

/// Warnings shown in the message line; the rest are counted (all go to the log).
const EDS_WARNINGS_SHOWN: usize = 3;

fn load_eds(b: &mut Browser) {
    let path = b.eds_path.trim().to_owned();
    if path.is_empty() {
        b.message = Some(Err("give the path of an EDS or DCF file first".into()));
        return;
    }
    // A CANopen link's node id resolves the file's $NODEID formulas (COB-IDs).
    let node_id = match b.link_text.parse::<crate::link::LinkSpec>() {
        Ok(
            crate::link::LinkSpec::CanopenSocketcan { can, .. }
            | crate::link::LinkSpec::CanopenSlcan { can, .. }
            | crate::link::LinkSpec::CanopenSim { can },
        ) => Some(can.node),
        _ => None,
    };
    match Eds::load(std::path::Path::new(&path), node_id) {
        Ok(eds) => {
            let merged = eds.merged_with(crate::od::builtin());
            for w in &eds.warnings {
                tracing::warn!("{path}: {w}");
            }
            let mut text = format!(
                "loaded {} objects from {path} ({} {})",
                merged.catalog.len(),
                eds.device_info
                    .vendor_name
                    .as_deref()
                    .unwrap_or("unknown vendor"),
                eds.device_info
                    .product_name
                    .as_deref()
                    .unwrap_or("unknown product"),
            );
            if !eds.warnings.is_empty() {
                let shown: Vec<String> = eds
                    .warnings
                    .iter()
                    .take(EDS_WARNINGS_SHOWN)
                    .map(ToString::to_string)
                    .collect();
                text.push_str(&format!(
                    "; {} warning(s): {}",
                    eds.warnings.len(),
                    shown.join("; ")
                ));
                if eds.warnings.len() > EDS_WARNINGS_SHOWN {
                    text.push_str(" (the rest in the log)");
                }
            }
            b.message = Some(Ok(text));
            b.values.clear();
            b.eds = Some((path, merged.catalog));
        }
        Err(e) => b.message = Some(Err(format!("{path}: {e}"))),
    }
}

/// The progress row of a bulk read. Always drawn (idle: empty, Cancel disabled), so the
/// widgets below never jump when a read starts or ends: a click aimed at Cancel as the
/// read completes must not land on the button that moved under the pointer.
fn bulk_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>) {
    let (fraction, text, id, cancelled) = match &b.bulk {
        Some(bulk) => {
            let what = match &bulk.purpose {
                Purpose::Browse => "Reading",
                Purpose::Backup { .. } => "Reading for the backup",
                Purpose::Compare(_) => "Reading to compare",
                Purpose::Restore(_) => "Reading before the restore",
            };
            (
                bulk.done as f32 / bulk.total.max(1) as f32,
                format!("{what}: {} of {}", bulk.done, bulk.total),
                bulk.id,
                bulk.cancelled,
            )
        }
        None => (0.0, "no read running".to_owned(), None, false),
    };
    ui.horizontal(|ui| {
        let mut bar = egui::ProgressBar::new(fraction)
            .text(text)
            .desired_width(320.0);
        if id.is_none() {
            // Idle: no coloured fill, only the text.
            bar = bar.fill(ui.visuals().extreme_bg_color);
        }
        ui.add(bar);
        if ui
            .add_enabled(id.is_some() && !cancelled, egui::Button::new("Cancel"))
            .on_hover_text("Stop the read: what is not read yet is dropped")
            .clicked()
            && let Some(id) = id
        {
            outbox.push(Request::Cancel(id));
        }
    });
}

fn backup_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>, connected: bool) {
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("Backup").strong());
        super::widgets::named_text_edit(ui, &mut b.backup_path, 200.0, "Backup file");
        let idle = connected && b.bulk.is_none() && !b.restore.as_ref().is_some_and(|r| r.running);
        if ui
            .add_enabled(idle, egui::Button::new("Save backup"))
            .on_hover_text("Read every readable and writable configuration object and the identity into the file")
            .clicked()
        {
            let objects = backup::objects_to_read(b.catalog());
            let path = b.backup_path.trim().to_owned();
            b.comparison = None;
            b.restore = None;
            b.read_many(outbox, objects, Purpose::Backup { path });
        }
        if ui
            .add_enabled(idle, egui::Button::new("Compare with file"))
            .on_hover_text("Read the device and list where it differs from the file")
            .clicked()
            && let Some(file) = b.load()
        {
            b.restore = None;
            let objects = file.objects_to_read(b.catalog());
            b.read_many(outbox, objects, Purpose::Compare(file));
        }
        if ui
            .add_enabled(idle, egui::Button::new("Restore from file"))
            .on_hover_text("Read the device, then preview exactly what a restore would write, in order")
            .clicked()
            && let Some(file) = b.load()
        {
            b.comparison = None;
            let objects = file.objects_to_read(b.catalog());
            b.read_many(outbox, objects, Purpose::Restore(file));
        }
        if ui
            .add_enabled(idle, egui::Button::new("Store to device"))
            .on_hover_text("Write 65766173h (\"save\") to 1010h:01: the drive keeps its current values after a restart")
            .clicked()
        {
            b.confirm_store = true;
        }
    });
    if b.confirm_store {
        let modal = egui::Modal::new(egui::Id::unique("confirm_store")).show(ui.ctx(), |ui| {
            ui.heading("Store to device?");
            ui.label("Writes 65766173h (\"save\") to 1010h:01. The drive keeps every current value after a restart; this cannot be undone from here.");
            ui.horizontal(|ui| {
                if ui.button("Store").clicked() {
                    b.confirm_store = false;
                    let (address, value) = backup::STORE_ALL;
                    b.send(
                        outbox,
                        Request::WriteObject {
                            address,
                            dtype: DataType::Unsigned32,
                            value: Value::Uint(u64::from(value)),
                            path: ObjectPath::Auto,
                        },
                        Pending::Store,
                    );
                }
                if ui.button("Cancel").clicked() {
                    b.confirm_store = false;
                }
            });
        });
        if modal.should_close() {
            b.confirm_store = false;
        }
    }
}

fn comparison_ui(ui: &mut Ui, b: &mut Browser) {
    let Some((file, differences)) = &b.comparison else {
        return;
    };
    let mut close = false;
    ui.group(|ui| {
        ui.horizontal(|ui| {
            ui.label(RichText::new("Device against the file").strong());
            ui.weak(file.identity.summary());
            if ui.small_button("Close").clicked() {
                close = true;
            }
        });
        let same = differences
            .iter()
            .filter(|d| d.device == Comparison::Same)
            .count();
        let skipped = differences
            .iter()
            .filter(|d| matches!(d.device, Comparison::Skipped(_)))
            .count();
        ui.label(format!(
            "{same} of {} objects are the same; {skipped} entries of the file skipped (not settings: never compared nor restored)",
            differences.len() - skipped
        ));
        egui::Grid::new("comparison").striped(true).show(ui, |ui| {
            for title in ["Object", "Name", "File", "Device"] {
                ui.label(RichText::new(title).strong());
            }
            ui.end_row();
            for d in differences.iter().filter(|d| d.device != Comparison::Same) {
                ui.monospace(d.address.to_string());
                ui.label(&d.name);
                ui.label(d.file.to_string());
                match &d.device {
                    Comparison::Differs(v) => ui.colored_label(AMBER, v.to_string()),
                    Comparison::Unreadable(reason) => ui.colored_label(RED, reason),
                    Comparison::Skipped(reason) => ui.weak(format!("skipped: {reason}")),
                    Comparison::Same => ui.label(""),
                };
                ui.end_row();
            }
        });
    });
    if close {
        b.comparison = None;
    }
}

fn restore_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>, connected: bool) {
    let Some(restore) = &b.restore else {
        return;
    };
    let mut close = false;
    let mut start = false;
    ui.group(|ui| {
        ui.horizontal(|ui| {
            ui.label(RichText::new("Restore preview").strong());
            ui.weak(format!("from {}", restore.backup.identity.summary()));
            if ui.small_button("Close").clicked() {
                close = true;
            }
        });
        if restore.steps.is_empty() {
            ui.label("The device already matches the file: nothing to write.");
        }
        egui::Grid::new("restore_steps")
            .striped(true)
            .show(ui, |ui| {
                for title in ["#", "Object", "Name", "Now", "Writes", "Why", "Result"] {
                    ui.label(RichText::new(title).strong());
                }
                ui.end_row();
                for (n, (step, result)) in restore.steps.iter().zip(&restore.results).enumerate() {
                    ui.label((n + 1).to_string());
                    ui.monospace(step.address.to_string());
                    ui.label(&step.name);
                    ui.label(
                        step.before
                            .as_ref()
                            .map(Value::to_string)
                            .unwrap_or_default(),
                    );
                    ui.label(step.value.to_string());
                    match (&step.why, &step.warning) {
                        (_, Some(warning)) => ui.colored_label(AMBER, warning),
                        (Why::Procedure(text), None) => ui.weak(*text),
                        (Why::Restore, None) => ui.weak("as in the file"),
                    };
                    match result {
                        None => ui.label(""),
                        Some(Ok(())) => ui.colored_label(GREEN, "written"),
                        Some(Err(e)) => ui.colored_label(RED, e),
                    };
                    ui.end_row();
                }
            });
        for (address, reason) in &restore.skipped {
            let name = b
                .catalog()
                .get(*address)
                .map(Entry::full_name)
                .or_else(|| {
                    restore
                        .backup
                        .entries()
                        .find(|(a, _)| a == address)
                        .map(|(_, o)| o.name.clone())
                })
                .unwrap_or_default();
            ui.colored_label(AMBER, format!("{address} {name} skipped: {reason}"));
        }
        let can = connected
            && !restore.running
            && !restore.steps.is_empty()
            && restore.results.iter().all(Option::is_none);
        if ui
            .add_enabled(
                can,
                egui::Button::new(format!("Restore {} writes", restore.steps.len())),
            )
            .clicked()
        {
            start = true;
        }
    });
    if close {
        b.restore = None;
        return;
    }
    if start && let Some(restore) = b.restore.as_mut() {
        restore.confirm = true;
    }
    let confirm = b.restore.as_ref().is_some_and(|r| r.confirm);
    if confirm {
        let count = b.restore.as_ref().map_or(0, |r| r.steps.len());
        let modal = egui::Modal::new(egui::Id::unique("confirm_restore")).show(ui.ctx(), |ui| {
            ui.heading("Restore from the file?");
            ui.label(format!(
                "{count} writes, in the order listed. Settings that change how the drive is reached come last."
            ));
            let mut go = false;
            let mut cancel = false;
            ui.horizontal(|ui| {
                go = ui.button("Write them").clicked();
                cancel = ui.button("Cancel").clicked();
            });
            (go, cancel)
        });
        let (go, cancel) = modal.inner;
        if cancel || modal.should_close() {
            if let Some(r) = b.restore.as_mut() {
                r.confirm = false;
            }
        } else if go {
            let steps: Vec<Step> = match b.restore.as_mut() {
                Some(r) => {
                    r.confirm = false;
                    r.running = true;
                    r.steps.clone()
                }
                None => vec![],
            };
            for (n, step) in steps.into_iter().enumerate() {
                b.send(
                    outbox,
                    Request::WriteObject {
                        address: step.address,
                        dtype: step.dtype,
                        value: step.value,
                        path: ObjectPath::Auto,
                    },
                    Pending::RestoreStep(n),
                );
            }
        }
    }
}

fn confirm_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>) {
    let Some(confirm) = b.confirm.clone() else {
        return;
    };
    let modal = egui::Modal::new(egui::Id::unique("confirm_write")).show(ui.ctx(), |ui| {
        ui.heading("Write to the drive?");
        ui.label(format!("{} {}", confirm.address, confirm.name));
        ui.label(format!(
            "{} -> {}",
            confirm
                .before
                .as_ref()
                .map(Value::to_string)
                .unwrap_or_else(|| "(not read)".into()),
            confirm.value
        ));
        let mut go = false;
        let mut cancel = false;
        ui.horizontal(|ui| {
            let write = ui.button("Write");
            super::widgets::name_widget(&write, egui::accesskit::Role::Button, "Confirm write");
            go = write.clicked();
            cancel = ui.button("Cancel").clicked();
        });
        (go, cancel)
    });
    let (go, cancel) = modal.inner;
    if go {
        b.confirm = None;
        b.edit = None;
        b.write_results.remove(&confirm.address);
        b.send(
            outbox,
            Request::WriteObject {
                address: confirm.address,
                dtype: confirm.dtype,
                value: confirm.value,
                path: ObjectPath::Auto,
            },
            Pending::Write {
                address: confirm.address,
            },
        );
    } else if cancel || modal.should_close() {
        b.confirm = None;
    }
}

fn table_ui(ui: &mut Ui, b: &mut Browser, outbox: &mut Vec<Request>, connected: bool, clock: f64) {
    let rows: Vec<Entry> = b.rows().into_iter().cloned().collect();
    let mut visible = vec![];
    let mut actions: Vec<(Address, RowAction)> = vec![];
    // Wider than the panel on a laptop screen: the columns right of the value scroll into
    // view sideways, the header stays on top.
    egui::ScrollArea::horizontal()
        .id_salt("od_table_sideways")
        .show(ui, |ui| {
            TableBuilder::new(ui)
                .id_salt("od_table")
                .striped(true)
                .resizable(true)
                .auto_shrink([false, false])
                .min_scrolled_height(120.0)
                .column(Column::initial(70.0).at_least(60.0))
                .column(Column::initial(200.0).at_least(80.0).clip(true))
                .column(Column::initial(170.0).at_least(80.0).clip(true))
                .column(Column::initial(120.0).at_least(100.0))
                .column(Column::initial(90.0).clip(true))
                .column(Column::initial(46.0))
                .column(Column::initial(44.0))
                .column(Column::initial(80.0).clip(true))
                .column(Column::initial(110.0).clip(true))
                .column(Column::remainder().at_least(60.0))
                .header(20.0, |mut header| {
                    for title in [
                        "Object", "Name", "Value", "", "Hex", "Type", "Access", "Default",
                        "Limits", "Read",
                    ] {
                        header.col(|ui| {
                            ui.strong(title);
                        });
                    }
                })
                .body(|body| {
                    body.rows(22.0, rows.len(), |mut row| {
                        let Some(entry) = rows.get(row.index()) else {
                            return;
                        };
                        visible.push(entry.address);
                        let cell = b.values.get(&entry.address);
                        let editing = b.edit.as_ref().filter(|e| e.address == entry.address);
                        row.col(|ui| {
                            ui.monospace(entry.address.to_string());
                        });
                        row.col(|ui| {
                            let response = ui.label(entry.full_name());
                            if !entry.description.is_empty() {
                                response.on_hover_text(&entry.description);
                            }
                        });
                        row.col(|ui| match editing {
                            Some(edit) => {
                                let mut text = edit.text.clone();
                                let response = super::widgets::named_text_edit(
                                    ui,
                                    &mut text,
                                    110.0,
                                    &format!("New value {}", entry.address),
                                );
                                if text != edit.text {
                                    actions.push((entry.address, RowAction::Typed(text)));
                                }
                                if response.lost_focus()
                                    && ui.input(|i| i.key_pressed(egui::Key::Enter))
                                {
                                    actions.push((entry.address, RowAction::Submit));
                                }
                            }
                            None => {
                                if let Some(Err(e)) = b.write_results.get(&entry.address) {
                                    ui.colored_label(RED, e).on_hover_text(e);
                                } else {
                                    match cell.map(|c| &c.result) {
                                        Some(Ok(value)) => {
                                            ui.label(value_text(value, entry));
                                        }
                                        Some(Err(e)) => {
                                            ui.colored_label(RED, e).on_hover_text(e);
                                        }
                                        None => {
                                            ui.weak("?");
                                        }
                                    }
                                }
                            }
                        });
                        row.col(|ui| {
                            ui.horizontal(|ui| match editing {
                                Some(edit) => {
                                    let write = ui.small_button("Write…");
                                    super::widgets::name_widget(
                                        &write,
                                        egui::accesskit::Role::Button,
                                        &format!("Write {}", entry.address),
                                    );
                                    if write.clicked() {
                                        actions.push((entry.address, RowAction::Submit));
                                    }
                                    if ui.small_button("Cancel").clicked() {
                                        actions.push((entry.address, RowAction::CancelEdit));
                                    }
                                    if let Some(error) = &edit.error {
                                        ui.colored_label(RED, error);
                                    }
                                }
                                None => {
                                    let read = ui.add_enabled(
                                        connected && entry.access.readable(),
                                        egui::Button::new("Read").small(),
                                    );
                                    super::widgets::name_widget(
                                        &read,
                                        egui::accesskit::Role::Button,
                                        &format!("Read {}", entry.address),
                                    );
                                    if read.clicked() {
                                        actions.push((entry.address, RowAction::Read));
                                    }
                                    let plottable = entry.access.readable()
                                        && (entry.dtype.is_integer()
                                            || matches!(
                                                entry.dtype,
                                                DataType::Boolean
                                                    | DataType::Real32
                                                    | DataType::Real64
                                            ));
                                    if plottable {
                                        let plot = ui.small_button("Plot").on_hover_text(
                                            "Sample it every cycle and add it to the plots",
                                        );
                                        super::widgets::name_widget(
                                            &plot,
                                            egui::accesskit::Role::Button,
                                            &format!("Plot {}", entry.address),
                                        );
                                        if plot.clicked() {
                                            actions.push((entry.address, RowAction::Plot));
                                        }
                                    }
                                    let writable = entry.access.writable();
                                    let edit = ui.add_enabled(
                                        connected && writable,
                                        egui::Button::new("Edit").small(),
                                    );
                                    super::widgets::name_widget(
                                        &edit,
                                        egui::accesskit::Role::Button,
                                        &format!("Edit {}", entry.address),
                                    );
                                    let edit = edit.on_disabled_hover_text(if writable {
                                        "not connected"
                                    } else {
                                        "read-only: the drive does not take writes to it"
                                    });
                                    if edit.clicked() {
                                        actions.push((entry.address, RowAction::Edit));
                                    }
                                    if let Some(Ok(())) = b.write_results.get(&entry.address) {
                                        ui.colored_label(GREEN, "written");
                                    }
                                }
                            });
                        });
                        row.col(|ui| {
                            if let Some(Ok(value)) = cell.map(|c| &c.result) {
                                ui.monospace(value.to_hex(entry.dtype));
                            }
                        });
                        row.col(|ui| {
                            ui.label(entry.dtype.short_name());
                        });
                        row.col(|ui| {
                            ui.label(entry.access.short_name());
                        });
                        row.col(|ui| {
                            if let Some(default) = &entry.default {
                                ui.label(default.to_string());
                            }
                        });
                        row.col(|ui| {
                            ui.label(limits_text(entry));
                        });
                        row.col(|ui| {
                            if let Some(cell) = cell {
                                ui.weak(age_text(clock, cell.at));
                            }
                        });
                    });
                });
        });
    b.visible = visible;
    for (address, action) in actions {
        apply_row_action(b, outbox, address, action);
    }
}

/// What the user did in a row.
enum RowAction {
    Read,
    Plot,
    Edit,
    Typed(String),
    Submit,
    CancelEdit,
}

fn apply_row_action(
    b: &mut Browser,
    outbox: &mut Vec<Request>,
    address: Address,
    action: RowAction,
) {
    let Some(entry) = b.catalog().get(address).cloned() else {
        return;
    };
    match action {
        RowAction::Read => b.read_one(outbox, address, entry.dtype),
        RowAction::Plot => b.plot_request = Some(address),
        RowAction::Edit => {
            let text = match b.values.get(&address).map(|c| &c.result) {
                Some(Ok(Value::Bytes(bytes))) => bytes
                    .iter()
                    .map(|x| format!("{x:02X}"))
                    .collect::<Vec<_>>()
                    .join(" "),
                Some(Ok(Value::Text(t))) => t.clone(),
                Some(Ok(Value::Bool(v))) => u8::from(*v).to_string(),
                Some(Ok(v)) => v.to_string(),
                _ => entry
                    .default
                    .as_ref()
                    .map(Value::to_string)
                    .unwrap_or_default(),
            };
            b.edit = Some(Edit {
                address,
                text,
                error: None,
            });
        }
        RowAction::Typed(text) => {
            if let Some(edit) = b.edit.as_mut() {
                edit.text = text;
                edit.error = None;
            }
        }
        RowAction::CancelEdit => b.edit = None,
        RowAction::Submit => {
            let Some(edit) = b.edit.as_mut() else {
                return;
            };
            match parse_edit(&entry, &edit.text) {
                Err(reason) => edit.error = Some(reason),
                Ok(value) => {
                    let before = b
                        .values
                        .get(&address)
                        .and_then(|c| c.result.as_ref().ok().cloned());
                    b.confirm = Some(Confirm {
                        address,
                        name: entry.full_name(),
                        dtype: entry.dtype,
                        value,
                        before,
                    });
                }
            }
        }
    }
}
