//! The seam between a project and the window as it is today: the window shows one drive
//! at a time, so opening a project gives the window's settings the first drive's (or the
//! one named) connection, options and watched objects, and the project's plot layout. The
//! other drives are named in a note, not dropped without a word. The multi-drive window
//! replaces this with its own use of `crate::project::Project`.

use super::plots::PlotSettings;
use super::state::{ConnectionForm, Settings};
use crate::project::Project;

/// `settings` with `project`'s drive `drive` (the first when `None` or not found) put in,
/// and the notes to show about what the window could not take.
pub fn settings_for_project(
    mut settings: Settings,
    project: &Project,
    drive: Option<&str>,
) -> (Settings, Vec<String>) {
    let mut notes = vec![];
    let Some(shown) = drive
        .and_then(|name| project.drives.iter().find(|d| d.name == name))
        .or_else(|| project.drives.first())
    else {
        return (settings, notes);
    };
    settings.connection = ConnectionForm::from_spec(&shown.link, settings.connection);
    settings.poll_rate = shown.options.poll_rate;
    settings.on_link_loss = shown.options.on_link_loss;
    settings.lost_after = shown.options.lost_after;
    settings.watch.pins = shown.watch.clone();
    if let Some(plot) = &project.plot {
        match serde_json::from_value::<PlotSettings>(plot.clone()) {
            Ok(plot) => settings.plot = plot,
            Err(e) => notes.push(format!(
                "the project's plot layout is not one this window reads ({e}): the window keeps its own"
            )),
        }
    }
    let others: Vec<String> = project
        .drives
        .iter()
        .filter(|d| d.name != shown.name)
        .map(|d| format!("\"{}\"", d.name))
        .collect();
    if !others.is_empty() {
        notes.push(format!(
            "the window shows one drive at a time: \"{}\"; the project's other drives ({}) are reached with `drivedeck --project FILE --drive NAME …`",
            shown.name,
            others.join(", ")
        ));
    }
    (settings, notes)
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
    fn the_first_drive_and_the_plot_layout_reach_the_settings_and_the_others_are_named() {
        let project = project();
        let (settings, notes) = settings_for_project(Settings::default(), &project, None);
        assert_eq!(
            settings.connection.spec().expect("a spec"),
            project.drives[0].link
        );
        assert_eq!(settings.poll_rate, 250.0);
        assert_eq!(settings.on_link_loss, LinkLossAction::SwitchOff);
        assert_eq!(settings.lost_after, 7);
        assert_eq!(settings.watch.pins.len(), 1);
        assert_eq!(settings.plot.window_s, 3.0);
        assert_eq!(settings.plot.shown, vec!["velocity".to_owned()]);
        assert_eq!(notes.len(), 1);
        assert!(notes[0].contains("(\"Y axis\")"), "{notes:?}");
    }

    #[test]
    fn a_named_drive_is_the_one_shown_and_a_bad_layout_is_said() {
        let mut project = project();
        project.plot = Some(serde_json::json!({"window_s": "wide"}));
        let before = Settings::default();
        let (settings, notes) = settings_for_project(before.clone(), &project, Some("Y axis"));
        assert_eq!(
            settings.connection.spec().expect("a spec"),
            project.drives[1].link
        );
        assert_eq!(settings.plot, before.plot);
        assert!(
            notes[0].contains("plot layout is not one this window reads"),
            "{notes:?}"
        );
        assert!(notes[1].contains("(\"X axis\")"), "{notes:?}");
    }
}
