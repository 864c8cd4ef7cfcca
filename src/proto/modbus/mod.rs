//! Modbus: the PDU of every function code drivedeck uses, the TCP (MBAP) and RTU (CRC)
//! framing, and the PDI's register layout.
//!
//! The codec is our own: tokio-modbus 0.17 rejects FC 43 with MEI 0x0D on both sides
//! (slowtec/tokio-modbus#356) and cannot frame custom function codes over RTU (#123), and a
//! Nanotec drive needs both. tokio-modbus stays as an independent peer in the tests.

pub mod frame;
pub mod pdu;
pub mod registers;
