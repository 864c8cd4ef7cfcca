//! `drivedeck od …`: the object dictionary on the command line.
//!
//! `od list` lists the built-in catalog, or with `--eds FILE` the objects of an EDS (the
//! catalog adds the units and descriptions the file lacks, see `od::eds`). With `--link`
//! it reads every listed object through the one-shot session and shows its value; an
//! object that cannot be read shows the reason on its line and the list goes on. Only a
//! broken link stops the reading (the rest of the list says so, exit code 1).

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, usage};
use super::{EXIT_FAILED, OdArgs, OdCommand, OdListArgs, report};
use crate::link::LinkSpec;
use crate::od::eds::{DeviceInfo, Eds, EdsError};
use crate::od::{self, Catalog, Entry, Value};
use crate::text::shown;

pub(super) mod backup_cmd;

/// Names wider than this push their line's later columns right instead of widening all.
const NAME_WIDTH: usize = 48;
const DEFAULT_WIDTH: usize = 22;

pub fn run(
    link: Option<&LinkSpec>,
    args: &OdArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    // Dump, diff and restore talk to a drive: the built-in simulator without --link, as
    // every other one-shot command.
    let device = link.cloned().unwrap_or(LinkSpec::Sim);
    let outcome = match &args.command {
        OdCommand::List(list) => {
            list_objects(link, list, timeout, trace, context).map(|(report, stopped)| {
                print(&report, json);
                !stopped
            })
        }
        OdCommand::Dump(dump) => backup_cmd::dump(&device, dump, json, timeout, trace, context),
        OdCommand::Diff(diff) => backup_cmd::diff(&device, diff, json, timeout, trace, context),
        OdCommand::Restore(restore) => {
            backup_cmd::restore(&device, restore, json, timeout, trace, context)
        }
    };
    match outcome {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(EXIT_FAILED),
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

/// One listed object.
#[derive(Serialize, Debug)]
struct Row {
    address: String,
    index: u16,
    sub: u8,
    name: String,
    #[serde(rename = "type")]
    dtype: &'static str,
    access: &'static str,
    default: Option<Value>,
    /// The EDS's `$NODEID` formula for the default, when it has one.
    default_formula: Option<String>,
    min: Option<Value>,
    max: Option<Value>,
    unit: Option<String>,
    description: String,
    /// With --link: the value read, as text and in hex.
    value: Option<Value>,
    text: Option<String>,
    hex: Option<String>,
    /// With --link: why the object could not be read.
    error: Option<String>,
}

#[derive(Serialize, Debug)]
struct ListReport {
    /// `built-in catalog` or the EDS file.
    source: String,
    /// The EDS's [DeviceInfo].
    device: Option<DeviceInfo>,
    /// The node id the EDS's formulas were resolved with.
    node_id: Option<u8>,
    link: Option<String>,
    objects: Vec<Row>,
    warnings: Vec<String>,
    notes: Vec<String>,
}

/// The CANopen node id of a link, for `$NODEID`.
fn link_node_id(link: &LinkSpec) -> Option<u8> {
    match link {
        LinkSpec::CanopenSocketcan { can, .. }
        | LinkSpec::CanopenSlcan { can, .. }
        | LinkSpec::CanopenSim { can } => Some(can.node),
        _ => None,
    }
}

pub(super) fn load_eds(path: &Path, node_id: Option<u8>) -> Result<Eds, Failure> {
    Eds::load(path, node_id).map_err(|e| match e {
        EdsError::Read { .. } | EdsError::NotAFile(_) => usage(e.to_string()),
        _ => usage(format!("{}: {e}", path.display())),
    })
}

/// The list, and whether a broken link stopped the reading.
fn list_objects(
    link: Option<&LinkSpec>,
    args: &OdListArgs,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<(ListReport, bool), Failure> {
    let mut warnings = vec![];
    let mut notes = vec![];
    let filter = args.filter.as_deref().unwrap_or("");
    let (catalog, eds): (Catalog, Option<Eds>) = match &args.eds {
        Some(path) => {
            let node_id = args.node.or_else(|| link.and_then(link_node_id));
            let (catalog, eds) = eds_catalog(path, node_id, filter, &mut warnings, &mut notes)?;
            (catalog, Some(eds))
        }
        None => (od::builtin().clone(), None),
    };
    let entries: Vec<&Entry> = catalog.filter(filter).collect();
    if entries.is_empty() {
        notes.push(format!("no object matches '{filter}'"));
    }
    let mut rows: Vec<Row> = entries.iter().map(|e| row(e, eds.as_ref())).collect();
    let unresolved = rows
        .iter()
        .filter(|r| r.default.is_none() && r.default_formula.is_some())
        .count();
    if unresolved > 0 {
        notes.push(format!(
            "{unresolved} default(s) are $NODEID formulas: give --node N to see them for a node"
        ));
    }
    let mut stopped: Option<String> = None;
    if let Some(link) = link {
        stopped = read_values(
            link, &entries, &mut rows, timeout, trace, &mut notes, context,
        )?;
        if let Some(reason) = &stopped {
            warnings.push(format!(
                "reading stopped: {reason}; the objects after it were not read"
            ));
        }
    }
    let report = ListReport {
        source: args.eds.as_ref().map_or_else(
            || "built-in catalog".to_owned(),
            |p| p.display().to_string(),
        ),
        device: eds.as_ref().map(|e| e.device_info.clone()),
        node_id: eds.as_ref().and_then(|e| e.node_id),
        link: link.map(ToString::to_string),
        objects: rows,
        warnings,
        notes,
    };
    Ok((report, stopped.is_some()))
}

/// An EDS's dictionary, with the catalog's units and descriptions where the file lacks
/// them. The file's warnings go to `warnings`, the merge's notes on the objects that
/// `filter` lists to `notes`.
fn eds_catalog(
    path: &Path,
    node_id: Option<u8>,
    filter: &str,
    warnings: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Result<(Catalog, Eds), Failure> {
    let eds = load_eds(path, node_id)?;
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    );
    warnings.extend(
        eds.warnings
            .iter()
            .map(|w| format!("{file} {}", shown(&w.to_string()))),
    );
    let merged = eds.merged_with(od::builtin());
    let listed: Vec<_> = merged.catalog.filter(filter).map(|e| e.address).collect();
    notes.extend(
        merged
            .notes
            .into_iter()
            .filter(|n| listed.contains(&n.address))
            .map(|n| n.message),
    );
    Ok((merged.catalog, eds))
}

/// With --link: every readable object's value (or why it has none) in its row; the
/// reason when a broken link stopped the reading.
fn read_values(
    link: &LinkSpec,
    entries: &[&Entry],
    rows: &mut [Row],
    timeout: Duration,
    trace: bool,
    notes: &mut Vec<String>,
    context: &Context,
) -> Result<Option<String>, Failure> {
    let mut session = backup_cmd::open_session(link, timeout, trace, context, notes)?;
    let readable: Vec<_> = entries
        .iter()
        .filter(|e| e.access.readable())
        .map(|e| (e.address, e.dtype))
        .collect();
    let (reads, failure) = session.read_many_shown(readable, timeout, "reading", notes);
    notes.extend(session.take_notes());
    // A signal ends the command (exit code 130), the link closed on the way out.
    let failure = match failure {
        Some(f) if f.signal.is_some() => {
            return Err(f.and(format!("{} objects were read before it", reads.len())));
        }
        other => other,
    };
    let stopped = failure.map(|f| f.message);
    for (row, entry) in rows.iter_mut().zip(entries) {
        match reads.get(&entry.address) {
            _ if !entry.access.readable() => {
                row.error = Some("not read: a write-only object".into());
            }
            Some(Ok(value)) => {
                row.text = Some(value.to_string());
                row.hex = Some(value.to_hex(entry.dtype)).filter(|h| !h.is_empty());
                row.value = Some(value.clone());
            }
            Some(Err(refusal)) => row.error = Some(refusal.to_string()),
            None => {
                row.error = Some(format!(
                    "not read: {}",
                    stopped.as_deref().unwrap_or("no answer")
                ));
            }
        }
    }
    Ok(stopped)
}

fn row(entry: &Entry, eds: Option<&Eds>) -> Row {
    let info = eds.and_then(|e| e.entries.get(&entry.address));
    Row {
        address: entry.address.to_string(),
        index: entry.address.index,
        sub: entry.address.sub,
        name: entry.full_name(),
        dtype: entry.dtype.short_name(),
        access: info.map_or(entry.access.short_name(), |i| i.access.as_str()),
        default: entry.default.clone(),
        default_formula: info.and_then(|i| i.default_formula).map(|f| f.to_string()),
        min: entry.min.clone(),
        max: entry.max.clone(),
        unit: entry.unit.clone(),
        description: entry.description.clone(),
        value: None,
        text: None,
        hex: None,
        error: None,
    }
}

fn limits(row: &Row) -> String {
    match (&row.min, &row.max) {
        (None, None) => String::new(),
        (min, max) => format!(
            "{}..{}",
            min.as_ref().map(Value::to_string).unwrap_or_default(),
            max.as_ref().map(Value::to_string).unwrap_or_default()
        ),
    }
}

fn default_text(row: &Row) -> String {
    match (&row.default, &row.default_formula) {
        (Some(v), _) => v.to_string(),
        (None, Some(f)) => f.clone(),
        (None, None) => String::new(),
    }
}

fn print(report: &ListReport, json: bool) {
    report::print_lines(&report.notes, &report.warnings);
    if json {
        report::print_json(report, "list");
        return;
    }
    if report.objects.is_empty() {
        return;
    }
    let name_width = report
        .objects
        .iter()
        .map(|r| shown(&r.name).chars().count())
        .max()
        .unwrap_or(0)
        .clamp(4, NAME_WIDTH);
    let default_width = report
        .objects
        .iter()
        .map(|r| shown(&default_text(r)).chars().count())
        .max()
        .unwrap_or(0)
        .clamp(7, DEFAULT_WIDTH);
    let with_values = report.link.is_some();
    let last = if with_values { "VALUE" } else { "UNIT" };
    outln!(
        "{:<9}  {:<7} {:<6} {:<name_width$}  {:<default_width$}  {:<12}  {last}",
        "INDEX:SUB",
        "TYPE",
        "ACCESS",
        "NAME",
        "DEFAULT",
        "LIMITS"
    );
    for row in &report.objects {
        let last = if with_values {
            value_text(row)
        } else {
            row.unit.clone().unwrap_or_default()
        };
        // Names, defaults and values come from a file or a device: shown, never obeyed.
        let line = format!(
            "{:<9}  {:<7} {:<6} {:<name_width$}  {:<default_width$}  {:<12}  ",
            row.address,
            row.dtype,
            row.access,
            shown(&row.name),
            shown(&default_text(row)),
            shown(&limits(row)),
        );
        let last = shown(&last);
        outln!("{}", format!("{line}{last}").trim_end());
    }
}

/// The value column of a row read with --link: the value with its unit (and hex for
/// integers), or why it was not read.
fn value_text(row: &Row) -> String {
    match (&row.text, &row.error) {
        (_, Some(error)) => format!("error: {error}"),
        (Some(text), None) => {
            // Hex for integers; text and bytes speak for themselves.
            let hex = match (&row.value, &row.hex) {
                (Some(Value::Int(_) | Value::Uint(_)), Some(h)) => format!(" ({h})"),
                _ => String::new(),
            };
            let unit = match row.unit.as_deref() {
                None | Some("") => String::new(),
                Some(unit) => format!(" {unit}"),
            };
            format!("{text}{unit}{hex}")
        }
        (None, None) => String::new(),
    }
}
