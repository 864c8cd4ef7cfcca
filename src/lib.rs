//! drivedeck: a commissioning tool for Nanotec motor controllers.
//!
//! Layers, lowest first (ARCHITECTURE.md describes them and the rules between them):
//! `number`, `cia` and `pdi` (sans-IO, std only), `od` (object dictionary types and
//! catalog), `link` (the buses), `sim` (the simulated drive), `worker` (the thread that owns
//! the link), `telemetry`, `ui` and `cli`.

pub mod cia;
pub mod cli;
pub mod connect;
pub mod diagnostics;
pub mod injection;
pub mod link;
pub mod number;
pub mod od;
pub mod pdi;
pub mod proto;
pub mod signal;
pub mod sim;
pub mod telemetry;
pub mod ui;
pub mod worker;
