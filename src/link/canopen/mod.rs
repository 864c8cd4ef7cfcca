//! CANopen over real buses: the `CanBus` back ends (SocketCAN, slcan serial adapters, an
//! in-memory bus), one adapter shared by the drives on it, the node scan, and the link that runs the PDI over PDOs with SDO object
//! access. The CiA 301 codecs are in [`crate::proto::canopen`].

mod bus;
pub mod client;
pub mod scan;
pub mod shared;
pub mod slcan;
#[cfg(target_os = "linux")]
pub mod socketcan;

pub use bus::{CanBus, MemoryBus, MemoryPort};
pub use shared::SharedCanPort;
