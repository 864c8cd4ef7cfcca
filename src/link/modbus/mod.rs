//! Modbus TCP and RTU over real sockets and serial ports: the PDI in one FC 23 transaction
//! per cycle, object access through FC 43 (CiA 309-2) or the PDI, on one connection; the
//! slaves on one RS-485 line share its port. The codec is in [`crate::proto::modbus`].

pub mod client;
pub mod line;
pub mod transport;
