//! EtherNet/IP: the sans-IO codecs (encapsulation, Common Packet Format, CIP Message
//! Router, Forward_Open/Close, class 1 I/O datagrams, the drive's assemblies and Nanotec's
//! object dictionary services).
//!
//! Why our own codec and not rseip: rseip 0.3 (the only Rust CIP client) is a client
//! only, so the simulated adapter would need a second codec anyway; it has no class 1
//! I/O, which is how the PDI runs here; its high-level client wraps every request in
//! Unconnected_Send, which a Nanotec drive is not documented to route; its errors are its
//! own (`ClientError`) rather than our `thiserror` layers; and it has been dormant since
//! 2023. The layers below are small, tested against the vendor's example bytes, and the
//! same code serves both sides, so both are held to the same bytes.

pub mod assembly;
pub mod cip;
pub mod connection;
pub mod cpf;
pub mod describe;
pub mod encap;
pub mod identity;
pub mod io;
pub mod nanotec;
#[cfg(test)]
mod proptests;
pub mod wire;

pub use wire::{DecodeError, hex};
