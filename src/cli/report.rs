//! What a one-shot command prints: text for people, JSON for scripts.

use serde::Serialize;

use crate::cia::{AbortCode, ErrorCode, PowerState};
use crate::link::LinkSpec;
use crate::od::{self, Address, DataType, Value};
use crate::pdi::StatusBit;
use crate::worker::{CommandProgress, Sample};

#[derive(Serialize, Debug)]
#[serde(untagged)]
pub enum Report {
    Status(StatusReport),
    Object(ObjectReport),
    Command(CommandReport),
    Scan(ScanReport),
}

impl Report {
    pub fn set_warnings(&mut self, warnings: Vec<String>) {
        match self {
            Report::Status(r) => r.warnings = warnings,
            Report::Object(r) => r.warnings = warnings,
            Report::Command(r) => r.warnings = warnings,
            Report::Scan(r) => r.warnings = warnings,
        }
    }

    pub fn set_notes(&mut self, notes: Vec<String>) {
        match self {
            Report::Status(r) => r.notes = notes,
            Report::Object(r) => r.notes = notes,
            Report::Command(r) => r.notes = notes,
            Report::Scan(r) => r.notes = notes,
        }
    }

    fn notes(&self) -> &[String] {
        match self {
            Report::Status(r) => &r.notes,
            Report::Object(r) => &r.notes,
            Report::Command(r) => &r.notes,
            Report::Scan(r) => &r.notes,
        }
    }

    fn warnings(&self) -> &[String] {
        match self {
            Report::Status(r) => &r.warnings,
            Report::Object(r) => &r.warnings,
            Report::Command(r) => &r.warnings,
            Report::Scan(r) => &r.warnings,
        }
    }
}

#[derive(Serialize, Debug)]
pub struct Bit {
    pub bit: u8,
    pub name: &'static str,
    pub set: bool,
}

#[derive(Serialize, Debug)]
pub struct StatusReport {
    pub link: String,
    pub pdi_status: u16,
    pub bits: Vec<Bit>,
    pub undefined_bits: u16,
    pub error_code: u16,
    pub error_meaning: &'static str,
    pub return_value: i32,
    /// When PdiStatusError is set: ReturnValue as an abort code.
    pub return_error: Option<String>,
    pub statusword: Option<u16>,
    pub state: Option<&'static str>,
    pub mode: Option<i8>,
    pub position: Option<f64>,
    pub velocity: Option<f64>,
    pub torque: Option<f64>,
    pub following_error: Option<f64>,
    pub digital_inputs: Option<u32>,
    pub analog_input: Option<f64>,
    pub warnings: Vec<String>,
    /// What the link reported on the way (fallbacks chosen, mappings changed).
    pub notes: Vec<String>,
}

#[derive(Serialize, Debug)]
pub struct ObjectReport {
    pub address: String,
    pub name: Option<String>,
    #[serde(rename = "type")]
    pub dtype: Option<String>,
    pub value: Value,
    pub text: String,
    pub hex: Option<String>,
    pub unit: Option<String>,
    pub written: bool,
    pub warnings: Vec<String>,
    pub notes: Vec<String>,
}

#[derive(Serialize, Debug)]
pub struct ScanReport {
    pub bus: String,
    pub nodes: Vec<crate::link::FoundDevice>,
    pub warnings: Vec<String>,
    pub notes: Vec<String>,
}

pub fn scan(link: &LinkSpec, devices: Vec<crate::link::FoundDevice>) -> ScanReport {
    ScanReport {
        bus: link.to_string(),
        nodes: devices,
        warnings: vec![],
        notes: vec![],
    }
}

#[derive(Serialize, Debug)]
pub struct CommandReport {
    pub command: String,
    /// The RX image written: SetValue1 (4 bytes LE), SetValue2 (2), SetValue3 (1), PDI-Cmd.
    pub image: Option<[u8; 8]>,
    pub outcome: &'static str,
    pub return_value: Option<i32>,
    /// What the drive shows after the command (`enable` says whether it moved).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drive: Option<DriveAfter>,
    pub warnings: Vec<String>,
    pub notes: Vec<String>,
}

/// The drive as a command left it: CiA 402 state, speed and position.
#[derive(Serialize, Debug)]
pub struct DriveAfter {
    pub state: Option<&'static str>,
    pub velocity: Option<f64>,
    pub position: Option<f64>,
}

pub fn drive_after(sample: &Sample) -> DriveAfter {
    DriveAfter {
        state: sample
            .statusword()
            .and_then(PowerState::from_statusword)
            .map(|s| s.name()),
        velocity: sample.velocity(),
        position: sample.position(),
    }
}

pub fn status(link: &LinkSpec, sample: Option<Sample>) -> StatusReport {
    let sample = sample.unwrap_or_default();
    let status = sample.tx.status;
    let code = ErrorCode(sample.tx.error_code);
    StatusReport {
        link: link.to_string(),
        pdi_status: status.0,
        bits: StatusBit::ALL
            .iter()
            .map(|b| Bit {
                bit: b.bit(),
                name: b.name(),
                set: status.is_set(*b),
            })
            .collect(),
        undefined_bits: status.undefined_bits(),
        error_code: code.0,
        error_meaning: code.meaning(),
        return_value: sample.tx.return_value,
        return_error: status
            .is_set(StatusBit::Error)
            .then(|| AbortCode(sample.tx.return_value as u32).to_string()),
        statusword: sample.statusword(),
        state: sample
            .statusword()
            .and_then(PowerState::from_statusword)
            .map(PowerState::name),
        mode: sample.mode(),
        position: sample.position(),
        velocity: sample.velocity(),
        torque: sample.torque(),
        following_error: sample.following_error(),
        digital_inputs: sample.digital_inputs(),
        analog_input: sample.analog_input(),
        warnings: vec![],
        notes: vec![],
    }
}

pub fn object(
    address: Address,
    dtype: Option<DataType>,
    value: &Value,
    written: bool,
) -> ObjectReport {
    let entry = od::builtin().get(address);
    ObjectReport {
        address: address.to_string(),
        name: entry.map(|e| e.full_name()),
        dtype: dtype.map(|d| d.short_name().to_owned()),
        value: value.clone(),
        text: value.to_string(),
        hex: dtype.map(|d| value.to_hex(d)).filter(|h| !h.is_empty()),
        unit: entry.and_then(|e| e.unit.clone()),
        written,
        warnings: vec![],
        notes: vec![],
    }
}

pub fn command(what: String, image: Option<[u8; 8]>, progress: &CommandProgress) -> CommandReport {
    let (outcome, return_value) = match progress {
        CommandProgress::Done { return_value } => ("done", Some(*return_value)),
        CommandProgress::Accepted => ("accepted", None),
        _ => ("failed", None),
    };
    CommandReport {
        command: what,
        image,
        outcome,
        return_value,
        drive: None,
        warnings: vec![],
        notes: vec![],
    }
}

pub fn print(report: &Report, json: bool) {
    print_lines(report.notes(), report.warnings());
    if json {
        print_json(report, "report");
        return;
    }
    match report {
        Report::Status(s) => print_status(s),
        Report::Scan(r) => print_scan(r),
        Report::Object(o) => print_object(o),
        Report::Command(c) => print_command(c),
    }
}

/// A report's notes and warnings, on stderr.
pub fn print_lines(notes: &[String], warnings: &[String]) {
    for note in notes {
        eprintln!("note: {note}");
    }
    for warning in warnings {
        eprintln!("warning: {warning}");
    }
}

/// A report as JSON on stdout; `what` names it when it cannot be formatted.
pub fn print_json(report: &impl Serialize, what: &str) {
    match serde_json::to_string_pretty(report) {
        Ok(text) => outln!("{text}"),
        Err(e) => eprintln!("drivedeck: cannot format the {what} as JSON: {e}"),
    }
}

fn print_scan(r: &ScanReport) {
    if r.nodes.is_empty() {
        outln!("nothing answered on {}", r.bus);
    }
    let hex = |v: Option<u32>| v.map_or("?".to_owned(), |v| format!("{v:08X}h"));
    for n in &r.nodes {
        let (place, revision) = match n.node {
            Some(node) => (format!("node {node:>3}"), hex(n.revision)),
            // EtherNet/IP: the address, and the revision as major.minor.
            None => (
                n.address.clone(),
                n.revision
                    .map_or("?".into(), |r| format!("{}.{}", r >> 16, r & 0xFFFF)),
            ),
        };
        outln!(
            "{place}  vendor {}  product {}  revision {revision}  serial {}  {:<15} {}",
            hex(n.vendor),
            hex(n.product),
            hex(n.serial),
            crate::text::shown(n.state.as_deref().unwrap_or_default()),
            crate::text::shown(n.name.as_deref().unwrap_or_default())
        );
        if let Some(refused) = &n.refused {
            outln!("          {refused}");
        }
    }
}

fn print_object(o: &ObjectReport) {
    let name = o
        .name
        .as_deref()
        .map(|n| format!(" {n}"))
        .unwrap_or_default();
    let unit = o
        .unit
        .as_deref()
        .map(|u| format!(" {u}"))
        .unwrap_or_default();
    let hex = o
        .hex
        .as_deref()
        .map(|h| format!(" ({h})"))
        .unwrap_or_default();
    let verb = if o.written { "written: " } else { "" };
    // A string object's value is the device's: shown, never obeyed by the terminal.
    outln!(
        "{}{name} = {verb}{}{unit}{hex}",
        o.address,
        crate::text::escaped(&o.text)
    );
}

fn print_command(c: &CommandReport) {
    let image = c
        .image
        .map(|b| {
            format!(
                " [{}]",
                b.iter()
                    .map(|x| format!("{x:02X}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        })
        .unwrap_or_default();
    match c.return_value {
        Some(rv) => outln!("{}{image}: {} (ReturnValue {rv})", c.command, c.outcome),
        None => outln!("{}{image}: {}", c.command, c.outcome),
    }
    if let Some(d) = &c.drive {
        let mut parts = vec![d.state.unwrap_or("CiA 402 state unknown").to_owned()];
        if let Some(v) = d.velocity {
            parts.push(format!("velocity {v:.0} rpm"));
        }
        if let Some(p) = d.position {
            parts.push(format!("position {p:.0} (0.1°)"));
        }
        outln!("drive now   {}", parts.join(", "));
    }
}

fn print_status(s: &StatusReport) {
    outln!("link        {}", s.link);
    match (s.state, s.statusword) {
        (Some(state), Some(word)) => outln!("state       {state} (6041h = {word:04X}h)"),
        (None, Some(word)) => {
            outln!("state       statusword {word:04X}h matches no CiA 402 state")
        }
        _ => outln!("state       unknown (6041h not readable on this link)"),
    }
    let on: Vec<&str> = s.bits.iter().filter(|b| b.set).map(|b| b.name).collect();
    outln!(
        "PDI-Status  {:04X}h{}",
        s.pdi_status,
        if on.is_empty() {
            String::new()
        } else {
            format!(" {}", on.join(" "))
        }
    );
    if s.undefined_bits != 0 {
        outln!("            undefined bits {:04X}h", s.undefined_bits);
    }
    outln!("603Fh       {:04X}h {}", s.error_code, s.error_meaning);
    match &s.return_error {
        Some(text) => outln!("ReturnValue {:08X}h: {text}", s.return_value as u32),
        None => outln!("ReturnValue {}", s.return_value),
    }
    if let Some(mode) = s.mode {
        outln!("mode        {mode} (6061h)");
    }
    let mut actual = vec![];
    if let Some(p) = s.position {
        actual.push(format!("position {p:.0} (0.1°)"));
    }
    if let Some(v) = s.velocity {
        actual.push(format!("velocity {v:.0} rpm"));
    }
    if let Some(t) = s.torque {
        actual.push(format!("torque {t:.0} ‰"));
    }
    if let Some(f) = s.following_error {
        actual.push(format!("following error {f:.0}"));
    }
    if !actual.is_empty() {
        outln!("actual      {}", actual.join(", "));
    }
}

pub fn print_error(message: &str, json: bool) {
    if json {
        let body = serde_json::json!({ "error": message });
        outln!("{body}");
    } else {
        eprintln!("drivedeck: {message}");
    }
}
