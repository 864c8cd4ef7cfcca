//! The machine around the simulated motor: limit switches, a home cam and the encoder's
//! index pulse, all in world coordinates (units of 0.1°, independent of homing).

/// Positions of the simulated sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct World {
    /// The negative limit switch is active at and below this position.
    pub negative_limit: f64,
    /// The positive limit switch is active at and above this position.
    pub positive_limit: f64,
    /// The home switch is a cam, active from `home_start` to `home_end`.
    pub home_start: f64,
    pub home_end: f64,
    /// The index pulse comes once per revolution at `index_offset + n * index_period`.
    pub index_period: f64,
    pub index_offset: f64,
    /// What the motor drives besides itself.
    pub load: Load,
}

impl Default for World {
    fn default() -> Self {
        Self {
            negative_limit: -36_000.0,
            positive_limit: 36_000.0,
            home_start: 9_000.0,
            home_end: 9_900.0,
            index_period: 3_600.0,
            index_offset: 450.0,
            load: Load::default(),
        }
    }
}

/// The switch states at one position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sensors {
    pub negative_limit: bool,
    pub positive_limit: bool,
    pub home: bool,
}

impl Sensors {
    /// 60FDh bits 0-2 (CiA 402: negative limit, positive limit, home switch).
    pub fn digital_inputs(self) -> u32 {
        u32::from(self.negative_limit)
            | u32::from(self.positive_limit) << 1
            | u32::from(self.home) << 2
    }
}

impl World {
    pub fn sensors(&self, x: f64) -> Sensors {
        Sensors {
            negative_limit: x <= self.negative_limit,
            positive_limit: x >= self.positive_limit,
            home: x >= self.home_start && x <= self.home_end,
        }
    }

    /// The index pulse crossed when moving from `from` to `to`, if any (the first one).
    pub fn index_between(&self, from: f64, to: f64) -> Option<f64> {
        if from == to {
            return None;
        }
        let n_from = ((from - self.index_offset) / self.index_period).floor();
        let n_to = ((to - self.index_offset) / self.index_period).floor();
        if n_from == n_to {
            return None;
        }
        let n = if to > from { n_from + 1.0 } else { n_from };
        Some(self.index_offset + n * self.index_period)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensors_switch_at_their_positions() {
        let w = World::default();
        assert_eq!(w.sensors(0.0), Sensors::default());
        assert!(w.sensors(-36_000.0).negative_limit);
        assert!(w.sensors(36_001.0).positive_limit);
        assert!(w.sensors(9_500.0).home);
        assert_eq!(w.sensors(9_500.0).digital_inputs(), 0b100);
    }

    #[test]
    fn index_pulse_found_in_both_directions() {
        let w = World::default();
        assert_eq!(w.index_between(0.0, 500.0), Some(450.0));
        assert_eq!(w.index_between(500.0, 0.0), Some(450.0));
        assert_eq!(w.index_between(0.0, 400.0), None);
        assert_eq!(w.index_between(-100.0, -3200.0), Some(-3150.0));
    }
}

/// What the motor drives besides itself (the motor alone by default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Load {
    /// The load's inertia as a multiple of the motor's (0: the motor alone).
    pub inertia: f64,
    /// A constant torque against the motor (gravity on a vertical axis), ‰ of rated torque.
    pub torque: f64,
}

impl Load {
    /// The inertia the motor turns, as a multiple of its own.
    pub fn inertia_factor(&self) -> f64 {
        1.0 + self.inertia.max(0.0)
    }

    /// Whether `torque` ‰ breaks the motor away from standstill against a static
    /// friction of `friction` ‰.
    pub fn breaks_away(&self, torque: f64, friction: f64) -> bool {
        (torque - self.torque).abs() > friction
    }
}
