//! The window (eframe), in three kinds of module:
//!
//! - models, plain data with no egui: the window's own state ([`window`], [`settings`]),
//!   each drive's ([`drive`]), each panel's (`browser`, `watch`, `plots::model`,
//!   `changes::model`, …) and the user's intents ([`command`]);
//! - views, which read the models, edit their own panel's model and push commands
//!   (`*_ui` functions; [`view`] lays the window out and registers its panels);
//! - the [`app`], which owns it all: it applies the workers' events to the drives and the
//!   commands to the window, one place each, and hands each drive's requests to its
//!   worker.
//!
//! ARCHITECTURE.md lists which module is which; `tests/architecture.rs` keeps models free
//! of egui and the imports of `ui` free of circles.

pub mod app;
pub mod browser;
pub mod changes;
pub mod channel;
pub mod command;
pub mod commands;
pub mod connection;
pub mod connection_form;
pub mod drive;
pub mod drive_list;
pub mod drive_row;
pub mod faults;
pub mod fonts;
pub mod gains;
pub mod glance;
pub mod guide;
pub mod input;
pub mod io_panel;
pub mod jog;
pub mod leave;
pub mod log;
pub mod machine;
pub mod machine_table;
pub mod nanoj;
pub mod pace;
pub mod panel;
pub mod path_prompt;
pub mod plots;
pub mod power_state;
pub mod procedure;
pub mod project_files;
pub mod run;
pub mod scan;
pub mod settings;
pub mod status;
pub mod test_run;
pub mod timings;
pub mod view;
pub mod watch;
pub mod widgets;
pub mod window;

pub use app::{App, DriveError, SETTINGS_KEY};
pub use channel::WorkerClock;
pub use command::{Command, Said};
pub use drive::Drive;
pub use run::{Opening, run_window};
pub use settings::Settings;
pub use window::Window;
