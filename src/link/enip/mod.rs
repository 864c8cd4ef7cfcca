//! EtherNet/IP over real sockets: the encapsulation session (explicit messages over TCP),
//! the class 1 I/O connection (UDP), ListIdentity discovery, and the link that runs the PDI
//! over them. The codecs are in [`crate::proto::enip`].

pub mod client;
pub mod discovery;
mod implicit;
pub mod priority;
pub use implicit::{IoTiming, KEPT_WITHIN, STARTUP_SPAN};
pub mod session;
