//! The list of drives: each with its name, its colour, its own worker (and so its own
//! link) and its own model; adding, selecting, renaming, removing, stopping them all, and
//! leaving them when the window closes.

use std::time::SystemTime;

use super::{App, Slot};
use crate::link::{LinkSpec, SpecError};
use crate::pdi::Action;
use crate::ui::channel::Channel;
use crate::ui::connection_form::ConnectionForm;
use crate::ui::drive::{Connection, Drive};
use crate::ui::drive_row::DriveRow;
use crate::ui::leave;
use crate::ui::settings::DriveSettings;
use crate::worker::Request;

/// Why a drive could not be added.
#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    #[error(
        "'{name}' is a name already given to another drive ('{other}'): each drive needs its own, differing in more than upper and lower case"
    )]
    NameTaken { name: String, other: String },
    #[error("a drive needs a name")]
    NoName,
    #[error("the name '{name}' {reason}")]
    BadName { name: String, reason: String },
    #[error(transparent)]
    Spec(#[from] SpecError),
}

impl App {
    /// A drive named `name` with `settings`, its worker started; its index.
    pub(super) fn start_drive(&mut self, name: String, settings: DriveSettings) -> usize {
        // The first colour no drive of the list has: kept for good, whatever is selected.
        let color = (0..)
            .find(|c| self.drives.iter().all(|s| s.drive.color != *c))
            .unwrap_or_default();
        let plot = &self.window.settings.plot;
        let mut drive = Drive::new(name, color, settings, plot.history_rows, &plot.shown);
        drive.clock = self.started.elapsed().as_secs_f64();
        crate::ui::view::make_models(&mut drive.panels);
        let channel = Channel::spawn(&mut drive, self.notify.clone(), self.started, self.clock);
        self.drives.push(Slot { drive, channel });
        self.drives.len() - 1
    }

    /// Every drive's name and the link it is (or is to be) connected to.
    pub fn drives(&self) -> impl Iterator<Item = (&str, Option<LinkSpec>)> {
        self.drives.iter().map(|slot| {
            let drive = &slot.drive;
            let link = match &drive.link.connection {
                Connection::Disconnected => drive.settings.connection.spec().ok(),
                _ => drive.link.spec().cloned(),
            };
            (drive.name.as_str(), link)
        })
    }

    /// What the list's rows show at `now`.
    pub fn drive_rows(&self, now: SystemTime) -> Vec<DriveRow> {
        let unit = self.window.settings.plot.position_unit;
        self.drives
            .iter()
            .map(|slot| DriveRow::of(&slot.drive, unit, now))
            .collect()
    }

    /// Add a drive by its connection string and connect to it; its index in the list.
    pub fn add_drive(&mut self, name: String, link: &str) -> Result<usize, DriveError> {
        let spec: LinkSpec = link.parse()?;
        self.add_drive_spec(name, spec)
    }

    /// Add a drive on `spec` and connect to it: the shown drive's inputs and options, no
    /// pinned objects; its index in the list.
    pub fn add_drive_spec(&mut self, name: String, spec: LinkSpec) -> Result<usize, DriveError> {
        let mut settings = self.shown().settings.clone();
        settings.connection = ConnectionForm::from_spec(&spec, ConnectionForm::default());
        settings.watch.pins.clear();
        self.add_drive_with(name, spec, settings)
    }

    /// Add a drive on `spec` with its own `settings` (a project's drive) and connect it.
    pub(super) fn add_drive_with(
        &mut self,
        name: String,
        spec: LinkSpec,
        settings: DriveSettings,
    ) -> Result<usize, DriveError> {
        let name = self.free_name(name, None)?;
        let index = self.start_drive(name, settings);
        if let Some(drive) = self.drive_mut(index) {
            drive.ask(Request::Connect(spec));
        }
        Ok(index)
    }

    /// `name` trimmed, when no drive but `except` has it.
    fn free_name(&self, name: String, except: Option<usize>) -> Result<String, DriveError> {
        let name = name.trim().to_owned();
        if name.is_empty() {
            return Err(DriveError::NoName);
        }
        // The rules a project file holds its names to, so that the list can be saved.
        if let Some(reason) = crate::project::name_problem(&name) {
            return Err(DriveError::BadName { name, reason });
        }
        let taken =
            self.drives.iter().enumerate().find(|(i, s)| {
                Some(*i) != except && crate::project::same_name(&s.drive.name, &name)
            });
        if let Some((_, other)) = taken {
            return Err(DriveError::NameTaken {
                other: other.drive.name.clone(),
                name,
            });
        }
        Ok(name)
    }

    /// The next free name "Drive n".
    pub fn next_drive_name(&self) -> String {
        (1..)
            .map(|n| format!("Drive {n}"))
            .find(|name| self.drives.iter().all(|s| &s.drive.name != name))
            .unwrap_or_default()
    }

    /// Point the panels at the drive at `index`. A jog held on the drive left is
    /// released (its button is no longer on screen).
    pub fn select(&mut self, index: usize) {
        if index == self.selected || index >= self.drives.len() {
            return;
        }
        let shown = self.shown_mut();
        if shown.motion.jog.take().is_some() {
            shown.request(Request::JogStop);
        }
        self.window.list.name_draft = None;
        self.selected = index;
    }

    /// Rename the drive at `index`.
    pub fn rename(&mut self, index: usize, name: String) -> Result<(), DriveError> {
        let name = self.free_name(name, Some(index))?;
        if let Some(drive) = self.drive_mut(index) {
            drive.name = name;
        }
        Ok(())
    }

    /// Take the drive at `index` out of the list (its worker closes the link). The last
    /// drive stays, and a connected one must be disconnected first (leaving safely).
    pub fn remove_drive(&mut self, index: usize) -> Result<(), String> {
        if self.drives.len() <= 1 {
            return Err("the last drive stays in the list".into());
        }
        if self.drive(index).is_some_and(Drive::is_connected) {
            return Err("disconnect it first (the window asks what to leave behind)".into());
        }
        if index >= self.drives.len() {
            return Ok(());
        }
        if index == self.selected {
            let other = if index == 0 { 1 } else { index - 1 };
            self.select(other);
        }
        self.drives.remove(index);
        if self.selected > index {
            self.selected -= 1;
        }
        Ok(())
    }

    /// Whether any drive's link is up.
    pub fn any_connected(&self) -> bool {
        self.drives.iter().any(|s| s.drive.is_connected())
    }

    /// Quickstop or switch off every connected drive, ahead of everything queued on each.
    pub fn stop_all(&mut self, action: Action) {
        for slot in &mut self.drives {
            if slot.drive.is_connected() {
                slot.drive.stop_now(action);
            }
        }
    }

    /// Closing the window: ask once for every drive that needs it, or go.
    pub(super) fn start_closing(&mut self) {
        self.closing = true;
        let asking = self
            .drives
            .iter()
            .any(|s| s.drive.leaving.is_none() && s.drive.needs_leave_question());
        for slot in &mut self.drives {
            let drive = &mut slot.drive;
            if drive.leaving.is_none() && (!asking || drive.needs_leave_question()) {
                drive.ask_to_leave(true);
            }
        }
    }

    /// The leave question, and every drive's step of leaving; the window closes once all
    /// drives are left.
    pub(super) fn leave_steps(&mut self, ctx: &eframe::egui::Context) {
        let answered = {
            let mut drives: Vec<&mut Drive> =
                self.drives.iter_mut().map(|s| &mut s.drive).collect();
            leave::leave_dialog(ctx, &mut drives)
        };
        match answered {
            Some(leave::Answered::Cancelled) if self.closing => self.closing = false,
            Some(leave::Answered::Going) if self.closing => {
                // The drives that needed no question go too.
                for slot in &mut self.drives {
                    if slot.drive.leaving.is_none() {
                        slot.drive.ask_to_leave(true);
                    }
                }
            }
            _ => {}
        }
        let mut done = true;
        for slot in &mut self.drives {
            slot.drive.leave_step();
            done &= slot.drive.leaving.is_none();
        }
        if self.closing && done {
            self.may_close = true;
            ctx.send_viewport_cmd(eframe::egui::ViewportCommand::Close);
        }
    }
}
