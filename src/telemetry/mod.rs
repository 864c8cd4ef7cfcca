//! Recorded signals: bounded histories for the live plots.

mod history;

pub use history::{History, Signal, Trace};
