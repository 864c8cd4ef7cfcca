//! What the drive reports: PDI-Status, statusword, return value, and their objects.

use super::{Drive, ReturnMode, STANDSTILL};
use crate::cia::{ErrorCode, PowerState, power_state::controlword};
use crate::injection::Injection;
use crate::pdi::{Status, StatusBit};
use crate::sim::motion::units_to_rpm;

impl Drive {
    pub(super) fn reported_error_code(&self) -> ErrorCode {
        if self.state == PowerState::Fault {
            self.error_code
        } else {
            self.warning.unwrap_or(ErrorCode::NONE)
        }
    }

    /// PDI-Status, derived from the state.
    pub fn pdi_status(&self) -> Status {
        let faulted = matches!(
            self.state,
            PowerState::Fault | PowerState::FaultReactionActive
        );
        let sensors = self.switches();
        Status(0)
            .with(
                StatusBit::OperationEnabled,
                self.state == PowerState::OperationEnabled,
            )
            .with(StatusBit::Warning, self.warning.is_some())
            .with(StatusBit::Fault, faulted)
            .with(StatusBit::TargetReached, self.target_reached())
            .with(StatusBit::FollowingError, self.following_error)
            .with(
                StatusBit::LimitReached,
                sensors.negative_limit || sensors.positive_limit,
            )
            .with(
                StatusBit::QsHaltBit,
                self.state == PowerState::QuickStopActive || (self.halted && self.travel_active()),
            )
            .with(StatusBit::HomingDone, self.homing_done)
            .with(StatusBit::AutosetupDone, self.autosetup_done)
            .with(StatusBit::ToggleCmd, self.status_toggle)
            .with(StatusBit::Error, self.pdi_error)
    }

    pub(super) fn return_value(&self) -> i32 {
        match self.return_mode {
            ReturnMode::Position => self.position().round() as i32,
            ReturnMode::Velocity => self.velocity_rpm().round() as i32,
            ReturnMode::Torque => self.torque.round() as i32,
            ReturnMode::Fixed(v) => v,
        }
    }

    /// The CiA 402 statusword 6041h, consistent with the PDI state.
    pub fn statusword(&self) -> u16 {
        let sensors = self.switches();
        let mut word = self.state.statusword_bits();
        if !self.injected.contains(&Injection::UnderVoltage) {
            word |= 1 << 4;
        }
        if self.warning.is_some() {
            word |= 1 << 7;
        }
        word |= 1 << 9; // remote: the fieldbus is in control
        if self.target_reached() {
            word |= 1 << 10;
        }
        if sensors.negative_limit || sensors.positive_limit {
            word |= 1 << 11;
        }
        match self.od.int(0x6061, 0) {
            1 if self.following_error => {
                word |= 1 << 13;
            }
            3 if self.v.abs() < STANDSTILL => {
                word |= 1 << 12;
            }
            6 if self.homing_done => {
                word |= 1 << 12;
            }
            _ => {}
        }
        word
    }

    /// Copy the live state into the objects a master can read.
    pub(super) fn publish(&mut self) {
        let tx = self.tx_image();
        let statusword = self.statusword();
        let inputs = self.digital_inputs();
        let levels = self.input_levels();
        let nanoj = self.nanoj_status();
        let od = &mut self.od;
        // 2292h:01, 603Fh, 2292h:02 (TX_OBJECTS).
        for (object, value) in tx.object_values() {
            od.set_int(object.index, object.sub, value);
        }
        od.set_int(0x6041, 0, i64::from(statusword));
        let position = (self.x - self.offset).round() as i64;
        od.set_int(0x6064, 0, position);
        let rpm = units_to_rpm(self.v);
        od.set_int(0x606C, 0, rpm.round() as i64);
        od.set_int(0x6044, 0, rpm.round() as i64);
        od.set_int(0x6077, 0, self.torque.round() as i64);
        od.set_int(0x6078, 0, self.torque.round() as i64);
        let deviation = if self.state == PowerState::OperationEnabled {
            self.demand.position - self.x
        } else {
            0.0
        };
        od.set_int(0x60F4, 0, deviation.round() as i64);
        od.set_int(0x60FD, 0, i64::from(inputs));
        od.set_int(0x3240, 5, i64::from(levels));
        let rated = od.int(0x203B, 1) as f64;
        let current = self.torque * rated / 1000.0;
        od.set_int(0x2039, 2, current.round() as i64);
        od.set_int(0x2039, 5, current.abs().round() as i64);
        let supply = if self.injected.contains(&Injection::UnderVoltage) {
            9_000
        } else {
            24_000
        };
        od.set_int(0x4014, 1, supply);
        let temperature = if self.injected.contains(&Injection::OverTemperature) {
            850
        } else {
            350
        };
        od.set_int(0x4014, 3, temperature);
        let t = self.time.as_secs_f64();
        let analog = 500.0 + 100.0 * (std::f64::consts::TAU * t / 10.0).sin();
        od.set_int(0x3320, 1, analog.round() as i64);
        od.set_int(0x3220, 1, analog.round() as i64);
        od.set_int(0x230F, 0, self.time.as_secs() as i64);
        od.set_int(0x2301, 0, nanoj);
        let controlword = match self.state {
            PowerState::OperationEnabled => {
                controlword::ENABLE_OPERATION | if self.halted { controlword::HALT } else { 0 }
            }
            PowerState::QuickStopActive => controlword::QUICK_STOP,
            PowerState::ReadyToSwitchOn => controlword::SHUTDOWN,
            PowerState::SwitchedOn => controlword::SWITCH_ON,
            PowerState::Fault | PowerState::FaultReactionActive => od.int(0x6040, 0) as u16,
            _ => controlword::DISABLE_VOLTAGE,
        };
        // The drive's own value, like the rest: `set_int` (6040h is Unsigned16), so that
        // `Dictionary::changes` counts only what comes from outside.
        od.set_int(0x6040, 0, i64::from(controlword));
    }
}
