//! What belongs to the window whatever drive it shows: its settings (layout, plot and
//! dictionary choices, where exports go), the plots' view (one time axis for every
//! drive), the bottom panel's tab, and the list of drives as being edited.
//!
//! A model: no egui here.

use std::sync::Arc;

use crate::ui::machine_table::MachineSort;
use crate::ui::plots::files::{FilePicker, PromptingPicker, Prompts};
use crate::ui::plots::model::PlotView;
use crate::ui::settings::WindowSettings;

/// The id of the log's first tab, the commands: what the log shows at first.
pub const COMMANDS: &str = "commands";

/// The list of drives as the user edits it: the "+ Add drive" box, the selected drive's
/// name as typed, and what went wrong with the list.
#[derive(Clone, Debug, Default)]
pub struct DriveList {
    pub add_link: String,
    /// The selected drive's name as being typed (a name half typed may be empty or taken).
    pub name_draft: Option<String>,
    pub message: Option<String>,
}

/// The window's own state.
#[derive(Debug)]
pub struct Window {
    pub settings: WindowSettings,
    /// The plot panel's view: one for the window, every drive on its time axis.
    pub plot: PlotView,
    /// The log's tab shown (its id, one of `ui::view::BOTTOM`'s).
    pub bottom: &'static str,
    pub list: DriveList,
    /// Open and save questions no system dialog could show, asked in the window.
    pub prompts: Prompts,
    /// How the Machine tab's overview of every drive is sorted.
    pub machine: MachineSort,
}

impl Window {
    pub fn new(settings: WindowSettings) -> Self {
        let mut window = Self {
            settings,
            plot: PlotView::default(),
            bottom: COMMANDS,
            list: DriveList::default(),
            prompts: Prompts::default(),
            machine: MachineSort::default(),
        };
        let files = window.plot.files();
        window.use_files(files);
        window
    }

    /// Open and save through `files`, with the window's path field where they cannot
    /// show a dialog.
    pub fn use_files(&mut self, files: Arc<dyn FilePicker>) {
        let prompting = PromptingPicker::new(files, self.prompts.clone());
        self.plot.set_files(prompting);
    }
}
