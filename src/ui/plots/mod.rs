//! The plot panel: stacked plots of the sampled signals on one time axis, the status bits
//! as digital lanes, command markers, a cursor read-out, pause, follow, zoom and pan; the
//! stacked plots live in `traces` (each analog one in `analog`, which signals share a plot
//! and on which scales in `groups`), the status-bit lanes in `lanes`, pan and zoom of
//! their one time axis in `navigate`, the trigger and the exports in `trigger_view` and
//! `exports_view` (one row: `capture`), the PNG in `picture`, recordings opened from files
//! (and a frozen capture) in `review`, the dialogs in `files`.

mod analog;
mod capture;
pub mod exports;
mod exports_view;
pub mod files;
pub mod groups;
mod lanes;
pub mod model;
mod navigate;
mod picture;
pub mod readout;
pub mod review;
mod review_view;
pub mod spectrum;
mod spectrum_view;
mod traces;
pub mod trigger;
mod trigger_view;
pub mod view;

pub use crate::ui::command::PlotCommand;
pub use exports::{Beside, Export, Job};
pub use files::{Ask, FilePicker, NativePicker, ScriptedPicker};
pub use model::{
    DrawnPlot, FACTORY_POSITION_UNIT, Image, LineExtent, PlotSettings, PlotView, PositionUnit,
    default_together, lane_key, live_end, shown_scope, time_range, with_turns,
};
pub use review::Review;
pub use traces::{DRIVE_COLORS, PLOT_HEIGHT_MIN, colors, drive_color};
pub use trigger::TriggerForm;
pub use view::{Alone, Plots, fills_window, headless_frame, plots_ui};
