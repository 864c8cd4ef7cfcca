//! The closed loop of the simulated drive: the cascade with 3210h's gains takes over once
//! closed loop is chosen (3202h bit 0, the factory setting) and an auto setup has
//! measured the motor; the direction of each gain's effect is pinned here.

use super::*;

/// A drive after its auto setup, closed loop, at standstill.
fn tuned_rig() -> Rig {
    let mut rig = Rig::new();
    rig.done(Action::AutoSetup, 5000);
    rig.run_ms(200);
    rig
}

/// A velocity command of `rpm` with a steep ramp (30000 rpm/s): the actual velocity
/// every ms for `ms`.
fn velocity_step(rig: &mut Rig, rpm: i32, ms: u64) -> Vec<f64> {
    rig.write(0x6083, 0, Value::Int(30000));
    rig.write(0x6084, 0, Value::Int(30000));
    rig.send(Action::Velocity { speed: rpm });
    (0..ms)
        .map(|_| {
            rig.cycle();
            rig.drive.velocity_rpm()
        })
        .collect()
}

/// (10–90 % rise in ms, overshoot in %) of a velocity trace towards `to`.
fn rise_and_overshoot(trace: &[f64], to: f64) -> (usize, f64) {
    let at = |f: f64| {
        trace
            .iter()
            .position(|v| *v >= f * to)
            .unwrap_or(trace.len())
    };
    let peak = trace.iter().cloned().fold(f64::MIN, f64::max);
    (at(0.9) - at(0.1), (peak - to) / to * 100.0)
}

fn with_velocity_gain(factor: f64) -> (usize, f64) {
    let mut rig = tuned_rig();
    let factory = rig.od_int(0x3210, 3);
    rig.write(0x3210, 3, Value::Int((factory as f64 * factor) as i64));
    // A small step (5 rpm), so that the current limit does not hide the loop.
    let trace = velocity_step(&mut rig, 5, 500);
    rise_and_overshoot(&trace, 5.0)
}

#[test]
fn the_velocity_gain_of_3210h_shapes_a_velocity_step_once_the_loop_is_closed() {
    let (rise, overshoot) = with_velocity_gain(1.0);
    let (rise_up, overshoot_up) = with_velocity_gain(4.0);
    let (rise_down, _) = with_velocity_gain(0.25);
    assert!(
        overshoot_up > overshoot + 10.0,
        "×4: {overshoot_up} % against {overshoot} %"
    );
    assert!(rise_up < rise, "×4: {rise_up} ms against {rise} ms");
    assert!(rise_down > rise, "÷4: {rise_down} ms against {rise} ms");
}

#[test]
fn open_loop_or_no_auto_setup_leaves_the_gains_without_effect() {
    // Before an auto setup the loop is not closed: the gains do nothing.
    let run = |autosetup: bool, closed: i64, gain: i64| {
        let mut rig = if autosetup { tuned_rig() } else { Rig::new() };
        rig.write(0x3202, 0, Value::Int(closed));
        rig.write(0x3210, 3, Value::Int(gain));
        let trace = velocity_step(&mut rig, 30, 300);
        rise_and_overshoot(&trace, 30.0)
    };
    assert_eq!(run(false, 1, 12000), run(false, 1, 48000));
    assert_eq!(run(true, 0, 12000), run(true, 0, 48000));
    assert_ne!(run(true, 1, 12000), run(true, 1, 48000));
}

#[test]
fn a_closed_loop_move_lands_on_its_target_and_a_heavier_load_lags_more() {
    let peak_error = |inertia: f64| {
        let mut rig = tuned_rig();
        rig.drive.set_load(crate::sim::world::Load {
            inertia,
            torque: 0.0,
        });
        let start = rig.drive.position();
        let tag = rig.send(move_abs(start as i32 + 2000, 300));
        let mut peak = 0i128;
        for _ in 0..3000 {
            rig.cycle();
            peak = peak.max(rig.od_int(0x60F4, 0).abs());
            if rig.progress.iter().any(|p| p.tag() == tag && p.is_final()) {
                break;
            }
        }
        rig.run_ms(500);
        assert!(
            (rig.drive.position() - (start + 2000.0)).abs() < 1.0,
            "it lands: {}",
            rig.drive.position()
        );
        assert!(rig.drive.velocity_rpm().abs() < 0.5, "and stands still");
        peak
    };
    let alone = peak_error(0.0);
    let heavy = peak_error(4.0);
    assert!(heavy > alone, "{heavy} against {alone}");
}

#[test]
fn a_quick_stop_steeper_than_the_motor_can_brake_still_ends_at_standstill() {
    for option in [2, 6] {
        let mut rig = tuned_rig();
        rig.write(0x605A, 0, Value::Int(option));
        rig.send(Action::Velocity { speed: 600 });
        rig.run_ms(1500);
        let tag = rig.send(Action::Quickstop);
        rig.finish(tag, 1000);
        rig.run_ms(3000);
        assert!(
            rig.drive.velocity_rpm().abs() < 0.5,
            "option {option}: {} rpm",
            rig.drive.velocity_rpm()
        );
    }
}
