//! Projects in the window, as data: the project file (where it is, a dialog being
//! answered, a file waiting for the user's word before it is replaced, what the last open
//! or save said), and how a project's drive and plot layout become the window's settings.
//!
//! The project model and its file are `crate::project`'s; the window's use of it is
//! `App`'s (`app/project.rs`).
//!
//! A model: no egui here.

use std::path::{Path, PathBuf};

use crate::project::{self, Project};
use crate::ui::connection_form::ConnectionForm;
use crate::ui::plots::files::Answer;
use crate::ui::plots::model::PlotSettings;
use crate::ui::settings::DriveSettings;

/// The window's project file: where it is, a dialog being answered, a file waiting for
/// the user's word before it is replaced, and what the last action said.
#[derive(Default)]
pub struct ProjectFiles {
    /// The file the drives were opened from or last saved to.
    pub path: Option<PathBuf>,
    pub asking: Option<(Purpose, Answer)>,
    pub confirm: Option<PathBuf>,
    /// What the last open or save did (`Err`: it did not).
    pub message: Option<Result<String, String>>,
    /// The folder where the last project is remembered (`None`: the settings folder).
    pub remember_in: Option<PathBuf>,
}

impl ProjectFiles {
    /// A file dialog is open for the project.
    pub fn is_asking(&self) -> bool {
        self.asking.is_some()
    }

    /// Remember `path` as the project to reopen on the next start.
    pub fn remember(&self, path: &Path) -> Result<(), project::recent::RecentError> {
        match &self.remember_in {
            Some(dir) => project::recent::remember_in(dir, path),
            None => project::recent::remember(path),
        }
    }
}

/// What a project file dialog is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    Open,
    Save,
}

/// `settings` with the project drive's link, options and watched objects put in.
pub fn drive_settings(mut settings: DriveSettings, drive: &project::Drive) -> DriveSettings {
    settings.connection = ConnectionForm::from_spec(&drive.link, settings.connection);
    settings.poll_rate = drive.options.poll_rate;
    settings.on_link_loss = drive.options.on_link_loss;
    settings.lost_after = drive.options.lost_after;
    settings.watch.pins = drive.watch.clone();
    settings
}

/// The project's plot layout put into `settings`; a note when the window cannot read it
/// (then the window keeps its own).
pub fn apply_plot_layout(settings: &mut PlotSettings, project: &Project) -> Option<String> {
    let plot = project.plot.as_ref()?;
    match serde_json::from_value::<PlotSettings>(plot.clone()) {
        Ok(plot) => {
            *settings = plot;
            None
        }
        Err(e) => Some(format!(
            "the project's plot layout is not one this window reads ({e}): the window keeps its own"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::Address;
    use crate::project::{Drive, Format, Pin};
    use crate::worker::LinkLossAction;

    fn project() -> Project {
        let mut x = Drive::new("X axis", "modbus-tcp://10.0.0.5:502".parse().expect("spec"));
        x.options.poll_rate = 250.0;
        x.options.on_link_loss = LinkLossAction::SwitchOff;
        x.options.lost_after = 7;
        x.watch = vec![Pin {
            address: Address::new(0x6041, 0),
            format: Format::Bits,
        }];
        let y = Drive::new("Y axis", "canopen+sim://?node=2".parse().expect("spec"));
        let mut project = Project::new(vec![x, y]).expect("a project");
        project.plot = Some(serde_json::json!({"window_s": 3.0, "shown": ["velocity"]}));
        project
    }

    #[test]
    fn a_drive_and_the_plot_layout_reach_the_settings() {
        let project = project();
        let mut plot = PlotSettings::default();
        assert_eq!(apply_plot_layout(&mut plot, &project), None);
        let settings = drive_settings(DriveSettings::default(), &project.drives[0]);
        assert_eq!(
            settings.connection.spec().expect("a spec"),
            project.drives[0].link
        );
        assert_eq!(settings.poll_rate, 250.0);
        assert_eq!(settings.on_link_loss, LinkLossAction::SwitchOff);
        assert_eq!(settings.lost_after, 7);
        assert_eq!(settings.watch.pins.len(), 1);
        assert_eq!(plot.window_s, 3.0);
        assert_eq!(plot.shown, vec!["velocity".to_owned()]);
    }

    #[test]
    fn a_bad_layout_is_said_and_the_window_keeps_its_own() {
        let mut project = project();
        project.plot = Some(serde_json::json!({"window_s": "wide"}));
        let before = PlotSettings::default();
        let mut plot = before.clone();
        let note = apply_plot_layout(&mut plot, &project).expect("a note");
        assert!(
            note.contains("plot layout is not one this window reads"),
            "{note}"
        );
        assert_eq!(plot, before);
    }
}
