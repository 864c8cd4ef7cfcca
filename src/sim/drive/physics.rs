//! Time: the motor, its load and the target conditions, stepped in 1 ms.

use std::time::Duration;

use super::servo::{Gains, Servo, Want};
use super::{
    AUTO_SETUP_TIME, Activity, COULOMB, DAMPING, Drive, LOAD_LAG, STANDSTILL, STEP, TORQUE_GAIN,
    acceleration, sign,
};
use crate::cia::{AbortCode, ErrorCode, PowerState};
use crate::injection::Injection;
use crate::sim::dictionary::Dictionary;
use crate::sim::homing::{HomingRun, HomingStep};
use crate::sim::motion::{Demand, rpm_to_units, step_position, step_velocity, units_to_rpm};
use crate::sim::world::Sensors;

impl Drive {
    /// Advance simulated time.
    pub fn tick(&mut self, dt: Duration) {
        let mut left = dt;
        while !left.is_zero() {
            let step = left.min(STEP);
            self.step(step.as_secs_f64());
            self.time += step;
            self.step_nanoj();
            left -= step;
            self.finish_reboot();
        }
        self.publish();
    }

    fn step(&mut self, dt: f64) {
        let x_before = self.x;
        let demand_before = self.demand;
        let torque_controlled = match self.state {
            PowerState::OperationEnabled => self.step_activity(dt),
            PowerState::QuickStopActive => {
                self.step_quick_stop(dt);
                false
            }
            _ => false,
        };
        let energised = matches!(
            self.state,
            PowerState::OperationEnabled | PowerState::QuickStopActive
        );
        self.move_load(torque_controlled, energised, demand_before, dt);
        if !torque_controlled {
            self.torque = match &self.servo {
                Some(servo) => servo.current(),
                None if energised => self.demand_torque(demand_before.velocity, dt),
                None => 0.0,
            };
        }
        self.after_step(x_before, dt);
    }

    /// The running activity's demand, one step on; true when torque moves the load.
    fn step_activity(&mut self, dt: f64) -> bool {
        let acc = rpm_to_units(self.od.int(0x6083, 0) as f64);
        let dec = rpm_to_units(self.od.int(0x6084, 0) as f64);
        let quick = rpm_to_units(self.od.int(0x6085, 0) as f64);
        let mut torque_controlled = false;
        let mut activity = std::mem::replace(&mut self.activity, Activity::Idle);
        match &mut activity {
            Activity::Idle => step_velocity(&mut self.demand, 0.0, acc, dec, dt),
            _ if self.limit_stop => {
                step_velocity(&mut self.demand, 0.0, quick, quick, dt);
            }
            Activity::Position { .. } | Activity::Velocity { .. } | Activity::Torque { .. }
                if self.halted =>
            {
                step_velocity(&mut self.demand, 0.0, acc, dec, dt);
            }
            Activity::Position { target, speed_rpm } => {
                let world_target = *target as f64 + self.offset;
                let speed = rpm_to_units(*speed_rpm);
                step_position(&mut self.demand, world_target, speed, acc, dec, dt);
            }
            Activity::Velocity { speed_rpm } => {
                step_velocity(&mut self.demand, rpm_to_units(*speed_rpm), acc, dec, dt);
            }
            Activity::Torque {
                torque,
                max_speed_rpm,
            } => {
                torque_controlled = true;
                self.ramp_torque(*torque, dt);
                self.torque_physics(rpm_to_units(*max_speed_rpm), dt);
            }
            Activity::Homing { run, found } => {
                let homing_acc = rpm_to_units(self.od.int(0x609A, 0) as f64);
                let wanted = match found {
                    Some(_) => 0.0,
                    None => f64::from(run.direction()) * leg_speed(&self.od, run),
                };
                step_velocity(&mut self.demand, wanted, homing_acc, homing_acc, dt);
            }
            Activity::AutoSetup { elapsed, centre } => self.wiggle(elapsed, *centre, dt),
        }
        self.activity = activity;
        torque_controlled
    }

    /// Quick stop: brake to standstill, then switch off when the option code says so.
    fn step_quick_stop(&mut self, dt: f64) {
        let dec = rpm_to_units(self.od.int(0x6084, 0) as f64);
        let (decel, switch_off) = self.quick_stop.unwrap_or((dec, false));
        step_velocity(&mut self.demand, 0.0, decel, decel, dt);
        if self.demand.velocity == 0.0 && self.v.abs() < STANDSTILL && switch_off {
            self.state = PowerState::SwitchOnDisabled;
            self.quick_stop = None;
        }
    }

    /// Profile Torque: the torque demand ramps towards `torque` at the slope 6087h.
    fn ramp_torque(&mut self, torque: f64, dt: f64) {
        let slope = self.od.int(0x6087, 0) as f64;
        let step = slope * dt;
        self.torque_demand = if (torque - self.torque_demand).abs() <= step {
            torque
        } else {
            self.torque_demand + step.copysign(torque - self.torque_demand)
        };
    }

    /// Auto setup: a visible wiggle, the motor turns ±30° while it identifies itself and
    /// stands still again at the end.
    fn wiggle(&mut self, elapsed: &mut Duration, centre: f64, dt: f64) {
        *elapsed += Duration::from_secs_f64(dt);
        let t = elapsed.as_secs_f64().min(AUTO_SETUP_TIME.as_secs_f64());
        let next = centre
            + 300.0 * (std::f64::consts::TAU * t / AUTO_SETUP_TIME.as_secs_f64() * 4.0).sin();
        self.demand.velocity = (next - self.demand.position) / dt;
        self.demand.position = next;
    }

    /// The load, one step on: held by an injected following error, moved by the torque
    /// already (`torque_controlled`), by the closed loop (3202h bit 0), following the
    /// demand (open loop), or coasting unpowered.
    fn move_load(&mut self, torque_controlled: bool, energised: bool, before: Demand, dt: f64) {
        let closed_loop = energised && !torque_controlled && self.closed_loop();
        if !closed_loop {
            self.servo = None;
        }
        if self.injected.contains(&Injection::FollowingError) {
            self.v = 0.0;
        } else if torque_controlled {
            // torque_physics moved x and v already.
        } else if closed_loop {
            self.close_the_loop(before, dt);
        } else if energised {
            self.follow_demand(before.position, dt);
        } else {
            // Coasting with the power stage off.
            self.v *= (-dt / 0.15).exp();
            if self.v.abs() < STANDSTILL {
                self.v = 0.0;
            }
            self.x += self.v * dt;
            self.demand = Demand {
                position: self.x,
                velocity: self.v,
            };
        }
    }

    /// The load follows the demand with a first-order lag, solved exactly over the step
    /// (so the result does not depend on how time is cut into steps): e = demand − x obeys
    /// de/dt = v_demand − e/τ, and the load's speed is e/τ.
    fn follow_demand(&mut self, demand_position_before: f64, dt: f64) {
        let v_demand = (self.demand.position - demand_position_before) / dt;
        let e0 = demand_position_before - self.x;
        let decay = (-dt / LOAD_LAG).exp();
        let mut e = v_demand * LOAD_LAG + (e0 - v_demand * LOAD_LAG) * decay;
        if self.demand.velocity == 0.0 && e.abs() < 0.01 {
            // Settled: the load stands on the demand.
            e = 0.0;
        }
        self.x = self.demand.position - e;
        self.v = e / LOAD_LAG;
    }

    /// Whether the cascade runs: closed loop chosen (3202h bit 0) and the motor measured
    /// by an auto setup, which the firmware needs before it can close the loop. Until
    /// then the load follows the demand as in open loop.
    pub(super) fn closed_loop(&self) -> bool {
        self.od.int(0x3202, 0) & 1 == 1 && self.autosetup_done
    }

    /// Closed loop: the cascade with 3210h's gains moves the load towards the demand.
    fn close_the_loop(&mut self, before: Demand, dt: f64) {
        let want = Want {
            position: self.demand.position,
            velocity: self.demand.velocity,
            acceleration: (self.demand.velocity - before.velocity) / dt,
            position_loop: !matches!(self.activity, Activity::Velocity { .. }) || self.halted,
        };
        let gains = Gains::read(&self.od);
        let (x, v) = (self.x, self.v);
        let servo = self.servo.get_or_insert_with(|| Servo::starting_at(x, v));
        servo.step(&gains, &self.world.load, want, &mut self.x, &mut self.v, dt);
    }

    /// The torque it takes to drive the demand's acceleration against friction.
    fn demand_torque(&self, demand_velocity_before: f64, dt: f64) -> f64 {
        let accel = (self.demand.velocity - demand_velocity_before) / dt;
        ((accel + DAMPING * self.v) / TORQUE_GAIN + COULOMB * sign(self.v)).clamp(-3000.0, 3000.0)
    }

    fn torque_physics(&mut self, max_speed: f64, dt: f64) {
        let load = self.world.load;
        let mut accel = acceleration(&load, self.torque_demand, self.v);
        if self.v.abs() < STANDSTILL && !load.breaks_away(self.torque_demand, COULOMB) {
            accel = 0.0;
            self.v = 0.0;
        }
        let mut v_new = self.v + accel * dt;
        if v_new.abs() > max_speed {
            // The speed limit of Profile Torque: the drive holds the set maximum speed.
            v_new = max_speed.copysign(v_new);
        }
        self.x += 0.5 * (self.v + v_new) * dt;
        self.v = v_new;
        self.torque = self.torque_demand;
        self.demand = Demand {
            position: self.x,
            velocity: self.v,
        };
    }

    fn after_step(&mut self, x_before: f64, dt: f64) {
        let sensors = self.switches();
        let step = Duration::from_secs_f64(dt);
        if matches!(self.activity, Activity::Homing { .. }) {
            self.step_homing(x_before);
        } else if let Activity::AutoSetup { elapsed, .. } = self.activity
            && elapsed >= AUTO_SETUP_TIME
        {
            self.autosetup_done = true;
            self.activity = Activity::Idle;
            self.set_mode(0);
        }
        self.stop_at_limits(sensors);
        self.watch_following_error(step);
        // Target window timing.
        if self.target_condition() {
            self.in_window_for += step;
        } else {
            self.in_window_for = Duration::ZERO;
        }
    }

    /// Homing legs and the home point.
    fn step_homing(&mut self, x_before: f64) {
        if let Activity::Homing { run, found } = &mut self.activity {
            let at_leg_speed = self.v.abs() <= leg_speed(&self.od, run) * 1.1 + STANDSTILL;
            if found.is_none() {
                match run.step(&self.world, x_before, self.x, at_leg_speed) {
                    HomingStep::Moving { .. } => {}
                    HomingStep::Found { world } => {
                        *found = Some(world);
                    }
                    HomingStep::Failed => {
                        // Both limit switches met: the home switch is not where the
                        // method looks. The command fails with PdiStatusError.
                        self.activity = Activity::Idle;
                        self.refuse(AbortCode::GENERAL_ERROR);
                    }
                }
            }
        }
        if let Activity::Homing {
            found: Some(world), ..
        } = self.activity
            && self.demand.velocity == 0.0
        {
            self.home_at(world);
            self.homing_done = true;
            self.activity = Activity::Idle;
            self.demand.position = self.x;
        }
    }

    /// Limit switches stop travel into them (homing handles them itself).
    fn stop_at_limits(&mut self, sensors: Sensors) {
        if self.state != PowerState::OperationEnabled
            || matches!(self.activity, Activity::Homing { .. })
        {
            return;
        }
        let into_negative = sensors.negative_limit && self.demand.velocity < 0.0;
        let into_positive = sensors.positive_limit && self.demand.velocity > 0.0;
        if into_negative || into_positive {
            self.limit_stop = true;
            // Auto setup cannot finish against a limit switch: the drive gives it up
            // with PdiStatusError instead of standing there until the master times out.
            if matches!(self.activity, Activity::AutoSetup { .. }) {
                self.activity = Activity::Idle;
                self.refuse(AbortCode::DEVICE_STATE);
            }
        }
    }

    /// Following error: the demand against the load, beyond 6065h for longer than 6066h.
    fn watch_following_error(&mut self, step: Duration) {
        let position_control = self.state == PowerState::OperationEnabled
            && !matches!(self.activity, Activity::Torque { .. });
        let deviation = if position_control {
            self.demand.position - self.x
        } else {
            0.0
        };
        let window = self.od.int(0x6065, 0) as f64;
        let timeout = Duration::from_millis(self.od.int(0x6066, 0).max(0) as u64);
        if position_control && deviation.abs() > window {
            self.following_error_for += step;
            if self.following_error_for > timeout && !self.following_error {
                self.following_error = true;
                let reaction = self.od.int(0x3700, 0);
                if reaction >= 0 {
                    self.raise_fault(ErrorCode::FOLLOWING_ERROR, 13, 0x21);
                } else {
                    self.warning = Some(ErrorCode::FOLLOWING_ERROR);
                    self.record_history(ErrorCode::FOLLOWING_ERROR, 13, 0x21);
                }
            }
        } else {
            self.following_error_for = Duration::ZERO;
            if self.following_error && !matches!(self.state, PowerState::Fault) {
                self.following_error = false;
                if self.warning == Some(ErrorCode::FOLLOWING_ERROR) {
                    self.warning = None;
                }
            }
        }
    }

    /// Whether the mode's target condition holds right now (before the window time).
    fn target_condition(&self) -> bool {
        let standstill = self.v.abs() < STANDSTILL && self.demand.velocity == 0.0;
        match self.state {
            PowerState::QuickStopActive => return standstill,
            PowerState::OperationEnabled => {}
            _ => return false,
        }
        if self.halted {
            return standstill;
        }
        match &self.activity {
            Activity::Position { target, .. } => {
                let window = self.od.int(0x6067, 0) as f64;
                !self.limit_stop
                    && (self.position() - *target as f64).abs() <= window
                    && self.demand.velocity == 0.0
            }
            Activity::Velocity { speed_rpm } => {
                let window = self.od.int(0x606D, 0) as f64;
                let wanted = if self.limit_stop { 0.0 } else { *speed_rpm };
                (units_to_rpm(self.v) - wanted).abs() <= window
            }
            Activity::Torque { torque, .. } => (self.torque - *torque).abs() <= 10.0,
            Activity::Homing { .. } | Activity::AutoSetup { .. } => false,
            Activity::Idle => self.homing_done && standstill && self.od.int(0x6061, 0) == 6,
        }
    }

    pub(super) fn target_reached(&self) -> bool {
        let window_time = match &self.activity {
            Activity::Velocity { .. } | Activity::Torque { .. } => self.od.int(0x606E, 0),
            _ => self.od.int(0x6068, 0),
        };
        self.target_condition()
            && self.in_window_for >= Duration::from_millis(window_time.max(0) as u64)
    }
}

/// The speed of the homing run's current leg: 6099h:01 (fast) or 6099h:02 (slow).
fn leg_speed(od: &Dictionary, run: &HomingRun) -> f64 {
    let fast = rpm_to_units(od.int(0x6099, 1) as f64);
    let slow = rpm_to_units(od.int(0x6099, 2) as f64);
    if run.leg_is_fast() { fast } else { slow }
}
