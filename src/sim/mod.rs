//! The simulated Nanotec drive: it behaves like the PDI spec on simulated time, so the
//! demo and every test work without hardware. It is reached in-process through
//! [`SimLink`], as a CANopen node on an in-memory bus through [`SimCanBus`], and on real
//! sockets and serial ports through the servers in [`server`].

pub mod canbus;
mod dictionary;
mod drive;
pub mod eds;
mod homing;
pub mod link;
mod motion;
pub mod server;
mod world;

#[cfg(test)]
mod tests;

pub use crate::injection::Injection;
pub use canbus::SimCanBus;
pub use dictionary::{Dictionary, wrap_integer};
pub use drive::{AUTO_SETUP_TIME, BOOT_TIME, Drive, FACTORY_SETTINGS, STEP};
pub use homing::SUPPORTED_METHODS;
pub use link::SimLink;
pub use motion::{rpm_to_units, units_to_rpm};
pub use world::{Load, Sensors, World};
