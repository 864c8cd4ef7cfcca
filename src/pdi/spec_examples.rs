//! Every numbered example of the PDI spec, reproduced byte for byte through `PdiMaster`,
//! plus the master's judgement of acknowledgements, errors, completion and timeouts.

use std::time::{Duration, Instant};

use super::*;
use crate::cia::AbortCode;

/// A hand-driven drive: it answers each image with the status we choose.
struct Bench {
    master: PdiMaster,
    now: Instant,
    toggle: bool,
}

impl Bench {
    fn new() -> Self {
        let mut master = PdiMaster::new(Timing::default());
        let now = Instant::now();
        master.on_tx(TxImage::default(), now);
        Self {
            master,
            now,
            toggle: false,
        }
    }

    fn tick(&mut self, ms: u64) {
        self.now += Duration::from_millis(ms);
    }

    /// The drive reports `bits` (plus its toggle bit) and a return value.
    fn answer(&mut self, bits: &[StatusBit], return_value: i32) -> Vec<Progress> {
        let mut status = Status(0).with(StatusBit::ToggleCmd, self.toggle);
        for bit in bits {
            status = status.with(*bit, true);
        }
        self.master.on_tx(
            TxImage {
                status,
                error_code: 0,
                return_value,
            },
            self.now,
        );
        self.master.drain_progress()
    }

    /// Start `action` as command `tag`, now: the image the master writes.
    fn start(&mut self, tag: u64, action: Action) -> RxImage {
        self.master.start(tag, action, self.now).unwrap()
    }

    /// The drive detects a new command: its status toggle flips.
    fn detect(&mut self, bits: &[StatusBit], return_value: i32) -> Vec<Progress> {
        self.toggle = !self.toggle;
        self.answer(bits, return_value)
    }
}

/// Command `tag` done, with this ReturnValue.
fn done(tag: u64, return_value: i32) -> Progress {
    Progress::Done { tag, return_value }
}

fn move_to(target: i32, speed: i16) -> Action {
    Action::MoveAbsolute { target, speed }
}

fn move_by(distance: i32, speed: i16) -> Action {
    Action::MoveRelative { distance, speed }
}

fn od_read(index: u16, sub: u8) -> Action {
    Action::OdRead { index, sub }
}

fn bytes(image: RxImage) -> [u8; 8] {
    image.to_bytes()
}

#[test]
fn od_read_of_3320h_01h_then_a_second_read_toggles() {
    // Spec 2.2.5: SetValue2 = 13088 (3320h), SetValue3 = 1, Cmd = 14.
    let mut b = Bench::new();
    let image = b.start(1, od_read(0x3320, 1));
    assert_eq!(image.values.value2, 13088);
    assert_eq!(image.values.value3, 1);
    assert_eq!(image.cmd, 14);
    assert_eq!(bytes(image), [0, 0, 0, 0, 0x20, 0x33, 1, 14]);
    b.tick(10);
    assert_eq!(b.answer(&[], 0), vec![]); // not detected yet
    let progress = b.detect(&[], 1234);
    assert_eq!(progress, vec![Progress::Accepted { tag: 1 }, done(1, 1234)]);
    // "To read out a second value, you must toggle the ToggleCmd bit."
    let again = b.start(2, od_read(0x3320, 1));
    assert_eq!(again.cmd, 0x8E);
}

#[test]
fn od_write_of_1000_to_203bh_01h() {
    // Spec 2.2.6: SetValue2 = 8251 (203Bh), SetValue3 = 1, SetValue1 = 1000, Cmd = 15.
    let mut b = Bench::new();
    let action = Action::from_inputs(Opcode::OdWrite, &[0x203B, 1, 1000]).unwrap();
    let image = b.start(7, action);
    assert_eq!(image.values.value2, 8251);
    assert_eq!(image.values.value3, 1);
    assert_eq!(image.values.value1, 1000);
    assert_eq!(image.cmd, 15);
    assert_eq!(bytes(image), [0xE8, 0x03, 0, 0, 0x3B, 0x20, 1, 15]);
    let progress = b.detect(&[], 1000);
    assert_eq!(progress.last(), Some(&done(7, 1000)));
    // "To write a second value, you must toggle the ToggleCmd bit."
    let second = b.start(8, action);
    assert_eq!(second.cmd, 15 | 0x80);
}

#[test]
fn absolute_move_to_2000_at_200_waits_for_target_reached() {
    // Spec 2.2.10.
    let mut b = Bench::new();
    let image = b.start(1, move_to(2000, 200));
    assert_eq!(image.values.value1, 2000);
    assert_eq!(image.values.value2, 200);
    assert_eq!(image.cmd, 20);
    // Accepted while the old TargetReached is still set: not done yet.
    let progress = b.detect(&[StatusBit::OperationEnabled, StatusBit::TargetReached], 0);
    assert_eq!(progress, vec![Progress::Accepted { tag: 1 }]);
    b.tick(10);
    assert_eq!(b.answer(&[StatusBit::OperationEnabled], 500), vec![]);
    b.tick(10);
    assert_eq!(b.answer(&[StatusBit::OperationEnabled], 1500), vec![]);
    b.tick(10);
    let progress = b.answer(
        &[StatusBit::OperationEnabled, StatusBit::TargetReached],
        2000,
    );
    assert_eq!(progress, vec![done(1, 2000)]);
}

#[test]
fn a_move_to_where_the_motor_already_is_finishes_after_the_settle_time() {
    let mut b = Bench::new();
    b.start(1, move_to(0, 100));
    let on = [StatusBit::OperationEnabled, StatusBit::TargetReached];
    assert_eq!(b.detect(&on, 0), vec![Progress::Accepted { tag: 1 }]);
    b.tick(100);
    assert_eq!(b.answer(&on, 0), vec![]);
    b.tick(60);
    assert_eq!(b.answer(&on, 0), vec![done(1, 0)]);
}

#[test]
fn velocity_300() {
    // Spec 2.2.12: SetValue1 = 300, Cmd = 23.
    let mut b = Bench::new();
    let image = b.start(1, Action::Velocity { speed: 300 });
    assert_eq!(bytes(image), [0x2C, 0x01, 0, 0, 0, 0, 0, 23]);
}

#[test]
fn torque_500_with_max_speed_100() {
    // Spec 2.2.13: SetValue2 = 100, SetValue1 = 500, Cmd = 25.
    let mut b = Bench::new();
    let image = b.start(
        1,
        Action::Torque {
            torque: 500,
            max_speed: 100,
        },
    );
    assert_eq!(bytes(image), [0xF4, 0x01, 0, 0, 100, 0, 0, 25]);
}

#[test]
fn halt_84_then_20_resumes_the_old_target() {
    // Spec 2.2.14, first example.
    let mut b = Bench::new();
    let first = b.start(1, move_to(2000, 200));
    assert_eq!(first.cmd, 20);
    b.detect(&[StatusBit::OperationEnabled], 0);
    let halt = b.master.halt(2, b.now).unwrap();
    assert_eq!(halt.cmd, 84);
    assert_eq!(halt.values, first.values);
    assert_eq!(
        b.master.drain_progress(),
        vec![Progress::Superseded {
            tag: 1,
            acknowledged: true
        }]
    );
    // The drive brakes: QsHaltBit first, TargetReached once it stands still.
    b.tick(10);
    let progress = b.answer(&[StatusBit::OperationEnabled, StatusBit::QsHaltBit], 800);
    assert_eq!(progress, vec![Progress::Accepted { tag: 2 }]);
    b.tick(10);
    let stopped = [
        StatusBit::OperationEnabled,
        StatusBit::QsHaltBit,
        StatusBit::TargetReached,
    ];
    b.tick(200);
    let progress = b.answer(&stopped, 900);
    assert_eq!(progress, vec![done(2, 900)]);
    let resume = b.master.resume(3, b.now).unwrap();
    assert_eq!(resume.cmd, 20);
    assert_eq!(resume.values, first.values);
    let progress = b.answer(&[StatusBit::OperationEnabled], 950);
    assert_eq!(progress, vec![Progress::Accepted { tag: 3 }]);
    let progress = b.answer(
        &[StatusBit::OperationEnabled, StatusBit::TargetReached],
        2000,
    );
    assert_eq!(progress, vec![done(3, 2000)]);
}

#[test]
fn halt_84_then_new_target_and_148() {
    // Spec 2.2.14, second example.
    let mut b = Bench::new();
    b.start(1, move_to(2000, 200));
    b.detect(&[StatusBit::OperationEnabled], 0);
    assert_eq!(b.master.halt(2, b.now).unwrap().cmd, 84);
    b.answer(&[StatusBit::OperationEnabled, StatusBit::QsHaltBit], 500);
    let image = b.start(3, move_to(5000, 200));
    assert_eq!(image.cmd, 148);
    assert_eq!(image.values.value1, 5000);
    assert!(!b.master.is_halted());
}

#[test]
fn three_relative_moves_21_149_21() {
    // Spec 2.2.15.
    let mut b = Bench::new();
    let mut sent = vec![];
    for tag in 0..3 {
        let image = b.start(tag, move_by(2000, 200));
        sent.push(image.cmd);
        b.detect(&[StatusBit::OperationEnabled], 0);
    }
    assert_eq!(sent, [21, 149, 21]);
}

#[test]
fn a_refused_command_reports_the_abort_code_and_its_text() {
    let mut b = Bench::new();
    b.start(1, od_read(0x2FFF, 0));
    let progress = b.detect(&[StatusBit::Error], 0x0602_0000);
    let failure = Failure::Refused { code: 0x0602_0000 };
    assert_eq!(progress, vec![Progress::Failed { tag: 1, failure }]);
    assert_eq!(failure.abort_text(), AbortCode::NO_OBJECT.text());
    assert_eq!(
        failure.to_string(),
        "refused by the drive (PdiStatusError): ReturnValue 06020000h: Object does not exist in the object dictionary"
    );
    // Error codes that are not abort codes are shown as u32 hex.
    assert_eq!(
        Failure::Refused { code: 0xFFFF_FFFE }.to_string(),
        "refused by the drive (PdiStatusError): ReturnValue FFFFFFFEh (not a CiA 301 abort code)"
    );
}

#[test]
fn no_acknowledgement_times_out() {
    let mut b = Bench::new();
    b.master.adopt(RxImage::default());
    b.start(1, Action::SwitchOff);
    b.tick(999);
    b.master.poll(b.now);
    assert_eq!(b.master.drain_progress(), vec![]);
    b.tick(1);
    b.master.poll(b.now);
    assert_eq!(
        b.master.drain_progress(),
        vec![Progress::TimedOut {
            tag: 1,
            waiting_for: Waiting::Acknowledgement,
            after: Duration::from_millis(1000)
        }]
    );
}

#[test]
fn unknown_device_byte_is_resent_with_the_toggle_flipped() {
    // Without adopting the drive's image the master cannot know whether the drive already
    // holds our byte; it flips ToggleCmd once if no acknowledgement comes.
    let mut b = Bench::new();
    let image = b.start(1, Action::Velocity { speed: 10 });
    assert_eq!(image.cmd, 23);
    b.tick(500);
    b.master.poll(b.now);
    assert_eq!(b.master.drain_progress(), vec![Progress::Resent { tag: 1 }]);
    assert_eq!(b.master.outgoing().map(|rx| rx.cmd), Some(23 | 0x80));
    assert_eq!(b.detect(&[], 0), vec![Progress::Accepted { tag: 1 }]);
}

#[test]
fn clear_error_with_the_cause_still_present_fails() {
    let mut b = Bench::new();
    b.start(1, Action::ClearError);
    assert_eq!(
        b.detect(&[StatusBit::Fault], 0),
        vec![Progress::Accepted { tag: 1 }]
    );
    b.tick(200);
    let progress = b.answer(&[StatusBit::Fault], 0);
    assert!(matches!(
        progress.as_slice(),
        [Progress::Failed {
            tag: 1,
            failure: Failure::FaultPersists { .. }
        }]
    ));
}

#[test]
fn a_fault_during_a_move_fails_it() {
    let mut b = Bench::new();
    b.start(1, move_by(100, 10));
    b.detect(&[StatusBit::OperationEnabled], 0);
    let mut status = Status(0)
        .with(StatusBit::Fault, true)
        .with(StatusBit::ToggleCmd, b.toggle);
    status = status.with(StatusBit::FollowingError, true);
    b.master.on_tx(
        TxImage {
            status,
            error_code: 0x8611,
            return_value: 0,
        },
        b.now,
    );
    assert_eq!(
        b.master.drain_progress(),
        vec![Progress::Failed {
            tag: 1,
            failure: Failure::DriveFault { error_code: 0x8611 }
        }]
    );
}

#[test]
fn halt_without_a_travel_command_is_an_error() {
    let mut b = Bench::new();
    assert_eq!(b.master.halt(1, b.now), Err(Error::NoTravel));
    b.start(1, Action::Velocity { speed: 5 });
    assert_eq!(b.master.resume(2, b.now), Err(Error::NotHalted));
}

#[test]
fn commands_need_a_status_first() {
    let mut master = PdiMaster::new(Timing::default());
    assert_eq!(
        master.start(1, Action::Nop, Instant::now()),
        Err(Error::NoStatusYet)
    );
}

#[test]
fn a_move_stays_watched_while_an_od_read_runs_under_it() {
    let mut b = Bench::new();
    b.start(1, move_to(900, 100));
    b.detect(&[StatusBit::OperationEnabled], 0);
    b.start(2, od_read(0x6064, 0));
    assert_eq!(b.master.drain_progress(), vec![]);
    assert_eq!(b.master.background_tag(), Some(1));
    // The read fails; the move is not affected by that PdiStatusError.
    let progress = b.detect(
        &[StatusBit::OperationEnabled, StatusBit::Error],
        0x0602_0000,
    );
    assert_eq!(
        progress,
        vec![Progress::Failed {
            tag: 2,
            failure: Failure::Refused { code: 0x0602_0000 }
        }]
    );
    let progress = b.answer(&[StatusBit::OperationEnabled, StatusBit::TargetReached], 0);
    assert_eq!(progress, vec![done(1, 0)]);
    // A new move, by contrast, supersedes the watched one.
    b.start(3, move_to(0, 100));
    b.detect(&[StatusBit::OperationEnabled], 0);
    b.start(4, od_read(0x6064, 0));
    b.start(5, Action::Quickstop);
    let progress = b.master.drain_progress();
    assert!(
        progress.contains(&Progress::Superseded {
            tag: 3,
            acknowledged: true
        }),
        "{progress:?}"
    );
    assert!(
        progress.contains(&Progress::Superseded {
            tag: 4,
            acknowledged: false
        }),
        "{progress:?}"
    );
}

#[test]
fn an_adopted_travel_command_can_be_halted() {
    let mut b = Bench::new();
    b.master.adopt(RxImage {
        values: SetValues {
            value1: 5000,
            value2: 150,
            value3: 0,
        },
        cmd: 20 | 0x80,
    });
    let halt = b.master.halt(1, b.now).unwrap();
    assert_eq!(halt.cmd, 20 | 0x40 | 0x80);
    assert_eq!(halt.values.value1, 5000);
}

#[test]
fn a_command_the_drive_takes_from_another_master_fails_the_running_move_and_is_counted() {
    let mut bench = Bench::new();
    bench.start(1, move_by(30_000, 100));
    // Our move acknowledged: one flip, expected.
    assert_eq!(
        bench.detect(&[StatusBit::OperationEnabled], 0),
        vec![Progress::Accepted { tag: 1 }]
    );
    bench.tick(10);
    assert!(bench.answer(&[StatusBit::OperationEnabled], 0).is_empty());
    // Another master writes its own command: the status toggle flips on its own.
    bench.tick(10);
    let said = bench.detect(&[StatusBit::OperationEnabled], 0);
    assert_eq!(
        said,
        vec![Progress::Failed {
            tag: 1,
            failure: Failure::AnotherMaster { flips: 1 }
        }]
    );
    assert!(
        Failure::AnotherMaster { flips: 1 }
            .to_string()
            .starts_with("another master writes the PDI image")
    );
    // It writes every cycle: every flip is counted, idle or not.
    bench.tick(10);
    bench.detect(&[StatusBit::OperationEnabled], 0);
    assert_eq!(bench.master.take_foreign(), 2);
    assert_eq!(bench.master.take_foreign(), 0);
}

#[test]
fn our_own_commands_halts_and_a_resend_are_never_taken_for_another_master() {
    let mut bench = Bench::new();
    for tag in 1..=3 {
        bench.start(tag, move_by(1000, 100));
        bench.tick(5);
        bench.detect(&[StatusBit::OperationEnabled], 0);
        bench.tick(5);
        bench.answer(&[StatusBit::OperationEnabled], 0);
    }
    // Two commands sent before the first is seen: the drive may take both.
    bench.start(4, move_by(1000, 100));
    bench.start(5, od_read(0x6064, 0));
    bench.detect(&[StatusBit::OperationEnabled], 0);
    bench.detect(&[StatusBit::OperationEnabled], 0);
    // A halt that a drive counts as a new command.
    bench.master.halt(6, bench.now).unwrap();
    bench.detect(&[StatusBit::OperationEnabled, StatusBit::QsHaltBit], 0);
    assert_eq!(bench.master.take_foreign(), 0);
    // After a link loss the toggle is judged afresh.
    bench.master.abandon();
    bench.detect(&[StatusBit::OperationEnabled], 0);
    assert_eq!(bench.master.take_foreign(), 0);
}

#[test]
fn an_image_read_back_that_is_not_ours_is_another_masters() {
    let mut bench = Bench::new();
    bench.master.adopt(RxImage::default());
    let ours = bench.start(1, move_by(30_000, 100));
    bench.detect(&[StatusBit::OperationEnabled], 0);
    // Ours, and the one before it (a bus that applies images late), are no verdict.
    assert!(bench.master.read_back_due(bench.now));
    bench.master.on_read_back(ours, bench.now);
    bench.master.on_read_back(RxImage::default(), bench.now);
    assert!(bench.master.drain_progress().is_empty());
    // Not due again until a while later.
    assert!(!bench.master.read_back_due(bench.now));
    bench.tick(300);
    assert!(bench.master.read_back_due(bench.now));
    // Another master's move: the running move fails, and it is counted.
    let theirs = RxImage::new(
        SetValues {
            value1: -5000,
            value2: 300,
            value3: 0,
        },
        Command {
            opcode: Opcode::MoveAbsolute,
            halt: false,
            toggle: false,
        },
    );
    bench.master.on_read_back(theirs, bench.now);
    assert_eq!(
        bench.master.drain_progress(),
        vec![Progress::Failed {
            tag: 1,
            failure: Failure::AnotherMaster { flips: 1 }
        }]
    );
    assert_eq!(bench.master.foreign_report(bench.now), Some(1));
    // Reported at most every few seconds.
    bench.master.on_read_back(theirs, bench.now);
    assert_eq!(bench.master.foreign_report(bench.now), None);
}
