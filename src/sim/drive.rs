//! The simulated Nanotec drive: object dictionary, CiA 402 power states, the PDI command
//! interpreter, motion profiles, homing, auto setup, a load model and injectable faults.
//!
//! It runs on simulated time: `tick(dt)` advances it, so tests are deterministic. Every
//! access from outside goes through `read`/`write` (the object dictionary, with abort
//! codes) or `write_rx`/`tx_image` (the 8-byte PDI process images, which are the same
//! objects 2291h/2292h/603Fh).
//!
//! Assumptions where the vendor text is silent (drivedeck's own; [L] as in protocol
//! notes §0.2):
//! * A new command is detected when PDI-Cmd changes in any bit but the halt bit; a change
//!   of the halt bit alone halts or resumes the travel command and does not toggle
//!   PdiStatusToggleCmd.
//! * Non-travel commands (OD-Read, OD-Write, NOP) leave a running or halted travel
//!   command as it is.
//! * A new homing or auto setup clears HomingDone / AutosetupDone until it succeeds.
//! * A travel command while a fault is active is refused with PdiStatusError and
//!   08000022h ("present device state").
//! * A following error beyond 6065h/6066h only sets PdiStatusFollowingError and a warning
//!   when 3700h is -1 (factory: no reaction); 0, 1 or 2 make it a fault (8611h).

use std::collections::BTreeSet;
use std::time::Duration;

use crate::cia::{AbortCode, ErrorCode, HistoryEntry, PowerState, power_state::controlword};
use crate::od::{Address, Catalog, DataType, Value};
use crate::pdi::{
    Command, Opcode, RxImage, SetValues, Status, StatusBit, TxImage, set_value2_to_index,
    set_value3_to_subindex,
};

use super::dictionary::{Dictionary, wrap_integer};
use super::homing::{HomingRun, HomingStep};
use super::motion::{Demand, rpm_to_units, step_position, step_velocity, units_to_rpm};
use super::world::World;
use crate::injection::Injection;

/// The simulation step: every `tick` is cut into steps of at most this length.
pub const STEP: Duration = Duration::from_millis(1);

/// How long auto setup takes.
pub const AUTO_SETUP_TIME: Duration = Duration::from_secs(3);

/// Acceleration of the unloaded motor per ‰ of rated torque, units/s².
const TORQUE_GAIN: f64 = 50.0;
/// Viscous friction, 1/s.
const DAMPING: f64 = 0.3;
/// Coulomb friction, ‰ of rated torque.
const COULOMB: f64 = 20.0;
/// Time constant of the load following the demand, s.
const LOAD_LAG: f64 = 0.004;
/// Standstill threshold, units/s (0.1 rpm).
const STANDSTILL: f64 = 6.0;

/// What the drive is doing while energised.
#[derive(Clone, Debug)]
enum Activity {
    Idle,
    Position { target: i64, speed_rpm: f64 },
    Velocity { speed_rpm: f64 },
    Torque { torque: f64, max_speed_rpm: f64 },
    Homing { run: HomingRun, found: Option<f64> },
    AutoSetup { elapsed: Duration, centre: f64 },
}

/// What PDI-ReturnValue shows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ReturnMode {
    Position,
    Velocity,
    Torque,
    Fixed(i32),
}

/// The simulated drive.
#[derive(Clone, Debug)]
pub struct Drive {
    od: Dictionary,
    world: World,
    state: PowerState,
    activity: Activity,
    halted: bool,
    /// Quick stop: the deceleration to brake with and whether to switch off at standstill.
    quick_stop: Option<(f64, bool)>,
    /// Actual world position and velocity of the load, units and units/s.
    x: f64,
    v: f64,
    /// The drive's position counter is `x - offset`.
    offset: f64,
    demand: Demand,
    torque: f64,
    torque_demand: f64,
    // PDI
    last_cmd: u8,
    status_toggle: bool,
    pdi_error: bool,
    return_mode: ReturnMode,
    homing_done: bool,
    autosetup_done: bool,
    // Monitoring
    injected: BTreeSet<Injection>,
    error_code: ErrorCode,
    warning: Option<ErrorCode>,
    following_error_for: Duration,
    following_error: bool,
    in_window_for: Duration,
    limit_stop: bool,
    time: Duration,
}

impl Drive {
    /// A drive with the built-in catalog's dictionary and the default machine.
    pub fn new() -> Self {
        Self::with_catalog(crate::od::builtin(), World::default())
    }

    pub fn with_catalog(catalog: &Catalog, world: World) -> Self {
        let mut od = Dictionary::from_catalog(catalog);
        let text = |s: &str| Value::Text(s.to_owned());
        od.set(Address::new(0x1008, 0), text("drivedeck simulated drive"));
        od.set(Address::new(0x1009, 0), text("SIM-1"));
        od.set(
            Address::new(0x100A, 0),
            text(concat!("drivedeck-sim ", env!("CARGO_PKG_VERSION"))),
        );
        od.set(Address::new(0x4040, 0), text("SIM0000001234"));
        od.set(
            Address::new(0x4041, 0),
            Value::Bytes(vec![0x53, 0x49, 0x4D, 0x01]),
        );
        od.set(
            Address::new(0x6505, 0),
            text("https://github.com/drivedeck"),
        );
        let mut drive = Self {
            od,
            world,
            state: PowerState::SwitchOnDisabled,
            activity: Activity::Idle,
            halted: false,
            quick_stop: None,
            x: 0.0,
            v: 0.0,
            offset: 0.0,
            demand: Demand::default(),
            torque: 0.0,
            torque_demand: 0.0,
            last_cmd: 0,
            status_toggle: false,
            pdi_error: false,
            return_mode: ReturnMode::Position,
            homing_done: false,
            autosetup_done: false,
            injected: BTreeSet::new(),
            error_code: ErrorCode::NONE,
            warning: None,
            following_error_for: Duration::ZERO,
            following_error: false,
            in_window_for: Duration::ZERO,
            limit_stop: false,
            time: Duration::ZERO,
        };
        drive.publish();
        drive
    }

    /// The machine around the motor.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Time since power-on.
    pub fn time(&self) -> Duration {
        self.time
    }

    pub fn power_state(&self) -> PowerState {
        self.state
    }

    /// The position counter (6064h) as a float, for tests.
    pub fn position(&self) -> f64 {
        self.x - self.offset
    }

    /// The load's position in world coordinates (the machine's, independent of homing).
    pub fn world_position(&self) -> f64 {
        self.x
    }

    /// Actual velocity in rpm (606Ch), for tests.
    pub fn velocity_rpm(&self) -> f64 {
        units_to_rpm(self.v)
    }

    pub fn torque_permille(&self) -> f64 {
        self.torque
    }

    /// Put the load somewhere in world coordinates (tests and demos), at rest.
    pub fn place(&mut self, world_x: f64) {
        self.x = world_x;
        self.v = 0.0;
        self.demand = Demand {
            position: world_x,
            velocity: 0.0,
        };
        self.publish();
    }

    // ---------------------------------------------------------------- faults

    /// Inject a condition of the drive. (Link conditions belong to the link: ignored.)
    pub fn inject(&mut self, injection: Injection) {
        if injection.is_link() {
            return;
        }
        self.injected.insert(injection);
        if injection.is_fault() {
            self.raise_fault(
                injection.error_code(),
                injection.error_number(),
                injection.error_register(),
            );
        } else {
            self.warning = Some(injection.error_code());
            self.record_history(
                injection.error_code(),
                injection.error_number(),
                injection.error_register(),
            );
        }
        self.publish();
    }

    /// Withdraw an injected condition. A fault stays latched until Clear Error.
    pub fn withdraw(&mut self, injection: Injection) {
        self.injected.remove(&injection);
        if !injection.is_fault() && self.warning == Some(injection.error_code()) {
            self.warning = None;
        }
        self.publish();
    }

    /// The fieldbus master stopped talking (an EtherNet/IP I/O connection timed out): the
    /// drive stops and latches fault 8000h (fieldbus monitoring) with the communication
    /// bit in 1001h, until Clear Error.
    pub fn fieldbus_lost(&mut self) {
        self.raise_fault(ErrorCode::FIELDBUS_MONITORING, 0, 0x11);
        self.publish();
    }

    pub fn injected(&self) -> impl Iterator<Item = Injection> + '_ {
        self.injected.iter().copied()
    }

    fn raise_fault(&mut self, code: ErrorCode, number: u8, register: u8) {
        self.state = PowerState::Fault;
        self.error_code = code;
        self.activity = Activity::Idle;
        self.halted = false;
        self.quick_stop = None;
        self.torque_demand = 0.0;
        self.record_history(code, number, register);
    }

    fn record_history(&mut self, code: ErrorCode, number: u8, register: u8) {
        let count = self.od.int(0x1003, 0).clamp(0, 8) as u8;
        for sub in (1..8u8).rev() {
            let older = self.od.int(0x1003, sub);
            self.od.set_int(0x1003, sub + 1, older);
        }
        let entry = HistoryEntry {
            number,
            class: register,
            code,
        };
        self.od.set_int(0x1003, 1, i64::from(entry.to_raw()));
        self.od.set_int(0x1003, 0, i64::from((count + 1).min(8)));
        let reg = self.od.int(0x1001, 0) as u8 | register;
        self.od.set_int(0x1001, 0, i64::from(reg));
    }

    fn fault_cause_present(&self) -> bool {
        self.injected.iter().any(|i| i.is_fault())
    }

    // ---------------------------------------------------------------- object access

    /// Read an object as a master would (SDO, FC 43, CIP 32h…).
    pub fn read(&self, address: Address) -> Result<Value, AbortCode> {
        self.od.read(address)
    }

    /// The catalog entry behind an address, if the drive has it.
    pub fn entry(&self, address: Address) -> Option<&crate::od::Entry> {
        self.od.entry(address)
    }

    /// Every address the drive holds.
    pub fn addresses(&self) -> impl Iterator<Item = Address> + '_ {
        self.od.addresses()
    }

    /// Set an object as the drive itself would (no access check, no side effects): for the
    /// servers that configure communication objects, e.g. PDO COB-IDs from the node id.
    pub fn set_raw(&mut self, address: Address, value: Value) {
        self.od.set(address, value);
    }

    /// Write an object as a master would. Writes to 2291h:04h run the PDI command.
    pub fn write(&mut self, address: Address, value: Value) -> Result<(), AbortCode> {
        self.od.check_write(address, &value)?;
        match (address.index, address.sub) {
            (0x2291, 4) => {
                let byte = value.as_i128().unwrap_or(0) as u8;
                self.od.set(address, value);
                self.on_command_byte(byte);
            }
            (0x6040, 0) => {
                let word = value.as_i128().unwrap_or(0) as u16;
                self.od.set(address, value);
                self.on_controlword(word);
            }
            (0x1003, 0) => {
                if value.as_i128() != Some(0) {
                    return Err(AbortCode::VALUE_RANGE);
                }
                for sub in 0..=8 {
                    self.od.set_int(0x1003, sub, 0);
                }
            }
            (0x1010 | 0x1011, _) if address.sub > 0 => {
                let signature = if address.index == 0x1010 {
                    0x6576_6173
                } else {
                    0x6461_6F6C
                };
                if value.as_i128() != Some(signature) {
                    return Err(AbortCode::CANNOT_STORE);
                }
            }
            _ => self.od.set(address, value),
        }
        self.publish();
        Ok(())
    }

    /// The RX process image as a cyclic master writes it: set values first, then the
    /// command byte (so a new command always sees its own set values).
    pub fn write_rx(&mut self, rx: &RxImage) {
        self.od.set_int(0x2291, 1, i64::from(rx.values.value1));
        self.od.set_int(0x2291, 2, i64::from(rx.values.value2));
        self.od.set_int(0x2291, 3, i64::from(rx.values.value3));
        self.od.set_int(0x2291, 4, i64::from(rx.cmd as i8));
        self.on_command_byte(rx.cmd);
        self.publish();
    }

    /// The RX image the drive holds now (2291h), read back.
    pub fn rx_image(&self) -> RxImage {
        RxImage {
            values: self.set_values(),
            cmd: self.last_cmd,
        }
    }

    /// The TX process image: PDI-Status, 603Fh, PDI-ReturnValue.
    pub fn tx_image(&self) -> TxImage {
        TxImage {
            status: self.pdi_status(),
            error_code: self.reported_error_code().0,
            return_value: self.return_value(),
        }
    }

    fn set_values(&self) -> SetValues {
        SetValues {
            value1: self.od.int(0x2291, 1) as i32,
            value2: self.od.int(0x2291, 2) as i16,
            value3: self.od.int(0x2291, 3) as i8,
        }
    }

    // ---------------------------------------------------------------- PDI interpreter

    /// Whether the PDI is active (2290h bit 0, on from the factory).
    pub fn pdi_active(&self) -> bool {
        self.od.int(0x2290, 0) & 1 != 0
    }

    fn on_command_byte(&mut self, byte: u8) {
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

    fn refuse(&mut self, code: AbortCode) {
        self.pdi_error = true;
        self.return_mode = ReturnMode::Fixed(code.0 as i32);
    }

    fn travel_active(&self) -> bool {
        matches!(
            self.activity,
            Activity::Position { .. } | Activity::Velocity { .. } | Activity::Torque { .. }
        ) && self.state == PowerState::OperationEnabled
    }

    fn execute(&mut self, command: Command) {
        let values = self.set_values();
        match command.opcode {
            Opcode::Nop => {}
            Opcode::SwitchOff => {
                if self.state != PowerState::Fault {
                    self.state = PowerState::SwitchOnDisabled;
                }
                self.activity = Activity::Idle;
                self.halted = false;
                self.quick_stop = None;
                self.return_mode = ReturnMode::Position;
            }
            Opcode::ClearError => self.clear_error(),
            Opcode::Quickstop => self.quickstop(),
            Opcode::OdRead => self.pdi_od_read(values),
            Opcode::OdWrite => self.pdi_od_write(values),
            Opcode::AutoSetup => {
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
            Opcode::HomeHere => {
                self.offset = self.x - f64::from(values.value1);
                self.demand.position = self.x;
                self.homing_done = true;
                self.return_mode = ReturnMode::Position;
                if matches!(self.activity, Activity::Position { .. }) {
                    self.activity = Activity::Idle;
                }
            }
            Opcode::Homing => {
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
            Opcode::MoveAbsolute | Opcode::MoveRelative => {
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
            Opcode::Velocity => {
                if !self.energise() {
                    return;
                }
                self.od.set_int(0x60FF, 0, i64::from(values.value1));
                self.set_mode(3);
                self.activity = Activity::Velocity {
                    speed_rpm: f64::from(values.value1),
                };
                self.start_travel(command.halt, ReturnMode::Velocity);
            }
            Opcode::Torque => {
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
                self.start_travel(command.halt, ReturnMode::Torque);
            }
        }
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

    fn set_mode(&mut self, mode: i64) {
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
        let result = self.od.read(address).and_then(|value| {
            let dtype = self
                .od
                .entry(address)
                .map_or(DataType::Integer32, |e| e.dtype);
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
        if address.index == 0x2291 || address.index == 0x2292 {
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
    fn on_controlword(&mut self, word: u16) {
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

    fn home_at(&mut self, world_x: f64) {
        let home_offset = self.od.int(0x607C, 0) as f64;
        // The position counter reads the home offset at the home point.
        self.offset = world_x - home_offset;
    }

    // ---------------------------------------------------------------- time

    /// Advance simulated time.
    pub fn tick(&mut self, dt: Duration) {
        let mut left = dt;
        while !left.is_zero() {
            let step = left.min(STEP);
            self.step(step.as_secs_f64());
            self.time += step;
            left -= step;
        }
        self.publish();
    }

    fn step(&mut self, dt: f64) {
        let acc = rpm_to_units(self.od.int(0x6083, 0) as f64);
        let dec = rpm_to_units(self.od.int(0x6084, 0) as f64);
        let x_before = self.x;
        let demand_velocity_before = self.demand.velocity;
        let demand_position_before = self.demand.position;
        let quick = rpm_to_units(self.od.int(0x6085, 0) as f64);
        let mut torque_controlled = false;
        match self.state {
            PowerState::OperationEnabled => {
                let mut activity = std::mem::replace(&mut self.activity, Activity::Idle);
                match &mut activity {
                    Activity::Idle => step_velocity(&mut self.demand, 0.0, acc, dec, dt),
                    _ if self.limit_stop => {
                        step_velocity(&mut self.demand, 0.0, quick, quick, dt);
                    }
                    Activity::Position { target, speed_rpm } => {
                        if self.halted {
                            step_velocity(&mut self.demand, 0.0, acc, dec, dt);
                        } else {
                            let world_target = *target as f64 + self.offset;
                            step_position(
                                &mut self.demand,
                                world_target,
                                rpm_to_units(*speed_rpm),
                                acc,
                                dec,
                                dt,
                            );
                        }
                    }
                    Activity::Velocity { speed_rpm } => {
                        let wanted = if self.halted {
                            0.0
                        } else {
                            rpm_to_units(*speed_rpm)
                        };
                        step_velocity(&mut self.demand, wanted, acc, dec, dt);
                    }
                    Activity::Torque {
                        torque,
                        max_speed_rpm,
                    } => {
                        if self.halted {
                            step_velocity(&mut self.demand, 0.0, acc, dec, dt);
                        } else {
                            torque_controlled = true;
                            let slope = self.od.int(0x6087, 0) as f64;
                            let step = slope * dt;
                            self.torque_demand = if (*torque - self.torque_demand).abs() <= step {
                                *torque
                            } else {
                                self.torque_demand + step.copysign(*torque - self.torque_demand)
                            };
                            self.torque_physics(rpm_to_units(*max_speed_rpm), dt);
                        }
                    }
                    Activity::Homing { run, found } => {
                        let homing_acc = rpm_to_units(self.od.int(0x609A, 0) as f64);
                        let fast = rpm_to_units(self.od.int(0x6099, 1) as f64);
                        let slow = rpm_to_units(self.od.int(0x6099, 2) as f64);
                        let wanted = match found {
                            Some(_) => 0.0,
                            None => {
                                let speed = if run.leg_is_fast() { fast } else { slow };
                                f64::from(run.direction()) * speed
                            }
                        };
                        step_velocity(&mut self.demand, wanted, homing_acc, homing_acc, dt);
                    }
                    Activity::AutoSetup { elapsed, centre } => {
                        *elapsed += Duration::from_secs_f64(dt);
                        // A visible wiggle: the motor turns ±30° while it identifies itself,
                        // and stands still again at the end.
                        let t = elapsed.as_secs_f64().min(AUTO_SETUP_TIME.as_secs_f64());
                        let next = *centre
                            + 300.0
                                * (std::f64::consts::TAU * t / AUTO_SETUP_TIME.as_secs_f64() * 4.0)
                                    .sin();
                        self.demand.velocity = (next - self.demand.position) / dt;
                        self.demand.position = next;
                    }
                }
                self.activity = activity;
            }
            PowerState::QuickStopActive => {
                let (decel, switch_off) = self.quick_stop.unwrap_or((dec, false));
                step_velocity(&mut self.demand, 0.0, decel, decel, dt);
                if self.demand.velocity == 0.0 && self.v.abs() < STANDSTILL && switch_off {
                    self.state = PowerState::SwitchOnDisabled;
                    self.quick_stop = None;
                }
            }
            _ => {}
        }

        // The load.
        let energised = matches!(
            self.state,
            PowerState::OperationEnabled | PowerState::QuickStopActive
        );
        let blocked = self.injected.contains(&Injection::FollowingError);
        if blocked {
            self.v = 0.0;
        } else if torque_controlled {
            // torque_physics moved x and v already.
        } else if energised {
            // The load follows the demand with a first-order lag, solved exactly over the
            // step (so the result does not depend on how time is cut into steps):
            // e = demand − x obeys de/dt = v_demand − e/τ, and the load's speed is e/τ.
            let v_demand = (self.demand.position - demand_position_before) / dt;
            let e0 = demand_position_before - self.x;
            let decay = (-dt / LOAD_LAG).exp();
            let mut e = v_demand * LOAD_LAG + (e0 - v_demand * LOAD_LAG) * decay;
            if self.demand.velocity == 0.0 && e.abs() < 0.01 {
                // Settled: the load stands on the demand.
                e = 0.0;
            }
            self.x = self.demand.position - e;
            self.v = e / LOAD_LAG;
        } else {
            // Coasting with the power stage off.
            self.v *= (-dt / 0.15).exp();
            if self.v.abs() < STANDSTILL {
                self.v = 0.0;
            }
            self.x += self.v * dt;
            self.demand = Demand {
                position: self.x,
                velocity: self.v,
            };
        }
        if !torque_controlled {
            self.torque = if energised {
                // The torque it takes to drive the demand's acceleration against friction.
                let accel = (self.demand.velocity - demand_velocity_before) / dt;
                ((accel + DAMPING * self.v) / TORQUE_GAIN + COULOMB * sign(self.v))
                    .clamp(-3000.0, 3000.0)
            } else {
                0.0
            };
        }

        self.after_step(x_before, dt);
    }

    fn torque_physics(&mut self, max_speed: f64, dt: f64) {
        let mut accel =
            TORQUE_GAIN * (self.torque_demand - COULOMB * sign(self.v)) - DAMPING * self.v;
        if self.v.abs() < STANDSTILL && self.torque_demand.abs() <= COULOMB {
            accel = 0.0;
            self.v = 0.0;
        }
        let mut v_new = self.v + accel * dt;
        if v_new.abs() > max_speed {
            // The speed limit of Profile Torque: the drive holds the set maximum speed.
            v_new = max_speed.copysign(v_new);
        }
        self.x += 0.5 * (self.v + v_new) * dt;
        self.v = v_new;
        self.torque = self.torque_demand;
        self.demand = Demand {
            position: self.x,
            velocity: self.v,
        };
    }

    fn after_step(&mut self, x_before: f64, dt: f64) {
        let sensors = self.world.sensors(self.x);
        let step = Duration::from_secs_f64(dt);

        // Homing legs and the home point.
        let fast = rpm_to_units(self.od.int(0x6099, 1) as f64);
        let slow = rpm_to_units(self.od.int(0x6099, 2) as f64);
        if let Activity::Homing { run, found } = &mut self.activity {
            let leg_speed = if run.leg_is_fast() { fast } else { slow };
            let at_leg_speed = self.v.abs() <= leg_speed * 1.1 + STANDSTILL;
            if found.is_none() {
                match run.step(&self.world, x_before, self.x, at_leg_speed) {
                    HomingStep::Moving { .. } => {}
                    HomingStep::Found { world } => {
                        *found = Some(world);
                    }
                    HomingStep::Failed => {
                        // Both limit switches met: the home switch is not where the
                        // method looks. The command fails with PdiStatusError.
                        self.activity = Activity::Idle;
                        self.refuse(AbortCode::GENERAL_ERROR);
                    }
                }
            }
            if let Activity::Homing {
                found: Some(world), ..
            } = self.activity
                && self.demand.velocity == 0.0
            {
                self.home_at(world);
                self.homing_done = true;
                self.activity = Activity::Idle;
                self.demand.position = self.x;
            }
        } else if let Activity::AutoSetup { elapsed, .. } = self.activity
            && elapsed >= AUTO_SETUP_TIME
        {
            self.autosetup_done = true;
            self.activity = Activity::Idle;
            self.set_mode(0);
        }

        // Limit switches stop travel into them (homing handles them itself).
        if self.state == PowerState::OperationEnabled
            && !matches!(self.activity, Activity::Homing { .. })
        {
            let into_negative = sensors.negative_limit && self.demand.velocity < 0.0;
            let into_positive = sensors.positive_limit && self.demand.velocity > 0.0;
            if into_negative || into_positive {
                self.limit_stop = true;
            }
        }

        // Following error: the demand against the load.
        let position_control = self.state == PowerState::OperationEnabled
            && !matches!(self.activity, Activity::Torque { .. });
        let deviation = if position_control {
            self.demand.position - self.x
        } else {
            0.0
        };
        let window = self.od.int(0x6065, 0) as f64;
        let timeout = Duration::from_millis(self.od.int(0x6066, 0).max(0) as u64);
        if position_control && deviation.abs() > window {
            self.following_error_for += step;
            if self.following_error_for > timeout && !self.following_error {
                self.following_error = true;
                let reaction = self.od.int(0x3700, 0);
                if reaction >= 0 {
                    self.raise_fault(ErrorCode::FOLLOWING_ERROR, 13, 0x21);
                } else {
                    self.warning = Some(ErrorCode::FOLLOWING_ERROR);
                    self.record_history(ErrorCode::FOLLOWING_ERROR, 13, 0x21);
                }
            }
        } else {
            self.following_error_for = Duration::ZERO;
            if self.following_error && !matches!(self.state, PowerState::Fault) {
                self.following_error = false;
                if self.warning == Some(ErrorCode::FOLLOWING_ERROR) {
                    self.warning = None;
                }
            }
        }

        // Target window timing.
        if self.target_condition() {
            self.in_window_for += step;
        } else {
            self.in_window_for = Duration::ZERO;
        }
    }

    /// Whether the mode's target condition holds right now (before the window time).
    fn target_condition(&self) -> bool {
        let standstill = self.v.abs() < STANDSTILL && self.demand.velocity == 0.0;
        match self.state {
            PowerState::QuickStopActive => return standstill,
            PowerState::OperationEnabled => {}
            _ => return false,
        }
        if self.halted {
            return standstill;
        }
        match &self.activity {
            Activity::Position { target, .. } => {
                let window = self.od.int(0x6067, 0) as f64;
                !self.limit_stop
                    && (self.position() - *target as f64).abs() <= window
                    && self.demand.velocity == 0.0
            }
            Activity::Velocity { speed_rpm } => {
                let window = self.od.int(0x606D, 0) as f64;
                let wanted = if self.limit_stop { 0.0 } else { *speed_rpm };
                (units_to_rpm(self.v) - wanted).abs() <= window
            }
            Activity::Torque { torque, .. } => (self.torque - *torque).abs() <= 10.0,
            Activity::Homing { .. } | Activity::AutoSetup { .. } => false,
            Activity::Idle => self.homing_done && standstill && self.od.int(0x6061, 0) == 6,
        }
    }

    fn target_reached(&self) -> bool {
        let window_time = match &self.activity {
            Activity::Velocity { .. } | Activity::Torque { .. } => self.od.int(0x606E, 0),
            _ => self.od.int(0x6068, 0),
        };
        self.target_condition()
            && self.in_window_for >= Duration::from_millis(window_time.max(0) as u64)
    }

    // ---------------------------------------------------------------- status

    fn reported_error_code(&self) -> ErrorCode {
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
        let sensors = self.world.sensors(self.x);
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

    fn return_value(&self) -> i32 {
        match self.return_mode {
            ReturnMode::Position => self.position().round() as i32,
            ReturnMode::Velocity => self.velocity_rpm().round() as i32,
            ReturnMode::Torque => self.torque.round() as i32,
            ReturnMode::Fixed(v) => v,
        }
    }

    /// The CiA 402 statusword 6041h, consistent with the PDI state.
    pub fn statusword(&self) -> u16 {
        let sensors = self.world.sensors(self.x);
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
    fn publish(&mut self) {
        let status = self.pdi_status();
        let tx = self.tx_image();
        let statusword = self.statusword();
        let sensors = self.world.sensors(self.x);
        let od = &mut self.od;
        od.set_int(0x2292, 1, i64::from(status.to_i16()));
        od.set_int(0x2292, 2, i64::from(tx.return_value));
        od.set_int(0x603F, 0, i64::from(tx.error_code));
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
        od.set_int(0x60FD, 0, i64::from(sensors.digital_inputs()));
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
        od.set(
            Address::new(0x6040, 0),
            wrap_integer(DataType::Unsigned16, i64::from(controlword)),
        );
    }
}

impl Default for Drive {
    fn default() -> Self {
        Self::new()
    }
}

fn sign(v: f64) -> f64 {
    if v.abs() < STANDSTILL {
        0.0
    } else {
        v.signum()
    }
}
