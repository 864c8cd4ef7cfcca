//! The simulated drive's inputs through 3240h: the raw levels of the machine's wiring
//! (normally closed limit switches on inputs 1–2, a home switch on 3, outputs 1–2 looped
//! to inputs 5–6), inversion, forcing, the special functions the drive acts on, and a
//! broken wire.

use super::*;

const RAW: (u16, u8) = (0x3240, 5);

fn raw(rig: &Rig) -> i128 {
    rig.od_int(RAW.0, RAW.1)
}

fn inputs(rig: &Rig) -> i128 {
    rig.od_int(0x60FD, 0)
}

#[test]
fn between_the_switches_the_closed_limit_contacts_read_high_and_inactive() {
    let mut rig = Rig::new();
    rig.run_ms(2);
    assert_eq!(
        rig.od_int(0x3240, 1),
        0b111,
        "special functions of inputs 1–3"
    );
    assert_eq!(rig.od_int(0x3240, 2), 0b011, "inputs 1–2 inverted");
    assert_eq!(
        raw(&rig),
        0b011,
        "both limit contacts closed, home switch open"
    );
    assert_eq!(inputs(&rig), 0, "no switch active, no input high");
    // On the home cam: input 3 high, 60FDh bit 2 and bit 18.
    rig.drive.place(9_500.0);
    rig.run_ms(2);
    assert_eq!(raw(&rig), 0b111);
    assert_eq!(inputs(&rig), 0b100 | 1 << 18);
}

#[test]
fn inversion_and_forcing_change_60fdh_but_not_the_raw_value() {
    let mut rig = Rig::new();
    // Input 3 inverted: the home switch reads active off the cam.
    rig.write(0x3240, 2, Value::Uint(0b111));
    rig.run_ms(2);
    assert_eq!(raw(&rig), 0b011);
    assert_eq!(inputs(&rig), 0b100 | 1 << 18);
    // Input 7 forced high, input 3 forced low.
    rig.write(0x3240, 3, Value::Uint(0b100_0100));
    rig.write(0x3240, 4, Value::Uint(0b100_0000));
    rig.run_ms(2);
    assert_eq!(raw(&rig), 0b011, "the raw value is the wiring's");
    assert_eq!(inputs(&rig), 1 << 22);
}

#[test]
fn a_special_function_switched_off_is_shown_but_not_acted_on() {
    let mut rig = Rig::new();
    rig.write(0x3240, 1, Value::Uint(0b101)); // positive limit switch's function off
    rig.done(move_abs(40_000, 3000), 20_000);
    let x = rig.drive.position();
    assert!((x - 40_000.0).abs() < 1.0, "ran past the switch to {x}");
    assert!(!rig.status().is_set(StatusBit::LimitReached));
    // Input 2 still reads the pressed switch (bit 17), not as a limit (bit 1).
    assert_eq!(inputs(&rig) & 0b10, 0);
    assert_ne!(inputs(&rig) & 1 << 17, 0);
}

#[test]
fn a_broken_wire_to_the_negative_limit_switch_reads_as_pressed_and_stops_travel_into_it() {
    let mut rig = Rig::new();
    rig.drive.inject(Injection::WireBreak);
    rig.run_ms(2);
    assert_eq!(raw(&rig) & 1, 0, "input 1 low");
    assert_eq!(inputs(&rig) & 1, 1, "negative limit switch active");
    assert!(rig.status().is_set(StatusBit::LimitReached));
    assert!(
        !rig.status().is_set(StatusBit::Warning),
        "not the drive's own fault"
    );
    assert!(!rig.status().is_set(StatusBit::Fault));
    // Travel into it is stopped at once; away from it is allowed.
    let tag = rig.send(move_abs(-2_000, 300));
    rig.run_ms(500);
    assert!(rig.drive.position() > -50.0, "{}", rig.drive.position());
    assert!(!rig.progress.iter().any(|p| p.tag() == tag && p.is_final()));
    rig.done(move_abs(1_000, 300), 5_000);
    rig.drive.withdraw(Injection::WireBreak);
    rig.run_ms(2);
    assert_eq!(inputs(&rig) & 1, 0);
    rig.done(move_abs(-2_000, 300), 10_000);
}

#[test]
fn a_forced_output_is_switched_only_with_its_mask_and_loops_back_to_an_input() {
    let mut rig = Rig::new();
    rig.write(0x60FE, 1, Value::Uint(1 << 16));
    rig.run_ms(2);
    assert_eq!(
        inputs(&rig) & 1 << 20,
        0,
        "not enabled by the mask: output 1 off"
    );
    rig.write(0x60FE, 2, Value::Uint(1 << 16));
    rig.run_ms(2);
    assert_ne!(inputs(&rig) & 1 << 20, 0, "output 1 on: input 5 high");
    assert_ne!(raw(&rig) & 1 << 4, 0);
    rig.write(0x60FE, 2, Value::Uint(0));
    rig.run_ms(2);
    assert_eq!(inputs(&rig) & 1 << 20, 0, "released: off");
}
