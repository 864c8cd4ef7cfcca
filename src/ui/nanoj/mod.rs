//! The NanoJ tab: the drive's program, started and stopped, its error in words, its
//! inputs and outputs.

pub mod model;
pub mod view;

pub use model::NanojPanel;
pub use view::{NANOJ, nanoj_ui};
