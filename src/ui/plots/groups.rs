//! Several signals in one plot, as a scope's channels: which signals share a plot (the
//! user's "plot with …" choices), and how each keeps a scale of its own there. Each signal
//! is drawn on a normalised axis where a grid line is one of its own steps (1, 2 or 5 ×
//! 10ⁿ of its unit), so every signal's y axis labels the same grid lines with round values
//! of its own; the read-out gives the true values.
//!
//! No egui here: the arithmetic of the layout, tested alone.

use std::collections::BTreeMap;

/// The plots for the signals `ids` (in the order drawn), each a list of indices into
/// `ids`, the host first: a signal joins the plot of the signal `together` names for it
/// when that one is drawn and has a plot of its own (not with a third: no chains, no
/// circles); otherwise it has its own plot. Plots keep the order of their hosts.
pub fn plot_groups(ids: &[&str], together: &BTreeMap<String, String>) -> Vec<Vec<usize>> {
    let index_of = |id: &str| ids.iter().position(|x| *x == id);
    let host = |i: usize| -> Option<usize> {
        let host = index_of(together.get(ids[i])?)?;
        let host_is_guest = together
            .get(ids[host])
            .is_some_and(|h| index_of(h).is_some_and(|h| h != host));
        (host != i && !host_is_guest).then_some(host)
    };
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut group_of: Vec<Option<usize>> = vec![None; ids.len()];
    for (i, group) in group_of.iter_mut().enumerate() {
        if host(i).is_none() {
            *group = Some(groups.len());
            groups.push(vec![i]);
        }
    }
    for i in 0..ids.len() {
        if let Some(h) = host(i)
            && let Some(g) = group_of[h]
        {
            groups[g].push(i);
        }
    }
    groups
}

/// One signal's scale in a shared plot: a value v is drawn at (v − origin) / step, so the
/// grid lines at 0, 1, 2 … are origin, origin + step, … in its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    pub origin: f64,
    pub step: f64,
}

impl Scale {
    /// Where `value` is drawn.
    pub fn to_drawn(self, value: f64) -> f64 {
        (value - self.origin) / self.step
    }

    /// The value at the drawn height `y`.
    pub fn value_at(self, y: f64) -> f64 {
        self.origin + y * self.step
    }
}

/// About as many grid steps as a plot shows of one signal alone.
const STEPS: f64 = 3.0;
/// The most grid steps a plot shows.
const MAX_STEPS: f64 = 4.0;

/// The grid of `step` that holds `low..=high`: its first line, and how many steps.
fn grid(low: f64, high: f64, step: f64) -> (f64, f64) {
    let origin = (low / step).floor() * step;
    (origin, ((high - origin) / step).ceil().max(1.0))
}

/// The scales of the signals of one plot, from each one's lowest and highest value in view
/// (NaN: nothing in view), and the number of grid steps the plot shows (the most any of
/// them needs): each signal fills most of the plot with round grid values of its own.
pub fn scales(ranges: &[(f64, f64)]) -> (Vec<Scale>, u32) {
    let mut steps = 1;
    let scales = ranges
        .iter()
        .map(|&(low, high)| {
            let (low, high) = if low.is_finite() && high.is_finite() {
                (low, high)
            } else {
                (-1.0, 1.0)
            };
            // A flat line gets a span around it (it is not squeezed into nothing).
            let (low, high) = if high > low {
                (low, high)
            } else {
                (low - 1.0, high + 1.0)
            };
            let span = high - low;
            let mut step = nice_step(span / STEPS);
            let (mut origin, mut needed) = grid(low, high, step);
            // No more than four steps: on a plot at its least height each label keeps
            // a text line of room (egui_plot leaves out labels closer than that).
            while needed > MAX_STEPS {
                step = nice_step(step * 1.01);
                (origin, needed) = grid(low, high, step);
            }
            steps = steps.max(needed as u32);
            Scale { origin, step }
        })
        .collect();
    (scales, steps)
}

/// The smallest 1, 2 or 5 × 10ⁿ at or above `raw`.
pub fn nice_step(raw: f64) -> f64 {
    let decade = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * decade)
}

/// A grid value at its step's precision: a 0.05 step gives "12.35", a 20 step "140".
pub fn value_label(value: f64, step: f64) -> String {
    let decimals = if step > 0.0 && step < 1.0 {
        (-step.log10()).ceil().clamp(0.0, 9.0) as usize
    } else {
        0
    };
    let text = format!("{value:.decimals$}");
    // No "-0".
    if text.trim_start_matches(['-', '0', '.']).is_empty() {
        text.trim_start_matches('-').to_owned()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(a, b)| ((*a).to_owned(), (*b).to_owned()))
            .collect()
    }

    #[test]
    fn a_signal_joins_its_hosts_plot_when_the_host_has_one_of_its_own() {
        let ids = ["position", "velocity", "torque", "following_error"];
        assert_eq!(
            plot_groups(&ids, &BTreeMap::new()),
            [vec![0], vec![1], vec![2], vec![3]]
        );
        let together = map(&[("following_error", "position"), ("torque", "velocity")]);
        assert_eq!(plot_groups(&ids, &together), [vec![0, 3], vec![1, 2]]);
        // A host not drawn, a chain, a circle, itself: each its own plot where it breaks.
        let together = map(&[("velocity", "gone"), ("torque", "velocity")]);
        assert_eq!(plot_groups(&ids, &together), [vec![0], vec![1, 2], vec![3]]);
        let chain = map(&[("torque", "velocity"), ("velocity", "position")]);
        assert_eq!(plot_groups(&ids, &chain), [vec![0, 1], vec![2], vec![3]]);
        let circle = map(&[("torque", "velocity"), ("velocity", "torque")]);
        assert_eq!(
            plot_groups(&ids, &circle),
            [vec![0], vec![1], vec![2], vec![3]]
        );
        let own = map(&[("torque", "torque")]);
        assert_eq!(plot_groups(&ids, &own).len(), 4);
    }

    #[test]
    fn each_signal_fills_the_plot_on_round_values_of_its_own() {
        let (scales, steps) = scales(&[(-1000.0, 1000.0), (0.2, 0.9), (f64::NAN, f64::NAN)]);
        // Three to five labelled grid lines.
        assert!((2..=4).contains(&steps), "{steps}");
        // However the range falls on the grid.
        for (low, high) in [(-0.9, 3.1), (0.1, 1.05), (-101.0, 299.0), (7.0, 7.5)] {
            let (_, steps) = self::scales(&[(low, high)]);
            assert!((2..=4).contains(&steps), "{low} {high}: {steps}");
        }
        for (scale, (low, high)) in scales.iter().zip([(-1000.0, 1000.0), (0.2, 0.9)]) {
            // Inside the grid, filling at least half of it.
            let (a, b) = (scale.to_drawn(low), scale.to_drawn(high));
            assert!(a >= 0.0 && b <= f64::from(steps), "{scale:?} {a} {b}");
            assert!((b - a) >= f64::from(steps) / 2.0 - 1.0, "{scale:?} {a} {b}");
            assert!((scale.value_at(scale.to_drawn(123.0)) - 123.0).abs() < 1e-9);
        }
        assert_eq!(scales[0].step, 1000.0);
        assert_eq!(value_label(scales[1].value_at(1.0), scales[1].step), "0.5");
        assert_eq!(value_label(-0.0, 0.5), "0.0");
        // A flat line still has a step.
        let (flat, _) = self::scales(&[(5.0, 5.0)]);
        assert!(flat[0].step > 0.0);
    }
}
