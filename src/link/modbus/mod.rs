//! Modbus TCP and RTU: the PDI in one FC 23 transaction per cycle, object access through
//! FC 43 (CiA 309-2) or the PDI, on one connection.
//!
//! The codec is our own, sans-IO (`pdu`, `frame`, `registers`): tokio-modbus 0.17 rejects
//! FC 43 with MEI 0x0D on both sides (slowtec/tokio-modbus#356) and cannot frame custom
//! function codes over RTU (#123), and a Nanotec drive needs both. tokio-modbus stays as an
//! independent peer in the tests.

pub mod client;
pub mod frame;
pub mod pdu;
pub mod registers;
pub mod transport;
