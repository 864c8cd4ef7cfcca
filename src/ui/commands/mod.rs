//! The command panel: a button for every PDI command with its set values, each field with
//! its unit and range; a button stays disabled, with the reason as its tooltip, while a
//! field is invalid. The halt toggle sits on top.

pub mod model;
pub mod view;

pub use view::{STRIP_WIDTH, button_label, collapsed_strip_ui, commands_ui, field_label};
