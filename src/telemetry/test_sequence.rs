//! A test run under way, as a sequence without I/O: the move to the start, each step's
//! command, its dwell, its samples and figures, cycle after cycle. The window's Test tab
//! and a commissioning procedure's test step both run it; whoever drives it sends the
//! commands it asks for and hands it the samples and each command's outcome.

use super::test_run::{Plan, StepReport, step_report};
use crate::pdi::Action;
use crate::signal::Sample;

/// Where a run stands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Going to the start (not measured).
    ToStart,
    /// A step's command sent; its samples collected.
    Step { index: usize, cycle: u32 },
    /// The step's move is done; the dwell runs until `until` (sample time).
    Dwell {
        index: usize,
        cycle: u32,
        until: f64,
    },
}

/// What the sequence asks for next.
#[derive(Clone, Debug, PartialEq)]
pub enum Next {
    /// Nothing yet.
    Wait,
    /// Send this command (a step's); its outcome comes back to `on_command_over`.
    Send(Action),
    /// The run is over: `None` after its last cycle, else why it ended early.
    Over(Option<String>),
}

/// A run under way.
#[derive(Clone, Debug)]
pub struct Sequence {
    pub plan: Plan,
    pub phase: Phase,
    /// Every step measured so far.
    pub steps: Vec<StepReport>,
    /// (t from the first step's command, value) of the measured signal.
    pub trace: Vec<[f64; 2]>,
    /// The times (from the first step) each step began.
    pub step_starts: Vec<f64>,
    /// The current step's samples, the first from its command on.
    samples: Vec<Sample>,
    /// When the current step's command was sent (the newest sample's time then).
    step_t0: Option<f64>,
    /// The first step's command time.
    run_t0: Option<f64>,
    /// The newest sample's time.
    last_t: Option<f64>,
}

impl Sequence {
    /// A run of `plan`, `last_t` the newest sample's time: send `plan.start` first.
    pub fn new(plan: Plan, last_t: Option<f64>) -> Sequence {
        Sequence {
            plan,
            phase: Phase::ToStart,
            steps: Vec::new(),
            trace: Vec::new(),
            step_starts: Vec::new(),
            samples: Vec::new(),
            step_t0: None,
            run_t0: None,
            last_t,
        }
    }

    /// The command waited for, if any.
    pub fn waiting_for(&self) -> Option<Action> {
        match self.phase {
            Phase::ToStart => Some(self.plan.start),
            Phase::Step { index, .. } => self.plan.steps.get(index).map(|s| s.2),
            Phase::Dwell { .. } => None,
        }
    }

    /// Where it stands, in words.
    pub fn progress(&self) -> String {
        let steps = self.plan.steps.len();
        match self.phase {
            Phase::ToStart => "moving to the start".into(),
            Phase::Step { index, cycle } => format!(
                "cycle {cycle} of {}, step {} of {steps}: moving",
                self.plan.cycles,
                index + 1
            ),
            Phase::Dwell { index, cycle, .. } => format!(
                "cycle {cycle} of {}, step {} of {steps}: dwell",
                self.plan.cycles,
                index + 1
            ),
        }
    }

    /// New samples: kept for the step under way; a dwell may end with them.
    pub fn on_samples(&mut self, samples: &[Sample]) -> Next {
        if let Some(last) = samples.last() {
            self.last_t = Some(last.t);
        }
        let Some(t0) = self.step_t0 else {
            return Next::Wait;
        };
        self.samples
            .extend(samples.iter().filter(|s| s.t >= t0).cloned());
        if let Phase::Dwell { until, .. } = self.phase
            && self.last_t.is_some_and(|t| t >= until)
        {
            return self.step_over();
        }
        Next::Wait
    }

    /// The command waited for ended: done, or how it ended otherwise (in words).
    pub fn on_command_over(&mut self, outcome: Result<(), String>) -> Next {
        if let Err(how) = outcome {
            let what = if self.phase == Phase::ToStart {
                "the move to the start"
            } else {
                "the step"
            };
            return Next::Over(Some(format!("{what} did not end well: {how}")));
        }
        match self.phase {
            Phase::ToStart => self.begin_step(0, 1),
            Phase::Step { index, cycle } => {
                let now = self.last_t.unwrap_or(0.0);
                self.phase = Phase::Dwell {
                    index,
                    cycle,
                    until: now + self.plan.dwell,
                };
                if self.plan.dwell <= 0.0 {
                    return self.step_over();
                }
                Next::Wait
            }
            Phase::Dwell { .. } => Next::Wait,
        }
    }

    /// Send step `index` of `cycle`.
    fn begin_step(&mut self, index: usize, cycle: u32) -> Next {
        let Some(&(_, _, action)) = self.plan.steps.get(index) else {
            return Next::Over(Some("the plan has no such step".into()));
        };
        let t0 = self.last_t.unwrap_or(0.0);
        self.step_t0 = Some(t0);
        let run_t0 = *self.run_t0.get_or_insert(t0);
        self.step_starts.push(t0 - run_t0);
        self.samples.clear();
        self.phase = Phase::Step { index, cycle };
        Next::Send(action)
    }

    /// The dwell is over: the step's figures, then the next step, cycle or the end.
    fn step_over(&mut self) -> Next {
        let (Phase::Dwell { index, cycle, .. } | Phase::Step { index, cycle }) = self.phase else {
            return Next::Wait;
        };
        let (from, to, _) = self.plan.steps[index];
        let step = step_report(
            cycle,
            (from, to),
            self.plan.band,
            self.plan.signal,
            &self.samples,
        );
        self.steps.push(step);
        let run_t0 = self.run_t0.unwrap_or(0.0);
        let signal = self.plan.signal;
        self.trace.extend(
            self.samples
                .iter()
                .filter_map(|s| s.signals.get(signal).map(|v| [s.t - run_t0, v])),
        );
        if index + 1 < self.plan.steps.len() {
            self.begin_step(index + 1, cycle)
        } else if cycle < self.plan.cycles {
            self.begin_step(0, cycle + 1)
        } else {
            Next::Over(None)
        }
    }
}
