//! The Test tab's model: a test move (back and forth between two positions) or velocity
//! steps, run from the window with the same plan and figures as `drivedeck test-move` and
//! `test-velocity` (`telemetry::test_run`): the form as typed and checked, the run under
//! way (the move to the start, each step's command, its dwell, its samples), and the runs
//! kept for this session — each step's figures, their summary, and the measured signal
//! for the overlay — so that two runs can be compared before and after a gain change.
//! Stop halts the drive and ends the run with the steps measured so far.
//!
//! A model: no egui here.

use crate::pdi::Action;
use crate::signal::{Sample, Signal};
use crate::telemetry::test_run::{
    MoveTest, Plan, StepReport, Summary, VelocityTest, move_plan, summary, velocity_plan,
};
use crate::telemetry::test_sequence::{Next, Sequence};
use crate::ui::panel::PanelModel;
use crate::worker::{CommandProgress, Event, Request};

/// The tag of the move to the start.
const START: u64 = 1;
/// The tag of a step's command.
const STEP: u64 = 2;
/// The tag of the halt that ends a run stopped by the user.
const HALT: u64 = 3;

/// Runs kept in a session (the oldest goes first).
pub const MAX_RUNS: usize = 20;

/// Which test the form makes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Kind {
    #[default]
    Move,
    Velocity,
}

/// The form, as typed.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    pub kind: Kind,
    pub from: String,
    pub to: String,
    pub speed: String,
    pub dwell: String,
    pub cycles: String,
    pub band: String,
}

impl Default for Form {
    fn default() -> Self {
        Form {
            kind: Kind::Move,
            from: "0".into(),
            to: "2000".into(),
            speed: "300".into(),
            dwell: "0.3".into(),
            cycles: "2".into(),
            band: String::new(),
        }
    }
}

impl Form {
    /// The plan the form makes, or what is wrong with it (nothing moves then).
    pub fn plan(&self) -> Result<Plan, String> {
        let int = |name: &str, text: &str| {
            crate::number::parse_integer(text.trim(), false)
                .and_then(|v| i64::try_from(v).ok())
                .ok_or_else(|| format!("{name}: {:?} is not a whole number", text.trim()))
        };
        let real = |name: &str, text: &str| {
            text.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{name}: {:?} is not a number", text.trim()))
        };
        let cycles = int("cycles", &self.cycles)?;
        let cycles =
            u32::try_from(cycles).map_err(|_| format!("cycles: {cycles} is out of range"))?;
        let band = if self.band.trim().is_empty() {
            None
        } else {
            Some(real("band", &self.band)?)
        };
        match self.kind {
            Kind::Move => move_plan(&MoveTest {
                from: int("from", &self.from)?,
                to: int("to", &self.to)?,
                speed: int("speed", &self.speed)?,
                dwell: real("dwell", &self.dwell)?,
                cycles,
                band,
            }),
            Kind::Velocity => velocity_plan(&VelocityTest {
                speed: int("speed", &self.speed)?,
                hold: real("hold", &self.dwell)?,
                cycles,
                band,
            }),
        }
    }
}

/// A run: its plan in words, its steps' figures, and the signal measured (for the
/// overlay), its times from the run's first step.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    pub number: usize,
    pub title: String,
    pub signal: Signal,
    pub steps: Vec<StepReport>,
    pub summary: Summary,
    /// (t from the first step's command, value) of the signal the figures are of.
    pub trace: Vec<[f64; 2]>,
    /// The times (from the first step) each step began, for the markers.
    pub step_starts: Vec<f64>,
    /// Why it ended before its last cycle, if it did.
    pub ended_early: Option<String>,
}

/// The run under way: its sequence and what the list will show of it.
#[derive(Clone, Debug)]
struct Running {
    sequence: Sequence,
    run: Run,
}

/// The Test tab of one drive.
#[derive(Debug, Default)]
pub struct TestRuns {
    pub form: Form,
    /// Why the form cannot run (shown under it), or the last run's end.
    pub message: Option<Result<String, String>>,
    pub runs: Vec<Run>,
    /// The runs ticked for the comparison and the overlay (by number).
    pub compared: Vec<usize>,
    /// Where "Save run" writes (CSV, or JSON for a `.json` path).
    pub save_path: String,
    running: Option<Running>,
    connected: bool,
    /// The newest sample's time: where a step begins.
    last_t: Option<f64>,
    next_number: usize,
    requests: Vec<(u64, Request)>,
}

impl PanelModel for TestRuns {
    fn on_event(&mut self, event: &Event) {
        match event {
            Event::Connected(_) => self.connected = true,
            Event::Disconnected { reason } => {
                self.connected = false;
                let why = reason
                    .clone()
                    .unwrap_or_else(|| "the drive was disconnected".into());
                self.end(Some(format!("the link was lost: {why}")));
            }
            Event::Samples(samples) => self.on_samples(samples),
            _ => {}
        }
    }

    fn on_reply(&mut self, tag: u64, event: &Event) -> bool {
        match event {
            Event::Progress { progress, .. } => {
                if !progress.is_final() {
                    return false;
                }
                if tag == HALT {
                    return true;
                }
                self.on_command_over(progress);
                true
            }
            Event::Rejected { reason, .. } => {
                if tag != HALT {
                    self.end(Some(format!("not sent: {reason}")));
                }
                true
            }
            _ => false,
        }
    }

    fn take_requests(&mut self) -> Vec<(u64, Request)> {
        std::mem::take(&mut self.requests)
    }
}

impl TestRuns {
    pub fn is_connected(&self) -> bool {
        self.connected
    }

    pub fn is_running(&self) -> bool {
        self.running.is_some()
    }

    /// Where the run under way stands, in words.
    pub fn progress(&self) -> Option<String> {
        Some(self.running.as_ref()?.sequence.progress())
    }

    /// Start a run from the form (refused with the reason when the form is wrong, the
    /// drive not connected, or a run under way).
    pub fn start(&mut self) {
        if self.running.is_some() {
            return;
        }
        if !self.connected {
            self.message = Some(Err("not connected: nothing moves".into()));
            return;
        }
        let plan = match self.form.plan() {
            Ok(plan) => plan,
            Err(why) => {
                self.message = Some(Err(why));
                return;
            }
        };
        self.next_number += 1;
        let title = match self.form.kind {
            Kind::Move => format!(
                "Run {}: {} ↔ {} at {} rpm, dwell {} s, {} cycle(s)",
                self.next_number,
                self.form.from.trim(),
                self.form.to.trim(),
                plan.speed,
                plan.dwell,
                plan.cycles
            ),
            Kind::Velocity => format!(
                "Run {}: 0 → {v} → −{v} → 0 rpm, hold {} s, {} cycle(s)",
                self.next_number,
                plan.dwell,
                plan.cycles,
                v = plan.speed
            ),
        };
        self.message = None;
        self.requests.push((START, Request::Command(plan.start)));
        self.running = Some(Running {
            run: Run {
                number: self.next_number,
                title,
                signal: plan.signal,
                steps: Vec::new(),
                summary: Summary::default(),
                trace: Vec::new(),
                step_starts: Vec::new(),
                ended_early: None,
            },
            sequence: Sequence::new(plan, self.last_t),
        });
    }

    /// Stop: the drive halts, the run ends with the steps measured so far.
    pub fn stop(&mut self) {
        if self.running.is_some() {
            self.requests.push((HALT, Request::Halt));
            self.end(Some("stopped by the user (the drive halted)".into()));
        }
    }

    /// Tick or untick a run for the comparison.
    pub fn toggle_compared(&mut self, number: usize) {
        match self.compared.iter().position(|n| *n == number) {
            Some(at) => {
                self.compared.remove(at);
            }
            None => self.compared.push(number),
        }
    }

    /// Drop every run kept.
    pub fn clear(&mut self) {
        self.runs.clear();
        self.compared.clear();
    }

    fn on_samples(&mut self, samples: &[Sample]) {
        if let Some(last) = samples.last() {
            self.last_t = Some(last.t);
        }
        if let Some(running) = self.running.as_mut() {
            let next = running.sequence.on_samples(samples);
            self.follow(next);
        }
    }

    /// Do what the sequence asks for.
    fn follow(&mut self, next: Next) {
        match next {
            Next::Wait => {}
            Next::Send(action) => self.requests.push((STEP, Request::Command(action))),
            Next::Over(why) => self.end(why),
        }
    }

    /// A step's or the start's command ended.
    fn on_command_over(&mut self, progress: &CommandProgress) {
        let Some(running) = self.running.as_mut() else {
            return;
        };
        let outcome = match progress {
            CommandProgress::Done { .. } => Ok(()),
            other => Err(other.to_string()),
        };
        let next = running.sequence.on_command_over(outcome);
        self.follow(next);
    }

    /// The run ends (`why`: before its last cycle): kept in the list with its figures.
    fn end(&mut self, why: Option<String>) {
        let Some(running) = self.running.take() else {
            return;
        };
        let mut run = running.run;
        let sequence = running.sequence;
        run.steps = sequence.steps;
        run.trace = sequence.trace;
        run.step_starts = sequence.step_starts;
        run.summary = summary(&run.steps);
        self.message = Some(match &why {
            None => Ok(format!(
                "{} done: {} step(s) measured",
                run.title,
                run.steps.len()
            )),
            Some(why) => Err(format!(
                "{} ended after {} step(s): {why}",
                run.title,
                run.steps.len()
            )),
        });
        run.ended_early = why;
        self.compared.retain(|n| *n != run.number);
        self.compared.push(run.number);
        while self.compared.len() > 2 {
            self.compared.remove(0);
        }
        if self.save_path.trim().is_empty() {
            self.save_path = "test-runs.csv".into();
        }
        self.runs.push(run);
        if self.runs.len() > MAX_RUNS {
            let gone = self.runs.remove(0).number;
            self.compared.retain(|n| *n != gone);
        }
    }

    /// Run `number` as a recording: the measured signal over the run, a marker at each
    /// step's start with its figures, the run's title as its note.
    pub fn recording(&self, number: usize) -> Option<crate::telemetry::Recording> {
        let run = self.runs.iter().find(|r| r.number == number)?;
        let (id, name, unit) = match run.signal {
            Signal::Velocity => ("velocity", "Velocity 606Ch", "rpm"),
            _ => ("position", "Position 6064h", "0.1°"),
        };
        let markers = run
            .step_starts
            .iter()
            .zip(&run.steps)
            .map(|(t, s)| crate::telemetry::Marker {
                t: *t,
                text: format!(
                    "cycle {} step {} → {}: rise {} s, overshoot {} %, settling {} s, peak following error {}",
                    s.cycle,
                    s.from,
                    s.to,
                    shown(s.rise_time_s, 3),
                    shown(s.overshoot_pct, 1),
                    shown(s.settling_time_s, 3),
                    shown(s.peak_following_error, 1)
                ),
            })
            .collect();
        Some(crate::telemetry::Recording {
            meta: crate::telemetry::Metadata {
                note: Some(run.title.clone()),
                ended_early: run.ended_early.clone(),
                ..Default::default()
            },
            channels: vec![crate::telemetry::ChannelInfo {
                id: id.into(),
                name: name.into(),
                unit: unit.into(),
            }],
            times: run.trace.iter().map(|p| p[0]).collect(),
            columns: vec![run.trace.iter().map(|p| p[1]).collect()],
            markers,
        })
    }

    /// Save the newest ticked run to `save_path`; the outcome in `message`.
    pub fn save_newest(&mut self) {
        let Some(&number) = self.compared.last() else {
            self.message = Some(Err("tick a run to save it".into()));
            return;
        };
        let Some(recording) = self.recording(number) else {
            return;
        };
        let path = self.save_path.trim().to_owned();
        if path.is_empty() {
            self.message = Some(Err("give a file to save the run to".into()));
            return;
        }
        self.message = Some(
            crate::telemetry::save_recording(&recording, &path)
                .map(|said| format!("Run {number}: {said}")),
        );
    }

    /// The runs ticked for the comparison, in the order ticked.
    pub fn compared_runs(&self) -> Vec<&Run> {
        self.compared
            .iter()
            .filter_map(|n| self.runs.iter().find(|r| r.number == *n))
            .collect()
    }

    /// The command the run under way waits for, if any (for tests and the view).
    pub fn waiting_for(&self) -> Option<Action> {
        self.running.as_ref()?.sequence.waiting_for()
    }
}

/// A figure for a marker: its value, or "–".
fn shown(value: Option<f64>, digits: usize) -> String {
    value.map_or("–".to_owned(), |v| format!("{v:.digits$}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{LinkInfo, LinkSpec};
    use crate::pdi::{Status, StatusBit, TxImage};
    use crate::signal::Signals;

    fn connected() -> TestRuns {
        let mut runs = TestRuns::default();
        runs.on_event(&Event::Connected(LinkInfo {
            spec: LinkSpec::Sim,
            description: String::new(),
            native_objects: true,
            can_inject: true,
            pdi: true,
            homing_methods: None,
            commands_refused: None,
        }));
        runs
    }

    fn sample(t: f64, position: f64) -> Sample {
        Sample {
            t,
            tx: TxImage {
                status: Status::default().with(StatusBit::TargetReached, position >= 2000.0),
                error_code: 0,
                return_value: position as i32,
            },
            signals: Signals::default()
                .with(Signal::Position, position)
                .with(Signal::FollowingError, 0.0),
            watched: Default::default(),
        }
    }

    fn done(runs: &mut TestRuns, tag: u64) {
        runs.on_reply(
            tag,
            &Event::Progress {
                id: 0,
                progress: CommandProgress::Done { return_value: 0 },
            },
        );
    }

    #[test]
    fn a_bad_form_moves_nothing_and_says_why() {
        let mut runs = connected();
        runs.form.to = "0".into();
        runs.start();
        assert!(runs.take_requests().is_empty());
        assert!(matches!(&runs.message, Some(Err(m)) if m.contains("the same position")));
        runs.form.to = "abc".into();
        runs.start();
        assert!(matches!(&runs.message, Some(Err(m)) if m.contains("not a whole number")));
    }

    #[test]
    fn a_run_goes_to_the_start_steps_dwells_and_keeps_its_figures() {
        let mut runs = connected();
        runs.form.cycles = "1".into();
        runs.form.dwell = "0.2".into();
        runs.on_event(&Event::Samples(vec![sample(0.0, 0.0)]));
        runs.start();
        let requests = runs.take_requests();
        assert!(
            matches!(
                requests.as_slice(),
                [(
                    START,
                    Request::Command(Action::MoveAbsolute { target: 0, .. })
                )]
            ),
            "{requests:?}"
        );
        done(&mut runs, START);
        // Step 1: 0 → 2000.
        let requests = runs.take_requests();
        assert!(
            matches!(
                requests.as_slice(),
                [(
                    STEP,
                    Request::Command(Action::MoveAbsolute { target: 2000, .. })
                )]
            ),
            "{requests:?}"
        );
        let ramp: Vec<Sample> = (0..=50)
            .map(|i| sample(i as f64 * 0.01, (i * 40) as f64))
            .collect();
        runs.on_event(&Event::Samples(ramp));
        done(&mut runs, STEP);
        assert!(runs.progress().unwrap().contains("dwell"));
        let rest: Vec<Sample> = (51..=75).map(|i| sample(i as f64 * 0.01, 2000.0)).collect();
        runs.on_event(&Event::Samples(rest));
        // Step 2: back to 0.
        let requests = runs.take_requests();
        assert!(
            matches!(
                requests.as_slice(),
                [(
                    STEP,
                    Request::Command(Action::MoveAbsolute { target: 0, .. })
                )]
            ),
            "{requests:?}"
        );
        let back: Vec<Sample> = (76..=126)
            .map(|i| sample(i as f64 * 0.01, (2000 - (i - 76) * 40) as f64))
            .collect();
        runs.on_event(&Event::Samples(back));
        done(&mut runs, STEP);
        runs.on_event(&Event::Samples(
            (127..=160).map(|i| sample(i as f64 * 0.01, 0.0)).collect(),
        ));
        assert!(!runs.is_running());
        let run = &runs.runs[0];
        assert_eq!(run.steps.len(), 2);
        assert!(
            run.steps[0]
                .rise_time_s
                .is_some_and(|r| (r - 0.4).abs() < 0.05),
            "{:?}",
            run.steps[0]
        );
        assert_eq!(run.step_starts.len(), 2);
        assert!(run.trace.len() > 100);
        assert_eq!(runs.compared, vec![1]);
        assert!(matches!(&runs.message, Some(Ok(m)) if m.contains("2 step(s) measured")));

        // Saved as a recording that opens again, a marker with the figures at each step.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.csv");
        runs.save_path = path.to_str().unwrap().into();
        runs.save_newest();
        assert!(
            matches!(&runs.message, Some(Ok(m)) if m.contains("Run 1: saved")),
            "{:?}",
            runs.message
        );
        let back = crate::telemetry::load_recording(&path, 1 << 20).unwrap();
        assert_eq!(back.markers.len(), 2);
        assert!(
            back.markers[0].text.contains("rise 0.4"),
            "{:?}",
            back.markers
        );
        assert_eq!(back.channels[0].id, "position");
    }

    #[test]
    fn stop_halts_and_keeps_what_was_measured_and_a_failed_step_ends_the_run() {
        let mut runs = connected();
        runs.on_event(&Event::Samples(vec![sample(0.0, 0.0)]));
        runs.start();
        done(&mut runs, START);
        runs.take_requests();
        runs.stop();
        let requests = runs.take_requests();
        assert!(
            matches!(requests.as_slice(), [(HALT, Request::Halt)]),
            "{requests:?}"
        );
        assert!(
            runs.runs[0]
                .ended_early
                .as_deref()
                .is_some_and(|w| w.contains("stopped by the user"))
        );

        runs.start();
        done(&mut runs, START);
        runs.on_reply(
            STEP,
            &Event::Progress {
                id: 0,
                progress: CommandProgress::Superseded,
            },
        );
        assert!(!runs.is_running());
        assert!(
            runs.runs[1]
                .ended_early
                .as_deref()
                .is_some_and(|w| w.contains("did not end well"))
        );
        // Two runs ticked for the comparison, the newest last.
        assert_eq!(runs.compared, vec![1, 2]);
    }
}
