//! `drivedeck store`, `defaults` and `reboot` (protocol notes §4.2.1): "save" to 1010h:01
//! keeps every value written so far for the next power-on; "load" to 1011h:01 brings the
//! factory values back at the next restart; "boot" to 2800h:01 restarts the firmware, and
//! `reboot` waits until the drive answers again and says after how long, checking that it
//! is the same drive.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;
use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed};
use super::report;
use super::session::Session;
use crate::link::LinkSpec;
use crate::od::{Address, DataType, Value};

/// "save", "load" and "boot" in ASCII, read as little-endian u32.
const SAVE: u64 = 0x6576_6173;
const LOAD: u64 = 0x6461_6F6C;
const BOOT: u64 = 0x746F_6F62;

/// How long after the reboot command the drive is first looked for again.
const FIRST_LOOK: Duration = Duration::from_millis(300);
/// How often it is looked for while it does not answer.
const LOOK_EVERY: Duration = Duration::from_millis(250);

#[derive(Args, Debug, Clone)]
pub struct DefaultsArgs {
    /// Restart the drive at once, so that the factory values are in force now.
    #[arg(long)]
    pub reboot: bool,
}

#[derive(Serialize, Debug, Default)]
struct StorageReport {
    link: String,
    /// What was written, in words.
    done: Vec<String>,
    /// The reboot: seconds until the drive answered again.
    #[serde(skip_serializing_if = "Option::is_none")]
    back_after_s: Option<f64>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    notes: Vec<String>,
}

pub enum What {
    Store,
    Defaults { reboot: bool },
    Reboot,
}

pub fn run(
    link: &LinkSpec,
    what: What,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    if *link == LinkSpec::Sim {
        report::print_error(
            "the in-process simulated drive starts anew with every command, so nothing it \
             stores outlives the command: serve it with `drivedeck sim --modbus-tcp \
             127.0.0.1:1502` and give --link modbus-tcp://127.0.0.1:1502",
            json,
        );
        return ExitCode::from(super::EXIT_USAGE);
    }
    let mut report = StorageReport {
        link: link.to_string(),
        ..StorageReport::default()
    };
    match act(link, what, timeout, trace, context, &mut report) {
        Ok(()) => {
            if json {
                report::print_json(&report, "report");
            } else {
                for line in report.done.iter().chain(&report.notes) {
                    println!("{line}");
                }
            }
            ExitCode::SUCCESS
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn act(
    link: &LinkSpec,
    what: What,
    timeout: Duration,
    trace: bool,
    context: &Context,
    report: &mut StorageReport,
) -> Result<(), Failure> {
    let mut session = Session::open(link, timeout, trace, context)?;
    match what {
        What::Store => {
            signature(&mut session, Address::new(0x1010, 1), SAVE, timeout)?;
            report.done.push(
                "stored (\"save\" to 1010h:01): every value as it is now comes back at the next power-on"
                    .into(),
            );
            Ok(())
        }
        What::Defaults { reboot } => {
            signature(&mut session, Address::new(0x1011, 1), LOAD, timeout)?;
            report.done.push(
                "factory values restored (\"load\" to 1011h:01): in force from the next restart"
                    .into(),
            );
            if reboot {
                restart(session, link, timeout, trace, context, report)
            } else {
                report
                    .notes
                    .push("restart the drive for them to take effect: drivedeck reboot".into());
                Ok(())
            }
        }
        What::Reboot => restart(session, link, timeout, trace, context, report),
    }
}

/// Write a 4-character signature; the drive's refusal is said with its reason.
fn signature(
    session: &mut Session,
    address: Address,
    value: u64,
    timeout: Duration,
) -> Result<(), Failure> {
    let text: String = value
        .to_le_bytes()
        .iter()
        .take(4)
        .map(|b| char::from(*b))
        .collect();
    session
        .try_write(address, DataType::Unsigned32, Value::Uint(value), timeout)?
        .map_err(|e| failed(format!("the drive refused {text:?} at {address}: {e}")))
}

/// The drive's identity (1018h:01–04), as far as it answers.
fn identity(session: &mut Session, timeout: Duration) -> Vec<Option<Value>> {
    let objects: Vec<(Address, DataType)> = (1..=4)
        .map(|sub| (Address::new(0x1018, sub), DataType::Unsigned32))
        .collect();
    let (reads, _) = session.read_many(objects.clone(), timeout, |_, _| {});
    objects
        .iter()
        .map(|(a, _)| reads.get(a).and_then(|r| r.as_ref().ok()).cloned())
        .collect()
}

/// Restart the drive and wait until it answers again (within `timeout`).
fn restart(
    mut session: Session,
    link: &LinkSpec,
    timeout: Duration,
    trace: bool,
    context: &Context,
    report: &mut StorageReport,
) -> Result<(), Failure> {
    let before = identity(&mut session, timeout);
    let delay = session
        .try_read(
            Address::new(0x2800, 2),
            Some(DataType::Unsigned32),
            crate::worker::ObjectPath::Auto,
            timeout,
        )
        .ok()
        .and_then(|r| r.ok())
        .and_then(|v| v.as_i128())
        .map_or(Duration::ZERO, |ms| {
            Duration::from_millis(ms.clamp(0, 60_000) as u64)
        });
    let sent = Instant::now();
    // A drive may restart before it answers the write: no answer is no failure here, a
    // refusal is.
    match session.try_write(
        Address::new(0x2800, 1),
        DataType::Unsigned32,
        Value::Uint(BOOT),
        timeout.min(Duration::from_secs(2)),
    ) {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            return Err(failed(format!(
                "the drive refused the restart (\"boot\" to 2800h:01): {e}; firmware before \
                 FIR-v1540 has no restart by object, switch its supply off and on"
            )));
        }
        Err(f) => report.notes.push(format!(
            "the drive did not answer the restart command ({})",
            f.message
        )),
    }
    drop(session);
    report
        .done
        .push("restart (\"boot\" to 2800h:01) sent".into());
    std::thread::sleep(delay + FIRST_LOOK);
    let deadline = sent + delay + timeout;
    let mut tries = 0;
    let back = loop {
        tries += 1;
        match Session::open(link, timeout.min(Duration::from_secs(2)), trace, context) {
            Ok(session) => break session,
            Err(f) if Instant::now() < deadline => {
                let _ = f;
                std::thread::sleep(LOOK_EVERY);
            }
            Err(f) => {
                return Err(failed(format!(
                    "the drive did not answer again within {:.1} s of the restart: {}",
                    timeout.as_secs_f64(),
                    f.message
                )));
            }
        }
    };
    let after = sent.elapsed().as_secs_f64() - delay.as_secs_f64();
    let mut back = back;
    let now = identity(&mut back, timeout);
    if now != before {
        return Err(failed(format!(
            "another device answers after the restart: identity 1018h was {}, is {}",
            shown(&before),
            shown(&now)
        )));
    }
    report.back_after_s = Some((after * 10.0).round() / 10.0);
    report.done.push(format!(
        "the drive answers again after {after:.1} s, the same drive (1018h)"
    ));
    if tries == 1 && after < 0.5 {
        report.notes.push(
            "it answered at the first look: check that it restarted (2800h:01 needs firmware \
             FIR-v1540 or later)"
                .into(),
        );
    }
    Ok(())
}

fn shown(identity: &[Option<Value>]) -> String {
    identity
        .iter()
        .map(|v| v.as_ref().map_or("?".into(), |v| v.to_string()))
        .collect::<Vec<_>>()
        .join("/")
}
