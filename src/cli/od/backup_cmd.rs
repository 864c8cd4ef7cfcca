//! `od dump`, `od diff` and `od restore`: a drive's configuration to a file, the drive
//! compared with a file, and a file written back. The rules (what is saved, what a restore
//! may write, how values compare, the safe order of a restore) are `od::backup`'s, shared
//! with the window. A file is loaded and checked before the link is opened: a broken,
//! ambiguous or empty file never reaches the drive.

use std::path::Path;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::super::context::Context;
use super::super::failure::{Failure, failed, interrupted, usage};
use super::super::interrupt;
use super::super::progress;
use super::super::report::{print_json, print_lines};
use super::super::session::{Reads, Session};
use super::super::{JudgeArgs, OdDumpArgs, OdFileArgs, OdRestoreArgs};
use super::load_eds;
use crate::link::LinkSpec;
use crate::od::backup::{self, Backup, BackupError, Comparison, DeviceIdentity, Step, Why};
use crate::od::{self, Address, Catalog, DataType, Value};
use crate::text::shown as safe;

/// A value as the browser shows it: with its unit where the catalog knows one; COB-IDs
/// and mapping entries (32-bit communication objects) in hex.
fn shown(address: Address, value: &Value) -> String {
    if let Value::Uint(v) = value
        && address.index < 0x2000
        && od::builtin()
            .get(address)
            .is_some_and(|e| e.dtype == DataType::Unsigned32)
    {
        return format!("{v:08X}h");
    }
    match od::builtin().get(address) {
        Some(entry) => backup::shown(value, entry),
        None => value.to_string(),
    }
}

fn seconds_since_epoch() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The notes and warnings, then the report: as JSON, or as `text` for people.
fn print_report<R: Serialize>(
    report: &R,
    notes: &[String],
    warnings: &[String],
    json: bool,
    text: fn(&R),
) {
    print_lines(notes, warnings);
    if json {
        print_json(report, "report");
    } else {
        text(report);
    }
}

/// Read `objects` with a progress bar; the summary goes to `notes`. A broken link fails.
fn read_all(
    session: &mut Session,
    objects: Vec<(Address, DataType)>,
    what: &'static str,
    timeout: Duration,
    notes: &mut Vec<String>,
) -> Result<Reads, Failure> {
    let asked = objects.len();
    let (reads, failure) = session.read_many_shown(objects, timeout, what, notes);
    match failure {
        // A signal keeps its exit code (130), a broken link its own.
        Some(f) => Err(Failure {
            message: format!(
                "{}; {} of {asked} objects were read before it, nothing was saved or written",
                f.message,
                reads.len()
            ),
            ..f
        }),
        None => Ok(reads),
    }
}

/// A session on `link` that a signal (Ctrl-C, SIGTERM, SIGHUP) ends cleanly from the
/// start: the signals are caught before connecting, so that one during the connection or
/// the reading ends the command with exit code 130 and the link is closed on the way out,
/// which puts back what opening it changed (a CANopen drive's PDO mapping for the PDI).
/// A signal while connecting is said at once; the command ends as soon as the connection
/// is made (and closed again) or has failed. Where the signals cannot be caught, a warning
/// says so.
pub(in crate::cli) fn open_session(
    link: &LinkSpec,
    timeout: Duration,
    trace: bool,
    context: &Context,
    warnings: &mut Vec<String>,
) -> Result<Session, Failure> {
    let installed = interrupt::install();
    let watch = installed.is_ok().then(ConnectWatch::start).flatten();
    let opened = Session::open(link, timeout, trace, context);
    if let Some(signal) = watch.and_then(ConnectWatch::stop) {
        // Dropping the session closes the link again.
        drop(opened);
        return Err(interrupted(signal).and("while connecting: nothing was read or written"));
    }
    let mut session = opened?;
    if let Err(e) = installed.and_then(|()| session.catch_signals()) {
        warnings.push(format!(
            "{e}: Ctrl-C ends drivedeck at once, without putting back a CANopen drive's PDO mapping"
        ));
    }
    Ok(session)
}

/// While a session connects (which no signal interrupts): a thread that takes a signal
/// and says at once that the command will stop.
struct ConnectWatch {
    done: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<Option<interrupt::OsSignal>>,
}

impl ConnectWatch {
    /// How often the watch looks for a signal.
    const POLL: Duration = Duration::from_millis(50);

    /// `None` when no thread can be started (a signal then waits for the reading).
    fn start() -> Option<ConnectWatch> {
        use std::sync::atomic::Ordering;
        let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let watching = std::sync::Arc::clone(&done);
        let thread = std::thread::Builder::new()
            .name("drivedeck-connect-watch".into())
            .spawn(move || {
                while !watching.load(Ordering::SeqCst) {
                    if let Some(signal) = interrupt::take() {
                        eprintln!(
                            "drivedeck: {signal}: stopping once the connection is made or has failed (again: at once)"
                        );
                        return Some(signal);
                    }
                    std::thread::sleep(Self::POLL);
                }
                None
            })
            .ok()?;
        Some(ConnectWatch { done, thread })
    }

    /// The signal taken while connecting, if one was.
    fn stop(self) -> Option<interrupt::OsSignal> {
        self.done.store(true, std::sync::atomic::Ordering::SeqCst);
        self.thread.join().ok().flatten()
    }
}

/// The dictionary a command works with: an EDS's (with the catalog's descriptions), or the
/// built-in catalog. The EDS's warnings go to `warnings`.
pub(in crate::cli) fn dictionary(
    eds: Option<&Path>,
    node: Option<u8>,
    warnings: &mut Vec<String>,
) -> Result<Catalog, Failure> {
    match eds {
        Some(path) => {
            let eds = load_eds(path, node)?;
            warnings.extend(
                eds.warnings
                    .iter()
                    .map(|w| format!("{} {}", path.display(), safe(&w.to_string()))),
            );
            Ok(eds.merged_with(od::builtin()).catalog)
        }
        None => Ok(od::builtin().clone()),
    }
}

fn load_backup(path: &Path) -> Result<Backup, Failure> {
    Backup::load(path).map_err(|e| match e {
        BackupError::File(_) => usage(e.to_string()),
        _ => usage(format!("{}: {e}", path.display())),
    })
}

#[derive(Serialize)]
pub(in crate::cli) struct DumpReport {
    pub(in crate::cli) file: String,
    pub(in crate::cli) identity: DeviceIdentity,
    pub(in crate::cli) objects: usize,
    pub(in crate::cli) unreadable: Vec<(String, String)>,
    pub(in crate::cli) seconds: f64,
    pub(in crate::cli) notes: Vec<String>,
}

/// `od dump --out FILE`: true when every object could be read.
pub fn dump(
    link: &LinkSpec,
    args: &OdDumpArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let out = match (&args.out, &args.dir) {
        (Some(out), _) => out,
        (None, Some(dir)) => {
            return Err(usage(format!(
                "od dump {}: a folder is for --project (one backup per drive); for one drive give --out FILE.json",
                dir.display()
            )));
        }
        (None, None) => {
            return Err(usage(
                "od dump needs --out FILE.json (or, with --project, a folder: `od dump DIR`)",
            ));
        }
    };
    let mut warnings = vec![];
    let catalog = dictionary(args.eds.as_deref(), args.node, &mut warnings)?;
    let report = dump_to(link, &catalog, out, timeout, trace, context)?;
    print_report(&report, &report.notes, &warnings, json, print_dump);
    Ok(report.unreadable.is_empty())
}

/// Read the settings `catalog` names from the drive at `link` and write them to `out`.
pub(in crate::cli) fn dump_to(
    link: &LinkSpec,
    catalog: &Catalog,
    out: &Path,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<DumpReport, Failure> {
    let (file, seconds, notes) = read_backup(link, catalog, timeout, trace, context)?;
    crate::file::write_whole(out, file.to_json())
        .map_err(|e| failed(format!("cannot write {}: {e}", out.display())))?;
    Ok(DumpReport {
        file: out.display().to_string(),
        identity: file.identity.clone(),
        objects: file.objects.len(),
        unreadable: file.unreadable.clone(),
        seconds,
        notes,
    })
}

/// A backup of the settings `catalog` names, read from the drive at `link`: the backup,
/// the seconds the reading took, and the notes on the way.
pub(in crate::cli) fn read_backup(
    link: &LinkSpec,
    catalog: &Catalog,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<(Backup, f64, Vec<String>), Failure> {
    let mut notes = vec![];
    let mut session = open_session(link, timeout, trace, context, &mut notes)?;
    let started = Instant::now();
    let reads = read_all(
        &mut session,
        backup::objects_to_read(catalog),
        "reading",
        timeout,
        &mut notes,
    )?;
    let seconds = started.elapsed().as_secs_f64();
    notes.extend(session.take_notes());
    let file = Backup::new(&link.to_string(), catalog, &reads, seconds_since_epoch());
    Ok((file, seconds, notes))
}

fn print_dump(report: &DumpReport) {
    outln!(
        "saved {} settings of {} to {}",
        report.objects,
        report.identity.summary(),
        report.file
    );
    for (address, reason) in &report.unreadable {
        outln!("not saved: {address}: {reason}");
    }
}

/// One object of a comparison, as reported.
#[derive(Serialize)]
struct DiffRow {
    address: String,
    name: String,
    /// `same`, `differs`, `unreadable` or `skipped`.
    state: &'static str,
    file: String,
    device: Option<String>,
    error: Option<String>,
    /// Why a skipped entry is neither compared nor ever restored.
    reason: Option<String>,
}

#[derive(Serialize)]
struct DiffReport {
    file: String,
    file_identity: DeviceIdentity,
    device_identity: DeviceIdentity,
    same: usize,
    differs: usize,
    unreadable: usize,
    /// Entries of the file that are not settings the dictionary knows: never restored.
    skipped: usize,
    objects: Vec<DiffRow>,
    notes: Vec<String>,
    warnings: Vec<String>,
}

/// Identity differences worth a warning: another product, or another unit of the same.
fn identity_warnings(file: &DeviceIdentity, device: &DeviceIdentity) -> Vec<String> {
    file.mismatch(device)
        .map(|m| m.text().to_owned())
        .into_iter()
        .collect()
}

fn diff_report(
    path: &Path,
    file: &Backup,
    catalog: &Catalog,
    reads: &Reads,
    all: bool,
) -> DiffReport {
    let device_identity = DeviceIdentity::from_reads(reads);
    let mut report = DiffReport {
        file: path.display().to_string(),
        file_identity: file.identity.clone(),
        warnings: identity_warnings(&file.identity, &device_identity),
        device_identity,
        same: 0,
        differs: 0,
        unreadable: 0,
        skipped: 0,
        objects: vec![],
        notes: vec![],
    };
    for d in backup::compare(file, catalog, reads) {
        let (state, device, error, reason) = match &d.device {
            Comparison::Same => {
                report.same += 1;
                ("same", Some(shown(d.address, &d.file)), None, None)
            }
            Comparison::Differs(v) => {
                report.differs += 1;
                ("differs", Some(shown(d.address, v)), None, None)
            }
            Comparison::Unreadable(reason) => {
                report.unreadable += 1;
                ("unreadable", None, Some(reason.clone()), None)
            }
            Comparison::Skipped(reason) => {
                report.skipped += 1;
                ("skipped", None, None, Some(reason.clone()))
            }
        };
        if all || state != "same" {
            report.objects.push(DiffRow {
                address: d.address.to_string(),
                name: d.name,
                state,
                file: shown(d.address, &d.file),
                device,
                error,
                reason,
            });
        }
    }
    report
}

fn print_diff(report: &DiffReport) {
    if !report.objects.is_empty() {
        let name_width = report
            .objects
            .iter()
            .map(|r| safe(&r.name).chars().count())
            .max()
            .unwrap_or(4)
            .clamp(4, 48);
        let file_width = report
            .objects
            .iter()
            .map(|r| safe(&r.file).chars().count())
            .max()
            .unwrap_or(4)
            .clamp(4, 32);
        outln!(
            "{:<9}  {:<10}  {:<name_width$}  {:<file_width$}  DEVICE",
            "INDEX:SUB",
            "STATE",
            "NAME",
            "FILE"
        );
        for row in &report.objects {
            let device = match (&row.device, &row.error, &row.reason) {
                (_, _, Some(reason)) => format!("not compared: {reason}"),
                (_, Some(e), None) => format!("error: {e}"),
                (Some(v), None, None) => safe(v).into_owned(),
                (None, None, None) => String::new(),
            };
            outln!(
                "{:<9}  {:<10}  {:<name_width$}  {:<file_width$}  {device}",
                row.address,
                row.state,
                safe(&row.name),
                safe(&row.file)
            );
        }
    }
    outln!(
        "{} of {} saved settings differ, {} cannot be read, {} are the same",
        report.differs,
        report.same + report.differs + report.unreadable,
        report.unreadable,
        report.same
    );
    if report.skipped > 0 {
        outln!(
            "{} entries of the file are skipped: not settings of the dictionary in use, never restored",
            report.skipped
        );
    }
}

/// A backup file, the dictionary that judges it, and the drive's values of its objects.
struct Opened {
    file: Backup,
    catalog: Catalog,
    session: Session,
    reads: Reads,
    warnings: Vec<String>,
    notes: Vec<String>,
}

impl Opened {
    /// The notes so far, the session's included.
    fn take_notes(&mut self) -> Vec<String> {
        let mut notes = std::mem::take(&mut self.notes);
        notes.extend(self.session.take_notes());
        notes
    }
}

/// Load the file and the dictionary (both checked before connecting), connect, and read
/// what the file names.
fn open_and_read(
    link: &LinkSpec,
    path: &Path,
    judge: &JudgeArgs,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<Opened, Failure> {
    let file = load_backup(path)?;
    let mut warnings = vec![];
    let catalog = dictionary(judge.eds.as_deref(), judge.node, &mut warnings)?;
    let mut notes = vec![];
    let mut session = open_session(link, timeout, trace, context, &mut warnings)?;
    let reads = read_all(
        &mut session,
        file.objects_to_read(&catalog),
        "reading",
        timeout,
        &mut notes,
    )?;
    Ok(Opened {
        file,
        catalog,
        session,
        reads,
        warnings,
        notes,
    })
}

/// `od diff FILE`: true when the drive matches the file.
pub fn diff(
    link: &LinkSpec,
    args: &OdFileArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let mut opened = open_and_read(link, &args.file, &args.judge, timeout, trace, context)?;
    let (file, catalog, reads) = (&opened.file, &opened.catalog, &opened.reads);
    let mut report = diff_report(&args.file, file, catalog, reads, args.all);
    report.notes = opened.take_notes();
    report.warnings.splice(0..0, opened.warnings);
    print_report(&report, &report.notes, &report.warnings, json, print_diff);
    Ok(report.differs == 0 && report.unreadable == 0)
}

/// One write of a restore, as reported.
#[derive(Serialize)]
struct StepRow {
    address: String,
    name: String,
    before: Option<String>,
    value: String,
    /// Why the write is there when it is a step of a mapping procedure.
    procedure: Option<&'static str>,
    warning: Option<String>,
    /// `planned` (dry run), `written`, `refused` or `not written`.
    result: &'static str,
    error: Option<String>,
}

/// An entry of the file a restore leaves alone, as reported.
#[derive(Serialize)]
struct SkippedRow {
    address: String,
    name: String,
    /// The file's value.
    file: String,
    reason: String,
}

#[derive(Serialize)]
struct RestoreReport {
    file: String,
    dry_run: bool,
    steps: Vec<StepRow>,
    /// Entries of the file that are not settings of the dictionary in use: never written.
    skipped: Vec<SkippedRow>,
    written: usize,
    refused: usize,
    /// Whether 1010h:01 stored the parameters.
    stored: Option<Result<(), String>>,
    /// What still differs when the drive was compared again after the writes.
    still_differs: Option<usize>,
    notes: Vec<String>,
    warnings: Vec<String>,
}

impl RestoreReport {
    /// Take the notes so far into the report and print it.
    fn print(&mut self, opened: &mut Opened, json: bool) {
        self.notes = opened.take_notes();
        print_report(self, &self.notes, &self.warnings, json, print_restore);
    }
}

fn step_row(step: &Step) -> StepRow {
    StepRow {
        address: step.address.to_string(),
        name: step.name.clone(),
        before: step.before.as_ref().map(|v| shown(step.address, v)),
        value: shown(step.address, &step.value),
        procedure: match step.why {
            Why::Procedure(what) => Some(what),
            Why::Restore => None,
        },
        warning: step.warning.clone(),
        result: "planned",
        error: None,
    }
}

/// The entries left alone; false when there is nothing to write (said).
fn print_restore_head(report: &RestoreReport) -> bool {
    for row in &report.skipped {
        outln!(
            "skipped: {:<9}  {} = {}: {}",
            row.address,
            safe(&row.name),
            safe(&row.file),
            row.reason
        );
    }
    if report.steps.is_empty() {
        outln!(
            "the drive already matches {}: nothing to write",
            report.file
        );
        return false;
    }
    true
}

/// Write number `n` (from 0), with its outcome unless a dry run.
fn print_step(n: usize, row: &StepRow, dry_run: bool) {
    let before = row.before.as_deref().unwrap_or("?");
    let result = match (&row.error, dry_run) {
        (_, true) => String::new(),
        (Some(e), false) => format!("  {}: {e}", row.result),
        (None, false) => format!("  {}", row.result),
    };
    let procedure = row.procedure.map(|p| format!(" ({p})")).unwrap_or_default();
    outln!(
        "{:>3}. {:<9}  {}: {} -> {}{procedure}{result}",
        n + 1,
        row.address,
        safe(&row.name),
        safe(before),
        safe(&row.value)
    );
    if let Some(w) = &row.warning {
        outln!("     warning: {w}");
    }
}

/// What came of the writes: how many, stored or not, compared again.
fn print_restore_tail(report: &RestoreReport) {
    if report.dry_run {
        outln!(
            "dry run: {} writes would be made, nothing was written",
            report.steps.len()
        );
        return;
    }
    outln!(
        "{} of {} writes done, {} refused",
        report.written,
        report.steps.len(),
        report.refused
    );
    match &report.stored {
        Some(Ok(())) => outln!("stored in the drive (1010h:01): kept after a restart"),
        Some(Err(e)) => outln!("not stored: {e}"),
        None => outln!("not stored: the values are lost at a restart unless stored (--store)"),
    }
    match report.still_differs {
        Some(0) => outln!("compared again: the drive matches the file"),
        Some(n) => outln!("compared again: {n} settings still differ (od diff lists them)"),
        None => {}
    }
}

fn print_restore(report: &RestoreReport) {
    if !print_restore_head(report) {
        return;
    }
    for (n, row) in report.steps.iter().enumerate() {
        print_step(n, row, report.dry_run);
    }
    print_restore_tail(report);
}

/// `od restore FILE [--dry-run] [--store]`: true when every write was accepted and the
/// drive matches the file afterwards. In text each write is printed as it is made; a
/// signal lets the write in flight finish, stops, and says what was written and what not
/// (exit code 130).
pub fn restore(
    link: &LinkSpec,
    args: &OdRestoreArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<bool, Failure> {
    let mut opened = open_and_read(link, &args.file, &args.judge, timeout, trace, context)?;
    let (plan, mut report) = plan_restore(args, &mut opened)?;
    if args.dry_run {
        report.print(&mut opened, json);
        return Ok(report.refused == 0);
    }
    // Text: what is known so far, then each write as it is made.
    let streamed = !json;
    if streamed {
        print_lines(&opened.take_notes(), &report.warnings);
        if !print_restore_head(&report) {
            return Ok(true);
        }
    }
    // JSON: a bar on a terminal's stderr while writing; the report at the end.
    let mut bar = progress::bar("writing");
    let total = plan.len();
    let stopped = write_plan(
        &mut opened.session,
        &plan,
        &mut report,
        timeout,
        |n, row| {
            if streamed {
                print_step(n, row, false);
            } else {
                bar(n + 1, total);
            }
        },
    );
    let finish = |report: &mut RestoreReport, opened: &mut Opened| {
        if streamed {
            print_lines(&opened.take_notes(), &[]);
            print_restore_tail(report);
        } else {
            report.print(opened, json);
        }
    };
    match stopped {
        Stopped::Done => {}
        Stopped::Lost(reason) => {
            finish(&mut report, &mut opened);
            return Err(failed(format!(
                "the restore stopped after {} writes: {reason}",
                report.written + report.refused
            )));
        }
        Stopped::Signal(signal) => {
            finish(&mut report, &mut opened);
            let not_written = report.steps.len() - report.written - report.refused;
            return Err(interrupted(signal).and(format!(
                "the restore stopped after the write in flight: written {}, refused {}, not written {not_written} of {} writes; run `od restore` again to write the rest",
                report.written,
                report.refused,
                report.steps.len()
            )));
        }
    }
    if args.store {
        report.stored = Some(store_all(&mut opened.session, report.refused, timeout)?);
    }
    report.still_differs = Some(compare_again(&mut opened, timeout)?);
    finish(&mut report, &mut opened);
    Ok(report.refused == 0
        && report.still_differs.unwrap_or(0) == 0
        && !matches!(report.stored, Some(Err(_))))
}

/// The writes of a restore and the report that will tell of them. A file of another kind
/// of device is refused unless forced (or only a dry run).
fn plan_restore(
    args: &OdRestoreArgs,
    opened: &mut Opened,
) -> Result<(Vec<Step>, RestoreReport), Failure> {
    let Opened {
        file,
        catalog,
        reads,
        warnings,
        ..
    } = opened;
    let device = DeviceIdentity::from_reads(reads);
    let mut warnings = std::mem::take(warnings);
    warnings.extend(identity_warnings(&file.identity, &device));
    if !file.identity.same_product(&device) && !args.force && !args.dry_run {
        return Err(usage(format!(
            "{}: saved from {}, but the drive is {}; --force restores it anyway",
            args.file.display(),
            file.identity.summary(),
            device.summary()
        )));
    }
    let (skipped, unreadable) = left_alone(file, catalog, reads);
    if unreadable > 0 {
        warnings.push(format!(
            "{unreadable} saved settings cannot be read from the drive and are left out (od diff lists them)"
        ));
    }
    let plan = backup::restore_plan(file, catalog, reads);
    let report = RestoreReport {
        file: args.file.display().to_string(),
        dry_run: args.dry_run,
        steps: plan.iter().map(step_row).collect(),
        skipped,
        written: 0,
        refused: 0,
        stored: None,
        still_differs: None,
        notes: vec![],
        warnings,
    };
    Ok((plan, report))
}

/// The entries of the file a restore skips (not settings of the dictionary), and how
/// many of its settings cannot be read from the drive.
fn left_alone(file: &Backup, catalog: &Catalog, reads: &Reads) -> (Vec<SkippedRow>, usize) {
    let comparison = backup::compare(file, catalog, reads);
    let unreadable = comparison
        .iter()
        .filter(|d| matches!(d.device, Comparison::Unreadable(_)))
        .count();
    let skipped = comparison
        .into_iter()
        .filter_map(|d| match d.device {
            Comparison::Skipped(reason) => Some(SkippedRow {
                address: d.address.to_string(),
                name: catalog
                    .get(d.address)
                    .map_or(d.name.clone(), |e| e.full_name()),
                file: shown(d.address, &d.file),
                reason,
            }),
            _ => None,
        })
        .collect();
    (skipped, unreadable)
}

/// Why the writing of a plan ended.
enum Stopped {
    /// Every write was made (or refused).
    Done,
    /// A broken link: the writes after it were not made.
    Lost(String),
    /// A signal: the write in flight was finished, the ones after it not made.
    Signal(interrupt::OsSignal),
}

/// Write the plan in order, each outcome in its row, `shown(n, row)` after each. A write
/// is never cut short: a signal is looked at between writes (the write in flight
/// finishes), and ends the writing there. A broken link ends it too. The rows after the
/// end say why they were not written.
fn write_plan(
    session: &mut Session,
    plan: &[Step],
    report: &mut RestoreReport,
    timeout: Duration,
    mut shown: impl FnMut(usize, &StepRow),
) -> Stopped {
    let catching = session.interruptible;
    // A signal no longer ends the waiting for an answer: it is taken between writes.
    session.interruptible = false;
    let mut stopped = Stopped::Done;
    for (n, (step, row)) in plan.iter().zip(report.steps.iter_mut()).enumerate() {
        if catching
            && matches!(stopped, Stopped::Done)
            && let Some(signal) = interrupt::take()
        {
            stopped = Stopped::Signal(signal);
        }
        match &stopped {
            Stopped::Done => {}
            Stopped::Lost(reason) => {
                row.result = "not written";
                row.error = Some(reason.clone());
                continue;
            }
            Stopped::Signal(signal) => {
                row.result = "not written";
                row.error = Some(format!("interrupted by {signal}"));
                continue;
            }
        }
        match session.try_write(step.address, step.dtype, step.value.clone(), timeout) {
            Ok(Ok(())) => {
                row.result = "written";
                report.written += 1;
            }
            Ok(Err(refusal)) => {
                row.result = "refused";
                row.error = Some(refusal.to_string());
                report.refused += 1;
            }
            Err(f) => {
                row.result = "not written";
                row.error = Some(f.message.clone());
                stopped = Stopped::Lost(f.message);
            }
        }
        shown(n, row);
    }
    // A signal that came with the last write.
    if catching
        && matches!(stopped, Stopped::Done)
        && let Some(signal) = interrupt::take()
    {
        stopped = Stopped::Signal(signal);
    }
    session.interruptible = catching;
    stopped
}

/// `--store`: 1010h:01 = "save", unless some writes were refused.
fn store_all(
    session: &mut Session,
    refused: usize,
    timeout: Duration,
) -> Result<Result<(), String>, Failure> {
    if refused > 0 {
        return Ok(Err("not stored, since some writes were refused".to_owned()));
    }
    let (address, value) = backup::STORE_ALL;
    Ok(session
        .try_write(
            address,
            DataType::Unsigned32,
            Value::Uint(value.into()),
            timeout,
        )?
        .map_err(|e| format!("1010h:01 refused: {e}")))
}

/// Read the file's objects again after a restore: how many settings still differ.
fn compare_again(opened: &mut Opened, timeout: Duration) -> Result<usize, Failure> {
    let again = read_all(
        &mut opened.session,
        opened.file.objects_to_read(&opened.catalog),
        "comparing",
        timeout,
        &mut opened.notes,
    )?;
    Ok(backup::compare(&opened.file, &opened.catalog, &again)
        .iter()
        .filter(|d| matches!(d.device, Comparison::Differs(_)))
        .count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_warnings_name_product_and_unit() {
        let a = DeviceIdentity {
            vendor: Some(0x26C),
            product: Some(1),
            serial: Some(7),
            ..Default::default()
        };
        assert!(identity_warnings(&a, &a).is_empty());
        let other_unit = DeviceIdentity {
            serial: Some(8),
            ..a.clone()
        };
        let w = identity_warnings(&a, &other_unit);
        assert!(
            w[0].contains("another unit") && w[0].contains("00000008h"),
            "{w:?}"
        );
        let other_product = DeviceIdentity {
            product: Some(2),
            ..a.clone()
        };
        assert!(identity_warnings(&a, &other_product)[0].contains("another kind of device"));
    }
}
