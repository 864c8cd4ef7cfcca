//! Homing of the simulated drive (CiA 402 homing methods, the subset a Nanotec PDI user
//! meets most): a plan of legs, each moving one way until a switch edge or the index pulse.

use super::world::{Sensors, World};

/// Homing methods the simulator supports.
pub const SUPPORTED_METHODS: [i8; 10] = [17, 18, 19, 20, 21, 22, 33, 34, 35, 37];

/// What ends a leg.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Until {
    NegativeLimit(bool),
    PositiveLimit(bool),
    Home(bool),
    Index,
}

/// One movement of a homing run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Leg {
    /// +1 or -1
    pub direction: i8,
    /// Fast = 6099h:01 (search for switch), slow = 6099h:02 (search for zero).
    pub fast: bool,
    pub until: Until,
    /// A search leg turns round once at a limit switch it was not looking for.
    pub may_reverse: bool,
}

const fn leg(direction: i8, fast: bool, until: Until) -> Leg {
    Leg {
        direction,
        fast,
        until,
        may_reverse: fast,
    }
}

/// The legs of a method, given the switches at the start. `None` for an unsupported
/// method.
pub fn plan(method: i8, at_start: Sensors) -> Option<Vec<Leg>> {
    use Until::*;
    let home = at_start.home;
    let legs = match method {
        17 => vec![
            leg(-1, true, NegativeLimit(true)),
            leg(1, false, NegativeLimit(false)),
        ],
        18 => vec![
            leg(1, true, PositiveLimit(true)),
            leg(-1, false, PositiveLimit(false)),
        ],
        19 => {
            let mut legs = vec![];
            if !home {
                legs.push(leg(1, true, Home(true)));
            }
            legs.push(leg(-1, false, Home(false)));
            legs
        }
        20 => {
            let mut legs = vec![];
            if !home {
                legs.push(leg(1, true, Home(true)));
            }
            legs.push(leg(-1, false, Home(false)));
            legs.push(leg(1, false, Home(true)));
            legs
        }
        21 => {
            let mut legs = vec![];
            if !home {
                legs.push(leg(-1, true, Home(true)));
            }
            legs.push(leg(1, false, Home(false)));
            legs
        }
        22 => {
            let mut legs = vec![];
            if !home {
                legs.push(leg(-1, true, Home(true)));
            }
            legs.push(leg(1, false, Home(false)));
            legs.push(leg(-1, false, Home(true)));
            legs
        }
        33 => vec![leg(-1, false, Index)],
        34 => vec![leg(1, false, Index)],
        35 | 37 => vec![],
        _ => return None,
    };
    Some(legs)
}

/// The outcome of one step of a homing run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HomingStep {
    /// Keep moving at this velocity sign and speed class.
    Moving { direction: i8, fast: bool },
    /// The home point was found at this world position; brake and finish.
    Found { world: f64 },
    /// The run failed: a limit switch met where none was expected, after turning once.
    Failed,
}

/// A homing run in progress.
#[derive(Clone, Debug)]
pub struct HomingRun {
    legs: Vec<Leg>,
    current: usize,
    direction: i8,
    reversed: bool,
}

impl HomingRun {
    pub fn new(method: i8, at_start: Sensors) -> Option<Self> {
        let legs = plan(method, at_start)?;
        let direction = legs.first().map_or(1, |l| l.direction);
        Some(Self {
            legs,
            current: 0,
            direction,
            reversed: false,
        })
    }

    /// Whether the run has nothing to move (methods 35 and 37).
    pub fn is_immediate(&self) -> bool {
        self.legs.is_empty()
    }

    /// Advance with the actual position moving from `from` to `to`. `at_leg_speed` says
    /// whether the axis has slowed to the leg's speed: an edge found faster than that
    /// would be imprecise, so it only counts at leg speed.
    pub fn step(&mut self, world: &World, from: f64, to: f64, at_leg_speed: bool) -> HomingStep {
        let Some(leg) = self.legs.get(self.current).copied() else {
            return HomingStep::Found { world: to };
        };
        if (to - from) * f64::from(self.direction) <= 0.0 {
            // Still braking from the previous leg: edges only count in the leg's direction.
            return HomingStep::Moving {
                direction: self.direction,
                fast: leg.fast,
            };
        }
        let after = world.sensors(to);
        let edge = if at_leg_speed {
            edge_between(leg.until, world, from, to)
        } else {
            None
        };
        if let Some(at) = edge {
            self.current += 1;
            self.reversed = false;
            return match self.legs.get(self.current) {
                Some(next) => {
                    self.direction = next.direction;
                    HomingStep::Moving {
                        direction: next.direction,
                        fast: next.fast,
                    }
                }
                None => HomingStep::Found { world: at },
            };
        }
        // A limit switch in the direction of travel that this leg is not looking for.
        let blocked = match self.direction {
            d if d < 0 => after.negative_limit && !matches!(leg.until, Until::NegativeLimit(_)),
            _ => after.positive_limit && !matches!(leg.until, Until::PositiveLimit(_)),
        };
        if blocked {
            if leg.may_reverse && !self.reversed {
                self.reversed = true;
                self.direction = -self.direction;
            } else {
                return HomingStep::Failed;
            }
        }
        HomingStep::Moving {
            direction: self.direction,
            fast: leg.fast,
        }
    }

    pub fn direction(&self) -> i8 {
        self.direction
    }

    pub fn leg_is_fast(&self) -> bool {
        self.legs.get(self.current).is_some_and(|l| l.fast)
    }
}

/// Where the axis moving from `from` to `to` passes the edge a leg looks for, if it does.
fn edge_between(until: Until, world: &World, from: f64, to: f64) -> Option<f64> {
    let before = world.sensors(from);
    let after = world.sensors(to);
    match until {
        Until::Index => world.index_between(from, to),
        Until::Home(want) => (before.home != want && after.home == want).then_some({
            // The cam edge crossed, exactly.
            if (to > from) == want {
                world.home_start
            } else {
                world.home_end
            }
        }),
        Until::NegativeLimit(want) => (before.negative_limit != want
            && after.negative_limit == want)
            .then_some(world.negative_limit),
        Until::PositiveLimit(want) => (before.positive_limit != want
            && after.positive_limit == want)
            .then_some(world.positive_limit),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Drive a run with a perfect axis: constant speed steps.
    fn run(method: i8, start: f64) -> (Option<f64>, Vec<i8>) {
        let world = World::default();
        let mut run = HomingRun::new(method, world.sensors(start)).unwrap();
        if run.is_immediate() {
            return (Some(start), vec![]);
        }
        let mut x = start;
        let mut dirs = vec![run.direction()];
        for _ in 0..1_000_000 {
            let speed = if run.leg_is_fast() { 50.0 } else { 5.0 };
            let next = x + f64::from(run.direction()) * speed;
            match run.step(&world, x, next, true) {
                HomingStep::Moving { direction, .. } => {
                    if dirs.last() != Some(&direction) {
                        dirs.push(direction);
                    }
                }
                HomingStep::Found { world } => return (Some(world), dirs),
                HomingStep::Failed => return (None, dirs),
            }
            x = next;
        }
        panic!("homing never ended");
    }

    #[test]
    fn limit_switch_methods_home_on_the_switch_edge() {
        assert_eq!(run(17, 0.0).0, Some(-36_000.0));
        assert_eq!(run(18, 0.0).0, Some(36_000.0));
    }

    #[test]
    fn home_switch_methods_find_the_same_edge_from_either_side() {
        for start in [0.0, 9_500.0, 20_000.0] {
            assert_eq!(run(19, start).0, Some(9_000.0), "19 from {start}");
            assert_eq!(run(20, start).0, Some(9_000.0), "20 from {start}");
            assert_eq!(run(21, start).0, Some(9_900.0), "21 from {start}");
            assert_eq!(run(22, start).0, Some(9_900.0), "22 from {start}");
        }
        // From the right of the cam, method 19 first runs into the positive limit and turns.
        let (_, dirs) = run(19, 20_000.0);
        assert_eq!(dirs[..2], [1, -1]);
    }

    #[test]
    fn index_methods_stop_on_the_next_pulse() {
        assert_eq!(run(34, 0.0).0, Some(450.0));
        assert_eq!(run(33, 0.0).0, Some(-3_150.0));
    }

    #[test]
    fn current_position_methods_are_immediate_and_others_unsupported() {
        assert_eq!(run(37, 123.0).0, Some(123.0));
        assert!(
            HomingRun::new(35, Sensors::default())
                .unwrap()
                .is_immediate()
        );
        for m in [-1, 0, 1, 16, 23, 36, 38, 127] {
            assert!(HomingRun::new(m, Sensors::default()).is_none(), "{m}");
        }
    }
}
