//! The Gains tab: the closed-loop controller's gains and the limits that shape a response,
//! read from the drive, edited with a confirmation, every write undoable in Changes.

pub mod housekeeping;
pub mod model;
pub mod view;

pub use housekeeping::Housekeeping;
pub use model::{GainEdit, GainRow, GainsPanel};
pub use view::{GAINS, gains_ui};
