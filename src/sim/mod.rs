//! The simulated Nanotec drive: it behaves like the PDI spec on simulated time, so the
//! demo and every test work without hardware. `server` exposes it on real sockets as a
//! Modbus TCP/RTU server, a CANopen node and an EtherNet/IP adapter.

mod dictionary;
mod drive;
pub mod eds;
mod faults;
mod homing;
mod motion;
pub mod server;
mod world;

#[cfg(test)]
mod tests;

pub use dictionary::{Dictionary, wrap_integer};
pub use drive::{AUTO_SETUP_TIME, Drive, STEP};
pub use faults::Injection;
pub use homing::SUPPORTED_METHODS;
pub use motion::{rpm_to_units, units_to_rpm};
pub use world::{Sensors, World};
