//! Motion profiles of the simulated drive, in user units (tenths of a degree) and seconds.
//!
//! The profile generator moves a *demand* (position and velocity); the load model in
//! `drive.rs` makes the actual position follow it. Factory units: position in 0.1°,
//! speed in rpm, acceleration in rpm/s. One revolution is 3600 units, so 1 rpm is
//! 60 units/s and 1 rpm/s is 60 units/s².

/// Units per second per rpm.
pub const UNITS_PER_S_PER_RPM: f64 = 60.0;

/// The profile generator's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Demand {
    /// units
    pub position: f64,
    /// units/s
    pub velocity: f64,
}

pub fn rpm_to_units(rpm: f64) -> f64 {
    rpm * UNITS_PER_S_PER_RPM
}

pub fn units_to_rpm(units_per_s: f64) -> f64 {
    units_per_s / UNITS_PER_S_PER_RPM
}

/// Move `current` toward `target` by at most `max_step`.
fn approach(current: f64, target: f64, max_step: f64) -> f64 {
    if (target - current).abs() <= max_step {
        target
    } else {
        current + max_step.copysign(target - current)
    }
}

/// One step of a trapezoidal point-to-point profile (Profile Position). Accelerates with
/// `acc` up to `v_max`, brakes with `dec` so that it stops on `target`; a move started at
/// speed, or toward a new target, blends without a jump in velocity. Returns true once the
/// demand stands on the target.
pub fn step_position(d: &mut Demand, target: f64, v_max: f64, acc: f64, dec: f64, dt: f64) -> bool {
    let v_max = v_max.abs().max(0.0);
    let (acc, dec) = (acc.max(1e-6), dec.max(1e-6));
    let remaining = target - d.position;
    if remaining.abs() < 1e-6 && d.velocity.abs() <= dec * dt {
        d.position = target;
        d.velocity = 0.0;
        return true;
    }
    // The fastest speed at the end of this step from which the demand can still stop on
    // the target: v²/2·dec + (v0 + v)/2·dt = remaining, solved for v (the discrete form of
    // v = √(2·dec·d), so the demand lands without overshoot).
    let toward = d.velocity * remaining.signum();
    let disc = dec * dec * dt * dt - 4.0 * (dec * dt * toward - 2.0 * dec * remaining.abs());
    let braking_speed = if disc > 0.0 {
        ((-dec * dt + disc.sqrt()) / 2.0).max(0.0)
    } else {
        0.0
    };
    let wanted = braking_speed.min(v_max).copysign(remaining);
    let speeding_up = wanted.abs() > d.velocity.abs() && wanted.signum() == d.velocity.signum();
    let from_rest = d.velocity == 0.0;
    let rate = if speeding_up || from_rest { acc } else { dec };
    let v_new = approach(d.velocity, wanted, rate * dt);
    let step = 0.5 * (d.velocity + v_new) * dt;
    // Landing within this step: stand on the target.
    if step.abs() >= remaining.abs()
        && step.signum() == remaining.signum()
        && v_new.abs() <= (dec * dt).max(braking_speed)
    {
        d.position = target;
        d.velocity = 0.0;
        return true;
    }
    d.position += step;
    d.velocity = v_new;
    false
}

/// One step of a velocity ramp (Profile Velocity, halt and quick stop): toward `v_target`
/// with `acc` when speeding up and `dec` when slowing down.
pub fn step_velocity(d: &mut Demand, v_target: f64, acc: f64, dec: f64, dt: f64) {
    let speeding_up = v_target.abs() > d.velocity.abs()
        && (d.velocity == 0.0 || v_target.signum() == d.velocity.signum());
    let rate = if speeding_up { acc } else { dec };
    let v_new = approach(d.velocity, v_target, rate.max(1e-6) * dt);
    d.position += 0.5 * (d.velocity + v_new) * dt;
    d.velocity = v_new;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_move(start: f64, target: f64, v_max: f64, acc: f64) -> (f64, f64, usize) {
        let mut d = Demand {
            position: start,
            velocity: 0.0,
        };
        let dt = 0.001;
        let mut peak: f64 = 0.0;
        for step in 0..1_000_000 {
            if step_position(&mut d, target, v_max, acc, acc, dt) {
                return (d.position, peak, step);
            }
            peak = peak.max(d.velocity.abs());
        }
        panic!("never arrived");
    }

    #[test]
    fn a_long_move_cruises_at_the_set_speed_and_lands_exactly() {
        // 2000 units at 200 rpm (12000 units/s), 500 rpm/s (30000 units/s²).
        let (end, peak, steps) = run_move(0.0, 20000.0, rpm_to_units(200.0), rpm_to_units(500.0));
        assert_eq!(end, 20000.0);
        assert!((peak - 12000.0).abs() < 1.0, "{peak}");
        // 0.4 s up, 0.4 s down, cruise (20000 - 4800) / 12000 = 1.27 s.
        let t = steps as f64 * 0.001;
        assert!((t - 2.067).abs() < 0.02, "{t}");
    }

    #[test]
    fn a_short_move_is_triangular() {
        let (end, peak, _) = run_move(0.0, -2000.0, rpm_to_units(200.0), rpm_to_units(500.0));
        assert_eq!(end, -2000.0);
        assert!(peak < 12000.0 && peak > 7000.0, "{peak}");
    }

    #[test]
    fn a_new_target_behind_the_motor_brakes_first() {
        let mut d = Demand {
            position: 0.0,
            velocity: 6000.0,
        };
        let mut min_pos = 0.0f64;
        let mut max_pos = 0.0f64;
        for _ in 0..100_000 {
            if step_position(&mut d, -100.0, 6000.0, 30000.0, 30000.0, 0.001) {
                break;
            }
            min_pos = min_pos.min(d.position);
            max_pos = max_pos.max(d.position);
        }
        assert_eq!(d.position, -100.0);
        // It overshoots forward by about v²/2a = 600 units before it turns round.
        assert!((max_pos - 600.0).abs() < 20.0, "{max_pos}");
    }

    #[test]
    fn velocity_ramp_reaches_and_holds() {
        let mut d = Demand::default();
        for _ in 0..1000 {
            step_velocity(&mut d, 3000.0, 30000.0, 30000.0, 0.001);
        }
        assert_eq!(d.velocity, 3000.0);
        for _ in 0..1000 {
            step_velocity(&mut d, 0.0, 30000.0, 30000.0, 0.001);
        }
        assert_eq!(d.velocity, 0.0);
    }
}
