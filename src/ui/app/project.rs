//! Projects in the window: `drivedeck PROJECT.json` (or the last project, on a start
//! without arguments) opens every drive of the project, each with its name, link,
//! options and watched objects, the plot layout shared; each drive's identity (1018h) is
//! compared with the one the project saw as soon as it is read, and what differs (or a
//! drive that does not answer) is said in that drive's log and its row of the list. The
//! "Project" menu saves the window's drives as a project, or opens another.

use std::path::{Path, PathBuf};

use eframe::egui;

use super::App;
use crate::project::{self, DriveOptions, Project};
use crate::ui::plots::files::{Answer, Ask, Picked, take};
use crate::ui::project_files::{Purpose, apply_plot_layout, drive_settings};
use crate::ui::settings::Settings;
use crate::worker::{self, Request};

impl App {
    /// The window opened on `project` (from `path`): every drive in the list and
    /// connecting, the one named `show` (else the first) selected.
    pub fn with_project(
        settings: Settings,
        notify: worker::Notify,
        project: &Project,
        path: Option<PathBuf>,
        show: Option<&str>,
    ) -> App {
        let Some(first) = project.drives.first() else {
            return App::new(settings, notify, true);
        };
        let (mut window, drive) = settings.split();
        let note = apply_plot_layout(&mut window.plot, project);
        let settings = Settings::join(window, drive_settings(drive, first));
        let mut app = App::new(settings, notify, true);
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
        let note = apply_plot_layout(&mut self.window.settings.plot, project);
        let drive = self.shown_mut();
        drive.settings = drive_settings(drive.settings.clone(), first);
        drive.project.check = None;
        drive.ask(Request::Connect(first.link.clone()));
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
        let base = self.shown().settings.clone();
        if let Some(slot) = self.drives.first_mut() {
            slot.drive.name = first.name.clone();
            slot.drive.project.drive = Some(first.clone());
        }
        for drive in &project.drives[1..] {
            let settings = drive_settings(base.clone(), drive);
            match self.add_drive_with(drive.name.clone(), drive.link.clone(), settings) {
                Ok(i) => {
                    if let Some(added) = self.drive_mut(i) {
                        added.project.drive = Some(drive.clone());
                    }
                }
                Err(e) => self
                    .shown_mut()
                    .info(format!("the project's drive \"{}\": {e}", drive.name)),
            }
        }
        if let Some(note) = note {
            self.shown_mut().info(note);
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
                None => self.shown_mut().info(format!(
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
        for (slot, link) in self.drives.iter().zip(links) {
            let state = &slot.drive;
            let name = &state.name;
            let link = link.ok_or_else(|| {
                format!("\"{name}\" has no valid connection string: give it one first")
            })?;
            let saved = state.project.drive.as_ref().filter(|s| s.link == link);
            let mut drive = project::Drive::new(name.clone(), link);
            drive.options = DriveOptions {
                poll_rate: state.settings.poll_rate,
                on_link_loss: state.settings.on_link_loss,
                lost_after: state.settings.lost_after,
            };
            drive.watch = state.settings.watch.pins.clone();
            drive.identity = state
                .link
                .identity
                .clone()
                .or_else(|| saved.and_then(|s| s.identity.clone()));
            drive.backup = saved.and_then(|s| s.backup.clone());
            drives.push(drive);
        }
        let mut project = Project::new(drives).map_err(|e| e.to_string())?;
        project.plot = serde_json::to_value(&self.window.settings.plot).ok();
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
        for (slot, drive) in self.drives.iter_mut().zip(&project.drives) {
            slot.drive.project.drive = Some(drive.clone());
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
    pub(super) fn ask_project_file(&mut self, purpose: Purpose) {
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
        self.window
            .plot
            .files()
            .pick(ask, answer.clone(), self.notify.clone());
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
                    self.shown_mut().info(format!(
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
