//! The PDI interpreter (2291h:04h commands) and the CiA 402 controlword.

use std::time::Duration;

use super::{Activity, Drive, ReturnMode};
use crate::cia::{AbortCode, ErrorCode, PowerState, power_state::controlword};
use crate::injection::Injection;
use crate::od::{Address, DataType, Value};
use crate::pdi::{
    Command, Opcode, PDI_INPUT, PDI_OUTPUT, SetValues, set_value2_to_index, set_value3_to_subindex,
};
use crate::sim::homing::HomingRun;
use crate::sim::motion::{Demand, rpm_to_units};

impl Drive {
    /// Whether the PDI is active (2290h bit 0, on from the factory).
    pub fn pdi_active(&self) -> bool {
        self.od.int(0x2290, 0) & 1 != 0
    }

    pub(super) fn on_command_byte(&mut self, byte: u8) {
        if !self.pdi_active() {
            // PDI-Ctrl off: 2291h is a plain object, no command runs, nothing toggles.
            self.last_cmd = byte;
            return;
        }
        let last = self.last_cmd;
        self.last_cmd = byte;
        let new_command = byte & !Command::HALT_BIT != last & !Command::HALT_BIT;
        let halt_changed = (byte ^ last) & Command::HALT_BIT != 0;
        if new_command {
            self.status_toggle = !self.status_toggle;
            self.pdi_error = false;
            match Command::from_byte(byte) {
                Ok(command) => self.execute(command),
                Err(_) => self.refuse(AbortCode::VALUE_RANGE),
            }
        } else if halt_changed && self.travel_active() {
            self.halted = byte & Command::HALT_BIT != 0;
            self.in_window_for = Duration::ZERO;
        }
    }

    pub(super) fn refuse(&mut self, code: AbortCode) {
        self.pdi_error = true;
        self.return_mode = ReturnMode::Fixed(code.0 as i32);
    }

    pub(super) fn travel_active(&self) -> bool {
        matches!(
            self.activity,
            Activity::Position { .. } | Activity::Velocity { .. } | Activity::Torque { .. }
        ) && self.state == PowerState::OperationEnabled
    }

    fn execute(&mut self, command: Command) {
        let values = self.set_values();
        match command.opcode {
            Opcode::Nop => {}
            Opcode::SwitchOff => self.switch_off(),
            Opcode::ClearError => self.clear_error(),
            Opcode::Quickstop => self.quickstop(),
            Opcode::OdRead => self.pdi_od_read(values),
            Opcode::OdWrite => self.pdi_od_write(values),
            Opcode::AutoSetup => self.start_auto_setup(),
            Opcode::HomeHere => self.home_here(values),
            Opcode::Homing => self.start_homing(values),
            Opcode::MoveAbsolute | Opcode::MoveRelative => self.start_move(command, values),
            Opcode::Velocity => self.start_velocity(command.halt, values),
            Opcode::Torque => self.start_torque(command.halt, values),
        }
    }

    fn switch_off(&mut self) {
        if self.state != PowerState::Fault {
            self.state = PowerState::SwitchOnDisabled;
        }
        self.activity = Activity::Idle;
        self.halted = false;
        self.quick_stop = None;
        self.return_mode = ReturnMode::Position;
    }

    fn start_auto_setup(&mut self) {
        if self.energise() {
            self.autosetup_done = false;
            self.set_mode(-2);
            self.activity = Activity::AutoSetup {
                elapsed: Duration::ZERO,
                centre: self.demand.position,
            };
            self.return_mode = ReturnMode::Position;
        }
    }

    /// The load's position becomes SetValue1.
    fn home_here(&mut self, values: SetValues) {
        self.offset = self.x - f64::from(values.value1);
        self.demand.position = self.x;
        self.homing_done = true;
        self.return_mode = ReturnMode::Position;
        if matches!(self.activity, Activity::Position { .. }) {
            self.activity = Activity::Idle;
        }
    }

    /// Homing with the method in SetValue3.
    fn start_homing(&mut self, values: SetValues) {
        let method = values.value3;
        let Some(run) = HomingRun::new(method, self.world.sensors(self.x)) else {
            self.refuse(AbortCode::VALUE_RANGE);
            return;
        };
        if !self.energise() {
            return;
        }
        self.od.set_int(0x6098, 0, i64::from(method));
        self.set_mode(6);
        self.homing_done = false;
        self.return_mode = ReturnMode::Position;
        if run.is_immediate() {
            self.home_at(self.x);
            self.homing_done = true;
            self.activity = Activity::Idle;
        } else {
            self.activity = Activity::Homing { run, found: None };
        }
    }

    /// Move absolute or relative: SetValue1 the position, SetValue2 the speed.
    fn start_move(&mut self, command: Command, values: SetValues) {
        if !self.energise() {
            return;
        }
        let base = match (&self.activity, command.opcode) {
            (_, Opcode::MoveAbsolute) => 0,
            (Activity::Position { target, .. }, _) => *target,
            _ => self.position().round() as i64,
        };
        let target = base + i64::from(values.value1);
        self.od.set_int(0x607A, 0, target);
        self.od
            .set_int(0x6081, 0, i64::from(values.value2.unsigned_abs()));
        self.set_mode(1);
        self.activity = Activity::Position {
            target,
            speed_rpm: f64::from(values.value2.unsigned_abs()),
        };
        self.start_travel(command.halt, ReturnMode::Position);
    }

    /// Velocity mode: SetValue1 the speed.
    fn start_velocity(&mut self, halt: bool, values: SetValues) {
        if !self.energise() {
            return;
        }
        self.od.set_int(0x60FF, 0, i64::from(values.value1));
        self.set_mode(3);
        self.activity = Activity::Velocity {
            speed_rpm: f64::from(values.value1),
        };
        self.start_travel(halt, ReturnMode::Velocity);
    }

    /// Profile Torque: SetValue1 the torque (limited by 6072h), SetValue2 the top speed.
    fn start_torque(&mut self, halt: bool, values: SetValues) {
        if !self.energise() {
            return;
        }
        let max = self.od.int(0x6072, 0) as f64;
        let torque = f64::from(values.value1).clamp(-max, max);
        self.od.set_int(0x6071, 0, torque as i64);
        self.set_mode(4);
        self.torque_demand = self.torque;
        self.activity = Activity::Torque {
            torque,
            max_speed_rpm: f64::from(values.value2.unsigned_abs()),
        };
        self.start_travel(halt, ReturnMode::Torque);
    }

    fn start_travel(&mut self, halt: bool, mode: ReturnMode) {
        self.halted = halt;
        self.limit_stop = false;
        self.in_window_for = Duration::ZERO;
        self.return_mode = mode;
    }

    /// Switch the power stage on for a command that moves. Refused while a fault is active.
    fn energise(&mut self) -> bool {
        if matches!(
            self.state,
            PowerState::Fault | PowerState::FaultReactionActive
        ) {
            self.refuse(AbortCode::DEVICE_STATE);
            return false;
        }
        if self.state != PowerState::OperationEnabled {
            // Take over the load where it is, without a jump.
            self.demand = Demand {
                position: self.x,
                velocity: self.v,
            };
        }
        self.state = PowerState::OperationEnabled;
        self.quick_stop = None;
        true
    }

    pub(super) fn set_mode(&mut self, mode: i64) {
        self.od.set_int(0x6060, 0, mode);
        self.od.set_int(0x6061, 0, mode);
    }

    fn clear_error(&mut self) {
        if matches!(
            self.state,
            PowerState::Fault | PowerState::FaultReactionActive
        ) {
            if self.fault_cause_present() {
                return;
            }
            self.state = PowerState::SwitchOnDisabled;
            self.activity = Activity::Idle;
        }
        self.error_code = ErrorCode::NONE;
        self.following_error = false;
        self.following_error_for = Duration::ZERO;
        if !self.injected.contains(&Injection::OverTemperature) {
            self.warning = None;
        }
        self.od.set_int(0x1001, 0, 0);
    }

    fn quickstop(&mut self) {
        let option = self.od.int(0x605A, 0);
        let slow = rpm_to_units(self.od.int(0x6084, 0) as f64);
        let quick = rpm_to_units(self.od.int(0x6085, 0) as f64);
        self.halted = false;
        if self.state != PowerState::OperationEnabled {
            return;
        }
        self.activity = Activity::Idle;
        match option {
            0 => self.state = PowerState::SwitchOnDisabled,
            1 => self.quick_stop = Some((slow, true)),
            5 => self.quick_stop = Some((slow, false)),
            6 => self.quick_stop = Some((quick, false)),
            _ => self.quick_stop = Some((quick, true)),
        }
        if self.quick_stop.is_some() {
            self.state = PowerState::QuickStopActive;
        }
        self.return_mode = ReturnMode::Position;
    }

    fn pdi_od_read(&mut self, values: SetValues) {
        let address = Address::new(
            set_value2_to_index(values.value2),
            set_value3_to_subindex(values.value3),
        );
        self.publish();
        let result = self.read_typed(address).and_then(|(value, dtype)| {
            value
                .to_pdi(dtype)
                .map_err(|_| AbortCode::TYPE_LENGTH_TOO_HIGH)
        });
        match result {
            Ok(raw) => self.return_mode = ReturnMode::Fixed(raw),
            Err(code) => self.refuse(code),
        }
    }

    fn pdi_od_write(&mut self, values: SetValues) {
        let address = Address::new(
            set_value2_to_index(values.value2),
            set_value3_to_subindex(values.value3),
        );
        if address.index == PDI_INPUT || address.index == PDI_OUTPUT {
            // Writing the PDI's own objects through the PDI would replace this command.
            self.refuse(AbortCode::DEVICE_STATE);
            return;
        }
        let Some(dtype) = self.od.entry(address).map(|e| e.dtype) else {
            let code = match self.od.read(address) {
                Err(code) => code,
                Ok(_) => AbortCode::NO_OBJECT,
            };
            self.refuse(code);
            return;
        };
        if !dtype.fits_pdi() {
            self.refuse(AbortCode::TYPE_LENGTH_TOO_HIGH);
            return;
        }
        let raw = values.value1;
        // Unsigned objects take SetValue1's bits; signed ones its value.
        let wide = if dtype.is_signed() {
            i128::from(raw)
        } else {
            i128::from(raw as u32)
        };
        let value = if dtype == DataType::Real32 {
            Ok(Value::Real(f64::from(f32::from_bits(raw as u32))))
        } else {
            Value::from_i128(dtype, wide)
        };
        let result = value
            .map_err(|_| AbortCode::VALUE_RANGE)
            .and_then(|v| self.write(address, v));
        match result {
            Ok(()) => self.return_mode = ReturnMode::Fixed(raw),
            Err(code) => self.refuse(code),
        }
    }

    /// CiA 402 controlword: the power state machine's transitions (device-control
    /// commands only; the PDI is this simulator's way to move).
    pub(super) fn on_controlword(&mut self, word: u16) {
        use PowerState::*;
        if matches!(self.state, Fault | FaultReactionActive) {
            if word & controlword::FAULT_RESET != 0 {
                self.clear_error();
            }
            return;
        }
        let wanted = match word & 0x0F {
            w if w & 0x02 == 0 => SwitchOnDisabled,
            w if w & 0x04 == 0 => QuickStopActive,
            w if w & 0x01 == 0 => ReadyToSwitchOn,
            w if w & 0x08 == 0 => SwitchedOn,
            _ => OperationEnabled,
        };
        let allowed = match (self.state, wanted) {
            (_, SwitchOnDisabled) => true,
            (OperationEnabled, QuickStopActive) => {
                self.quickstop();
                return;
            }
            (_, QuickStopActive) => {
                self.state = SwitchOnDisabled;
                false
            }
            (SwitchOnDisabled | SwitchedOn | OperationEnabled, ReadyToSwitchOn) => true,
            (ReadyToSwitchOn | OperationEnabled, SwitchedOn) => true,
            (SwitchedOn | QuickStopActive, OperationEnabled) => true,
            _ => false,
        };
        if allowed && wanted != self.state {
            if wanted == OperationEnabled {
                self.demand = Demand {
                    position: self.x,
                    velocity: self.v,
                };
            }
            if matches!(wanted, SwitchOnDisabled | ReadyToSwitchOn | SwitchedOn) {
                self.activity = Activity::Idle;
            }
            self.state = wanted;
        }
        self.halted = word & controlword::HALT != 0 && self.travel_active();
    }

    pub(super) fn home_at(&mut self, world_x: f64) {
        let home_offset = self.od.int(0x607C, 0) as f64;
        // The position counter reads the home offset at the home point.
        self.offset = world_x - home_offset;
    }
}
