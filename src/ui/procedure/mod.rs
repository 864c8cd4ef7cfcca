//! The Procedure tab: a commissioning procedure run on the drive shown, its record written
//! when it ends (the runner is `procedure::runner`, shared with `drivedeck commission`).

pub mod model;
pub mod view;

pub use model::ProcedurePanel;
pub use view::{PROCEDURE, procedure_ui};
