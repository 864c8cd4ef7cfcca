//! `drivedeck nanoj status | start | stop`: the drive's NanoJ program — its state and
//! error in words, the programs on the drive, the objects mapped into it, its outputs and
//! the uptime; `start` waits until the program reports running (or its error) and says
//! which, `stop` until it reports stopped.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Args, Subcommand};
use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed};
use super::report;
use super::session::Session;
use crate::link::LinkSpec;
use crate::od::nanoj::{error_text, mapping, program_names, status_text};
use crate::od::{Address, DataType, Value, builtin};

/// How often the status is read while waiting for a start or a stop.
const POLL: Duration = Duration::from_millis(50);
/// How long a start or a stop may take at most (the vendor: "up to 200 ms").
const WAIT_AT_MOST: Duration = Duration::from_secs(5);

#[derive(Args, Debug, Clone)]
pub struct NanojArgs {
    #[command(subcommand)]
    pub command: NanojCommand,
}

#[derive(Subcommand, Debug, Clone, Copy)]
pub enum NanojCommand {
    /// The program's state, error, name, mapping, outputs and the uptime.
    Status,
    /// Start the program (2300h bit 0 = 1) and wait until it runs or stops with an error.
    Start,
    /// Stop the program (2300h = 0) and wait until it reports stopped.
    Stop,
}

#[derive(Serialize, Debug, Default)]
struct Mapped {
    object: String,
    name: String,
    bits: u8,
}

#[derive(Serialize, Debug, Default)]
struct NanojReport {
    link: String,
    /// 2301h and its meaning.
    status: Option<u32>,
    state: String,
    /// 2302h and its meaning.
    error_code: Option<u32>,
    error: String,
    programs: Vec<String>,
    inputs: Vec<Mapped>,
    outputs: Vec<Mapped>,
    /// 2500h:01–04 as read.
    nanoj_outputs: Vec<i64>,
    uptime_s: Option<u64>,
    /// What start or stop did, and how long it took.
    #[serde(skip_serializing_if = "Option::is_none")]
    done: Option<String>,
}

pub fn run(
    link: &LinkSpec,
    args: &NanojArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    let outcome = (|| {
        let mut session = Session::open(link, timeout, trace, context)?;
        let done = match args.command {
            NanojCommand::Status => None,
            NanojCommand::Start => Some(change(&mut session, true, timeout)?),
            NanojCommand::Stop => Some(change(&mut session, false, timeout)?),
        };
        let mut report = status(&mut session, link, timeout)?;
        let ok = match (&done, args.command) {
            (Some(_), NanojCommand::Start) => report.status == Some(1),
            (Some(_), NanojCommand::Stop) => report.status == Some(0),
            _ => true,
        };
        report.done = done.map(|(text, _)| text);
        Ok::<_, Failure>((report, ok))
    })();
    match outcome {
        Ok((report, ok)) => {
            if json {
                report::print_json(&report, "NanoJ report");
            } else {
                print(&report);
            }
            if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(super::EXIT_FAILED)
            }
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

/// An unsigned object read in its catalog type (a refusal or a broken link: `None`).
fn read_u32(session: &mut Session, index: u16, sub: u8, timeout: Duration) -> Option<u32> {
    session.read_int(index, sub, timeout).map(|v| v as u32)
}

/// Write 2300h and wait for 2301h to say the program runs (or stopped by an error) or
/// stopped: what happened in words, and how long it took.
fn change(session: &mut Session, start: bool, timeout: Duration) -> Result<(String, f64), Failure> {
    let asked = Instant::now();
    session
        .try_write(
            Address::new(0x2300, 0),
            DataType::Unsigned32,
            Value::Uint(u64::from(start)),
            timeout,
        )?
        .map_err(|e| {
            failed(format!(
                "the drive refused 2300h = {}: {e}",
                u8::from(start)
            ))
        })?;
    let limit = timeout.min(WAIT_AT_MOST);
    loop {
        let status = read_u32(session, 0x2301, 0, timeout);
        let took = asked.elapsed().as_secs_f64();
        match (start, status) {
            (true, Some(1)) => {
                return Ok((format!("started: the program runs ({took:.2} s)"), took));
            }
            (_, Some(s)) if s >= 2 => {
                let code = read_u32(session, 0x2302, 0, timeout).unwrap_or(0);
                return Ok((
                    format!(
                        "the program stopped with an error after {took:.2} s: {code:X}h, {}",
                        error_text(code)
                    ),
                    took,
                ));
            }
            (false, Some(0)) => return Ok((format!("stopped ({took:.2} s)"), took)),
            _ => {}
        }
        if asked.elapsed() >= limit {
            let what = if start { "running" } else { "stopped" };
            return Ok((
                format!(
                    "the program did not report {what} within {:.1} s (2301h = {})",
                    limit.as_secs_f64(),
                    status.map_or("unread".into(), |s| s.to_string())
                ),
                took,
            ));
        }
        std::thread::sleep(POLL);
    }
}

/// The mapping entries of a selection object (2310h, 2320h), named by the catalog.
fn mapped(session: &mut Session, index: u16, timeout: Duration) -> Vec<Mapped> {
    let count = read_u32(session, index, 0, timeout).unwrap_or(0).min(16) as u8;
    (1..=count)
        .filter_map(|sub| read_u32(session, index, sub, timeout))
        .filter(|entry| *entry != 0)
        .map(|entry| {
            let (object, sub, bits) = mapping(entry);
            let address = Address::new(object, sub);
            Mapped {
                object: address.to_string(),
                name: builtin()
                    .get(address)
                    .map_or_else(String::new, |e| e.full_name()),
                bits,
            }
        })
        .collect()
}

fn status(
    session: &mut Session,
    link: &LinkSpec,
    timeout: Duration,
) -> Result<NanojReport, Failure> {
    let status = read_u32(session, 0x2301, 0, timeout);
    let error_code = read_u32(session, 0x2302, 0, timeout);
    let names = read_u32(session, 0x2304, 0, timeout).unwrap_or(0).min(40) as u8;
    let words: Vec<u32> = (1..=names)
        .filter_map(|sub| read_u32(session, 0x2304, sub, timeout))
        .collect();
    Ok(NanojReport {
        link: link.to_string(),
        status,
        state: status.map_or("not read".into(), |s| status_text(s).to_owned()),
        error_code,
        error: error_code.map_or("not read".into(), error_text),
        programs: program_names(&words),
        inputs: mapped(session, 0x2310, timeout),
        outputs: mapped(session, 0x2320, timeout),
        nanoj_outputs: (1..=4)
            .filter_map(|sub| read_u32(session, 0x2500, sub, timeout))
            .map(|v| i64::from(v as i32))
            .collect(),
        uptime_s: read_u32(session, 0x230F, 0, timeout).map(u64::from),
        done: None,
    })
}

fn print(r: &NanojReport) {
    if let Some(done) = &r.done {
        println!("{done}");
    }
    println!(
        "NanoJ program: {}{}",
        r.state,
        r.status
            .map_or(String::new(), |s| format!(" (2301h = {s})"))
    );
    if let Some(code) = r.error_code.filter(|c| *c != 0) {
        println!("error 2302h = {code:X}h: {}", r.error);
    }
    if !r.programs.is_empty() {
        println!("programs on the drive: {}", r.programs.join(", "));
    }
    for (what, list) in [("inputs", &r.inputs), ("outputs", &r.outputs)] {
        for m in list.iter() {
            println!("  {what}: {} {} ({} bits)", m.object, m.name, m.bits);
        }
    }
    if !r.nanoj_outputs.is_empty() {
        let shown: Vec<String> = r.nanoj_outputs.iter().map(i64::to_string).collect();
        println!("NanoJ outputs 2500h:01–04: {}", shown.join(", "));
    }
    if let Some(up) = r.uptime_s {
        println!("uptime: {up} s");
    }
}
