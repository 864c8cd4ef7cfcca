//! The simulated drive's NanoJ program: started and stopped by 2300h with the start
//! delay, its status and error in 2301h/2302h, what it does with its inputs and outputs,
//! its name in 2304h and its mapping in 2310h/2320h.

use super::*;

fn nanoj(rig: &mut Rig, on: bool) {
    rig.write(0x2300, 0, Value::Int(i64::from(on)));
}

#[test]
fn the_program_starts_after_its_delay_and_stops_at_once() {
    let mut rig = Rig::new();
    assert_eq!(rig.od_int(0x2301, 0), 0);
    nanoj(&mut rig, true);
    rig.run_ms(150);
    assert_eq!(rig.od_int(0x2301, 0), 0, "not yet: it takes up to 200 ms");
    rig.run_ms(100);
    assert_eq!(rig.od_int(0x2301, 0), 1, "running");
    assert_eq!(rig.od_int(0x2302, 0), 0);
    nanoj(&mut rig, false);
    rig.run_ms(1);
    assert_eq!(rig.od_int(0x2301, 0), 0, "stopped");
}

#[test]
fn the_program_copies_input_1_counts_its_cycles_and_moves_the_motor_on_input_2() {
    let mut rig = Rig::new();
    rig.done(Action::Velocity { speed: 0 }, 2000);
    nanoj(&mut rig, true);
    rig.run_ms(300);
    rig.write(0x2400, 1, Value::Int(42));
    rig.run_ms(2);
    assert_eq!(rig.od_int(0x2500, 1), 42);
    let cycles = rig.od_int(0x2500, 2);
    rig.run_ms(100);
    assert!(
        (rig.od_int(0x2500, 2) - cycles - 100).abs() <= 1,
        "a cycle a millisecond"
    );
    // Input 2: back and forth.
    rig.write(0x2400, 2, Value::Int(1));
    rig.run_ms(800);
    assert!(
        rig.drive.velocity_rpm() > 30.0,
        "{}",
        rig.drive.velocity_rpm()
    );
    rig.run_ms(1000);
    assert!(
        rig.drive.velocity_rpm() < -30.0,
        "turned round: {}",
        rig.drive.velocity_rpm()
    );
    rig.write(0x2400, 2, Value::Int(0));
    rig.run_ms(1000);
    assert_eq!(rig.drive.velocity_rpm(), 0.0, "stopped with input 2");
}

#[test]
fn an_injected_error_stops_the_program_with_its_code_and_a_start_clears_it() {
    let mut rig = Rig::new();
    nanoj(&mut rig, true);
    rig.run_ms(300);
    rig.write(0x2400, 3, Value::Int(5));
    rig.run_ms(2);
    assert_eq!(rig.od_int(0x2301, 0), 2, "stopped by an error");
    assert_eq!(rig.od_int(0x2302, 0), 5, "ran too long without yield()");
    rig.write(0x2400, 3, Value::Int(0));
    nanoj(&mut rig, true);
    rig.run_ms(300);
    assert_eq!(rig.od_int(0x2301, 0), 1);
    assert_eq!(rig.od_int(0x2302, 0), 0);
}

#[test]
fn the_program_is_named_and_its_mapping_filled_in() {
    let rig = Rig::new();
    let word = |sub| rig.od_int(0x2304, sub) as u32;
    let mut name = word(1).to_le_bytes().to_vec();
    name.extend(word(2).to_le_bytes());
    assert_eq!(String::from_utf8(name).unwrap(), "demo.usr");
    assert_eq!(rig.od_int(0x2310, 0), 3);
    assert_eq!(rig.od_int(0x2310, 1), 0x2400_0120);
    assert_eq!(rig.od_int(0x2320, 2), 0x2500_0220);
}
