//! Projects in the window: `drivedeck PROJECT.json` (or the last project, on a start
//! without arguments) opens every drive of the project, each with its name, link,
//! options and watched objects, the plot layout shared; each drive's identity (1018h) is
//! compared with the one the project saw as soon as it is read, and what differs (or a
//! drive that does not answer) is said in that drive's log and its row of the list. The
//! "Project" menu saves the window's drives as a project, or opens another.
//!
//! The project model and its file are `crate::project`'s; this is the window's use of it.

use std::path::{Path, PathBuf};

use eframe::egui::{self, Ui};

use super::App;
use super::plots::PlotSettings;
use super::plots::files::{Answer, Ask, Picked, take};
use super::state::{AppState, Connection, ConnectionForm, LogEntry, Outcome, Settings};
use crate::od::backup::DeviceIdentity;
use crate::project::check::{DriveCheck, Verdict};
use crate::project::{self, DriveOptions, Project};
use crate::worker::{self, Request};

/// The window's project file: where it is, a dialog being answered, a file waiting for
/// the user's word before it is replaced, and what the last action said.
#[derive(Default)]
pub struct ProjectFiles {
    /// The file the drives were opened from or last saved to.
    pub path: Option<PathBuf>,
    asking: Option<(Purpose, Answer)>,
    confirm: Option<PathBuf>,
    /// What the last open or save did (`Err`: it did not).
    pub message: Option<Result<String, String>>,
    /// The folder where the last project is remembered (`None`: the settings folder).
    remember_in: Option<PathBuf>,
}

impl ProjectFiles {
    /// Remember `path` as the project to reopen on the next start.
    fn remember(&self, path: &Path) -> Result<(), project::recent::RecentError> {
        match &self.remember_in {
            Some(dir) => project::recent::remember_in(dir, path),
            None => project::recent::remember(path),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    Open,
    Save,
}

/// `settings` with the project drive's link, options and watched objects put in.
pub fn drive_settings(mut settings: Settings, drive: &project::Drive) -> Settings {
    settings.connection = ConnectionForm::from_spec(&drive.link, settings.connection);
    settings.poll_rate = drive.options.poll_rate;
    settings.on_link_loss = drive.options.on_link_loss;
    settings.lost_after = drive.options.lost_after;
    settings.watch.pins = drive.watch.clone();
    settings
}

/// The project's plot layout put into `settings`; a note when the window cannot read it
/// (then the window keeps its own).
pub fn apply_plot_layout(settings: &mut Settings, project: &Project) -> Option<String> {
    let plot = project.plot.as_ref()?;
    match serde_json::from_value::<PlotSettings>(plot.clone()) {
        Ok(plot) => {
            settings.plot = plot;
            None
        }
        Err(e) => Some(format!(
            "the project's plot layout is not one this window reads ({e}): the window keeps its own"
        )),
    }
}

impl App {
    /// The window opened on `project` (from `path`): every drive in the list and
    /// connecting, the one named `show` (else the first) selected.
    pub fn with_project(
        mut settings: Settings,
        notify: worker::Notify,
        project: &Project,
        path: Option<PathBuf>,
        show: Option<&str>,
    ) -> App {
        let Some(first) = project.drives.first() else {
            return App::new(settings, notify, true);
        };
        let note = apply_plot_layout(&mut settings, project);
        let mut app = App::new(drive_settings(settings, first), notify, true);
        app.adopt(project, note, path, show);
        app
    }

    /// Open `project` in place of the drives the window has: refused while any drive is
    /// connected (leaving one is the user's decision, asked per drive). The selected
    /// drive's history stays on the plots; the others go with their workers.
    pub fn open_project(&mut self, project: &Project, path: Option<PathBuf>) -> Result<(), String> {
        let Some(first) = project.drives.first() else {
            return Err("the project has no drives".into());
        };
        if self.any_connected() {
            return Err(
                "disconnect every drive first (each is asked what to leave behind), then open the project"
                    .into(),
            );
        }
        let selected = self.selected;
        let mut index = 0;
        self.drives.retain(|_| {
            index += 1;
            index - 1 == selected
        });
        self.selected = 0;
        let mut settings = self.state.settings.clone();
        let note = apply_plot_layout(&mut settings, project);
        self.state.settings = drive_settings(settings, first);
        self.state.project_check = None;
        self.state.request(Request::Connect(first.link.clone()));
        self.adopt(project, note, path, None);
        Ok(())
    }

    /// The first drive is set up and connecting: name it, and add the others.
    fn adopt(
        &mut self,
        project: &Project,
        note: Option<String>,
        path: Option<PathBuf>,
        show: Option<&str>,
    ) {
        let Some(first) = project.drives.first() else {
            return;
        };
        if let Some(drive) = self.drives.first_mut() {
            drive.name = first.name.clone();
        }
        self.state.project_drive = Some(first.clone());
        for drive in &project.drives[1..] {
            let settings = drive_settings(self.state.settings.clone(), drive);
            match self.add_drive_with(drive.name.clone(), drive.link.clone(), settings) {
                Ok(i) => {
                    if let Some(state) = self.drive_state_mut(i) {
                        state.project_drive = Some(drive.clone());
                    }
                }
                Err(e) => self
                    .state
                    .info(format!("the project's drive \"{}\": {e}", drive.name)),
            }
        }
        if let Some(note) = note {
            self.state.info(note);
        }
        let from = path
            .as_ref()
            .map(|p| format!(" from {}", p.display()))
            .unwrap_or_default();
        self.project.message = Some(Ok(format!(
            "opened {} drive(s){from}; each is checked against the identity the project saw",
            project.drives.len()
        )));
        self.project.path = path;
        if let Some(name) = show {
            match project.drives.iter().position(|d| d.name == name) {
                Some(i) => self.select(i),
                None => self.state.info(format!(
                    "the project has no drive \"{name}\"; its drives: {}",
                    project.names()
                )),
            }
        }
    }

    /// The window's drives as a project: names, links, options, watched objects, the
    /// identity each drive showed (else the one the project had), the backup a project
    /// kept for a drive on the same link, and the plot layout.
    pub fn project(&self) -> Result<Project, String> {
        let links: Vec<_> = self.drives().map(|(_, link)| link).collect();
        let mut drives = Vec::new();
        for (i, link) in links.into_iter().enumerate() {
            let (Some(state), Some(name)) = (self.drive_state(i), self.drives.get(i)) else {
                continue;
            };
            let name = &name.name;
            let link = link.ok_or_else(|| {
                format!("\"{name}\" has no valid connection string: give it one first")
            })?;
            let saved = state.project_drive.as_ref().filter(|s| s.link == link);
            let mut drive = project::Drive::new(name.clone(), link);
            drive.options = DriveOptions {
                poll_rate: state.settings.poll_rate,
                on_link_loss: state.settings.on_link_loss,
                lost_after: state.settings.lost_after,
            };
            drive.watch = state.settings.watch.pins.clone();
            drive.identity = state
                .plot
                .identity
                .clone()
                .or_else(|| saved.and_then(|s| s.identity.clone()));
            drive.backup = saved.and_then(|s| s.backup.clone());
            drives.push(drive);
        }
        let mut project = Project::new(drives).map_err(|e| e.to_string())?;
        project.plot = serde_json::to_value(&self.state.settings.plot).ok();
        Ok(project)
    }

    /// Remember opened and saved projects in `dir` instead of the settings folder (tests,
    /// and scripts that must not change which project reopens).
    pub fn remember_projects_in(&mut self, dir: PathBuf) {
        self.project.remember_in = Some(dir);
    }

    /// The project file the drives were opened from or saved to, and what the last open
    /// or save said.
    pub fn project_file(&self) -> (Option<&Path>, Option<&Result<String, String>>) {
        (self.project.path.as_deref(), self.project.message.as_ref())
    }

    /// Save the window's drives as the project at `path` (whole or not at all), remember
    /// it as the one to reopen, and take it as each drive's reference from now on.
    pub fn save_project(&mut self, path: &Path) -> Result<String, String> {
        let project = self.project()?;
        project::save(&project, path).map_err(|e| e.to_string())?;
        for (i, drive) in project.drives.iter().enumerate() {
            if let Some(state) = self.drive_state_mut(i) {
                state.project_drive = Some(drive.clone());
            }
        }
        self.project.path = Some(path.to_path_buf());
        let mut said = format!(
            "saved {} drive(s) to {}",
            project.drives.len(),
            path.display()
        );
        if let Err(e) = self.project.remember(path) {
            said.push_str(&format!("; it will not reopen by itself next time: {e}"));
        }
        Ok(said)
    }

    /// Ask the dialog for a project file to open or save to.
    fn ask_project_file(&mut self, ctx: &egui::Context, purpose: Purpose) {
        let directory = self
            .project
            .path
            .as_ref()
            .and_then(|p| p.parent())
            .map(Path::to_path_buf);
        let name = self
            .project
            .path
            .as_ref()
            .and_then(|p| p.file_name())
            .map_or_else(
                || "machine.json".to_owned(),
                |n| n.to_string_lossy().into_owned(),
            );
        let ask = Ask {
            save: purpose == Purpose::Save,
            title: match purpose {
                Purpose::Open => "Open a drivedeck project".into(),
                Purpose::Save => "Save the drives as a project".into(),
            },
            directory,
            name,
            filters: vec![("drivedeck project".into(), vec!["json".into()])],
        };
        let answer = Answer::default();
        self.state
            .plot
            .files
            .clone()
            .pick(ask, answer.clone(), ctx.clone());
        self.project.asking = Some((purpose, answer));
    }

    /// A dialog's answer, once there.
    fn poll_project_file(&mut self) {
        let Some(picked) = self.project.asking.as_ref().and_then(|(_, a)| take(a)) else {
            return;
        };
        let Some((purpose, _)) = self.project.asking.take() else {
            return;
        };
        let path = match picked {
            Picked::File(path) => path,
            Picked::Cancelled => {
                self.project.message = Some(Ok(match purpose {
                    Purpose::Open => "no project opened".into(),
                    Purpose::Save => "cancelled: no project written".into(),
                }));
                return;
            }
            Picked::NoDialog(why) => {
                self.project.message = Some(Err(why));
                return;
            }
        };
        match purpose {
            Purpose::Open => self.open_project_file(&path),
            Purpose::Save if path.exists() && self.project.path.as_deref() != Some(&path) => {
                self.project.confirm = Some(path);
            }
            Purpose::Save => self.project.message = Some(self.save_project(&path)),
        }
    }

    /// Open the project file at `path` in place of the window's drives.
    pub fn open_project_file(&mut self, path: &Path) {
        let opened = project::open(path)
            .map_err(|e| e.to_string())
            .and_then(|project| self.open_project(&project, Some(path.to_path_buf())));
        match opened {
            Ok(()) => {
                if let Err(e) = self.project.remember(path) {
                    self.state.info(format!(
                        "the project will not reopen by itself next time: {e}"
                    ));
                }
            }
            Err(e) => {
                self.project.message = Some(Err(format!(
                    "{} not opened: {e}; the drives stay as they were",
                    path.display()
                )));
            }
        }
    }

    /// The question before another file is replaced by the project.
    fn confirm_project_ui(&mut self, ctx: &egui::Context) {
        let Some(path) = self.project.confirm.clone() else {
            return;
        };
        let mut choice = None;
        let modal = egui::Modal::new(egui::Id::unique("project_replace_file")).show(ctx, |ui| {
            ui.set_max_width(520.0);
            ui.heading("Replace the file?");
            ui.label(format!(
                "{} exists already. Saving the project there replaces it; the old file is gone.",
                path.display()
            ));
            ui.horizontal(|ui| {
                if ui.button("Replace").clicked() {
                    choice = Some(true);
                }
                if ui.button("Cancel").clicked() {
                    choice = Some(false);
                }
            });
        });
        if modal.should_close() && choice.is_none() {
            choice = Some(false);
        }
        match choice {
            Some(true) => {
                self.project.confirm = None;
                self.project.message = Some(self.save_project(&path));
            }
            Some(false) => {
                self.project.confirm = None;
                self.project.message = Some(Ok(format!(
                    "no project written: {} kept as it was",
                    path.display()
                )));
            }
            None => {}
        }
    }

    /// The project's dialogs and questions, every frame.
    pub(super) fn project_steps(&mut self, ctx: &egui::Context) {
        self.poll_project_file();
        self.confirm_project_ui(ctx);
    }
}

/// The "Project" menu beside the list's title: open, save, save as; the project's file
/// and the last action's outcome under the list.
pub fn project_menu_ui(ui: &mut Ui, app: &mut App) {
    let ctx = ui.ctx().clone();
    let busy = app.project.asking.is_some();
    ui.menu_button("Project", |ui| {
        ui.set_min_width(220.0);
        let connected = app.any_connected();
        let open = ui
            .add_enabled(!connected && !busy, egui::Button::new("Open project…"))
            .on_hover_text(
                "The drives, their options, watched objects and the plot layout of a project file",
            )
            .on_disabled_hover_text(
                "Disconnect every drive first: opening a project replaces the drives",
            );
        if open.clicked() {
            app.ask_project_file(&ctx, Purpose::Open);
            ui.close();
        }
        let save_to = app.project.path.clone();
        let save = ui
            .add_enabled(!busy, egui::Button::new("Save project"))
            .on_hover_text(match &save_to {
                Some(path) => format!("Write the drives to {}", path.display()),
                None => "Write the drives to a project file (asks where)".into(),
            });
        if save.clicked() {
            match &save_to {
                Some(path) => app.project.message = Some(app.save_project(path)),
                None => app.ask_project_file(&ctx, Purpose::Save),
            }
            ui.close();
        }
        if ui
            .add_enabled(!busy, egui::Button::new("Save project as…"))
            .clicked()
        {
            app.ask_project_file(&ctx, Purpose::Save);
            ui.close();
        }
    });
}

/// The project's file and the last open or save, under the list's title.
pub fn project_line_ui(ui: &mut Ui, app: &App) {
    match &app.project.message {
        Some(Ok(text)) => {
            ui.add(egui::Label::new(egui::RichText::new(text).small().weak()).wrap());
        }
        Some(Err(text)) => {
            ui.add(
                egui::Label::new(egui::RichText::new(text).small().color(super::widgets::RED))
                    .wrap(),
            );
        }
        None => {}
    }
}

impl AppState {
    /// Compare the drive with the project's record of it, now that its identity was read
    /// (`Ok`) or its connection failed (`Err`). Said once per verdict, in the colour of the
    /// outcome; a failed connection is said only while nothing better is known.
    pub(crate) fn check_against_project(&mut self, now: Result<&DeviceIdentity, &str>) {
        let Some(saved) = &self.project_drive else {
            return;
        };
        if now.is_err() && self.project_check.is_some() {
            return;
        }
        let check = project::check::check(saved, now);
        if self.project_check.as_ref() == Some(&check) {
            return;
        }
        let outcome = match &check.verdict {
            Verdict::Same => Outcome::Succeeded("the device the project saw".into()),
            Verdict::Changed(_) => Outcome::Failed(format!(
                "not the device the project saw: {}",
                verdict_text(&check)
            )),
            Verdict::NoAnswer(_) => Outcome::Failed(verdict_text(&check)),
            Verdict::NotRecorded(_) => Outcome::Caution(verdict_text(&check)),
        };
        self.push_log(LogEntry {
            at: self.clock,
            id: None,
            what: format!("project check of \"{}\"", check.name),
            image: None,
            outcome,
        });
        self.project_check = Some(check);
    }

    /// What the list's row says of the project check, and whether it is an alarm (red)
    /// or a caution (amber): nothing while the drive is the one the project saw (or not
    /// yet checked, or answering now after a failed first try).
    pub fn project_warning(&self) -> Option<(String, bool)> {
        let check = self.project_check.as_ref()?;
        match &check.verdict {
            Verdict::Same => None,
            Verdict::Changed(_) => Some((
                format!("not the project's device: {}", verdict_text(check)),
                true,
            )),
            Verdict::NoAnswer(_) if matches!(self.connection, Connection::Connected(_)) => None,
            Verdict::NoAnswer(_) => Some((verdict_text(check), true)),
            Verdict::NotRecorded(_) => Some((
                "identity not in the project yet: Project > Save project keeps it".into(),
                false,
            )),
        }
    }
}

/// A check's words without the drive's name.
fn verdict_text(check: &DriveCheck) -> String {
    let text = check.to_string();
    text.strip_prefix(&format!("{}: ", check.name))
        .map(str::to_owned)
        .unwrap_or(text)
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
        let mut settings = Settings::default();
        assert_eq!(apply_plot_layout(&mut settings, &project), None);
        let settings = drive_settings(settings, &project.drives[0]);
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
    }

    #[test]
    fn a_bad_layout_is_said_and_the_window_keeps_its_own() {
        let mut project = project();
        project.plot = Some(serde_json::json!({"window_s": "wide"}));
        let before = Settings::default();
        let mut settings = before.clone();
        let note = apply_plot_layout(&mut settings, &project).expect("a note");
        assert!(
            note.contains("plot layout is not one this window reads"),
            "{note}"
        );
        assert_eq!(settings.plot, before.plot);
    }
}
