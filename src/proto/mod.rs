//! The sans-IO codecs of every bus: bytes in, values out, and the state machines that
//! decide what comes next, with no socket, no clock of their own and no tokio. The links
//! (`crate::link`) run them over real I/O; the simulated drive (`crate::sim`) serves them.
//! Each codec is pinned to the vendor's example bytes or to the public standard by its
//! tests, and every decoder of device bytes is property-tested.

pub mod canopen;
pub mod enip;
pub mod modbus;
