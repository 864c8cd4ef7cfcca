//! `drivedeck --link URL record --signals position,velocity --rate 500 --duration 5s
//! --out run.csv`: sample the drive through the worker and write what came, with the
//! device's identity and the units in the file's header. With `--trigger` it waits for
//! the condition and records `--pre` before and `--duration` after it.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::oneshot::{Failure, Session, failed, usage};
use super::progress;
use super::{EXIT_FAILED, RecordArgs, report};
use crate::link::LinkSpec;
use crate::od::backup::{DeviceIdentity, IDENTITY};
use crate::od::{self, Address};
use crate::telemetry::{
    Builtin, CaptureState, Condition, Edge, Kind, Scope, ScopeEvent, Trigger, WatchedObject,
    metadata, save_recording, watchable,
};
use crate::worker::{Event, MAX_WATCHED, Request};

#[derive(Serialize, Debug)]
struct RecordReport {
    file: String,
    samples: usize,
    seconds: f64,
    /// Samples per second actually taken.
    rate: f64,
    signals: Vec<SignalReport>,
    trigger: Option<String>,
    trigger_time_s: Option<f64>,
    notes: Vec<String>,
    warnings: Vec<String>,
}

#[derive(Serialize, Debug)]
struct SignalReport {
    id: String,
    unit: String,
    /// Rows that carry a value of this signal.
    samples: usize,
}

pub fn run(
    link: &LinkSpec,
    args: &RecordArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
) -> ExitCode {
    match record(link, args, timeout, trace) {
        Ok(report) => {
            print(&report, json);
            if report.signals.iter().all(|s| s.samples > 0) {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(EXIT_FAILED)
            }
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

/// A duration as typed: `5s`, `500ms`, `2m`, `1.5` (seconds).
pub fn parse_duration(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 0.001)
    } else if let Some(n) = t.strip_suffix("min") {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('h') {
        (n, 3600.0)
    } else {
        (t, 1.0)
    };
    number
        .trim()
        .parse::<f64>()
        .ok()
        .map(|v| v * scale)
        .filter(|v| v.is_finite() && *v >= 0.0 && *v <= 86_400.0)
        .ok_or_else(|| format!("'{text}' is not a duration (e.g. 5s, 500ms, 2m)"))
}

/// Objects to sample besides the built-in signals, with their types.
type Watched = Vec<(WatchedObject, od::DataType)>;

/// The signals asked for (their ids), built-in ids or object addresses.
fn signals(text: &str) -> Result<(Vec<String>, Watched), String> {
    let mut ids = Vec::new();
    let mut watched = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        if let Some(b) = Builtin::from_id(part) {
            ids.push(b.id().to_owned());
            continue;
        }
        if part.parse::<Address>().is_err() {
            let known: Vec<&str> = Builtin::ALL.iter().map(|b| b.id()).collect();
            return Err(format!(
                "unknown signal '{part}': use {} or an object address such as 2031:00",
                known.join(", ")
            ));
        }
        let (object, dtype) = watchable(od::builtin(), part)?;
        ids.push(format!(
            "{:04X}h_{:02X}h",
            object.address.index, object.address.sub
        ));
        watched.push((object, dtype));
    }
    if ids.is_empty() {
        return Err("no signals: name at least one, e.g. --signals position,velocity".into());
    }
    if watched.len() > MAX_WATCHED {
        return Err(format!(
            "at most {MAX_WATCHED} objects besides the built-in signals"
        ));
    }
    Ok((ids, watched))
}

/// `position rises 1000`, `velocity falls 0`, `torque crosses 200`,
/// `pdi_status bit 10 rises`, `digital_inputs bit 16 changes`.
pub fn parse_trigger(text: &str, scope: &Scope) -> Result<Condition, String> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let edge = |w: &str| match w {
        "rises" | "rising" => Ok(Edge::Rising),
        "falls" | "falling" => Ok(Edge::Falling),
        "crosses" | "changes" | "either" => Ok(Edge::Either),
        other => Err(format!(
            "'{other}' is not an edge: rises, falls or crosses/changes"
        )),
    };
    let bad = || {
        format!("trigger '{text}': write e.g. 'position rises 1000' or 'pdi_status bit 10 rises'")
    };
    let signal = words.first().ok_or_else(bad)?;
    let def = scope
        .signal(signal)
        .ok_or_else(|| format!("trigger: no signal '{signal}'"))?;
    match words.as_slice() {
        [_, "bit", bit, e] => {
            let bit: u8 = bit
                .parse()
                .ok()
                .filter(|b| *b < 32)
                .ok_or_else(|| format!("trigger: '{bit}' is not a bit number 0 to 31"))?;
            if def.kind != Kind::Bits {
                return Err(format!("trigger: {signal} has no bits; use a threshold"));
            }
            Ok(Condition::Bit {
                channel: def.column,
                bit,
                edge: edge(e)?,
            })
        }
        [_, e, level] => {
            let level: f64 = level
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| format!("trigger: '{level}' is not a number"))?;
            Ok(Condition::Threshold {
                channel: def.column,
                level,
                edge: edge(e)?,
            })
        }
        _ => Err(bad()),
    }
}

fn record(
    link: &LinkSpec,
    args: &RecordArgs,
    timeout: Duration,
    trace: bool,
) -> Result<RecordReport, Failure> {
    let duration = parse_duration(&args.duration).map_err(usage)?;
    let pre = parse_duration(&args.pre).map_err(usage)?;
    if !(1.0..=2000.0).contains(&args.rate) {
        return Err(usage(format!(
            "a rate of {} Hz is outside 1 to 2000 Hz",
            args.rate
        )));
    }
    let (ids, watched) = signals(&args.signals).map_err(usage)?;
    let rows = ((duration + pre) * args.rate * 1.5) as usize + 1_000;
    let mut scope = Scope::new(rows.min(50_000_000));
    let objects: Vec<WatchedObject> = watched.iter().map(|(w, _)| w.clone()).collect();
    scope.set_watched(&objects);
    for signal in scope.signals_mut() {
        signal.shown = ids.contains(&signal.info.id);
        signal.auto = false;
    }
    let trigger = match &args.trigger {
        Some(text) => Some(Trigger {
            condition: parse_trigger(text, &scope).map_err(usage)?,
            pre_s: pre,
            post_s: duration,
        }),
        None => None,
    };

    let mut session = Session::open_at(link, timeout, trace, args.rate)?;
    let (reads, _) = session.read_many(IDENTITY.to_vec(), timeout, |_, _| {});
    let identity = DeviceIdentity::from_reads(&reads);
    scope.meta = metadata(Some(&identity), &link.to_string(), args.rate);
    if !watched.is_empty() {
        session.send_request(Request::Watch(
            watched.iter().map(|(w, d)| (w.address, *d)).collect(),
        ))?;
    }
    if let Some(trigger) = &trigger {
        scope.meta.trigger = Some(scope.describe_trigger(trigger));
        scope.arm(trigger.clone());
    }

    let wait = args
        .wait
        .as_deref()
        .map(parse_duration)
        .transpose()
        .map_err(usage)?
        .unwrap_or(timeout.as_secs_f64());
    let started = Instant::now();
    let total_ms = (duration * 1000.0) as usize;
    let mut bar = progress::bar(if trigger.is_some() {
        "recording after the trigger (ms)"
    } else {
        "recording (ms)"
    });
    let waiting_note = trigger.is_some() && std::io::stderr().is_terminal();
    if waiting_note {
        eprintln!(
            "waiting for the trigger: {}",
            scope.meta.trigger.clone().unwrap_or_default()
        );
    }
    let mut first_t: Option<f64> = None;
    let mut window: Option<(f64, f64)> = None;
    let mut fired_at = None;
    while window.is_none() {
        let deadline = Instant::now() + Duration::from_secs(5);
        let event = session.next_event(deadline)?;
        let Event::Samples(samples) = event else {
            continue;
        };
        for sample in &samples {
            let start = *first_t.get_or_insert(sample.t);
            let event = scope.push(sample);
            match (&trigger, event) {
                (None, _) => {
                    bar(
                        ((sample.t - start) * 1000.0).min(duration * 1000.0) as usize,
                        total_ms,
                    );
                    if sample.t - start >= duration {
                        window = Some((start, start + duration));
                        break;
                    }
                }
                (Some(_), Some(ScopeEvent::Fired(at))) => fired_at = Some(at),
                (Some(_), Some(ScopeEvent::Recorded)) => {
                    if let CaptureState::Complete { from, to, .. } = scope.capture_state() {
                        bar(total_ms, total_ms);
                        window = Some((from, to));
                        break;
                    }
                }
                (Some(_), None) => {
                    if let Some(at) = fired_at {
                        bar(
                            ((sample.t - at) * 1000.0).max(0.0) as usize,
                            total_ms.max(1),
                        );
                    } else if started.elapsed().as_secs_f64() > wait {
                        return Err(failed(format!(
                            "the trigger did not fire within {wait:.1} s ({})",
                            scope.meta.trigger.clone().unwrap_or_default()
                        )));
                    }
                }
            }
        }
    }
    let (from, to) = window.ok_or_else(|| failed("no samples came"))?;
    let mut meta = scope.meta.clone();
    meta.trigger_time_s = fired_at;
    let recording = scope.export(from, to, meta, true);
    let path = args.out.to_string_lossy().into_owned();
    let message = save_recording(&recording, &path).map_err(failed)?;
    let mut notes = session.take_notes();
    notes.push(message);
    let seconds = recording.duration();
    let mut warnings = Vec::new();
    let signals: Vec<SignalReport> = recording
        .channels
        .iter()
        .zip(&recording.columns)
        .map(|(info, column)| {
            let samples = column.iter().filter(|v| !v.is_nan()).count();
            if samples == 0 {
                warnings.push(format!(
                    "{}: no samples; this link does not deliver it",
                    info.id
                ));
            }
            SignalReport {
                id: info.id.clone(),
                unit: info.unit.clone(),
                samples,
            }
        })
        .collect();
    Ok(RecordReport {
        file: path,
        samples: recording.len(),
        seconds,
        rate: if seconds > 0.0 {
            (recording.len().saturating_sub(1)) as f64 / seconds
        } else {
            0.0
        },
        signals,
        trigger: recording.meta.trigger.clone(),
        trigger_time_s: fired_at,
        notes,
        warnings,
    })
}

fn print(report: &RecordReport, json: bool) {
    if json {
        match serde_json::to_string_pretty(report) {
            Ok(text) => println!("{text}"),
            Err(e) => eprintln!("drivedeck: cannot print the report: {e}"),
        }
        return;
    }
    println!(
        "recorded {} samples over {:.3} s ({:.0} samples/s) to {}",
        report.samples, report.seconds, report.rate, report.file
    );
    if let (Some(trigger), Some(at)) = (&report.trigger, report.trigger_time_s) {
        println!("trigger: {trigger}; fired at {at:.3} s");
    }
    for s in &report.signals {
        println!(
            "  {:<18} {:>8} samples{}",
            s.id,
            s.samples,
            if s.unit.is_empty() {
                String::new()
            } else {
                format!("  [{}]", s.unit)
            }
        );
    }
    for note in &report.notes {
        eprintln!("note: {note}");
    }
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
}
