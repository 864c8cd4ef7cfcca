//! The figures a servo engineer reads off one step of a test move: rise time (10–90 %),
//! overshoot, settling time into a band, steady-state error, peak and RMS following error,
//! and the time to TargetReached. Computed from the samples alone (sans-IO), so the window,
//! the command line and the tests get the same numbers.
//!
//! A step goes from `from` to `to`, commanded at `t0`. The figures follow the usual
//! definitions of a step response:
//! * rise time: from the first crossing of 10 % of the way to the first crossing of 90 %
//!   (linearly interpolated between samples);
//! * overshoot: the furthest the value goes beyond `to`, in the direction of the step, in
//!   units and in percent of the step (0 when it never passes `to`);
//! * settling time: from `t0` until the value enters the band `to ± band` for good (`None`
//!   when the last sample is outside the band);
//! * steady-state error: `to` less the mean of the last tenth of the samples (at least one);
//! * following error: the peak of its absolute value and its RMS over the step;
//! * time to TargetReached: from `t0` to the first sample with the bit set.

/// The figures of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepFigures {
    /// 10–90 % rise time, seconds.
    pub rise_time_s: Option<f64>,
    /// Overshoot beyond the target, in the signal's units (0 when none).
    pub overshoot: Option<f64>,
    /// Overshoot in percent of the step.
    pub overshoot_pct: Option<f64>,
    /// From the command until the value stays within the band, seconds.
    pub settling_time_s: Option<f64>,
    /// Target less the mean of the last tenth of the samples.
    pub steady_state_error: Option<f64>,
    /// Largest absolute following error.
    pub peak_following_error: Option<f64>,
    /// Root mean square of the following error.
    pub rms_following_error: Option<f64>,
    /// From the command to the first sample with TargetReached set, seconds.
    pub time_to_target_reached_s: Option<f64>,
}

/// One step as sampled: the value's samples, and where they go.
#[derive(Clone, Copy, Debug)]
pub struct Step<'a> {
    /// Sample times, non-decreasing, seconds.
    pub times: &'a [f64],
    /// The value (position or velocity) at each time; NaN is a gap.
    pub values: &'a [f64],
    /// Where the step starts and where it is sent.
    pub from: f64,
    pub to: f64,
    /// When the step was commanded.
    pub t0: f64,
    /// Half the width of the settling band, in the value's units.
    pub band: f64,
}

impl Step<'_> {
    /// The figures of the value's own response (no following error, no TargetReached).
    pub fn figures(&self) -> StepFigures {
        let samples: Vec<(f64, f64)> = self
            .times
            .iter()
            .zip(self.values)
            .filter(|(t, v)| **t >= self.t0 && v.is_finite() && t.is_finite())
            .map(|(t, v)| (*t, *v))
            .collect();
        let span = self.to - self.from;
        if samples.is_empty() || span == 0.0 || !span.is_finite() {
            return StepFigures::default();
        }
        // Progress along the step: 0 at `from`, 1 at `to`, whatever its direction.
        let progress = |v: f64| (v - self.from) / span;
        let crossing = |fraction: f64| -> Option<f64> {
            let mut before: Option<(f64, f64)> = None;
            for &(t, v) in &samples {
                let p = progress(v);
                if p >= fraction {
                    return Some(match before {
                        Some((t1, p1)) if p > p1 => t1 + (t - t1) * (fraction - p1) / (p - p1),
                        _ => t,
                    });
                }
                before = Some((t, p));
            }
            None
        };
        let rise_time_s = match (crossing(0.1), crossing(0.9)) {
            // Interpolated crossings between far-apart samples may round past each other.
            (Some(low), Some(high)) => Some((high - low).max(0.0)),
            _ => None,
        };
        let furthest = samples
            .iter()
            .map(|&(_, v)| progress(v))
            .fold(f64::NEG_INFINITY, f64::max);
        let beyond = (furthest - 1.0).max(0.0);
        let settling_time_s = match samples.last() {
            Some(&(_, last)) if (last - self.to).abs() <= self.band => {
                // The first sample after the last one outside the band.
                let last_out = samples
                    .iter()
                    .rposition(|&(_, v)| (v - self.to).abs() > self.band);
                let entered = match last_out {
                    Some(i) => samples.get(i + 1).map(|&(t, _)| t),
                    None => samples.first().map(|&(t, _)| t),
                };
                entered.map(|t| t - self.t0)
            }
            _ => None,
        };
        let tail = (samples.len() / 10).max(1);
        let mean_tail = samples[samples.len() - tail..]
            .iter()
            .map(|&(_, v)| v)
            .sum::<f64>()
            / tail as f64;
        StepFigures {
            rise_time_s,
            overshoot: Some(beyond * span.abs()),
            overshoot_pct: Some(beyond * 100.0),
            settling_time_s,
            steady_state_error: Some(self.to - mean_tail),
            ..StepFigures::default()
        }
    }
}

/// Peak and RMS of a following error's samples from `t0` on (NaN samples left out).
pub fn following_error(times: &[f64], errors: &[f64], t0: f64) -> (Option<f64>, Option<f64>) {
    let errors: Vec<f64> = times
        .iter()
        .zip(errors)
        .filter(|(t, e)| **t >= t0 && e.is_finite())
        .map(|(_, e)| *e)
        .collect();
    if errors.is_empty() {
        return (None, None);
    }
    let peak = errors.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (Some(peak), Some(rms))
}

/// Seconds from `t0` to the first sample at or after it whose TargetReached is set.
pub fn time_to_target_reached(times: &[f64], reached: &[bool], t0: f64) -> Option<f64> {
    times
        .iter()
        .zip(reached)
        .find(|(t, r)| **t >= t0 && **r)
        .map(|(t, _)| t - t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampled(f: impl Fn(f64) -> f64, until: f64, dt: f64) -> (Vec<f64>, Vec<f64>) {
        let n = (until / dt).round() as usize;
        let times: Vec<f64> = (0..=n).map(|i| i as f64 * dt).collect();
        let values = times.iter().map(|&t| f(t)).collect();
        (times, values)
    }

    fn close(a: Option<f64>, b: f64, tolerance: f64) -> bool {
        a.is_some_and(|a| (a - b).abs() <= tolerance)
    }

    #[test]
    fn a_first_order_step_rises_in_tau_ln9_settles_in_tau_ln50_and_never_overshoots() {
        let tau = 0.2;
        let (times, values) = sampled(|t| 1000.0 * (1.0 - (-t / tau).exp()), 3.0, 0.001);
        let step = Step {
            times: &times,
            values: &values,
            from: 0.0,
            to: 1000.0,
            t0: 0.0,
            band: 20.0, // 2 %
        };
        let f = step.figures();
        assert!(close(f.rise_time_s, tau * 9f64.ln(), 0.002), "{f:?}");
        assert!(close(f.settling_time_s, tau * 50f64.ln(), 0.002), "{f:?}");
        assert_eq!(f.overshoot, Some(0.0));
        assert!(close(f.steady_state_error, 0.0, 0.01), "{f:?}");
    }

    #[test]
    fn an_underdamped_step_overshoots_as_its_damping_says_whatever_its_direction() {
        // Second order, ζ = 0.5, ωn = 10 rad/s: overshoot e^(-πζ/√(1-ζ²)) = 16.3 %.
        let (zeta, wn) = (0.5_f64, 10.0_f64);
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let unit = |t: f64| {
            1.0 - (-zeta * wn * t).exp() / (1.0 - zeta * zeta).sqrt() * (wd * t + zeta.acos()).sin()
        };
        let expected = (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp() * 100.0;
        for (from, to) in [(0.0, 500.0), (500.0, -500.0)] {
            let (times, values) = sampled(|t| from + (to - from) * unit(t), 3.0, 0.0005);
            let f = Step {
                times: &times,
                values: &values,
                from,
                to,
                t0: 0.0,
                band: (to - from).abs() * 0.02,
            }
            .figures();
            assert!(close(f.overshoot_pct, expected, 0.1), "{from}→{to}: {f:?}");
            assert!(
                close(f.overshoot, expected / 100.0 * (to - from).abs(), 0.5),
                "{f:?}"
            );
            assert!(
                f.settling_time_s.is_some_and(|s| s > 0.5 && s < 1.0),
                "{f:?}"
            );
        }
    }

    #[test]
    fn a_step_that_never_gets_there_has_no_rise_or_settling_and_says_its_error() {
        let (times, values) = sampled(|t| (t * 1000.0).min(600.0), 2.0, 0.01);
        let f = Step {
            times: &times,
            values: &values,
            from: 0.0,
            to: 1000.0,
            t0: 0.0,
            band: 10.0,
        }
        .figures();
        assert_eq!(f.rise_time_s, None);
        assert_eq!(f.settling_time_s, None);
        assert!(close(f.steady_state_error, 400.0, 1e-9), "{f:?}");
        // Nothing at all, or no step: no figures, no panic.
        let empty = Step {
            times: &[],
            values: &[],
            from: 0.0,
            to: 1.0,
            t0: 0.0,
            band: 0.1,
        };
        assert_eq!(empty.figures(), StepFigures::default());
    }

    /// The figures of a recorded step worked out by hand.
    fn hand_step(samples: &[(f64, f64)], band: f64) -> StepFigures {
        let times: Vec<f64> = samples.iter().map(|s| s.0).collect();
        let values: Vec<f64> = samples.iter().map(|s| s.1).collect();
        Step {
            times: &times,
            values: &values,
            from: 0.0,
            to: 100.0,
            t0: 0.0,
            band,
        }
        .figures()
    }

    #[test]
    fn a_step_that_overshoots_twice_has_the_figures_worked_out_by_hand() {
        let f = hand_step(
            &[
                (0.0, 0.0),
                (0.1, 5.0),
                (0.2, 30.0),
                (0.3, 70.0),
                (0.4, 95.0),
                (0.5, 112.0),
                (0.6, 96.0),
                (0.7, 104.0),
                (0.8, 99.5),
                (0.9, 100.2),
                (1.0, 100.0),
                (1.1, 100.0),
            ],
            1.0,
        );
        // 10 % between 5 and 30: 0.1 + 0.1 × 5/25 = 0.12 s; 90 % between 70 and 95:
        // 0.3 + 0.1 × 20/25 = 0.38 s.
        assert!(close(f.rise_time_s, 0.26, 1e-9), "{f:?}");
        // The first overshoot is the larger: 12 of 100.
        assert!(close(f.overshoot, 12.0, 1e-9) && close(f.overshoot_pct, 12.0, 1e-9));
        // Last outside ±1 at 0.7 s (104): in the band for good from the next sample.
        assert!(close(f.settling_time_s, 0.8, 1e-9), "{f:?}");
        // The last tenth (one sample of twelve) is on the target.
        assert!(close(f.steady_state_error, 0.0, 1e-9));
    }

    #[test]
    fn a_step_that_never_settles_has_no_settling_time_and_its_error_by_hand() {
        let f = hand_step(
            &[
                (0.0, 0.0),
                (0.5, 60.0),
                (1.0, 95.0),
                (1.5, 105.0),
                (2.0, 95.0),
                (2.5, 105.0),
            ],
            1.0,
        );
        // 10 % at 0.5 × 10/60; 90 % at 0.5 + 0.5 × 30/35.
        let rise = 0.5 + 0.5 * 30.0 / 35.0 - 0.5 * 10.0 / 60.0;
        assert!(close(f.rise_time_s, rise, 1e-9), "{f:?}");
        assert!(close(f.overshoot_pct, 5.0, 1e-9));
        assert_eq!(f.settling_time_s, None, "still swinging ±5 at the end");
        assert!(close(f.steady_state_error, -5.0, 1e-9), "{f:?}");
    }

    #[test]
    fn following_error_and_target_reached_are_measured_from_the_command() {
        let times = [0.0, 0.1, 0.2, 0.3, 0.4];
        let errors = [99.0, 3.0, -4.0, f64::NAN, 0.0];
        let (peak, rms) = following_error(&times, &errors, 0.1);
        assert_eq!(peak, Some(4.0));
        assert!(close(rms, (25.0_f64 / 3.0).sqrt(), 1e-12), "{rms:?}");
        let reached = [true, false, false, true, true];
        assert!(close(
            time_to_target_reached(&times, &reached, 0.1),
            0.2,
            1e-12
        ));
        assert_eq!(time_to_target_reached(&times, &[false; 5], 0.0), None);
    }

    proptest::proptest! {
        #[test]
        fn any_samples_give_figures_without_a_panic(
            values in proptest::collection::vec(proptest::num::f64::ANY, 0..200),
            from in -1e6f64..1e6,
            to in -1e6f64..1e6,
        ) {
            let times: Vec<f64> = (0..values.len()).map(|i| i as f64 * 0.01).collect();
            let f = Step { times: &times, values: &values, from, to, t0: 0.0, band: 1.0 }.figures();
            proptest::prop_assert!(f.overshoot.is_none_or(|o| o >= 0.0));
            proptest::prop_assert!(f.rise_time_s.is_none_or(|r| r >= 0.0));
        }
    }
}
