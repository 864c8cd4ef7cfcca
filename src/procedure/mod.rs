//! Commissioning procedures: a TOML file of ordered steps with acceptance limits
//! (`file`), run on one drive after the other by a runner without I/O (`runner`) that the
//! window's Procedure tab and `drivedeck commission` both drive, and the commissioning
//! record it produces (`record`), written as JSON and as one self-contained HTML page
//! (`html`).

pub mod file;
pub mod html;
pub mod record;
pub mod runner;

pub use file::{Kind, Procedure, ProcedureError, Step};
pub use record::{DriveRecord, Record, Verdict};
pub use runner::{DriveRun, DriveSetup, Prompt};
