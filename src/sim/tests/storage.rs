//! Store, factory values and restart: what survives a reboot of the simulated drive, and
//! that it is gone from every bus meanwhile.

use super::*;
use crate::sim::drive::BOOT_TIME;

const SAVE: i64 = 0x6576_6173;
const LOAD: i64 = 0x6461_6F6C;
const BOOT: i64 = 0x746F_6F62;

/// Reboot and wait until the drive is back.
fn reboot(rig: &mut Rig) {
    rig.write(0x2800, 1, Value::Int(BOOT));
    rig.drive.tick(Duration::from_millis(1));
    assert!(rig.drive.rebooting(), "restarting");
    rig.drive.tick(BOOT_TIME);
    assert!(!rig.drive.rebooting(), "back");
    // The master starts over with the drive, as after a reconnect.
    rig.master = PdiMaster::new(Timing::default());
    rig.master.adopt(rig.drive.rx_image());
    rig.master.on_tx(rig.drive.tx_image(), rig.now);
}

#[test]
fn a_stored_value_survives_a_restart_and_one_not_stored_does_not() {
    let mut rig = Rig::new();
    rig.write(0x6083, 0, Value::Int(1234));
    rig.write(0x1010, 1, Value::Int(SAVE));
    rig.write(0x6084, 0, Value::Int(4321));
    let factory_6084 = Drive::new().read(Address::new(0x6084, 0)).unwrap();
    reboot(&mut rig);
    assert_eq!(rig.drive.reboots(), 1);
    assert_eq!(rig.od_int(0x6083, 0), 1234, "stored");
    assert_eq!(
        rig.drive.read(Address::new(0x6084, 0)).unwrap(),
        factory_6084,
        "written after the store: gone"
    );
}

#[test]
fn factory_values_come_back_at_the_restart_after_load() {
    let mut rig = Rig::new();
    rig.write(0x6083, 0, Value::Int(1234));
    rig.write(0x1010, 1, Value::Int(SAVE));
    rig.write(0x1011, 1, Value::Int(LOAD));
    // Not before the restart.
    assert_eq!(rig.od_int(0x6083, 0), 1234);
    reboot(&mut rig);
    assert_eq!(rig.od_int(0x6083, 0), 500, "the factory's");
    // And the store is forgotten for the next restart too.
    reboot(&mut rig);
    assert_eq!(rig.od_int(0x6083, 0), 500);
}

#[test]
fn a_restart_switches_the_power_stage_off_and_starts_the_counter_at_zero() {
    let mut rig = Rig::new();
    rig.done(move_abs(3000, 600), 5000);
    assert!(rig.drive.power_state() == PowerState::OperationEnabled);
    reboot(&mut rig);
    assert_eq!(rig.drive.power_state(), PowerState::SwitchOnDisabled);
    assert!(rig.drive.position().abs() < 0.5, "{}", rig.drive.position());
    assert!(
        (rig.drive.world_position() - 3000.0).abs() < 1.0,
        "the load stays"
    );
    assert!(!rig.status().is_set(StatusBit::HomingDone));
}

#[test]
fn a_restart_waits_for_the_delay_of_2800h_02() {
    let mut rig = Rig::new();
    rig.write(0x2800, 2, Value::Int(200));
    rig.write(0x2800, 1, Value::Int(BOOT));
    rig.drive.tick(Duration::from_millis(150));
    assert!(!rig.drive.rebooting(), "not yet");
    rig.drive.tick(Duration::from_millis(100));
    assert!(rig.drive.rebooting());
}

#[test]
fn the_auto_setup_is_kept_only_when_stored_after_it() {
    let mut rig = Rig::new();
    rig.done(Action::AutoSetup, 5000);
    reboot(&mut rig);
    assert!(!rig.status().is_set(StatusBit::AutosetupDone), "not stored");
    rig.done(Action::AutoSetup, 5000);
    rig.write(0x1010, 1, Value::Int(SAVE));
    reboot(&mut rig);
    assert!(rig.status().is_set(StatusBit::AutosetupDone), "stored");
}

#[test]
fn a_wrong_signature_is_refused_and_changes_nothing() {
    let mut drive = Drive::new();
    for (index, sub) in [(0x1010, 1), (0x1011, 1)] {
        assert_eq!(
            drive.write(Address::new(index, sub), Value::Int(1)),
            Err(AbortCode::CANNOT_STORE)
        );
    }
    assert_eq!(
        drive.write(Address::new(0x2800, 1), Value::Int(1)),
        Err(AbortCode::VALUE_RANGE)
    );
    drive.tick(BOOT_TIME * 2);
    assert_eq!(drive.reboots(), 0);
}
