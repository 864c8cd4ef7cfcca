//! The simulated drive's NanoJ program (protocol notes §4.6): a small built-in program in
//! place of a NanoJ binary, run from 2300h with the vendor's start delay, reporting in
//! 2301h/2302h, named in 2304h, its mapping in 2310h/2320h.
//!
//! What the program does, once a millisecond while it runs:
//! * NanoJ output 1 (2500h:01) = NanoJ input 1 (2400h:01);
//! * NanoJ output 2 counts its cycles;
//! * while NanoJ input 2 is not 0 and the power stage is on, it drives the motor back and
//!   forth (a velocity of 60 rpm, the direction turned every second); when input 2 goes
//!   back to 0 it stops the motor;
//! * NanoJ input 3 (2400h:03) not 0 is the injectable error: the program "runs too long
//!   without yield()" and stops with 2302h = 5 (or the code written there, 1 to 7, so that
//!   every documented error can be shown).

use std::time::Duration;

use super::{Activity, Drive};
use crate::cia::PowerState;

/// How long the program takes to start ("may take up to 200 ms" in the vendor's library).
pub const START_DELAY: Duration = Duration::from_millis(200);
/// The program's name in 2304h ("demo.usr": two u32 of ASCII, little-endian).
pub const PROGRAM: &str = "demo.usr";
/// How fast and how often the program turns the motor round.
const SPEED_RPM: f64 = 60.0;
const TURN_EVERY: Duration = Duration::from_secs(1);

/// Where the program stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum Program {
    #[default]
    Stopped,
    /// Started; running from then (the drive's own time).
    Starting(Duration),
    Running,
    /// Stopped by an error (2302h).
    Failed(u32),
}

/// The program's state besides where it stands.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct NanoJ {
    pub(super) program: Program,
    cycles: u32,
    /// When the motor's direction last turned, and which way it goes (+1/−1).
    turned_at: Duration,
    direction: f64,
    /// The program has the motor turning (so it stops it when input 2 goes to 0).
    driving: bool,
}

impl Drive {
    /// A write to 2300h (NanoJ Control): bit 0 starts (1) or stops (0) the program.
    pub(super) fn nanoj_control(&mut self, value: i64) {
        let start = value & 1 == 1;
        match (start, self.nanoj.program) {
            (true, Program::Stopped | Program::Failed(_)) => {
                self.nanoj.program = Program::Starting(self.time + START_DELAY);
                self.od.set_int(0x2302, 0, 0);
            }
            (false, _) => {
                self.stop_program();
                self.nanoj.program = Program::Stopped;
            }
            _ => {}
        }
    }

    /// One millisecond of the program.
    pub(super) fn step_nanoj(&mut self) {
        match self.nanoj.program {
            Program::Starting(at) if self.time >= at => {
                self.nanoj.program = Program::Running;
                self.nanoj.cycles = 0;
                self.nanoj.turned_at = self.time;
                self.nanoj.direction = 1.0;
            }
            Program::Running => self.run_cycle(),
            _ => {}
        }
    }

    fn run_cycle(&mut self) {
        let error = self.od.int(0x2400, 3);
        if error != 0 {
            let code = if (1..=7).contains(&error) { error } else { 5 };
            self.stop_program();
            self.nanoj.program = Program::Failed(code as u32);
            self.od.set_int(0x2302, 0, code);
            return;
        }
        let input = self.od.int(0x2400, 1);
        self.od.set_int(0x2500, 1, input);
        self.nanoj.cycles = self.nanoj.cycles.wrapping_add(1);
        self.od
            .set_int(0x2500, 2, i64::from(self.nanoj.cycles as i32));
        let moving = self.od.int(0x2400, 2) != 0 && self.state == PowerState::OperationEnabled;
        if moving {
            if !self.nanoj.driving || self.time >= self.nanoj.turned_at + TURN_EVERY {
                if self.nanoj.driving {
                    self.nanoj.direction = -self.nanoj.direction;
                }
                self.nanoj.turned_at = self.time;
                self.nanoj.driving = true;
                self.activity = Activity::Velocity {
                    speed_rpm: SPEED_RPM * self.nanoj.direction,
                };
            }
        } else if self.nanoj.driving {
            self.stop_program_motion();
        }
    }

    /// The program stops: a motion it started is brought to a stop.
    fn stop_program(&mut self) {
        if self.nanoj.driving {
            self.stop_program_motion();
        }
    }

    fn stop_program_motion(&mut self) {
        self.nanoj.driving = false;
        if matches!(self.activity, Activity::Velocity { .. }) {
            self.activity = Activity::Velocity { speed_rpm: 0.0 };
        }
    }

    /// 2301h as the drive reports it: 0 stopped, 1 running, 2 stopped by an error.
    pub(super) fn nanoj_status(&self) -> i64 {
        match self.nanoj.program {
            Program::Stopped | Program::Starting(_) => 0,
            Program::Running => 1,
            Program::Failed(_) => 2,
        }
    }
}

/// The program table (2304h): the name as u32 pairs of ASCII, little-endian.
pub fn program_words(name: &str) -> Vec<u32> {
    name.as_bytes()
        .chunks(4)
        .map(|c| {
            let mut word = [0u8; 4];
            word[..c.len()].copy_from_slice(c);
            u32::from_le_bytes(word)
        })
        .collect()
}
