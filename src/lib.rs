//! drivedeck: a commissioning tool for Nanotec motor controllers.
//!
//! Layers, lowest first (ARCHITECTURE.md draws them and gives the table of which module
//! may import which; a test keeps it): the vocabulary (`number`, `text`, `file`, `cia`, `pdi`, `od`), the
//! shared facts (`signal`, `injection`, `proto`: the sans-IO codecs), the buses (`link`),
//! the simulated drive (`sim`), opening any link (`connect`), the loop (`worker`,
//! `telemetry`, `diagnostics`), the machine's project file (`project`) and the faces
//! (`ui`, `cli`).

pub mod cia;
pub mod cli;
pub mod connect;
pub mod diagnostics;
pub mod file;
pub mod guide;
pub mod injection;
pub mod link;
pub mod number;
pub mod od;
pub mod pdi;
pub mod procedure;
pub mod project;
pub mod proto;
pub mod signal;
pub mod sim;
pub mod telemetry;
pub mod text;
pub mod ui;
pub mod worker;
