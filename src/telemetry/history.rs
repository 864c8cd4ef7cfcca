//! A bounded history of the plot signals. Memory never grows past its capacity: the
//! oldest samples go first.

use std::collections::VecDeque;

/// One signal's samples, `[t, value]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    points: VecDeque<[f64; 2]>,
}

impl Trace {
    pub fn points(&self) -> impl ExactSizeIterator<Item = [f64; 2]> + '_ {
        self.points.iter().copied()
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    pub fn last(&self) -> Option<[f64; 2]> {
        self.points.back().copied()
    }

    /// The points with `from <= t <= to`.
    pub fn window(&self, from: f64, to: f64) -> Vec<[f64; 2]> {
        let start = self.points.partition_point(|p| p[0] < from);
        self.points
            .range(start..)
            .take_while(|p| p[0] <= to)
            .copied()
            .collect()
    }
}

/// The plotted signals, in the order `History::push` takes them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    Position,
    Velocity,
    Torque,
    FollowingError,
    AnalogInput,
}

impl Signal {
    pub const ALL: [Signal; 5] = [
        Signal::Position,
        Signal::Velocity,
        Signal::Torque,
        Signal::FollowingError,
        Signal::AnalogInput,
    ];

    /// The legend: name, object and unit.
    pub fn label(self) -> &'static str {
        match self {
            Signal::Position => "Position 6064h [0.1°]",
            Signal::Velocity => "Velocity 606Ch [rpm]",
            Signal::Torque => "Torque 6077h [‰]",
            Signal::FollowingError => "Following error 60F4h [0.1°]",
            Signal::AnalogInput => "Analog input 3220h:01",
        }
    }

    pub fn id(self) -> &'static str {
        match self {
            Signal::Position => "position",
            Signal::Velocity => "velocity",
            Signal::Torque => "torque",
            Signal::FollowingError => "following_error",
            Signal::AnalogInput => "analog_input",
        }
    }

    /// Whether the plot panel shows it even before any sample came (the other signals
    /// appear when a link delivers them, e.g. the EtherNet/IP Common set).
    pub fn always_shown(self) -> bool {
        matches!(self, Signal::Position | Signal::Velocity | Signal::Torque)
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// The plotted signals over time, each bounded to `capacity` samples.
#[derive(Clone, Debug, PartialEq)]
pub struct History {
    capacity: usize,
    traces: [Trace; 5],
}

impl History {
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(1),
            traces: Default::default(),
        }
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    pub fn trace(&self, signal: Signal) -> &Trace {
        &self.traces[signal.index()]
    }

    /// Append one sample (values in [`Signal::ALL`] order); a time that goes backwards (a
    /// new connection) starts afresh.
    pub fn push(&mut self, t: f64, values: [Option<f64>; 5]) {
        if self.latest_time().is_some_and(|latest| t < latest) {
            self.clear();
        }
        let capacity = self.capacity;
        for (trace, value) in self.traces.iter_mut().zip(values) {
            if let Some(v) = value {
                if trace.points.len() == capacity {
                    trace.points.pop_front();
                }
                trace.points.push_back([t, v]);
            }
        }
    }

    pub fn clear(&mut self) {
        for trace in &mut self.traces {
            trace.points.clear();
        }
    }

    /// The time of the newest sample.
    pub fn latest_time(&self) -> Option<f64> {
        self.traces
            .iter()
            .filter_map(|t| t.last().map(|p| p[0]))
            .reduce(f64::max)
    }

    /// Samples in the longest trace.
    pub fn len(&self) -> usize {
        self.traces.iter().map(Trace::len).max().unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_is_bounded_and_the_oldest_go_first() {
        let mut h = History::new(100);
        for i in 0..1000 {
            h.push(
                f64::from(i),
                [Some(f64::from(i)), Some(0.0), None, None, None],
            );
        }
        assert_eq!(h.trace(Signal::Position).len(), 100);
        assert_eq!(
            h.trace(Signal::Position).points().next(),
            Some([900.0, 900.0])
        );
        assert_eq!(h.trace(Signal::Torque).len(), 0);
        assert_eq!(h.len(), 100);
        assert_eq!(h.latest_time(), Some(999.0));
    }

    #[test]
    fn a_new_connection_starts_afresh() {
        let mut h = History::new(10);
        h.push(5.0, [Some(1.0), None, None, None, Some(3.0)]);
        h.push(0.1, [Some(2.0), None, None, None, None]);
        assert_eq!(
            h.trace(Signal::Position).points().collect::<Vec<_>>(),
            vec![[0.1, 2.0]]
        );
        assert!(h.trace(Signal::AnalogInput).is_empty());
    }

    #[test]
    fn window_selects_by_time() {
        let mut h = History::new(10);
        for i in 0..10 {
            h.push(f64::from(i), [Some(f64::from(i)), None, None, None, None]);
        }
        assert_eq!(
            h.trace(Signal::Position).window(2.5, 4.0),
            vec![[3.0, 3.0], [4.0, 4.0]]
        );
    }
}
