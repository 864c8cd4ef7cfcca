//! Closed loop: the simulated drive's cascaded controller on a motor model, tuned by the
//! gains of 3210h (protocol notes §4.2.1), so that a technician can tune it and see the
//! effect the way a real drive shows it.
//!
//! * Position loop: P (3210h:01) and I (:02) on the position error, plus velocity feed
//!   forward (:0B, ‰ of the demand's velocity) — gives the velocity set point.
//! * Velocity loop: PI (:03, :04) on the velocity error, plus acceleration feed forward
//!   (:0C, ‰ of the torque the demand's acceleration takes) — gives the current set
//!   point, clamped to the current limit (6073h, ‰ of the rated current) with the
//!   integrator held while clamped (anti-windup). The velocity it controls is measured
//!   through a first-order filter (as a drive derives it from encoder counts).
//! * Current loop: PI (:07, :08) on an R–L winding, run 16 times per step (16 kHz); the
//!   current is the torque (‰ of rated current = ‰ of rated torque).
//! * Mechanics: the motor's and the load's inertia, viscous and Coulomb friction, and a
//!   load torque (gravity), from [`Load`].
//!
//! The position and velocity loops run once per simulation step (1 kHz). The manuals give
//! neither units nor rates for 3210h: the scales below are drivedeck's own [L], chosen so
//! that the factory values give a well-damped response (velocity loop ≈ 20 Hz, position
//! loop 30/s, current loop ≈ 1 kHz) and so that the direction of every change is the one
//! a real cascade shows: more velocity gain rises faster and overshoots more until it
//! rings, less rises slower; more position gain follows the profile more closely.

use super::{COULOMB, STANDSTILL, TORQUE_GAIN, acceleration};
use crate::sim::dictionary::Dictionary;
use crate::sim::world::Load;

/// Position loop P per raw unit of 3210h:01, 1/s (factory 2048 → 30/s).
const POS_P: f64 = 30.0 / 2048.0;
/// Position loop I per raw unit of 3210h:02, 1/s² (factory 0).
const POS_I: f64 = 0.5;
/// Velocity loop P per raw unit of 3210h:03, ‰ per units/s (factory 12000 → a 20 Hz loop
/// on the motor alone).
const VEL_P: f64 = std::f64::consts::TAU * 20.0 / TORQUE_GAIN / 12000.0;
/// Velocity loop I per raw unit of 3210h:04, ‰ per unit (factory 30 → the PI's zero at a
/// tenth of the loop's crossover).
const VEL_I: f64 = VEL_P * 12000.0 * std::f64::consts::TAU * 20.0 / 10.0 / 30.0;
/// The winding's time constant L/R, s.
const WINDING: f64 = 0.001;
/// Current loop P per raw unit of 3210h:07 (factory 8920800 → a 1 kHz loop).
const CUR_P: f64 = std::f64::consts::TAU * 1000.0 * WINDING / 8_920_800.0;
/// Current loop I per raw unit of 3210h:08, 1/s (factory 509760 → the PI's zero on the
/// winding's pole, R/L).
const CUR_I: f64 = 1.0 / WINDING / 509_760.0;
/// Current loop steps per simulation step.
const CURRENT_STEPS: u32 = 16;
/// The supply limits the winding's voltage: in ‰ of what drives the rated current.
const VOLTAGE_LIMIT: f64 = 4000.0;
/// The velocity measurement's filter time constant, s.
const VELOCITY_FILTER: f64 = 0.002;

/// The controller's parameters, read from the dictionary in physical units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    pub position_p: f64,
    pub position_i: f64,
    pub velocity_p: f64,
    pub velocity_i: f64,
    pub current_p: f64,
    pub current_i: f64,
    pub velocity_feed_forward: f64,
    pub acceleration_feed_forward: f64,
    /// ‰ of the rated current.
    pub current_limit: f64,
}

impl Gains {
    pub fn read(od: &Dictionary) -> Gains {
        let raw = |sub| od.int(0x3210, sub) as f64;
        Gains {
            position_p: raw(1) * POS_P,
            position_i: raw(2) * POS_I,
            velocity_p: raw(3) * VEL_P,
            velocity_i: raw(4) * VEL_I,
            current_p: raw(7) * CUR_P,
            current_i: raw(8) * CUR_I,
            velocity_feed_forward: raw(0x0B) / 1000.0,
            acceleration_feed_forward: raw(0x0C) / 1000.0,
            current_limit: current_limit(od),
        }
    }
}

/// 6073h in ‰ of the rated current, no higher than 2031h allows (6073h × 203Bh:01 / 1000
/// is the limit in mA, itself limited by 2031h).
fn current_limit(od: &Dictionary) -> f64 {
    let max_current = od.int(0x6073, 0).max(0) as f64;
    let rated = od.int(0x203B, 1) as f64;
    let motor_max = od.int(0x2031, 0) as f64;
    if rated > 0.0 && motor_max > 0.0 {
        max_current.min(motor_max / rated * 1000.0)
    } else {
        max_current
    }
}

/// What the demand asks of the loop in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Want {
    /// units
    pub position: f64,
    /// units/s
    pub velocity: f64,
    /// units/s²
    pub acceleration: f64,
    /// The position loop runs (profile position, homing, standstill); off, the velocity
    /// loop follows the demand's velocity alone (profile velocity).
    pub position_loop: bool,
}

/// The controller's and the winding's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Servo {
    position_integral: f64,
    velocity_integral: f64,
    current_integral: f64,
    /// The winding's current, ‰ of rated.
    current: f64,
    /// The filtered velocity the loop sees, units/s.
    measured_velocity: f64,
    /// The position the loop sees, units.
    measured_position: f64,
    /// The current set point clamped at the limit in the last step.
    pub saturated: bool,
}

impl Servo {
    /// A loop taking over a load at `x`, at rest or moving at `v`.
    pub fn starting_at(x: f64, v: f64) -> Servo {
        Servo {
            measured_velocity: v,
            measured_position: x,
            ..Servo::default()
        }
    }

    /// The winding's current, ‰ of rated: the motor's torque.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// One step of `dt` s: the loops act on the load at `x`, `v` (moved in place).
    pub fn step(
        &mut self,
        gains: &Gains,
        load: &Load,
        want: Want,
        x: &mut f64,
        v: &mut f64,
        dt: f64,
    ) {
        // Position loop (on the position measured at the last step: one step's delay).
        let velocity_set = if want.position_loop {
            let position_error = want.position - self.measured_position;
            self.position_integral += position_error * dt;
            let correction =
                gains.position_p * position_error + gains.position_i * self.position_integral;
            // Far off, no faster than the motor can still stop from on the error left (at
            // most 80 % of what the current limit accelerates): else a large error, after
            // a quick stop steeper than the motor brakes, swings to and fro for seconds.
            let braking = 0.8 * TORQUE_GAIN * gains.current_limit / load.inertia_factor();
            let stoppable = (2.0 * braking * position_error.abs()).sqrt();
            gains.velocity_feed_forward * want.velocity + correction.clamp(-stoppable, stoppable)
        } else {
            self.position_integral = 0.0;
            want.velocity
        };
        // Velocity loop, on the filtered measurement of the last step.
        let velocity_error = velocity_set - self.measured_velocity;
        let feed_forward = gains.acceleration_feed_forward * want.acceleration / TORQUE_GAIN
            * load.inertia_factor();
        let unclamped = gains.velocity_p * velocity_error
            + gains.velocity_i * (self.velocity_integral + velocity_error * dt)
            + feed_forward;
        let limit = gains.current_limit;
        self.saturated = unclamped.abs() > limit;
        if !self.saturated || unclamped.signum() != velocity_error.signum() {
            self.velocity_integral += velocity_error * dt;
        }
        let current_set = unclamped.clamp(-limit, limit);
        // Current loop and mechanics, 16 kHz.
        let h = dt / f64::from(CURRENT_STEPS);
        for _ in 0..CURRENT_STEPS {
            let current_error = current_set - self.current;
            let voltage = (gains.current_p * current_error
                + gains.current_i * gains.current_p * (self.current_integral + current_error * h))
                .clamp(-VOLTAGE_LIMIT, VOLTAGE_LIMIT);
            if voltage.abs() < VOLTAGE_LIMIT {
                self.current_integral += current_error * h;
            }
            // L di/dt = u − R·i, with R = 1 and L = WINDING.
            self.current += (voltage - self.current) * h / WINDING;
            let torque = self.current;
            if v.abs() < STANDSTILL && !load.breaks_away(torque, COULOMB) {
                // Static friction holds the motor.
                *v = 0.0;
                continue;
            }
            let v_new = *v + acceleration(load, torque, *v) * h;
            *x += 0.5 * (*v + v_new) * h;
            *v = v_new;
        }
        // Measured now, used in the next step.
        let alpha = dt / (VELOCITY_FILTER + dt);
        self.measured_velocity += alpha * (*v - self.measured_velocity);
        self.measured_position = *x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factory's raw gains (3210h:01–0C).
    const FACTORY: [f64; 12] = [
        2048.0, 0.0, 12000.0, 30.0, 8920800.0, 509760.0, 8920800.0, 509760.0, 0.0, 0.0, 1000.0, 0.0,
    ];

    fn gains(velocity_p: f64, position_p: f64) -> Gains {
        Gains {
            position_p: FACTORY[0] * POS_P * position_p,
            position_i: 0.0,
            velocity_p: FACTORY[2] * VEL_P * velocity_p,
            velocity_i: FACTORY[3] * VEL_I,
            current_p: FACTORY[6] * CUR_P,
            current_i: FACTORY[7] * CUR_I,
            velocity_feed_forward: 1.0,
            acceleration_feed_forward: 0.0,
            current_limit: 3000.0,
        }
    }

    /// A velocity step of `to` units/s (the position demand follows it): the velocity's
    /// trace every ms for `seconds`.
    fn velocity_step(
        gains: &Gains,
        load: &Load,
        to: f64,
        seconds: f64,
        position_loop: bool,
    ) -> Vec<f64> {
        let mut servo = Servo::default();
        let (mut x, mut v) = (0.0, 0.0);
        let dt = 0.001;
        let mut trace = vec![];
        for k in 0..(seconds / dt) as usize {
            let want = Want {
                position: to * k as f64 * dt,
                velocity: to,
                acceleration: 0.0,
                position_loop,
            };
            servo.step(gains, load, want, &mut x, &mut v, dt);
            trace.push(v);
        }
        trace
    }

    /// (10–90 % rise time in s, overshoot in %, zero crossings of the error after the peak)
    fn figures(trace: &[f64], to: f64) -> (f64, f64, usize) {
        let at = |f: f64| {
            trace
                .iter()
                .position(|v| *v >= f * to)
                .unwrap_or(trace.len())
        };
        let rise = (at(0.9) - at(0.1)) as f64 * 0.001;
        let peak = trace.iter().cloned().fold(f64::MIN, f64::max);
        let overshoot = (peak - to) / to * 100.0;
        let tail = &trace[at(1.0).min(trace.len() - 1)..];
        let crossings = tail
            .windows(2)
            .filter(|w| (w[0] - to).signum() != (w[1] - to).signum())
            .count();
        (rise, overshoot, crossings)
    }

    fn step_figures(velocity_gain: f64, to: f64) -> (f64, f64, usize) {
        let trace = velocity_step(&gains(velocity_gain, 1.0), &Load::default(), to, 1.0, false);
        figures(&trace, to)
    }

    #[test]
    fn more_velocity_gain_rises_faster_and_overshoots_more_until_it_rings() {
        // A small step (1 rpm), the loop unsaturated.
        let (rise, overshoot, crossings) = step_figures(1.0, 60.0);
        assert!(
            overshoot < 5.0 && crossings <= 1,
            "{overshoot} % {crossings}"
        );
        let (rise_x4, overshoot_x4, _) = step_figures(4.0, 60.0);
        assert!(rise_x4 < rise, "{rise_x4} s against {rise} s");
        assert!(
            overshoot_x4 > overshoot + 20.0,
            "{overshoot_x4} % against {overshoot} %"
        );
        let (_, overshoot_x16, crossings_x16) = step_figures(16.0, 60.0);
        assert!(overshoot_x16 > overshoot_x4, "{overshoot_x16} %");
        assert!(crossings_x16 >= 5, "it rings: {crossings_x16} crossings");
    }

    #[test]
    fn less_velocity_gain_rises_slower() {
        let (rise, _, _) = step_figures(1.0, 60.0);
        let (rise_low, _, _) = step_figures(0.25, 60.0);
        assert!(rise_low > 2.0 * rise, "{rise_low} s against {rise} s");
    }

    /// Peak position error following a trapezoidal move of 2000 units at 12000 units/s,
    /// 30000 units/s² (300 rpm, 500 rpm/s).
    fn move_error(position_gain: f64, load: &Load) -> f64 {
        let gains = gains(1.0, position_gain);
        let mut servo = Servo::default();
        let mut demand = crate::sim::motion::Demand::default();
        let (mut x, mut v, mut peak) = (0.0, 0.0, 0.0f64);
        for _ in 0..1500 {
            let before = demand;
            crate::sim::motion::step_position(
                &mut demand,
                2000.0,
                12000.0,
                30000.0,
                30000.0,
                0.001,
            );
            let want = Want {
                position: demand.position,
                velocity: demand.velocity,
                acceleration: (demand.velocity - before.velocity) / 0.001,
                position_loop: true,
            };
            servo.step(&gains, load, want, &mut x, &mut v, 0.001);
            peak = peak.max((demand.position - x).abs());
        }
        assert!((x - 2000.0).abs() < 1.0, "it arrives: {x}");
        peak
    }

    #[test]
    fn more_position_gain_follows_the_profile_more_closely() {
        let factory = move_error(1.0, &Load::default());
        let more = move_error(2.0, &Load::default());
        let less = move_error(0.5, &Load::default());
        assert!(
            more < factory && factory < less,
            "{more} < {factory} < {less}"
        );
    }

    #[test]
    fn a_heavier_load_follows_less_closely() {
        let alone = move_error(1.0, &Load::default());
        let heavy = move_error(
            1.0,
            &Load {
                inertia: 4.0,
                torque: 0.0,
            },
        );
        assert!(heavy > 2.0 * alone, "{heavy} against {alone}");
    }
}
