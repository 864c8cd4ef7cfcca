//! The test-move and velocity-step steps: the shared test sequence run, its commands
//! followed, its figures judged at the end.

use super::*;

impl DriveRun {
    pub(super) fn begin_test(&mut self, plan: Plan, limits: Limits) {
        let budget = plan.cycles as f64 * plan.steps.len() as f64 * (plan.dwell + 10.0);
        let deadline = self.now + budget + TEST_SLACK_S;
        let start = plan.start;
        let sequence = Sequence::new(plan, self.latest.map(|s| s.t));
        self.phase = Phase::Test {
            sequence: Box::new(sequence),
            limits,
            deadline,
            limit_at: None,
        };
        self.send(Request::Command(start));
    }

    pub(super) fn follow(&mut self, next: Next) {
        match next {
            Next::Wait => {}
            Next::Send(action) => self.send(Request::Command(action)),
            Next::Over(why) => {
                let Phase::Test {
                    sequence,
                    limits,
                    limit_at,
                    ..
                } = std::mem::replace(&mut self.phase, Phase::Ready)
                else {
                    return;
                };
                self.end_test(*sequence, limits, why, limit_at);
            }
        }
    }

    pub(super) fn end_test(
        &mut self,
        sequence: Sequence,
        limits: Limits,
        why: Option<String>,
        limit_at: Option<f64>,
    ) {
        let signal = sequence.plan.signal;
        let figures = judge(&sequence.steps, &limits, signal);
        let (name, unit) = match signal {
            Signal::Velocity => ("velocity 606Ch", "rpm"),
            _ => ("position 6064h", "units"),
        };
        let plot = Plot {
            signal: name.into(),
            unit: unit.into(),
            points: thin(&sequence.trace, 2000),
            step_starts: sequence.step_starts.clone(),
        };
        let failed: Vec<String> = figures
            .iter()
            .filter(|f| f.passed == Some(false))
            .map(|f| match f.value {
                Some(v) => format!(
                    "{} {v:.3} {} over its limit {}",
                    f.name,
                    f.unit,
                    f.limit.clone().unwrap_or_default()
                ),
                None => format!(
                    "{} not measured (limit {})",
                    f.name,
                    f.limit.clone().unwrap_or_default()
                ),
            })
            .collect();
        let (verdict, note) = match (why, failed.is_empty()) {
            (Some(why), _) => (Verdict::Failed, why),
            (None, true) => (
                Verdict::Passed,
                format!(
                    "{} step(s) measured, every limit kept",
                    sequence.steps.len()
                ),
            ),
            (None, false) => (Verdict::Failed, failed.join("; ")),
        };
        // A limit switch reached explains figures that make no sense otherwise.
        let note = match limit_at {
            Some(at) => format!(
                "{note}; a limit switch was reached during the test (at position {at:.0}): \
                 the axis ran out of travel — shorten the test or move it away from the end"
            ),
            None => note,
        };
        self.end_step(verdict, note, figures);
        if let Some(last) = self.steps.last_mut() {
            last.plot = Some(plot);
        }
    }

    pub(super) fn on_command_over(&mut self, progress: &CommandProgress) {
        if matches!(progress, CommandProgress::Superseded) {
            // The run sends one command at a time: another came from elsewhere.
            return self.abort(
                "the step's command was replaced by another (a stop from the window — Esc — \
                 or another master)",
            );
        }
        match &mut self.phase {
            Phase::Test { sequence, .. } => {
                let outcome = match progress {
                    CommandProgress::Done { .. } => Ok(()),
                    other => Err(other.to_string()),
                };
                let next = sequence.on_command_over(outcome);
                self.follow(next);
            }
            Phase::Command { .. } => match progress {
                CommandProgress::Done { .. } => {
                    self.end_step(Verdict::Passed, "done".into(), vec![])
                }
                other => self.end_step(Verdict::Failed, other.to_string(), vec![]),
            },
            _ => {}
        }
    }
}
