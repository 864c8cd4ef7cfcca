//! The state tile: what the drive is and does, in words, large and coloured, always in
//! view (the fixed head of the status panel): DISABLED, ENABLED, MOVING +300 rpm, HALTED,
//! QUICK STOP, FAULT 2300h with its meaning, NO LINK with when the drive was last seen.
//! Beside it Enable (on without moving, PDI spec §2.2.2) and, while a fault is active,
//! Clear error; under it the limit switch that blocks travel and why the drive last
//! stopped or refused.

pub mod model;
pub mod view;

pub use model::{Glance, Tone, doing, limit_words, motion_words};
pub use view::{state_tile_ui, tone_color};
