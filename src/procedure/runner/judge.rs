//! A test step's figures held against its limits, the input and NanoJ steps' figures, and
//! the plots thinned for the record.

use super::*;

/// The figures of a test's steps against its limits: each the worst step's; a figure a
/// step could not measure fails its limit.
pub fn judge(steps: &[StepReport], limits: &Limits, signal: Signal) -> Vec<Figure> {
    let unit = if signal == Signal::Velocity {
        "rpm"
    } else {
        "units"
    };
    /// A figure of a step.
    type Of = fn(&StepReport) -> Option<f64>;
    let rows: [(&str, &str, Option<f64>, Of); 5] = [
        (
            "overshoot",
            "%",
            limits.overshoot_percent,
            |s: &StepReport| s.overshoot_pct.map(f64::abs),
        ),
        ("settling time", "s", limits.settling_s, |s: &StepReport| {
            s.settling_time_s
        }),
        ("rise time", "s", limits.rise_s, |s: &StepReport| {
            s.rise_time_s
        }),
        (
            "peak following error",
            "units",
            limits.peak_following_error,
            |s: &StepReport| s.peak_following_error.map(f64::abs),
        ),
        (
            "steady-state error",
            unit,
            limits.steady_state_error,
            |s: &StepReport| s.steady_state_error.map(f64::abs),
        ),
    ];
    rows.iter()
        // A velocity step has no following error to speak of.
        .filter(|(name, ..)| !(signal == Signal::Velocity && *name == "peak following error"))
        .filter_map(|(name, unit, limit, of)| {
            let values: Vec<Option<f64>> = steps.iter().map(of).collect();
            let measured = if values.iter().any(Option::is_none) {
                None
            } else {
                values.iter().flatten().copied().reduce(f64::max)
            };
            if limit.is_none() && measured.is_none() {
                return None;
            }
            Some(Figure {
                name: (*name).to_owned(),
                value: measured,
                unit: (*unit).to_owned(),
                limit: limit.map(|l| format!("≤ {l}")),
                passed: limit.map(|l| measured.is_some_and(|m| m <= l)),
            })
        })
        .collect()
}

pub(super) fn input_figure(name: &str, seen: Option<bool>, expect: bool) -> Figure {
    Figure {
        name: name.into(),
        value: seen.map(|s| if s { 1.0 } else { 0.0 }),
        unit: match seen {
            Some(true) => "active".into(),
            Some(false) => "inactive".into(),
            None => "not read".into(),
        },
        limit: Some(if expect { "= active" } else { "= inactive" }.into()),
        passed: Some(seen == Some(expect)),
    }
}

pub(super) fn nanoj_figure(object: Address, condition: Condition, last: Option<i64>) -> Figure {
    Figure {
        name: object.to_string(),
        value: last.map(|v| v as f64),
        unit: String::new(),
        limit: Some(condition.text()),
        passed: Some(last.is_some_and(|v| condition.holds(v))),
    }
}

/// At most `max` points of `points`, evenly picked (the record's plots stay small).
pub(super) fn thin(points: &[[f64; 2]], max: usize) -> Vec<[f64; 2]> {
    if points.len() <= max || max < 2 {
        return points.to_vec();
    }
    let step = points.len() as f64 / max as f64;
    (0..max)
        .map(|i| points[((i as f64 * step) as usize).min(points.len() - 1)])
        .collect()
}
