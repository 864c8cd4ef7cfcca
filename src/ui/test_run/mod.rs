//! The Test tab: test moves and velocity steps with figures, run from the window, kept per
//! session, two compared side by side and overlaid (before and after a gain change).

pub mod model;
pub mod view;

pub use model::{Form, Kind, Run, TestRuns};
pub use view::{TEST, test_ui};
