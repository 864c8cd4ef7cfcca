//! The simulated drive, driven through the PDI by `PdiMaster` on simulated time: every
//! command's behaviour and its error paths.

use std::time::{Duration, Instant};

use super::*;
use crate::cia::{AbortCode, ErrorCode, HistoryEntry, PowerState};
use crate::od::{Address, Value};
use crate::pdi::{
    Action, Error as PdiError, Failure, PdiMaster, Progress, RxImage, StatusBit, Timing,
};

/// A drive and a master, exchanging images every millisecond of simulated time.
struct Rig {
    drive: Drive,
    master: PdiMaster,
    now: Instant,
    next_tag: u64,
    progress: Vec<Progress>,
}

impl Rig {
    fn new() -> Self {
        let drive = Drive::new();
        let mut master = PdiMaster::new(Timing::default());
        let now = Instant::now();
        master.adopt(drive.rx_image());
        master.on_tx(drive.tx_image(), now);
        Self {
            drive,
            master,
            now,
            next_tag: 1,
            progress: vec![],
        }
    }

    fn cycle(&mut self) {
        self.drive.tick(Duration::from_millis(1));
        self.now += Duration::from_millis(1);
        if let Some(rx) = self.master.outgoing() {
            self.drive.write_rx(&rx);
        }
        self.master.on_tx(self.drive.tx_image(), self.now);
        self.master.poll(self.now);
        self.progress.extend(self.master.drain_progress());
    }

    fn run_ms(&mut self, ms: u64) {
        for _ in 0..ms {
            self.cycle();
        }
    }

    fn send(&mut self, action: Action) -> u64 {
        self.issue(|master, tag, now| master.start(tag, action, now))
    }

    fn halt(&mut self) -> u64 {
        self.issue(PdiMaster::halt)
    }

    fn resume(&mut self) -> u64 {
        self.issue(PdiMaster::resume)
    }

    /// Hand the master a new command, `command(master, tag, now)`; its tag.
    fn issue(
        &mut self,
        command: impl FnOnce(&mut PdiMaster, u64, Instant) -> Result<RxImage, PdiError>,
    ) -> u64 {
        let tag = self.next_tag;
        self.next_tag += 1;
        command(&mut self.master, tag, self.now).unwrap();
        self.progress.extend(self.master.drain_progress());
        tag
    }

    /// Cycle until the command's final verdict, at most `max_ms`.
    fn finish(&mut self, tag: u64, max_ms: u64) -> (Progress, u64) {
        for ms in 0..max_ms {
            if let Some(p) = self
                .progress
                .iter()
                .find(|p| p.tag() == tag && p.is_final())
            {
                return (*p, ms);
            }
            self.cycle();
        }
        panic!(
            "command {tag} not finished after {max_ms} ms; progress {:?}, status {}",
            self.progress,
            self.drive.pdi_status()
        );
    }

    fn done(&mut self, action: Action, max_ms: u64) -> i32 {
        let tag = self.send(action);
        match self.finish(tag, max_ms).0 {
            Progress::Done { return_value, .. } => return_value,
            other => panic!("{action} did not succeed: {other:?}"),
        }
    }

    fn failure(&mut self, action: Action) -> Failure {
        let tag = self.send(action);
        match self.finish(tag, 2000).0 {
            Progress::Failed { failure, .. } => failure,
            other => panic!("{action} did not fail: {other:?}"),
        }
    }

    fn status(&self) -> crate::pdi::Status {
        self.drive.pdi_status()
    }

    fn od_int(&self, index: u16, sub: u8) -> i128 {
        self.drive
            .read(Address::new(index, sub))
            .ok()
            .and_then(|v| v.as_i128())
            .unwrap_or(i128::MIN)
    }

    fn write(&mut self, index: u16, sub: u8, value: Value) {
        self.drive.write(Address::new(index, sub), value).unwrap();
    }
}

fn od_read(index: u16, sub: u8) -> Action {
    Action::OdRead { index, sub }
}

fn od_write(index: u16, sub: u8, value: i32) -> Action {
    Action::OdWrite { index, sub, value }
}

fn move_abs(target: i32, speed: i16) -> Action {
    Action::MoveAbsolute { target, speed }
}

#[test]
fn absolute_move_reaches_its_target_with_a_trapezoid() {
    let mut rig = Rig::new();
    assert!(!rig.status().is_set(StatusBit::OperationEnabled));
    let tag = rig.send(move_abs(2000, 200));
    let (verdict, ms) = rig.finish(tag, 5000);
    assert!(
        matches!(
            verdict,
            Progress::Done {
                return_value: 2000,
                ..
            }
        ),
        "{verdict:?}"
    );
    // 2000 units at 200 rpm with 500 rpm/s: triangular, about 0.52 s, plus the window time.
    assert!((500..800).contains(&ms), "{ms} ms");
    assert!((rig.drive.position() - 2000.0).abs() < 1.0);
    let status = rig.status();
    assert!(status.is_set(StatusBit::OperationEnabled));
    assert!(status.is_set(StatusBit::TargetReached));
    assert_eq!(rig.od_int(0x6064, 0), 2000);
    assert_eq!(rig.od_int(0x607A, 0), 2000);
    assert_eq!(rig.od_int(0x6061, 0), 1);
    assert_eq!(
        PowerState::from_statusword(rig.od_int(0x6041, 0) as u16),
        Some(PowerState::OperationEnabled)
    );
    assert_ne!(
        rig.od_int(0x6041, 0) & (1 << 10),
        0,
        "statusword target reached"
    );
    assert_eq!(rig.od_int(0x6040, 0), 0x0F);
}

#[test]
fn velocity_profile_ramps_at_6083h() {
    let mut rig = Rig::new();
    let tag = rig.send(Action::Velocity { speed: 300 });
    let (verdict, ms) = rig.finish(tag, 5000);
    assert!(matches!(verdict, Progress::Done { .. }), "{verdict:?}");
    // 300 rpm at 500 rpm/s: 0.6 s, then the 10 ms window time.
    assert!((590..700).contains(&ms), "{ms} ms");
    rig.run_ms(100);
    assert!((rig.drive.velocity_rpm() - 300.0).abs() < 1.0);
    assert_eq!(rig.drive.tx_image().return_value, 300);
    assert_eq!(rig.od_int(0x606C, 0), 300);
    assert_eq!(rig.od_int(0x6061, 0), 3);
}

#[test]
fn relative_moves_add_up_21_149_21() {
    let mut rig = Rig::new();
    for _ in 0..3 {
        rig.done(
            Action::MoveRelative {
                distance: 1000,
                speed: 300,
            },
            5000,
        );
    }
    assert!((rig.drive.position() - 3000.0).abs() < 1.0);
    assert_eq!(rig.drive.rx_image().cmd, 21);
}

#[test]
fn torque_with_slope_zero_never_builds_up() {
    let mut rig = Rig::new();
    assert_eq!(rig.od_int(0x6087, 0), 0, "factory torque slope is 0");
    let tag = rig.send(Action::Torque {
        torque: 500,
        max_speed: 100,
    });
    rig.run_ms(1000);
    assert!(rig.progress.contains(&Progress::Accepted { tag }));
    assert!(!rig.progress.iter().any(|p| p.tag() == tag && p.is_final()));
    assert_eq!(rig.drive.torque_permille(), 0.0);
    assert_eq!(rig.drive.velocity_rpm(), 0.0);
    assert!(!rig.status().is_set(StatusBit::TargetReached));
}

#[test]
fn torque_ramps_at_6087h_and_speed_is_limited() {
    let mut rig = Rig::new();
    rig.write(0x6087, 0, Value::Uint(1000)); // 1000 ‰/s
    let tag = rig.send(Action::Torque {
        torque: 500,
        max_speed: 100,
    });
    let (verdict, ms) = rig.finish(tag, 3000);
    assert!(matches!(verdict, Progress::Done { .. }), "{verdict:?}");
    assert!(
        (490..600).contains(&ms),
        "0.5 s to ramp to 500 ‰, took {ms} ms"
    );
    rig.run_ms(3000);
    assert!(
        (rig.drive.velocity_rpm() - 100.0).abs() < 0.5,
        "{}",
        rig.drive.velocity_rpm()
    );
    assert_eq!(rig.drive.tx_image().return_value, 500);
    assert_eq!(rig.od_int(0x6061, 0), 4);
}

#[test]
fn halt_stops_and_resume_continues_to_the_old_target() {
    let mut rig = Rig::new();
    rig.send(move_abs(30_000, 300));
    rig.run_ms(500);
    let halt = rig.halt();
    assert_eq!(rig.master.outgoing().map(|rx| rx.cmd), Some(84));
    let (verdict, _) = rig.finish(halt, 3000);
    assert!(matches!(verdict, Progress::Done { .. }), "{verdict:?}");
    let status = rig.status();
    assert!(status.is_set(StatusBit::QsHaltBit));
    assert!(
        status.is_set(StatusBit::TargetReached),
        "halted at standstill"
    );
    assert!(
        status.is_set(StatusBit::OperationEnabled),
        "stays energised"
    );
    let stopped_at = rig.drive.position();
    assert!(stopped_at < 29_000.0);
    rig.run_ms(200);
    assert!((rig.drive.position() - stopped_at).abs() < 0.5, "stays put");
    let resume = rig.resume();
    assert_eq!(rig.master.outgoing().map(|rx| rx.cmd), Some(20));
    let (verdict, _) = rig.finish(resume, 10_000);
    assert!(
        matches!(
            verdict,
            Progress::Done {
                return_value: 30_000,
                ..
            }
        ),
        "{verdict:?}"
    );
    assert!(!rig.status().is_set(StatusBit::QsHaltBit));
}

#[test]
fn halt_then_toggle_takes_the_new_target() {
    let mut rig = Rig::new();
    rig.send(move_abs(30_000, 300));
    rig.run_ms(300);
    let halt = rig.halt();
    rig.finish(halt, 3000);
    let tag = rig.send(move_abs(-1000, 300));
    assert_eq!(rig.master.outgoing().map(|rx| rx.cmd), Some(148));
    let (verdict, _) = rig.finish(tag, 10_000);
    assert!(
        matches!(
            verdict,
            Progress::Done {
                return_value: -1000,
                ..
            }
        ),
        "{verdict:?}"
    );
}

#[test]
fn halt_on_velocity_and_torque() {
    let mut rig = Rig::new();
    rig.send(Action::Velocity { speed: 200 });
    rig.run_ms(600);
    let halt = rig.halt();
    assert_eq!(rig.master.outgoing().map(|rx| rx.cmd), Some(23 | 64));
    rig.finish(halt, 3000);
    assert_eq!(rig.drive.velocity_rpm(), 0.0);
    let resume = rig.resume();
    rig.finish(resume, 3000);
    assert!((rig.drive.velocity_rpm() - 200.0).abs() < 1.0);
}

#[test]
fn switch_off_de_energises_and_drops_the_move() {
    let mut rig = Rig::new();
    rig.send(move_abs(30_000, 300));
    rig.run_ms(800);
    let tag = rig.send(Action::SwitchOff);
    let (verdict, _) = rig.finish(tag, 1000);
    assert!(matches!(verdict, Progress::Done { .. }), "{verdict:?}");
    assert_eq!(rig.drive.power_state(), PowerState::SwitchOnDisabled);
    assert!(!rig.status().is_set(StatusBit::OperationEnabled));
    rig.run_ms(2000);
    assert_eq!(rig.drive.velocity_rpm(), 0.0, "coasts to a stop");
    assert!(rig.drive.position() < 20_000.0, "the move was dropped");
    assert_eq!(rig.od_int(0x6040, 0), 0);
}

#[test]
fn quickstop_honours_every_605ah_option() {
    let mut distances = vec![];
    for option in [0, 1, 2, 5, 6] {
        let mut rig = Rig::new();
        rig.write(0x605A, 0, Value::Int(option));
        rig.send(Action::Velocity { speed: 600 });
        rig.run_ms(1500);
        let start = rig.drive.position();
        let tag = rig.send(Action::Quickstop);
        let (verdict, _) = rig.finish(tag, 1000);
        assert!(
            matches!(verdict, Progress::Done { .. }),
            "{option}: {verdict:?}"
        );
        rig.run_ms(3000);
        assert_eq!(rig.drive.velocity_rpm(), 0.0, "option {option} stops");
        let status = rig.status();
        assert!(
            !status.is_set(StatusBit::OperationEnabled),
            "option {option}"
        );
        let state = rig.drive.power_state();
        match option {
            0..=2 => {
                assert_eq!(state, PowerState::SwitchOnDisabled, "option {option}");
                assert!(!status.is_set(StatusBit::QsHaltBit));
            }
            _ => {
                assert_eq!(state, PowerState::QuickStopActive, "option {option}");
                assert!(status.is_set(StatusBit::QsHaltBit));
                assert!(status.is_set(StatusBit::TargetReached));
            }
        }
        distances.push((option, rig.drive.position() - start));
    }
    let d = |o: i64| {
        distances
            .iter()
            .find(|(x, _)| *x == o)
            .map(|(_, d)| *d)
            .unwrap()
    };
    // 600 rpm = 36000 units/s: slow ramp 500 rpm/s brakes over ~21600 units, the quick
    // stop ramp 3000 rpm/s over ~3600; option 0 lets the motor coast out.
    assert!((d(1) - 21_600.0).abs() < 300.0, "{}", d(1));
    assert!((d(5) - 21_600.0).abs() < 300.0, "{}", d(5));
    assert!((d(2) - 3_600.0).abs() < 200.0, "{}", d(2));
    assert!((d(6) - 3_600.0).abs() < 200.0, "{}", d(6));
    assert!(d(0) < 10_000.0, "{}", d(0));
}

#[test]
fn quick_stop_active_returns_to_operation_with_a_travel_command() {
    let mut rig = Rig::new();
    rig.write(0x605A, 0, Value::Int(6));
    rig.send(Action::Velocity { speed: 100 });
    rig.run_ms(500);
    let tag = rig.send(Action::Quickstop);
    rig.finish(tag, 1000);
    rig.run_ms(500);
    assert_eq!(rig.drive.power_state(), PowerState::QuickStopActive);
    rig.done(move_abs(0, 100), 10_000);
    assert_eq!(rig.drive.power_state(), PowerState::OperationEnabled);
}

#[test]
fn clear_error_only_clears_once_the_cause_is_gone() {
    let mut rig = Rig::new();
    rig.send(Action::Velocity { speed: 100 });
    rig.run_ms(300);
    rig.drive.inject(Injection::OverCurrent);
    rig.run_ms(10);
    let tx = rig.drive.tx_image();
    assert!(tx.status.is_set(StatusBit::Fault));
    assert!(!tx.status.is_set(StatusBit::OperationEnabled));
    assert_eq!(tx.error_code, 0x2300);
    assert_eq!(rig.drive.power_state(), PowerState::Fault);
    let failure = rig.failure(Action::ClearError);
    assert_eq!(failure, Failure::FaultPersists { error_code: 0x2300 });
    // A travel command is refused while the fault is active.
    let failure = rig.failure(Action::Velocity { speed: 100 });
    assert_eq!(
        failure,
        Failure::Refused {
            code: AbortCode::DEVICE_STATE.0
        }
    );
    rig.drive.withdraw(Injection::OverCurrent);
    rig.done(Action::ClearError, 1000);
    let tx = rig.drive.tx_image();
    assert!(!tx.status.is_set(StatusBit::Fault));
    assert_eq!(tx.error_code, 0);
    assert_eq!(rig.drive.power_state(), PowerState::SwitchOnDisabled);
    // The fault is in the error history (1003h) with Nanotec's layout.
    assert_eq!(rig.od_int(0x1003, 0), 1);
    let entry = HistoryEntry::from_raw(rig.od_int(0x1003, 1) as u32);
    assert_eq!(entry.code, ErrorCode::OUTPUT_CURRENT);
    assert_eq!(entry.number, 2);
}

#[test]
fn every_injection_reports_its_code() {
    for injection in Injection::DRIVE.into_iter().filter(|i| i.is_reported()) {
        let mut rig = Rig::new();
        rig.drive.inject(injection);
        rig.run_ms(5);
        let tx = rig.drive.tx_image();
        assert_eq!(tx.error_code, injection.error_code().0, "{injection}");
        assert_eq!(
            tx.status.is_set(StatusBit::Fault),
            injection.is_fault(),
            "{injection}"
        );
        assert_eq!(
            tx.status.is_set(StatusBit::Warning),
            !injection.is_fault(),
            "{injection}"
        );
        rig.drive.withdraw(injection);
        rig.done(Action::ClearError, 1000);
        assert_eq!(rig.drive.tx_image().error_code, 0, "{injection}");
    }
}

#[test]
fn under_voltage_shows_in_4014h() {
    let mut rig = Rig::new();
    assert_eq!(rig.od_int(0x4014, 1), 24_000);
    rig.drive.inject(Injection::UnderVoltage);
    assert_eq!(rig.od_int(0x4014, 1), 9_000);
    assert_eq!(
        rig.od_int(0x6041, 0) & (1 << 4),
        0,
        "voltage enabled bit drops"
    );
}

#[test]
fn blocked_load_during_a_move_is_a_following_error_fault() {
    let mut rig = Rig::new();
    let tag = rig.send(move_abs(20_000, 200));
    rig.run_ms(300);
    rig.drive.inject(Injection::FollowingError);
    let (verdict, _) = rig.finish(tag, 1000);
    assert_eq!(
        verdict,
        Progress::Failed {
            tag,
            failure: Failure::DriveFault { error_code: 0x8611 }
        }
    );
}

#[test]
fn following_error_window_warns_or_faults_per_3700h() {
    // A 10-unit window: the load lags the demand by more than that at speed.
    for (reaction, fault) in [(-1, false), (1, true)] {
        let mut rig = Rig::new();
        rig.write(0x6065, 0, Value::Uint(10));
        rig.write(0x3700, 0, Value::Int(reaction));
        rig.send(Action::Velocity { speed: 300 });
        rig.run_ms(1000);
        let tx = rig.drive.tx_image();
        assert_eq!(
            tx.status.is_set(StatusBit::Fault),
            fault,
            "3700h = {reaction}"
        );
        assert_eq!(tx.error_code, 0x8611, "3700h = {reaction}");
        if !fault {
            assert!(tx.status.is_set(StatusBit::FollowingError));
            assert!(tx.status.is_set(StatusBit::Warning));
            assert!(rig.od_int(0x60F4, 0).abs() > 10);
        }
    }
}

#[test]
fn od_read_and_write_through_the_pdi() {
    let mut rig = Rig::new();
    assert_eq!(rig.done(od_read(0x1018, 1), 100), 0x26C);
    rig.done(od_write(0x203B, 1, 1000), 100);
    assert_eq!(rig.done(od_read(0x203B, 1), 100), 1000);
    assert_eq!(rig.od_int(0x203B, 1), 1000);
    // Unsigned 32-bit values travel as two's complement.
    rig.done(od_write(0x60FE, 1, -1), 100);
    assert_eq!(rig.od_int(0x60FE, 1), 0xFFFF_FFFF);
    assert_eq!(rig.done(od_read(0x60FE, 1), 100), -1);
    // Signed 8-bit objects come back sign-extended.
    rig.write(0x6098, 0, Value::Int(-3));
    assert_eq!(rig.done(od_read(0x6098, 0), 100), -3);
}

#[test]
fn od_access_errors_come_back_as_abort_codes() {
    let mut rig = Rig::new();
    let refused = |code: AbortCode| Failure::Refused { code: code.0 };
    assert_eq!(
        rig.failure(od_read(0x2FFF, 0)),
        refused(AbortCode::NO_OBJECT)
    );
    // An index above 7FFFh travels as a negative SetValue2.
    assert_eq!(
        rig.failure(od_read(0xA000, 0x80)),
        refused(AbortCode::NO_OBJECT)
    );
    assert_eq!(
        rig.failure(od_read(0x1018, 9)),
        refused(AbortCode::NO_SUBINDEX)
    );
    assert_eq!(
        rig.failure(od_write(0x1018, 1, 5)),
        refused(AbortCode::READ_ONLY)
    );
    assert_eq!(
        rig.failure(od_write(0x2290, 0, 300)),
        refused(AbortCode::VALUE_RANGE)
    );
    assert_eq!(
        rig.failure(od_write(0x605A, 0, 7)),
        refused(AbortCode::VALUE_TOO_HIGH)
    );
    assert_eq!(
        rig.failure(od_read(0x1008, 0)),
        refused(AbortCode::TYPE_LENGTH_TOO_HIGH)
    );
    // After an error the next command works again and PdiStatusError clears.
    assert_eq!(rig.done(od_read(0x1018, 1), 100), 0x26C);
    assert!(!rig.status().is_set(StatusBit::Error));
}

#[test]
fn an_unknown_opcode_is_refused() {
    let mut rig = Rig::new();
    let before = rig.status().is_set(StatusBit::ToggleCmd);
    let mut rx = rig.drive.rx_image();
    rx.cmd = 5;
    rig.drive.write_rx(&rx);
    let tx = rig.drive.tx_image();
    assert_ne!(tx.status.is_set(StatusBit::ToggleCmd), before);
    assert!(tx.status.is_set(StatusBit::Error));
    assert_eq!(tx.return_value as u32, AbortCode::VALUE_RANGE.0);
}

#[test]
fn the_same_byte_twice_is_one_command() {
    let mut rig = Rig::new();
    let mut rx = rig.drive.rx_image();
    rx.cmd = 14;
    rx.values.value2 = 0x1018;
    rx.values.value3 = 1;
    rig.drive.write_rx(&rx);
    let toggle = rig.status().is_set(StatusBit::ToggleCmd);
    rig.drive.write_rx(&rx);
    assert_eq!(rig.status().is_set(StatusBit::ToggleCmd), toggle);
    rx.cmd = 14 | 0x80;
    rig.drive.write_rx(&rx);
    assert_ne!(rig.status().is_set(StatusBit::ToggleCmd), toggle);
}

#[test]
fn auto_setup_takes_a_visible_while() {
    let mut rig = Rig::new();
    let tag = rig.send(Action::AutoSetup);
    rig.run_ms(1000);
    assert!(!rig.status().is_set(StatusBit::AutosetupDone));
    assert!(
        rig.drive.velocity_rpm().abs() > 0.0 || rig.drive.position().abs() > 1.0,
        "it moves"
    );
    let (verdict, ms) = rig.finish(tag, 5000);
    assert!(matches!(verdict, Progress::Done { .. }), "{verdict:?}");
    assert!(ms + 1000 >= AUTO_SETUP_TIME.as_millis() as u64);
    assert!(rig.status().is_set(StatusBit::AutosetupDone));
    // The bit stays set through later commands.
    rig.done(od_read(0x1018, 1), 100);
    assert!(rig.status().is_set(StatusBit::AutosetupDone));
}

#[test]
fn homing_on_current_position_sets_the_position() {
    let mut rig = Rig::new();
    rig.done(move_abs(1234, 300), 5000);
    rig.done(Action::HomeHere { position: 5000 }, 1000);
    assert!((rig.drive.position() - 5000.0).abs() < 0.5);
    assert_eq!(rig.od_int(0x6064, 0), 5000);
    assert!(rig.status().is_set(StatusBit::HomingDone));
}

#[test]
fn homing_methods_find_their_reference() {
    let world = World::default();
    // (method, world position of the home point)
    let cases = [
        (17, world.negative_limit),
        (18, world.positive_limit),
        (19, world.home_start),
        (20, world.home_start),
        (21, world.home_end),
        (22, world.home_end),
        (33, world.index_offset - world.index_period),
        (34, world.index_offset),
    ];
    for (method, home) in cases {
        let mut rig = Rig::new();
        rig.write(0x607C, 0, Value::Int(100)); // home offset
        let tag = rig.send(Action::Homing { method });
        let (verdict, _) = rig.finish(tag, 120_000);
        assert!(
            matches!(verdict, Progress::Done { .. }),
            "method {method}: {verdict:?}"
        );
        assert!(
            rig.status().is_set(StatusBit::HomingDone),
            "method {method}"
        );
        // The position counter reads the home offset (100) at the home point, and the
        // motor stopped just past it.
        let past_home = rig.drive.position() - 100.0;
        assert!(
            past_home.abs() < 50.0,
            "method {method}: stopped {past_home} from home"
        );
        let world_now = rig.drive.world_position();
        assert!(
            (world_now - home - past_home).abs() < 1e-6,
            "method {method}: home at {home}"
        );
        assert_eq!(rig.od_int(0x6098, 0), i128::from(method));
    }
}

#[test]
fn homing_on_current_position_methods_and_unsupported_ones() {
    let mut rig = Rig::new();
    rig.done(move_abs(777, 300), 5000);
    rig.write(0x607C, 0, Value::Int(0));
    rig.done(Action::Homing { method: 37 }, 1000);
    assert!(rig.drive.position().abs() < 0.5);
    let failure = rig.failure(Action::Homing { method: 5 });
    assert_eq!(
        failure,
        Failure::Refused {
            code: AbortCode::VALUE_RANGE.0
        }
    );
}

#[test]
fn a_new_homing_clears_homing_done_until_it_succeeds() {
    let mut rig = Rig::new();
    rig.done(Action::HomeHere { position: 0 }, 1000);
    assert!(rig.status().is_set(StatusBit::HomingDone));
    rig.send(Action::Homing { method: 34 });
    rig.run_ms(20);
    assert!(!rig.status().is_set(StatusBit::HomingDone));
}

#[test]
fn limit_switches_stop_travel_into_them() {
    let mut rig = Rig::new();
    let tag = rig.send(move_abs(40_000, 3000));
    rig.run_ms(5000);
    assert!(!rig.progress.iter().any(|p| p.tag() == tag && p.is_final()));
    let status = rig.status();
    assert!(status.is_set(StatusBit::LimitReached));
    assert!(!status.is_set(StatusBit::TargetReached));
    assert_eq!(rig.drive.velocity_rpm(), 0.0);
    let x = rig.drive.position();
    assert!((36_000.0..38_000.0).contains(&x), "{x}");
    assert_ne!(rig.od_int(0x60FD, 0) & 0b10, 0, "positive limit input");
    // Moving away is allowed.
    rig.done(move_abs(0, 3000), 10_000);
    assert!(!rig.status().is_set(StatusBit::LimitReached));
}

#[test]
fn auto_setup_against_a_limit_switch_is_given_up_with_an_error() {
    let mut rig = Rig::new();
    // Homed onto the negative limit switch: the wiggle of auto setup runs into it.
    rig.done(Action::Homing { method: 17 }, 30_000);
    let tag = rig.send(Action::AutoSetup);
    let (verdict, ms) = rig.finish(tag, 5000);
    assert!(
        matches!(verdict, Progress::Failed { .. }),
        "refused, not waited out: {verdict:?}"
    );
    assert!(ms < AUTO_SETUP_TIME.as_millis() as u64, "{ms} ms");
    let status = rig.status();
    assert!(status.is_set(StatusBit::LimitReached));
    assert!(!status.is_set(StatusBit::AutosetupDone));
}

#[test]
fn controlword_drives_the_power_state_machine() {
    let mut rig = Rig::new();
    rig.write(0x6040, 0, Value::Uint(0x06));
    assert_eq!(rig.drive.power_state(), PowerState::ReadyToSwitchOn);
    rig.write(0x6040, 0, Value::Uint(0x07));
    assert_eq!(rig.drive.power_state(), PowerState::SwitchedOn);
    rig.write(0x6040, 0, Value::Uint(0x0F));
    assert_eq!(rig.drive.power_state(), PowerState::OperationEnabled);
    assert!(rig.drive.pdi_status().is_set(StatusBit::OperationEnabled));
    rig.write(0x6040, 0, Value::Uint(0x00));
    assert_eq!(rig.drive.power_state(), PowerState::SwitchOnDisabled);
    // Enable operation straight from Switch on disabled is not a CiA 402 transition.
    rig.write(0x6040, 0, Value::Uint(0x0F));
    assert_eq!(rig.drive.power_state(), PowerState::SwitchOnDisabled);
}

#[test]
fn strings_and_identity_read_directly() {
    let rig = Rig::new();
    assert_eq!(
        rig.drive.read(Address::new(0x1008, 0)),
        Ok(Value::Text("drivedeck simulated drive".into()))
    );
    assert_eq!(
        rig.drive.read(Address::new(0x1018, 1)),
        Ok(Value::Uint(0x26C))
    );
    assert_eq!(
        rig.drive.read(Address::new(0x2FFF, 0)),
        Err(AbortCode::NO_OBJECT)
    );
}

#[test]
fn pdi_objects_mirror_the_images() {
    let mut rig = Rig::new();
    rig.done(move_abs(100, 100), 5000);
    let tx = rig.drive.tx_image();
    assert_eq!(rig.od_int(0x2292, 1) as i16, tx.status.to_i16());
    assert_eq!(rig.od_int(0x2292, 2) as i32, tx.return_value);
    assert_eq!(rig.od_int(0x2291, 1), 100);
    assert_eq!(rig.od_int(0x2291, 4), 20);
}

#[test]
fn with_the_pdi_off_commands_are_not_acknowledged() {
    let mut rig = Rig::new();
    rig.write(0x2290, 0, Value::Uint(0));
    let tag = rig.send(move_abs(1000, 100));
    let (verdict, ms) = rig.finish(tag, 3000);
    assert!(
        matches!(
            verdict,
            Progress::TimedOut {
                waiting_for: crate::pdi::Waiting::Acknowledgement,
                ..
            }
        ),
        "{verdict:?}"
    );
    assert!((999..=1001).contains(&ms), "{ms}");
    assert_eq!(rig.drive.position(), 0.0);
    // Switched back on, the next command works.
    rig.write(0x2290, 0, Value::Uint(1));
    rig.done(move_abs(1000, 100), 5000);
}

mod inputs;
mod nanoj;
mod storage;
mod tuning;
