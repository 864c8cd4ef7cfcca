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

/// Position, velocity and torque over time, each bounded to `capacity` samples.
#[derive(Clone, Debug, PartialEq)]
pub struct History {
    capacity: usize,
    pub position: Trace,
    pub velocity: Trace,
    pub torque: Trace,
}

impl History {
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(1),
            position: Trace::default(),
            velocity: Trace::default(),
            torque: Trace::default(),
        }
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Append one sample; a time that goes backwards (a new connection) starts afresh.
    pub fn push(
        &mut self,
        t: f64,
        position: Option<f64>,
        velocity: Option<f64>,
        torque: Option<f64>,
    ) {
        if self.position.last().is_some_and(|p| t < p[0])
            || self.velocity.last().is_some_and(|p| t < p[0])
        {
            self.clear();
        }
        let capacity = self.capacity;
        for (trace, value) in [
            (&mut self.position, position),
            (&mut self.velocity, velocity),
            (&mut self.torque, torque),
        ] {
            if let Some(v) = value {
                if trace.points.len() == capacity {
                    trace.points.pop_front();
                }
                trace.points.push_back([t, v]);
            }
        }
    }

    pub fn clear(&mut self) {
        self.position.points.clear();
        self.velocity.points.clear();
        self.torque.points.clear();
    }

    /// The time of the newest sample.
    pub fn latest_time(&self) -> Option<f64> {
        [&self.position, &self.velocity, &self.torque]
            .iter()
            .filter_map(|t| t.last().map(|p| p[0]))
            .reduce(f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_is_bounded_and_the_oldest_go_first() {
        let mut h = History::new(100);
        for i in 0..1000 {
            h.push(f64::from(i), Some(f64::from(i)), Some(0.0), None);
        }
        assert_eq!(h.position.len(), 100);
        assert_eq!(h.position.points().next(), Some([900.0, 900.0]));
        assert_eq!(h.torque.len(), 0);
        assert_eq!(h.latest_time(), Some(999.0));
    }

    #[test]
    fn a_new_connection_starts_afresh() {
        let mut h = History::new(10);
        h.push(5.0, Some(1.0), None, None);
        h.push(0.1, Some(2.0), None, None);
        assert_eq!(h.position.points().collect::<Vec<_>>(), vec![[0.1, 2.0]]);
    }

    #[test]
    fn window_selects_by_time() {
        let mut h = History::new(10);
        for i in 0..10 {
            h.push(f64::from(i), Some(f64::from(i)), None, None);
        }
        assert_eq!(h.position.window(2.5, 4.0), vec![[3.0, 3.0], [4.0, 4.0]]);
    }
}
