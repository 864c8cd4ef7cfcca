//! `drivedeck gains`: the closed-loop controller's gains and the limits that shape a
//! response, read from the drive and listed with their addresses, units, factory values
//! and how firm the public record is about each (docs/protocol-notes.md, "Controller
//! gains"). Objects a drive does not have (another firmware's parameter set) are listed
//! with the drive's refusal, not left out.

use std::process::ExitCode;
use std::time::Duration;

use serde::Serialize;

use super::context::Context;
use super::failure::Failure;
use super::report;
use super::session::Session;
use crate::link::LinkSpec;
use crate::od::gains::{addresses, group_of};
use crate::od::{Address, DataType, builtin};

#[derive(Serialize, Debug)]
struct GainRow {
    address: String,
    group: &'static str,
    name: String,
    unit: String,
    /// The value read, as the drive gave it; `None` with `refused` when not read.
    value: Option<String>,
    refused: Option<String>,
    factory: Option<String>,
    /// The type's range, e.g. "0 … 4 294 967 295".
    range: String,
}

#[derive(Serialize, Debug)]
struct GainsReport {
    link: String,
    gains: Vec<GainRow>,
}

pub fn run(
    link: &LinkSpec,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    match gains(link, timeout, trace, context) {
        Ok(report) => {
            print(&report, json);
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn gains(
    link: &LinkSpec,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<GainsReport, Failure> {
    let catalog = builtin();
    let objects: Vec<(Address, DataType)> = addresses()
        .into_iter()
        .map(|a| {
            let dtype = catalog.get(a).map_or(DataType::Unsigned32, |e| e.dtype);
            (a, dtype)
        })
        .collect();
    let mut session = Session::open(link, timeout, trace, context)?;
    let (reads, failure) = session.read_many(objects.clone(), timeout, |_, _| {});
    if let Some(f) = failure {
        return Err(f);
    }
    let gains = objects
        .iter()
        .map(|(address, dtype)| {
            let entry = catalog.get(*address);
            let read = reads.get(address);
            GainRow {
                address: address.to_string(),
                group: group_of(*address),
                name: entry.map_or_else(|| address.to_string(), |e| e.full_name()),
                unit: entry.and_then(|e| e.unit.clone()).unwrap_or_default(),
                value: read.and_then(|r| r.as_ref().ok()).map(|v| v.to_string()),
                refused: match read {
                    Some(Err(e)) => Some(e.to_string()),
                    None => Some("not answered".into()),
                    Some(Ok(_)) => None,
                },
                factory: entry
                    .and_then(|e| e.default.as_ref())
                    .map(|v| v.to_string()),
                range: dtype
                    .integer_range()
                    .map(|(min, max)| crate::number::range_text(min, max))
                    .unwrap_or_default(),
            }
        })
        .collect();
    Ok(GainsReport {
        link: link.to_string(),
        gains,
    })
}

fn print(report: &GainsReport, json: bool) {
    if json {
        report::print_json(report, "gains");
        return;
    }
    let mut group = "";
    for row in &report.gains {
        if row.group != group {
            group = row.group;
            outln!("{group}:");
        }
        let value = match (&row.value, &row.refused) {
            (Some(v), _) => format!("{v} {}", row.unit).trim_end().to_owned(),
            (None, Some(why)) => format!("not on this drive ({why})"),
            (None, None) => "-".into(),
        };
        let factory = row
            .factory
            .as_ref()
            .filter(|f| Some(*f) != row.value.as_ref())
            .map(|f| format!("  (factory {f})"))
            .unwrap_or_default();
        outln!(
            "  {}  {:<72} {value}{factory}",
            row.address,
            crate::text::shown(&row.name)
        );
    }
}
