//! `drivedeck --link URL record --signals position,velocity --rate 500 --duration 5s
//! --out run.csv`: sample the drive through the worker and write what came, with the
//! device's identity and the units in the file's header. With `--trigger` it waits for
//! the condition and records `--pre` before and `--duration` after it.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime};

use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, failed, usage};
use super::progress;
use super::session::Session;
use super::stop::STOP_WAIT;
use super::{EXIT_FAILED, EXIT_INTERRUPTED, RecordArgs, report};
use crate::file::check_writable;
use crate::link::LinkSpec;
use crate::od::backup::{DeviceIdentity, IDENTITY};
use crate::od::{self, Address};
use crate::telemetry::{
    Builtin, CaptureState, ChannelInfo, Condition, Edge, Kind, Marker, Metadata, Scope, ScopeEvent,
    Summary, Trigger, WatchedObject, link_mark, metadata, utc_text, watchable,
};
use crate::worker::{Event, MAX_WATCHED, Request};

mod output;
use output::{Output, Saved, shown_path};

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
/// `pdi_status bit 3 rises`, `digital_inputs bit 16 changes`.
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
        format!("trigger '{text}': write e.g. 'position rises 1000' or 'pdi_status bit 3 rises'")
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
    // The ring holds only what is not in the file yet: the time before a trigger.
    let rows = match &args.trigger {
        Some(_) => ((pre * args.rate * 1.5) as usize + 1_000).min(50_000_000),
        None => UNTRIGGERED_ROWS,
    };
    let mut scope = Scope::new(rows);
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
            "{e}: Ctrl-C will end drivedeck without ending the recording's file (it holds the samples until then and says it was cut)"
        ));
    }
    let early_cut = prepare(&mut session, &mut plan, link, args.rate, timeout)?;
    let channels = recorded_channels(&plan.scope);
    let mut head = plan.scope.meta.clone();
    // The rate achieved is known at the end; the one asked for now.
    head.rate_hz = None;
    head.rate_asked_hz = Some(args.rate);
    let output = Output::open(&args.out, &head, &channels);
    if let Some(why) = &output.elsewhere {
        eprintln!(
            "warning: {why}; recording to {} instead",
            output.path.display()
        );
    }
    // It ends complete (`taker.window`) or cut short (`cut`).
    let (mut taker, cut) = take_samples(&mut session, plan, output, args.rate, early_cut);
    taker.close(cut.is_some());
    // Everything taken is on its way to the disk before the drive is stopped: a second
    // Ctrl-C while it brakes ends the process at once, and must not take the samples.
    let interrupted = cut.as_ref().filter(|f| f.signal.is_some());
    let stopping = interrupted.is_some() && session.is_moving_or_unknown();
    let action = session.on_exit();
    let mut ended_early = match (&cut, taker.window) {
        (Some(cut), None) => Some(early_why(cut, taker.summary.last_t)),
        _ => None,
    };
    let mut stopped = None;
    if let Some(cut) = interrupted.filter(|_| stopping) {
        if let Some(why) = &ended_early {
            taker.output.meta(&Metadata {
                ended_early: Some(format!(
                    "{why}; the drive was being stopped ({}, --on-exit) when this was written",
                    action.name()
                )),
                ..Metadata::default()
            });
        }
        let done = session.stop_drive(action, timeout.min(STOP_WAIT));
        ended_early = Some(format!("{}; {done}", early_why(cut, taker.summary.last_t)));
        stopped = Some(done);
    }
    let mut last = Metadata {
        ended_early,
        trigger_time_s: taker.fired_at,
        rate_asked_hz: Some(args.rate),
        ..Metadata::default()
    };
    // The file says the rate that was achieved beside the one asked for.
    last.rate_hz =
        (taker.summary.rows > 1).then_some((taker.summary.achieved_rate() * 10.0).round() / 10.0);
    let saved = taker.output.finish(&last, &taker.summary, channels.len());
    let taken = Taken {
        meta: {
            let mut meta = head;
            meta.merge(&last);
            meta
        },
        channels: channels.into_iter().map(|(_, info)| info).collect(),
        summary: taker.summary,
    };
    let ending = Ending {
        cut,
        stopped,
        saved,
    };
    Ok(finish(session, taken, ending, link, args, warnings))
}

/// The signals the file records: the ring column and the description of each.
fn recorded_channels(scope: &Scope) -> Vec<(usize, ChannelInfo)> {
    scope
        .signals()
        .iter()
        .filter(|s| scope.is_drawn(s))
        .map(|s| (s.column, s.info.clone()))
        .collect()
}

/// What was recorded: the header as it ended, the channels, the counts.
struct Taken {
    meta: Metadata,
    channels: Vec<ChannelInfo>,
    summary: Summary,
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

/// Take samples into the file until the recording is complete, or something cuts it
/// short (the failure says what: a signal, a lost link, a trigger that did not fire, a
/// file that cannot be written). Every outage, retry and lost link on the way is a
/// marker in the file at its time.
fn take_samples(
    session: &mut Session,
    plan: Plan,
    output: Output,
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
    let channels = recorded_channels(&plan.scope);
    let mut taker = Taker {
        columns: channels.iter().map(|(c, _)| *c).collect(),
        values: vec![f64::NAN; channels.len()],
        summary: Summary::new(channels.len()),
        scope: plan.scope,
        output,
        trigger: plan.trigger.as_ref().map(|t| (t.pre_s, t.post_s)),
        duration: plan.duration,
        half_period: 0.5 / rate,
        total_ms: (plan.duration * 1000.0) as usize,
        bar,
        first_t: None,
        window: None,
        fired_at: None,
        clock: SampleClock::default(),
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
                // Each batch the worker sends (about every 20 ms) goes to the system as
                // it came: a crash loses no sample that reached the recorder.
                if taker.streaming() {
                    taker.output.flush();
                }
            }
            Ok(Event::Notice(notice)) => {
                if let Some(text) = link_mark(&notice.text) {
                    taker.mark(text);
                }
            }
            Ok(_) => {}
            Err(f) => {
                if let Some(reason) = f.message.strip_prefix("the link was lost: ") {
                    taker.mark(format!("link lost: {reason}"));
                }
                return (taker, Some(f));
            }
        }
        if let Some(error) = taker.output.error.take() {
            return (taker, Some(failed(error)));
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

/// Why and when a recording ended early: the cut's words, the last sample's time and the
/// wall-clock time.
fn early_why(cut: &Failure, last_t: Option<f64>) -> String {
    format!(
        "{} at t = {:.3} s ({})",
        cut.message,
        last_t.unwrap_or(0.0),
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
    taken: Taken,
    ending: Ending,
    link: &LinkSpec,
    args: &RecordArgs,
    mut warnings: Vec<String>,
) -> RecordReport {
    let achieved = taken.summary.achieved_rate();
    if taken.summary.rows > 2 && achieved < 0.9 * args.rate {
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
                taken.summary.rows
            ));
            Some(path.clone())
        }
        Saved::Lost { why } => {
            warnings.push(format!("{why}; the recording is lost"));
            None
        }
        Saved::Short { why, path } => {
            warnings.push(why.clone());
            Some(path.clone())
        }
    };
    let signals = signal_reports(&taken, &mut warnings);
    let code = match (&cut, &saved) {
        (Some(f), _) if f.signal.is_some() => Some(EXIT_INTERRUPTED),
        (Some(_), _)
        | (None, Saved::Elsewhere { .. } | Saved::Lost { .. } | Saved::Short { .. }) => {
            Some(EXIT_FAILED)
        }
        (None, Saved::Here { .. }) => None,
    };
    RecordReport {
        file,
        samples: taken.summary.rows,
        seconds: taken.summary.duration(),
        rate: achieved,
        rate_asked: args.rate,
        signals,
        trigger: taken.meta.trigger.clone(),
        trigger_time_s: taken.meta.trigger_time_s,
        ended_early: taken.meta.ended_early.clone(),
        stopped,
        notes,
        warnings,
        code,
    }
}

/// Each channel and how many samples it has (a warning for one that has none).
fn signal_reports(taken: &Taken, warnings: &mut Vec<String>) -> Vec<SignalReport> {
    taken
        .channels
        .iter()
        .zip(&taken.summary.counts)
        .map(|(info, &samples)| {
            if samples == 0 && taken.summary.rows > 0 {
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

/// The samples' clock (the worker's) read between samples, for the time of a marker:
/// the worker's time is at least a sample's time plus how long ago it arrived, and the
/// sample that came soonest after it was taken tells it best.
#[derive(Default)]
struct SampleClock {
    since: Option<Instant>,
    /// The worker's time minus the seconds since `since`, as best known.
    offset: Option<f64>,
}

impl SampleClock {
    fn sample(&mut self, t: f64) {
        let since = *self.since.get_or_insert_with(Instant::now);
        let offset = t - since.elapsed().as_secs_f64();
        self.offset = Some(self.offset.map_or(offset, |o| o.max(offset)));
    }

    /// The worker's time now, if a sample came.
    fn now(&self) -> Option<f64> {
        Some(self.offset? + self.since?.elapsed().as_secs_f64())
    }
}

/// The samples of a recording as they come, into the file as they come. What it keeps
/// in memory does not grow with the samples: the ring of the scope holds the time before
/// a trigger (or a few rows without one), the file the rest.
struct Taker<F: FnMut(usize, usize)> {
    scope: Scope,
    /// The ring columns of the recorded channels, in the file's order.
    columns: Vec<usize>,
    /// The row being written (one value per recorded channel).
    values: Vec<f64>,
    summary: Summary,
    output: Output,
    /// The trigger's pre- and post-trigger seconds.
    trigger: Option<(f64, f64)>,
    duration: f64,
    /// Half the sampling period, s.
    half_period: f64,
    total_ms: usize,
    bar: F,
    first_t: Option<f64>,
    window: Option<(f64, f64)>,
    fired_at: Option<f64>,
    clock: SampleClock,
}

/// Rows the ring keeps without a trigger: only the newest is read back.
const UNTRIGGERED_ROWS: usize = 16;

impl<F: FnMut(usize, usize)> Taker<F> {
    /// Take one sample; `true` once the recording is complete.
    fn take(&mut self, sample: &crate::worker::Sample) -> bool {
        if self.window.is_some() {
            return true;
        }
        let start = *self.first_t.get_or_insert(sample.t);
        self.clock.sample(sample.t);
        let event = self.scope.push(sample);
        let (duration, total_ms) = (self.duration, self.total_ms);
        match (self.trigger, event) {
            (None, _) => {
                self.write_newest();
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
            (Some((pre, _)), Some(ScopeEvent::Fired(at))) => self.fired(at, pre),
            (Some((pre, post)), Some(ScopeEvent::Recorded)) => {
                if let CaptureState::Complete { from, at, to } = self.scope.capture_state() {
                    match self.fired_at {
                        // No time after the trigger: it fired and completed at once.
                        None => self.fired(at, pre),
                        Some(at) if sample.t <= at + post => self.write_newest(),
                        Some(_) => {}
                    }
                    (self.bar)(total_ms, total_ms);
                    self.window = Some((from, to));
                }
            }
            (Some((_, post)), None) => {
                if let Some(at) = self.fired_at {
                    if sample.t <= at + post {
                        self.write_newest();
                    }
                    (self.bar)(
                        ((sample.t - at) * 1000.0).max(0.0) as usize,
                        total_ms.max(1),
                    );
                }
            }
        }
        self.window.is_some()
    }

    /// Whether rows go to the file as they come (always without a trigger; from its
    /// firing with one).
    fn streaming(&self) -> bool {
        self.trigger.is_none() || self.fired_at.is_some()
    }

    /// Something that happened to the link, as a marker at its time on the samples'
    /// clock (never before the newest row).
    fn mark(&mut self, text: String) {
        let newest = self.scope.ring().last_time();
        let t = match (self.clock.now(), newest) {
            (Some(now), Some(newest)) => now.max(newest),
            (now, newest) => now.or(newest).unwrap_or(0.0),
        };
        if self.streaming() {
            self.output.mark(&Marker { t, text });
        } else {
            self.scope.mark(t, text);
        }
    }

    /// The trigger fired at `at`: the time before it (from the ring, with its markers)
    /// into the file, and the rows after it from now on.
    fn fired(&mut self, at: f64, pre: f64) {
        self.fired_at = Some(at);
        self.output.meta(&Metadata {
            trigger_time_s: Some(at),
            ..Metadata::default()
        });
        self.write_history(at - pre);
    }

    /// The rows of the ring from `from` on, with the scope's markers among them.
    fn write_history(&mut self, from: f64) {
        let ring = self.scope.ring();
        let mut markers: Vec<Marker> = self
            .scope
            .markers()
            .filter(|m| m.t >= from)
            .cloned()
            .collect();
        markers.sort_by(|a, b| a.t.total_cmp(&b.t));
        let mut markers = markers.into_iter().peekable();
        for i in ring.range(from, f64::INFINITY) {
            let Some(t) = ring.time(i) else { continue };
            while let Some(m) = markers.next_if(|m| m.t <= t) {
                self.output.mark(&m);
            }
            for (value, &column) in self.values.iter_mut().zip(&self.columns) {
                *value = ring.value(i, column).unwrap_or(f64::NAN);
            }
            self.summary.add(t, &self.values);
            self.output.row(t, &self.values);
        }
        for m in markers {
            self.output.mark(&m);
        }
    }

    /// The newest sample of the ring into the file.
    fn write_newest(&mut self) {
        let ring = self.scope.ring();
        let Some(i) = ring.len().checked_sub(1) else {
            return;
        };
        let Some(t) = ring.time(i) else { return };
        for (value, &column) in self.values.iter_mut().zip(&self.columns) {
            *value = ring.value(i, column).unwrap_or(f64::NAN);
        }
        self.summary.add(t, &self.values);
        self.output.row(t, &self.values);
    }

    /// The recording ends (`cut`: before its time): a trigger that never fired leaves the
    /// history it waited through in the file.
    fn close(&mut self, cut: bool) {
        if cut && !self.streaming() {
            self.write_history(f64::NEG_INFINITY);
        }
        self.output.flush();
    }

    /// Samples kept in memory (the ring's rows and the markers waiting for a trigger).
    #[cfg(test)]
    fn retained(&self) -> usize {
        self.scope.ring().len() + self.scope.markers().count()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{Signal, Signals};
    use crate::worker::Sample;
    use std::path::Path;

    fn sample(t: f64, position: f64) -> Sample {
        Sample {
            t,
            signals: Signals::default()
                .with(Signal::Position, position)
                .with(Signal::Velocity, 1.0),
            ..Sample::default()
        }
    }

    /// A taker as `record` makes one, of position and velocity, into `path`.
    fn taker(
        rows: usize,
        trigger: Option<Trigger>,
        duration: f64,
        path: &Path,
    ) -> Taker<impl FnMut(usize, usize)> {
        let mut scope = Scope::new(rows);
        for signal in scope.signals_mut() {
            signal.shown = ["position", "velocity"].contains(&signal.info.id.as_str());
            signal.auto = false;
        }
        if let Some(trigger) = &trigger {
            scope.arm(trigger.clone());
        }
        let channels = recorded_channels(&scope);
        let output = Output::open(path, &Metadata::default(), &channels);
        assert!(output.elsewhere.is_none() && output.lost.is_none());
        Taker {
            columns: channels.iter().map(|(c, _)| *c).collect(),
            values: vec![f64::NAN; channels.len()],
            summary: Summary::new(channels.len()),
            scope,
            output,
            trigger: trigger.map(|t| (t.pre_s, t.post_s)),
            duration,
            half_period: 0.0005,
            total_ms: (duration * 1000.0) as usize,
            bar: |_, _| {},
            first_t: None,
            window: None,
            fired_at: None,
            clock: SampleClock::default(),
        }
    }

    fn read(path: &Path) -> crate::telemetry::Recording {
        crate::telemetry::load_recording(path, crate::telemetry::MAX_RECORDING_BYTES)
            .expect("the file opens")
    }

    /// 200 000 samples at 1 kHz: the rows kept in memory stay as few as the ring holds,
    /// whatever came; every row is in the file.
    #[test]
    fn what_the_recorder_keeps_does_not_grow_with_the_samples() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("long.csv");
        let mut taker = taker(UNTRIGGERED_ROWS, None, 1000.0, &path);
        let mut most = 0;
        for i in 0..200_000 {
            let t = f64::from(i) * 0.001;
            assert!(!taker.take(&sample(t, f64::from(i))));
            if i == 100_000 {
                taker.mark("outage: an exchange with the drive failed".into());
            }
            most = most.max(taker.retained());
        }
        assert!(most <= UNTRIGGERED_ROWS, "{most} rows kept");
        assert_eq!(taker.summary.rows, 200_000);
        assert_eq!(taker.summary.counts, vec![200_000, 200_000]);
        taker.close(false);
        let saved = taker.output.finish(&Metadata::default(), &taker.summary, 2);
        assert!(matches!(saved, Saved::Here { .. }));
        let recording = read(&path);
        assert_eq!(recording.len(), 200_000);
        assert_eq!(recording.meta.cut, None);
        assert_eq!(recording.columns[0][123_456], 123_456.0);
        // The marker at its time: never before the newest row when it came.
        assert_eq!(recording.markers.len(), 1);
        assert!(recording.markers[0].t >= 100.0, "{:?}", recording.markers);
    }

    /// With a trigger, memory holds the time before it (the ring), never more, while it
    /// waits and after it fired; the file gets the time before it, the marker made while
    /// waiting, and every row after it.
    #[test]
    fn a_triggered_recording_keeps_only_the_time_before_the_trigger() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("triggered.json");
        let trigger = Trigger {
            condition: Condition::Threshold {
                channel: Builtin::Position as usize,
                level: 50_000.0,
                edge: Edge::Rising,
            },
            pre_s: 0.5,
            post_s: 60.0,
        };
        let ring = 1_000 + 750;
        let mut taker = taker(ring, Some(trigger), 60.0, &path);
        let mut most = 0;
        let mut done = None;
        for i in 0..150_000 {
            let t = f64::from(i) * 0.001;
            if i == 49_900 {
                taker.mark("retry: a reply lost, answered on try 2".into());
            }
            if taker.take(&sample(t, f64::from(i))) {
                done = Some(i);
                break;
            }
            most = most.max(taker.retained());
        }
        assert!(most <= ring + 1, "{most} rows kept");
        let at = taker.fired_at.expect("fired");
        assert!((49.999..=50.001).contains(&at), "fired at {at}");
        let done = f64::from(done.expect("complete")) * 0.001;
        assert!(
            done >= at + 60.0 - 1e-9 && done < at + 60.002,
            "complete 60 s after the trigger: {done}"
        );
        taker.close(false);
        taker.output.finish(&Metadata::default(), &taker.summary, 2);
        let recording = read(&path);
        assert_eq!(recording.meta.cut, None);
        assert_eq!(recording.meta.trigger_time_s, Some(at));
        assert_eq!(recording.len(), taker.summary.rows);
        let first = recording.times[0];
        assert!((at - first - 0.5).abs() < 0.002, "from {first}");
        assert!(recording.times.last().is_some_and(|t| *t <= at + 60.0));
        assert_eq!(recording.markers.len(), 1, "{:?}", recording.markers);
        assert!(recording.markers[0].text.starts_with("retry: "));
    }
}
