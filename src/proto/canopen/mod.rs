//! CANopen (CiA 301): the CAN frame, NMT and heartbeat, SDO (expedited and segmented,
//! client and server), PDO mapping, EMCY, the frame log's descriptions, and the slcan line
//! codec of serial CAN adapters.

pub mod describe;
pub mod emcy;
mod frame;
pub mod nmt;
pub mod pdo;
pub mod sdo;
pub mod slcan;

pub use frame::{CanFrame, FrameError};
