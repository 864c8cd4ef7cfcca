//! The Gains tab: the closed-loop controller's gains and the limits that shape a response,
//! read from the drive, edited with a confirmation, every write undoable in Changes.

pub mod model;
pub mod view;

pub use model::{GainEdit, GainRow, GainsPanel};
pub use view::{GAINS, gains_ui};
