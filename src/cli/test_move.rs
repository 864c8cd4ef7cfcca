//! `drivedeck test-move` and `test-velocity`: back and forth between two positions with a
//! dwell, or velocity steps 0 → v → −v → 0 with a hold, N cycles; for every step the
//! figures a servo engineer reads (rise time, overshoot, settling, steady-state error,
//! following error, time to TargetReached), then their summary. A signal or a failed step
//! stops the drive by the `--on-exit` rule, and the figures of the steps done so far are
//! still printed.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::context::Context;
use super::failure::{Failure, usage};
use super::report;
use super::session::Session;
use super::{EXIT_FAILED, TestMoveArgs, TestVelocityArgs};
use crate::link::LinkSpec;
use crate::pdi::Action;
use crate::signal::{Sample, Signal};
use crate::telemetry::test_run::{
    MoveTest, Plan, Spread, StepReport, Summary, VelocityTest, move_plan, step_report, summary,
    velocity_plan,
};
use crate::telemetry::{ChannelInfo, Marker, Metadata, StreamWriter, stream_layout};
use crate::worker::Request;

/// Samples a second while a test move runs: the figures need the response's shape.
const POLL_RATE: f64 = 200.0;
/// How long the drive may take to stop when a test move is ended early.
const STOP_WAIT: Duration = Duration::from_secs(5);

#[derive(Serialize, Debug)]
struct TestMoveReport {
    link: String,
    /// What the figures are of: `position` (0.1°) or `velocity` (rpm).
    signal: &'static str,
    speed: i64,
    dwell_s: f64,
    steps: Vec<StepReport>,
    summary: Summary,
    /// Why the test ended before its last cycle, if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    ended_early: Option<String>,
    /// Where the run was kept (`--record`).
    #[serde(skip_serializing_if = "Option::is_none")]
    recorded: Option<String>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    notes: Vec<String>,
}

/// The channels a kept run has, in its rows' order.
const KEPT: [(Signal, &str, &str, &str); 3] = [
    (Signal::Position, "position", "Position 6064h", "0.1°"),
    (Signal::Velocity, "velocity", "Velocity 606Ch", "rpm"),
    (
        Signal::FollowingError,
        "following_error",
        "Following error 60F4h",
        "0.1°",
    ),
];

/// A run being kept in a file as it goes (the recording format of `record`).
struct Kept {
    writer: StreamWriter,
    path: std::path::PathBuf,
    rows: usize,
}

impl Kept {
    fn create(path: &std::path::Path, link: &LinkSpec, note: String) -> Result<Kept, Failure> {
        let file = std::fs::File::create(path)
            .map_err(|e| usage(format!("cannot write the run to {}: {e}", path.display())))?;
        let meta = Metadata {
            link: Some(link.to_string()),
            rate_asked_hz: Some(POLL_RATE),
            note: Some(note),
            ..Metadata::default()
        };
        let mut channels: Vec<ChannelInfo> = KEPT
            .iter()
            .map(|(_, id, name, unit)| ChannelInfo {
                id: (*id).into(),
                name: (*name).into(),
                unit: (*unit).into(),
            })
            .collect();
        channels.push(ChannelInfo {
            id: "pdi_status".into(),
            name: "PDI-Status 2292h:01".into(),
            unit: String::new(),
        });
        let writer = StreamWriter::create(file, stream_layout(path), &meta, &channels)
            .map_err(|e| usage(format!("cannot write the run to {}: {e}", path.display())))?;
        Ok(Kept {
            writer,
            path: path.to_path_buf(),
            rows: 0,
        })
    }

    /// One step's samples, its marker (what it was, its figures) at its first.
    fn step(&mut self, step: &StepReport, samples: &[Sample]) -> std::io::Result<()> {
        if let Some(first) = samples.first() {
            self.writer.mark(&Marker {
                t: first.t,
                text: format!(
                    "cycle {}: {} → {}: rise {} s, overshoot {} %, settling {} s, reached {} s",
                    step.cycle,
                    step.from,
                    step.to,
                    cell(step.rise_time_s, 3),
                    cell(step.overshoot_pct, 1),
                    cell(step.settling_time_s, 3),
                    cell(step.time_to_target_reached_s, 3)
                ),
            })?;
        }
        for sample in samples {
            let mut values: Vec<f64> = KEPT
                .iter()
                .map(|(signal, ..)| sample.signals.get(*signal).unwrap_or(f64::NAN))
                .collect();
            values.push(f64::from(sample.tx.status.0));
            self.writer.row(sample.t, &values)?;
            self.rows += 1;
        }
        Ok(())
    }
}

/// `test-move`.
pub fn run(
    link: &LinkSpec,
    args: &TestMoveArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    finish(
        move_plan(&MoveTest {
            from: args.from,
            to: args.to,
            speed: args.speed,
            dwell: args.dwell,
            cycles: args.cycles,
            band: args.band,
        })
        .map_err(usage)
        .and_then(|plan| run_plan(link, &plan, args.record.as_deref(), timeout, trace, context)),
        json,
    )
}

/// `test-velocity`.
pub fn run_velocity(
    link: &LinkSpec,
    args: &TestVelocityArgs,
    json: bool,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> ExitCode {
    finish(
        velocity_plan(&VelocityTest {
            speed: args.speed,
            hold: args.hold,
            cycles: args.cycles,
            band: args.band,
        })
        .map_err(usage)
        .and_then(|plan| run_plan(link, &plan, args.record.as_deref(), timeout, trace, context)),
        json,
    )
}

fn finish(outcome: Result<(TestMoveReport, Option<u8>), Failure>, json: bool) -> ExitCode {
    match outcome {
        Ok((report, code)) => {
            print(&report, json);
            match code {
                Some(code) => ExitCode::from(code),
                None => ExitCode::SUCCESS,
            }
        }
        Err(f) => {
            report::print_error(&f.message, json);
            ExitCode::from(f.code)
        }
    }
}

fn run_plan(
    link: &LinkSpec,
    plan: &Plan,
    record: Option<&std::path::Path>,
    timeout: Duration,
    trace: bool,
    context: &Context,
) -> Result<(TestMoveReport, Option<u8>), Failure> {
    let mut session = Session::open_at(link, timeout, trace, POLL_RATE, true, context)?;
    if let Err(e) = session.catch_signals() {
        session.warnings.push(format!(
            "{e}: Ctrl-C will end drivedeck without stopping the drive"
        ));
    }
    let mut report = TestMoveReport {
        link: link.to_string(),
        signal: match plan.signal {
            Signal::Velocity => "velocity",
            _ => "position",
        },
        speed: plan.speed,
        dwell_s: plan.dwell,
        steps: Vec::new(),
        summary: Summary::default(),
        ended_early: None,
        recorded: None,
        notes: Vec::new(),
    };
    let mut kept = match record {
        Some(path) => {
            let note = format!(
                "{} test: {} cycle(s) of {} step(s), speed {}, dwell {} s",
                report.signal,
                plan.cycles,
                plan.steps.len(),
                plan.speed,
                plan.dwell
            );
            Some(Kept::create(path, link, note)?)
        }
        None => None,
    };
    let mut code = None;
    // To the start first: not measured.
    let mut outcome = move_to(&mut session, plan.start, timeout).map(|_| ());
    'cycles: for cycle in 1..=plan.cycles {
        if outcome.is_err() {
            break;
        }
        for &(from, to, action) in &plan.steps {
            match measured_step(&mut session, action, plan.dwell, timeout) {
                Ok(samples) => {
                    let step = step_report(cycle, (from, to), plan.band, plan.signal, &samples);
                    if let Some(k) = kept.as_mut()
                        && let Err(e) = k.step(&step, &samples)
                    {
                        report.notes.push(format!(
                            "writing the run to {} failed ({e}): the file holds the steps \
                             before; the test goes on",
                            k.path.display()
                        ));
                        kept = None;
                    }
                    report.steps.push(step);
                }
                Err(f) => {
                    outcome = Err(f);
                    break 'cycles;
                }
            }
        }
    }
    if let Err(f) = outcome {
        let mut message = f.message.clone();
        if f.stop {
            let done = session.stop_drive(session.on_exit(), timeout.min(STOP_WAIT));
            message = format!("{message}; {done}");
        }
        report.ended_early = Some(message);
        code = Some(if f.signal.is_some() {
            f.code
        } else {
            EXIT_FAILED
        });
    }
    report.summary = summary(&report.steps);
    if let Some(mut k) = kept {
        let last = Metadata {
            ended_early: report.ended_early.clone(),
            ..Metadata::default()
        };
        match k.writer.finish(&last, k.rows) {
            Ok(()) => report.recorded = Some(k.path.display().to_string()),
            Err(e) => report.notes.push(format!(
                "the run in {} could not be finished ({e}): it opens as cut",
                k.path.display()
            )),
        }
    }
    report.notes.extend(session.take_notes());
    Ok((report, code))
}

/// One move waited for; what the drive said.
fn move_to(session: &mut Session, action: Action, timeout: Duration) -> Result<(), Failure> {
    session
        .command(Request::Command(action), true, timeout)
        .map(|_| ())
        .map_err(|f| Failure { stop: true, ..f })
}

/// One step: the move, waited for, then the dwell; every sample from the command on.
fn measured_step(
    session: &mut Session,
    action: Action,
    dwell: f64,
    timeout: Duration,
) -> Result<Vec<Sample>, Failure> {
    // The samples before the command are not this step's.
    let _ = session.drain_samples();
    move_to(session, action, timeout)?;
    let end = Instant::now() + Duration::from_secs_f64(dwell);
    while Instant::now() < end {
        match session.next_event(end) {
            Ok(_) => {}
            Err(f) if f.signal.is_some() => return Err(f),
            // The dwell is over.
            Err(_) => break,
        }
    }
    Ok(session.drain_samples())
}

/// A figure for the table: its value with `digits` decimals, or "-" when there is none.
fn cell(value: Option<f64>, digits: usize) -> String {
    value.map_or("-".to_owned(), |v| format!("{v:.digits$}"))
}

fn print(report: &TestMoveReport, json: bool) {
    if json {
        report::print_json(report, "test-move report");
        return;
    }
    outln!(
        "{:>5} {:>8} {:>8} {:>8} {:>10} {:>8} {:>9} {:>9} {:>8} {:>8} {:>9}",
        "cycle",
        "from",
        "to",
        "rise s",
        "overshoot",
        "%",
        "settle s",
        "ss error",
        "FE peak",
        "FE rms",
        "reached s"
    );
    for s in &report.steps {
        outln!(
            "{:>5} {:>8} {:>8} {:>8} {:>10} {:>8} {:>9} {:>9} {:>8} {:>8} {:>9}",
            s.cycle,
            s.from,
            s.to,
            cell(s.rise_time_s, 3),
            cell(s.overshoot, 1),
            cell(s.overshoot_pct, 1),
            cell(s.settling_time_s, 3),
            cell(s.steady_state_error, 1),
            cell(s.peak_following_error, 1),
            cell(s.rms_following_error, 1),
            cell(s.time_to_target_reached_s, 3),
        );
    }
    let line = |name: &str, spread: Option<Spread>, digits: usize| {
        if let Some(s) = spread {
            outln!(
                "{name}: mean {:.digits$}, worst {:.digits$} ({} steps)",
                s.mean,
                s.worst,
                s.steps
            );
        }
    };
    let sum = &report.summary;
    line("rise time [s]", sum.rise_time_s, 3);
    line("overshoot [%]", sum.overshoot_pct, 1);
    line("settling time [s]", sum.settling_time_s, 3);
    line("steady-state error", sum.steady_state_error, 1);
    line("peak following error", sum.peak_following_error, 1);
    line("time to TargetReached [s]", sum.time_to_target_reached_s, 3);
    for note in &report.notes {
        eprintln!("note: {note}");
    }
    if let Some(path) = &report.recorded {
        eprintln!("the run is kept in {path} (open it in the window: Open recording…)");
    }
    if let Some(why) = &report.ended_early {
        eprintln!(
            "drivedeck: the test move ended early after {} step(s): {why}",
            report.steps.len()
        );
    }
}
