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

use crate::cia::{ErrorCode, PowerState};
use crate::od::{Address, Catalog, Value};

use super::dictionary::Dictionary;
use super::homing::HomingRun;
use super::motion::{Demand, units_to_rpm};
use super::world::{Load, World};
use crate::injection::Injection;

mod access;
mod faults;
mod inputs;
mod nanoj;
mod pdi;
mod physics;
mod servo;
mod status;
mod storage;

/// The simulation step: every `tick` is cut into steps of at most this length.
pub const STEP: Duration = Duration::from_millis(1);

pub use inputs::FACTORY_SETTINGS;
pub use storage::BOOT_TIME;

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
    /// The closed loop's state while it runs (3202h bit 0 set and the power stage on).
    servo: Option<servo::Servo>,
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
    /// The dictionary as it left the factory (for a restart after "load").
    factory: std::sync::Arc<Dictionary>,
    /// What survives a restart, and the restart under way.
    storage: storage::Storage,
    /// The built-in NanoJ program.
    nanoj: nanoj::NanoJ,
    reboots: u32,
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
        // The built-in NanoJ program: its name, its mapping, its metadata.
        let words = nanoj::program_words(nanoj::PROGRAM);
        od.set_int(0x2304, 0, words.len() as i64);
        for (k, word) in words.iter().enumerate() {
            od.set_int(0x2304, k as u8 + 1, i64::from(*word));
        }
        let mapping = |index: u16, sub: u8| (i64::from(index) << 16) | (i64::from(sub) << 8) | 32;
        od.set_int(0x2310, 0, 3);
        for sub in 1..=3 {
            od.set_int(0x2310, sub, mapping(0x2400, sub));
        }
        od.set_int(0x2320, 0, 2);
        for sub in 1..=2 {
            od.set_int(0x2320, sub, mapping(0x2500, sub));
        }
        od.set_int(0x2303, 1, 0x300);
        // The machine's switches: special functions of inputs 1–3 on, the normally
        // closed limit switches on inputs 1–2 inverted (`inputs`).
        for (index, sub, value) in inputs::FACTORY_SETTINGS {
            od.set_int(index, sub, i64::from(value));
        }
        Self::from_dictionary(std::sync::Arc::new(od), world)
    }

    /// A drive at power-on with the factory values of `factory`.
    fn from_dictionary(factory: std::sync::Arc<Dictionary>, world: World) -> Self {
        let mut drive = Self {
            od: (*factory).clone(),
            factory,
            storage: storage::Storage::default(),
            nanoj: nanoj::NanoJ::default(),
            reboots: 0,
            world,
            state: PowerState::SwitchOnDisabled,
            activity: Activity::Idle,
            halted: false,
            quick_stop: None,
            x: 0.0,
            v: 0.0,
            offset: 0.0,
            demand: Demand::default(),
            servo: None,
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

    /// Couple another load to the motor (it acts from the next step on).
    pub fn set_load(&mut self, load: Load) {
        self.world.load = load;
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
        self.servo = None;
        self.publish();
    }
}

impl Default for Drive {
    fn default() -> Self {
        Self::new()
    }
}

/// The motor's acceleration, units/s², at `torque` ‰ of rated torque while turning at
/// `v` units/s with `load` coupled: friction (Coulomb and viscous) and the load's torque
/// against it, the load's inertia added to the motor's.
fn acceleration(load: &Load, torque: f64, v: f64) -> f64 {
    let against = COULOMB * sign(v) + load.torque;
    TORQUE_GAIN * (torque - against) / load.inertia_factor() - DAMPING * v
}

fn sign(v: f64) -> f64 {
    if v.abs() < STANDSTILL {
        0.0
    } else {
        v.signum()
    }
}
