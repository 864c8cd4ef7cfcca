//! The I/O tab: the drive's digital inputs and outputs and its analog input; outputs
//! forced only after a yes, every force undoable in Changes.

pub mod model;
pub mod view;

pub use model::IoPanel;
pub use view::{IO, io_ui};
