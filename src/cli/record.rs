//! `drivedeck --link URL record --signals position,velocity --rate 500 --duration 5s
//! --out run.csv`: sample the drive through the worker and write what came, with the
//! device's identity and the units in the file's header. With `--trigger` it waits for
//! the condition and records `--pre` before and `--duration` after it.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime};

use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::progress;
use super::session::Session;
use super::stop::STOP_WAIT;
use super::{EXIT_FAILED, EXIT_INTERRUPTED, RecordArgs, report};
use crate::file::{check_writable, write_whole};
use crate::link::LinkSpec;
use crate::od::backup::{DeviceIdentity, IDENTITY};
use crate::od::{self, Address};
use crate::telemetry::{
    Builtin, CaptureState, Condition, Edge, Kind, Recording, Scope, ScopeEvent, Trigger,
    WatchedObject, metadata, recording_text, utc_text, watchable,
};
use crate::worker::{Event, MAX_WATCHED, Request};

#[derive(Serialize, Debug)]
struct RecordReport {
    /// Where the recording is; `None` when no place could take it.
    file: Option<String>,
    samples: usize,
    seconds: f64,
    /// Samples per second actually taken.
    rate: f64,
    /// Samples per second asked for.
    rate_asked: f64,
    signals: Vec<SignalReport>,
    trigger: Option<String>,
    trigger_time_s: Option<f64>,
    /// Why and when the recording ended before its time (a link loss, a signal, a write
    /// error); everything taken until then is in the file.
    ended_early: Option<String>,
    /// What was done to the drive on the way out after a signal.
    stopped: Option<String>,
    notes: Vec<String>,
    warnings: Vec<String>,
    /// The exit code of a run cut short (1; 130 for a signal).
    #[serde(skip)]
    code: Option<u8>,
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
    context: &Context,
) -> ExitCode {
    match record(link, args, timeout, trace, context) {
        Ok(report) => {
            print(&report, json);
            match report.code {
                Some(code) => ExitCode::from(code),
                None if report.signals.iter().all(|s| s.samples > 0) => ExitCode::SUCCESS,
                None => ExitCode::from(EXIT_FAILED),
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

/// What a `record` command asks for, checked before anything is connected.
struct Plan {
    duration: f64,
    /// How long to wait for the trigger.
    wait: f64,
    watched: Watched,
    scope: Scope,
    trigger: Option<Trigger>,
}

/// Read and check the arguments, and that the file can be written.
fn plan(args: &RecordArgs, timeout: Duration) -> Result<Plan, Failure> {
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
    let wait = args
        .wait
        .as_deref()
        .map(parse_duration)
        .transpose()
        .map_err(usage)?
        .unwrap_or(timeout.as_secs_f64());
    // A place that cannot take the file is found now, not after the whole recording.
    check_writable(&args.out).map_err(|e| {
        usage(format!(
            "cannot write --out {}: {e}; nothing was recorded",
            shown_path(&args.out)
        ))
    })?;
    Ok(Plan {
        duration,
        wait,
        watched,
        scope,
        trigger,
    })
}

fn record(
    link: &LinkSpec,
    args: &RecordArgs,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<RecordReport, Failure> {
    let mut plan = plan(args, timeout)?;
    let mut session = Session::open_at(link, timeout, trace, args.rate, true, context)?;
    let mut warnings = Vec::new();
    if let Err(e) = session.catch_signals() {
        warnings.push(format!(
            "{e}: Ctrl-C will end drivedeck without saving the recording"
        ));
    }
    let early_cut = prepare(&mut session, &mut plan, link, args.rate, timeout)?;
    let (taker, cut) = take_samples(&mut session, plan, args.rate, early_cut);
    let mut recording = cut_out(taker, &cut, args.rate)?;
    // Saved before the drive is stopped: a second Ctrl-C while it brakes ends the process
    // at once, and must not take the recording with it.
    let interrupted = cut.as_ref().filter(|f| f.signal.is_some());
    let stopping = interrupted.is_some() && session.is_moving_or_unknown();
    let action = session.on_exit();
    if stopping && let Some(why) = &mut recording.meta.ended_early {
        why.push_str(&format!(
            "; the drive was being stopped ({}, --on-exit) when this was written",
            action.name()
        ));
    }
    let mut saved = save_safely(&recording, &args.out);
    let mut stopped = None;
    if let Some(cut) = interrupted.filter(|_| stopping) {
        let done = session.stop_drive(action, timeout.min(STOP_WAIT));
        recording.meta.ended_early = Some(format!("{}; {done}", early_why(cut, &recording)));
        saved = saved.again(&recording);
        stopped = Some(done);
    }
    let ending = Ending {
        cut,
        stopped,
        saved,
    };
    Ok(finish(session, recording, ending, link, args, warnings))
}

/// The identity into the file's header, the watched objects asked for, the trigger armed.
/// A signal or a lost link while that is under way cuts the recording short: the failure
/// comes back as the cut.
fn prepare(
    session: &mut Session,
    plan: &mut Plan,
    link: &LinkSpec,
    rate: f64,
    timeout: Duration,
) -> Result<Option<Failure>, Failure> {
    let (reads, cut) = session.read_many(IDENTITY.to_vec(), timeout, |_, _| {});
    let identity = DeviceIdentity::from_reads(&reads);
    plan.scope.meta = metadata(Some(&identity), &link.to_string(), rate);
    if cut.is_some() {
        return Ok(cut);
    }
    if !plan.watched.is_empty() {
        session.send_request(Request::Watch(
            plan.watched.iter().map(|(w, d)| (w.address, *d)).collect(),
        ))?;
    }
    if let Some(trigger) = &plan.trigger {
        plan.scope.meta.trigger = Some(plan.scope.describe_trigger(trigger));
        plan.scope.arm(trigger.clone());
        if std::io::stderr().is_terminal() {
            eprintln!(
                "waiting for the trigger: {}",
                plan.scope.meta.trigger.clone().unwrap_or_default()
            );
        }
    }
    Ok(None)
}

/// Take samples until the recording is complete, or something cuts it short (the
/// failure says what: a signal, a lost link, a trigger that did not fire).
fn take_samples(
    session: &mut Session,
    plan: Plan,
    rate: f64,
    early_cut: Option<Failure>,
) -> (Taker<impl FnMut(usize, usize) + use<>>, Option<Failure>) {
    let started = Instant::now();
    let triggered = plan.trigger.is_some();
    let bar = progress::bar(if triggered {
        "recording after the trigger (ms)"
    } else {
        "recording (ms)"
    });
    let mut taker = Taker {
        scope: plan.scope,
        trigger: triggered,
        duration: plan.duration,
        half_period: 0.5 / rate,
        total_ms: (plan.duration * 1000.0) as usize,
        bar,
        first_t: None,
        window: None,
        fired_at: None,
    };
    // From the first sample on, the ones that came while connecting included (a slow
    // rate samples from t = 0).
    for sample in session.take_early_samples() {
        taker.take(&sample);
    }
    if early_cut.is_some() {
        return (taker, early_cut);
    }
    while taker.window.is_none() {
        let deadline = Instant::now() + Duration::from_secs(5);
        match session.next_event(deadline) {
            Ok(Event::Samples(samples)) => {
                for sample in &samples {
                    if taker.take(sample) {
                        break;
                    }
                }
            }
            Ok(_) => {}
            Err(f) => return (taker, Some(f)),
        }
        if triggered && taker.fired_at.is_none() && started.elapsed().as_secs_f64() > plan.wait {
            let cut = failed(format!(
                "the trigger did not fire within {:.1} s ({})",
                plan.wait,
                taker.scope.meta.trigger.clone().unwrap_or_default()
            ));
            return (taker, Some(cut));
        }
    }
    (taker, None)
}

/// The recording: the complete window, or everything taken until the cut, with why it
/// ended in its header.
fn cut_out<F: FnMut(usize, usize)>(
    taker: Taker<F>,
    cut: &Option<Failure>,
    rate: f64,
) -> Result<Recording, Failure> {
    let Taker {
        scope,
        window,
        fired_at,
        first_t,
        ..
    } = taker;
    let mut meta = scope.meta.clone();
    meta.trigger_time_s = fired_at;
    let (from, to) = match (window, cut) {
        (Some(window), _) => window,
        (None, Some(_)) => {
            let from = scope.ring().first_time().or(first_t).unwrap_or(0.0);
            (from, scope.ring().last_time().unwrap_or(from))
        }
        (None, None) => return Err(failed("no samples came")),
    };
    let mut recording = scope.export(from, to, meta, true);
    if window.is_none()
        && let Some(cut) = cut
    {
        recording.meta.ended_early = Some(early_why(cut, &recording));
    }
    // The file says the rate that was achieved beside the one asked for.
    recording.set_rates(rate);
    Ok(recording)
}

/// Why and when a recording ended early: the cut's words, the last sample's time and the
/// wall-clock time.
fn early_why(cut: &Failure, recording: &Recording) -> String {
    format!(
        "{} at t = {:.3} s ({})",
        cut.message,
        recording.times.last().copied().unwrap_or(0.0),
        utc_text(SystemTime::now())
    )
}

/// How a recording ended: what cut it short, what was done to the drive then, where the
/// file went.
struct Ending {
    cut: Option<Failure>,
    stopped: Option<String>,
    saved: Saved,
}

/// Say what was recorded, where it went, and how the run ended.
fn finish(
    mut session: Session,
    recording: Recording,
    ending: Ending,
    link: &LinkSpec,
    args: &RecordArgs,
    mut warnings: Vec<String>,
) -> RecordReport {
    let achieved = recording.achieved_rate();
    if recording.len() > 2 && achieved < 0.9 * args.rate {
        warnings.push(slow_rate(link, args.rate, achieved));
    }
    let Ending {
        cut,
        stopped,
        saved,
    } = ending;
    let mut notes = session.take_notes();
    let file = match &saved {
        Saved::Here { message, path } => {
            notes.push(message.clone());
            Some(path.clone())
        }
        Saved::Elsewhere { why, path } => {
            warnings.push(format!(
                "{why}; the recording ({} samples) was saved to {path} instead",
                recording.len()
            ));
            Some(path.clone())
        }
        Saved::Lost { why } => {
            warnings.push(format!("{why}; the recording is lost"));
            None
        }
    };
    let signals = signal_reports(&recording, &mut warnings);
    let code = match (&cut, &saved) {
        (Some(f), _) if f.signal.is_some() => Some(EXIT_INTERRUPTED),
        (Some(_), _) | (None, Saved::Elsewhere { .. } | Saved::Lost { .. }) => Some(EXIT_FAILED),
        (None, Saved::Here { .. }) => None,
    };
    RecordReport {
        file,
        samples: recording.len(),
        seconds: recording.duration(),
        rate: achieved,
        rate_asked: args.rate,
        signals,
        trigger: recording.meta.trigger.clone(),
        trigger_time_s: recording.meta.trigger_time_s,
        ended_early: recording.meta.ended_early.clone(),
        stopped,
        notes,
        warnings,
        code,
    }
}

/// Each channel and how many samples it has (a warning for one that has none).
fn signal_reports(recording: &Recording, warnings: &mut Vec<String>) -> Vec<SignalReport> {
    recording
        .channels
        .iter()
        .zip(&recording.columns)
        .map(|(info, column)| {
            let samples = column.iter().filter(|v| !v.is_nan()).count();
            if samples == 0 && !recording.is_empty() {
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
        .collect()
}

/// Why fewer samples came than asked for, where drivedeck knows.
fn slow_rate(link: &LinkSpec, asked: f64, achieved: f64) -> String {
    let why = match link {
        LinkSpec::Enip { enip, .. } if enip.io != crate::link::EnipIo::Explicit => format!(
            ": the EtherNet/IP I/O connection delivers one sample per RPI ({} ms, at most {:.0}/s); lower the RPI (rpi=N in the link) for more",
            enip.rpi_ms,
            1000.0 / f64::from(enip.rpi_ms.max(1))
        ),
        _ => {
            ": the link cannot exchange faster (see the exchanges per second in `drivedeck bench`)"
                .to_owned()
        }
    };
    format!("asked for {asked} samples/s, the link delivered {achieved:.1}/s{why}")
}

/// The samples of a recording as they come: the window to keep once it is complete.
struct Taker<F: FnMut(usize, usize)> {
    scope: Scope,
    trigger: bool,
    duration: f64,
    /// Half the sampling period, s.
    half_period: f64,
    total_ms: usize,
    bar: F,
    first_t: Option<f64>,
    window: Option<(f64, f64)>,
    fired_at: Option<f64>,
}

impl<F: FnMut(usize, usize)> Taker<F> {
    /// Take one sample; `true` once the recording is complete.
    fn take(&mut self, sample: &crate::worker::Sample) -> bool {
        if self.window.is_some() {
            return true;
        }
        let start = *self.first_t.get_or_insert(sample.t);
        let event = self.scope.push(sample);
        let (duration, total_ms) = (self.duration, self.total_ms);
        match (self.trigger, event) {
            (false, _) => {
                (self.bar)(
                    ((sample.t - start) * 1000.0).min(duration * 1000.0) as usize,
                    total_ms,
                );
                // Complete with the sample due at `duration` (half a period early, for
                // jitter), which belongs in the file.
                if sample.t - start >= duration - self.half_period {
                    self.window = Some((start, sample.t.max(start + duration)));
                }
            }
            (true, Some(ScopeEvent::Fired(at))) => self.fired_at = Some(at),
            (true, Some(ScopeEvent::Recorded)) => {
                if let CaptureState::Complete { from, to, .. } = self.scope.capture_state() {
                    (self.bar)(total_ms, total_ms);
                    self.window = Some((from, to));
                }
            }
            (true, None) => {
                if let Some(at) = self.fired_at {
                    (self.bar)(
                        ((sample.t - at) * 1000.0).max(0.0) as usize,
                        total_ms.max(1),
                    );
                }
            }
        }
        self.window.is_some()
    }
}

/// A path as the user can find it again: absolute where it can be made so.
fn shown_path(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_path_buf())
        .display()
        .to_string()
}

/// Where a recording went.
enum Saved {
    /// Where it was asked to go.
    Here { message: String, path: String },
    /// That place failed (`why`); the temporary directory took it.
    Elsewhere { why: String, path: String },
    /// No place took it.
    Lost { why: String },
}

impl Saved {
    /// Write the recording again where it went the first time (its header says more now);
    /// if that fails, the file as first written stands.
    fn again(self, recording: &Recording) -> Saved {
        let path = match &self {
            Saved::Here { path, .. } | Saved::Elsewhere { path, .. } => Path::new(path),
            Saved::Lost { .. } => return self,
        };
        if let Err(e) = write_whole(path, recording_text(recording, path)) {
            tracing::warn!(
                "{}: {e}; the file holds the recording as first written",
                path.display()
            );
        }
        self
    }
}

/// Write the recording to `path` whole or not at all. When that fails, the recording goes
/// to the temporary directory instead; only if that fails too is it lost.
fn save_safely(recording: &Recording, path: &Path) -> Saved {
    let shown = shown_path(path);
    let text = recording_text(recording, path);
    let why = match write_whole(path, &text) {
        Ok(()) => {
            return Saved::Here {
                message: format!(
                    "saved {} samples of {} signals ({:.2} s) to {shown}",
                    recording.len(),
                    recording.channels.len(),
                    recording.duration()
                ),
                path: path.to_string_lossy().into_owned(),
            };
        }
        Err(e) => format!("cannot write {shown}: {e}"),
    };
    let extension = path
        .extension()
        .map_or("csv".into(), |e| e.to_string_lossy().into_owned());
    let elsewhere = std::env::temp_dir().join(format!(
        "drivedeck-recording-{}-{}.{extension}",
        std::process::id(),
        SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
    ));
    match write_whole(&elsewhere, &text) {
        Ok(()) => Saved::Elsewhere {
            why,
            path: elsewhere.display().to_string(),
        },
        Err(e) => Saved::Lost {
            why: format!("{why}; nor to {}: {e}", elsewhere.display()),
        },
    }
}

fn print(report: &RecordReport, json: bool) {
    if json {
        match serde_json::to_string_pretty(report) {
            Ok(text) => outln!("{text}"),
            Err(e) => eprintln!("drivedeck: cannot print the report: {e}"),
        }
        return;
    }
    outln!(
        "recorded {} samples over {:.3} s ({:.1} samples/s, {} asked) to {}",
        report.samples,
        report.seconds,
        report.rate,
        report.rate_asked,
        report
            .file
            .as_deref()
            .unwrap_or("nowhere (see the warning)")
    );
    if let Some(why) = &report.ended_early {
        outln!("ended early: {why}");
    }
    if let (Some(trigger), Some(at)) = (&report.trigger, report.trigger_time_s) {
        outln!("trigger: {trigger}; fired at {at:.3} s");
    }
    for s in &report.signals {
        outln!(
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
