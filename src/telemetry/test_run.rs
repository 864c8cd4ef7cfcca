//! A test run as data, shared by `drivedeck test-move`/`test-velocity` and the window's
//! Test tab: the plan (the move to the start, the steps, the dwell, the cycles, the band,
//! which signal the figures are of), checked before anything moves; the figures of one
//! step from its samples; their summary over the run.

use serde::Serialize;

use super::figures::{self, Step, StepFigures};
use crate::pdi::{Action, Opcode, StatusBit};
use crate::signal::{Sample, Signal};

/// A test move: back and forth between two positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveTest {
    pub from: i64,
    pub to: i64,
    pub speed: i64,
    pub dwell: f64,
    pub cycles: u32,
    pub band: Option<f64>,
}

/// Velocity steps 0 → v → −v → 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityTest {
    pub speed: i64,
    pub hold: f64,
    pub cycles: u32,
    pub band: Option<f64>,
}

/// What a test runs: the move to its start, its steps (from, to, the command), how long
/// it stays after each, how many cycles, and which signal the figures are of.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub start: Action,
    pub steps: Vec<(i64, i64, Action)>,
    pub speed: i64,
    pub dwell: f64,
    pub cycles: u32,
    pub band: f64,
    pub signal: Signal,
}

/// One step measured: where it went and its figures.
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    pub cycle: u32,
    pub from: i64,
    pub to: i64,
    pub samples: usize,
    pub rise_time_s: Option<f64>,
    pub overshoot: Option<f64>,
    pub overshoot_pct: Option<f64>,
    pub settling_time_s: Option<f64>,
    pub band: f64,
    pub steady_state_error: Option<f64>,
    pub peak_following_error: Option<f64>,
    pub rms_following_error: Option<f64>,
    pub time_to_target_reached_s: Option<f64>,
}

/// The mean and the worst of one figure over the steps that have it.
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub mean: f64,
    pub worst: f64,
    pub steps: usize,
}

#[derive(Serialize, Debug, Default, Clone, Copy, PartialEq)]
pub struct Summary {
    pub rise_time_s: Option<Spread>,
    pub overshoot_pct: Option<Spread>,
    pub settling_time_s: Option<Spread>,
    pub steady_state_error: Option<Spread>,
    pub peak_following_error: Option<Spread>,
    pub time_to_target_reached_s: Option<Spread>,
}

/// The cycles and the dwell or hold, checked.
pub fn check_counts(cycles: u32, dwell: f64, what: &str) -> Result<(), String> {
    if !(1..=10_000).contains(&cycles) {
        return Err(format!(
            "--cycles {cycles} is out of range: give 1 to 10000"
        ));
    }
    if !(0.0..=3600.0).contains(&dwell) {
        return Err(format!(
            "--{what} {dwell} s is out of range: give 0 to 3600 seconds"
        ));
    }
    Ok(())
}

/// The settling band: as given, else 1 % of the step (at least one unit).
pub fn band(given: Option<f64>, step: i64) -> f64 {
    given
        .filter(|b| b.is_finite() && *b > 0.0)
        .unwrap_or_else(|| (step.abs() as f64 / 100.0).max(1.0))
}

/// The moves, checked before anything is sent: a typo never touches the drive.
pub fn move_plan(args: &MoveTest) -> Result<Plan, String> {
    if args.speed == 0 {
        return Err("test-move --speed 0 would never get there: give a speed".into());
    }
    if args.from == args.to {
        return Err("test-move --from and --to are the same position: give two positions".into());
    }
    check_counts(args.cycles, args.dwell, "dwell")?;
    let to = |position: i64| {
        Action::from_inputs(Opcode::MoveAbsolute, &[position, args.speed])
            .map_err(|e| e.to_string())
    };
    let (to_from, to_to) = (to(args.from)?, to(args.to)?);
    Ok(Plan {
        start: to_from,
        steps: vec![(args.from, args.to, to_to), (args.to, args.from, to_from)],
        speed: args.speed,
        dwell: args.dwell,
        cycles: args.cycles,
        band: band(args.band, args.to - args.from),
        signal: Signal::Position,
    })
}

/// The velocity steps 0 → v → −v → 0, checked.
pub fn velocity_plan(args: &VelocityTest) -> Result<Plan, String> {
    if args.speed == 0 {
        return Err("test-velocity --speed 0 makes no step: give the speed to step to".into());
    }
    check_counts(args.cycles, args.hold, "hold")?;
    let at =
        |speed: i64| Action::from_inputs(Opcode::Velocity, &[speed]).map_err(|e| e.to_string());
    let v = args.speed;
    Ok(Plan {
        start: at(0)?,
        steps: vec![(0, v, at(v)?), (v, -v, at(-v)?), (-v, 0, at(0)?)],
        speed: v,
        dwell: args.hold,
        cycles: args.cycles,
        band: band(args.band, v),
        signal: Signal::Velocity,
    })
}

/// The figures of one step from its samples (the first is the command's time).
pub fn step_report(
    cycle: u32,
    (from, to): (i64, i64),
    band: f64,
    signal: Signal,
    samples: &[Sample],
) -> StepReport {
    let times: Vec<f64> = samples.iter().map(|s| s.t).collect();
    let value = |signal: Signal| -> Vec<f64> {
        samples
            .iter()
            .map(|s| s.signals.get(signal).unwrap_or(f64::NAN))
            .collect()
    };
    let positions = value(signal);
    let errors = value(Signal::FollowingError);
    let reached: Vec<bool> = samples
        .iter()
        .map(|s| s.tx.status.is_set(StatusBit::TargetReached))
        .collect();
    let t0 = times.first().copied().unwrap_or(0.0);
    let step = Step {
        times: &times,
        values: &positions,
        from: from as f64,
        to: to as f64,
        t0,
        band,
    };
    let f: StepFigures = step.figures();
    let (peak, rms) = figures::following_error(&times, &errors, t0);
    // TargetReached may still be set from the step before until the drive takes the
    // command: counted from the first sample a tenth of the way there (moving by then).
    let span = (to - from) as f64;
    let moving = positions
        .iter()
        .position(|p| (p - from as f64) / span >= 0.1)
        .unwrap_or(samples.len());
    let reached_at = figures::time_to_target_reached(&times[moving..], &reached[moving..], t0);
    StepReport {
        cycle,
        from,
        to,
        samples: samples.len(),
        rise_time_s: f.rise_time_s,
        overshoot: f.overshoot,
        overshoot_pct: f.overshoot_pct,
        settling_time_s: f.settling_time_s,
        band,
        steady_state_error: f.steady_state_error,
        peak_following_error: peak,
        rms_following_error: rms,
        time_to_target_reached_s: reached_at,
    }
}

/// The mean and the worst (largest magnitude) of the values present.
pub fn spread(values: impl Iterator<Item = Option<f64>>) -> Option<Spread> {
    let values: Vec<f64> = values.flatten().filter(|v| v.is_finite()).collect();
    if values.is_empty() {
        return None;
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let worst = values
        .iter()
        .copied()
        .fold(0.0_f64, |w, v| if v.abs() > w.abs() { v } else { w });
    Some(Spread {
        mean,
        worst,
        steps: values.len(),
    })
}

pub fn summary(steps: &[StepReport]) -> Summary {
    Summary {
        rise_time_s: spread(steps.iter().map(|s| s.rise_time_s)),
        overshoot_pct: spread(steps.iter().map(|s| s.overshoot_pct)),
        settling_time_s: spread(steps.iter().map(|s| s.settling_time_s)),
        steady_state_error: spread(steps.iter().map(|s| s.steady_state_error)),
        peak_following_error: spread(steps.iter().map(|s| s.peak_following_error)),
        time_to_target_reached_s: spread(steps.iter().map(|s| s.time_to_target_reached_s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_takes_the_mean_and_the_worst_by_magnitude() {
        let s = spread([Some(1.0), None, Some(-3.0), Some(f64::NAN), Some(2.0)].into_iter());
        assert_eq!(
            s,
            Some(Spread {
                mean: 0.0,
                worst: -3.0,
                steps: 3
            })
        );
        assert_eq!(spread([None, None].into_iter()), None);
    }
}
