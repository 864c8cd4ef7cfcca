//! What the tool changed on the drive this session, with the values before, and "restore
//! what I changed": the old values written back in reverse order.

pub mod model;
pub mod view;

pub use model::{ChangeEntry, Changes, note_change, restore_requests};
pub use view::{CHANGES, changes_ui};
