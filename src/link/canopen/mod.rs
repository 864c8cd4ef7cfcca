//! CANopen (CiA 301): the CAN frame, the `CanBus` back ends (SocketCAN, slcan serial
//! adapters, an in-memory bus), the sans-IO CiA 301 codecs, and the link that runs the PDI
//! over PDOs with SDO object access.

mod bus;
pub mod client;
pub mod describe;
pub mod emcy;
mod frame;
pub mod nmt;
pub mod pdo;
pub mod scan;
pub mod sdo;
pub mod simbus;
pub mod slcan;
#[cfg(target_os = "linux")]
pub mod socketcan;

pub use bus::{CanBus, MemoryBus, MemoryPort};
pub use frame::{CanFrame, FrameError};
