//! The one place the user's intents change the window: every [`Command`] a view pushed
//! during the frame, applied after it is drawn, beside the workers' events (`events`).

use super::App;
use crate::telemetry::watchable;
use crate::ui::browser::Tone;
use crate::ui::command::PlotCommand;
use crate::ui::command::{Command, Said};
use crate::ui::project_files::Purpose;
use crate::ui::settings::PLOTS;
use crate::worker::MAX_WATCHED;

impl App {
    /// Apply the commands of this frame, in the order they were given.
    pub(super) fn apply_commands(&mut self) {
        for command in std::mem::take(&mut self.commands) {
            self.apply_command(command);
        }
    }

    /// Apply one command of the user's.
    pub fn apply_command(&mut self, command: Command) {
        // The drive shown's own first (a request, a jog, connecting, leaving…).
        let Some(command) = self.shown_mut().apply_command(command) else {
            return;
        };
        match command {
            Command::Select(index) => self.select(index),
            Command::AddDrive(link) => {
                let name = self.next_drive_name();
                match self.add_drive(name, &link) {
                    Ok(_) => {
                        self.window.list.message = None;
                        self.window.list.add_link.clear();
                    }
                    Err(e) => self.window.list.message = Some(e.to_string()),
                }
            }
            Command::AddDriveOn(spec) => {
                let name = self.next_drive_name();
                self.window.list.message =
                    self.add_drive_spec(name, spec).err().map(|e| e.to_string());
            }
            Command::RemoveDrive(index) => {
                self.window.list.message = self.remove_drive(index).err()
            }
            Command::Rename(index, name) => {
                let was = self
                    .drive(index)
                    .map(|d| d.name.clone())
                    .unwrap_or_default();
                self.window.list.message = self
                    .rename(index, name)
                    .err()
                    .map(|e| format!("{e}; the name stays '{was}'"));
            }
            Command::PlotBeside(index, on) => {
                if let Some(drive) = self.drive_mut(index) {
                    drive.in_plots = on;
                }
            }
            Command::StopAll(action) => self.stop_all(action),
            Command::ClearLog(tab) => self.clear_log(tab),
            Command::OpenGuide => {
                let said = match super::super::guide::open() {
                    Ok(index) => format!("the guide: {} opened in the browser", index.display()),
                    Err(why) => format!("the guide could not be opened: {why}"),
                };
                self.shown_mut().info(said);
            }
            Command::OpenProject => self.ask_project_file(Purpose::Open),
            Command::SaveProject => match self.project.path.clone() {
                Some(path) => self.project.message = Some(self.save_project(&path)),
                None => self.ask_project_file(Purpose::Save),
            },
            Command::SaveProjectAs => self.ask_project_file(Purpose::Save),
            Command::Plot(command) => self.apply_plot(command),
            Command::ClearPlots => {
                self.shown_mut().scope.clear();
                self.window.plot.cleared();
            }
            Command::SetHistory(rows) => {
                for slot in &mut self.drives {
                    slot.drive.scope.set_capacity(rows);
                }
                self.window.settings.plot.history_rows = rows;
                self.window
                    .plot
                    .say(Ok(format!("history: {rows} samples per signal")));
            }
            Command::PlotObject { text, from } => {
                let said = self.plot_object(&text);
                if from != Said::Plots {
                    self.say(from, said);
                }
            }
            // The drive's own, applied above.
            Command::Connect(_)
            | Command::Disconnect
            | Command::Request(_)
            | Command::SendCommand(_)
            | Command::RestoreChanges
            | Command::Inject { .. }
            | Command::Jog { .. }
            | Command::JogFocusLost => {}
            Command::UnplotObject(address) => {
                let drive = self.shown_mut();
                drive.plotted.retain(|(w, _)| w.address != address);
                drive.send_plotted();
            }
            Command::PinToWatch { address, from } => {
                let said = self.pin_to_watch(address);
                self.say(from, said);
            }
        }
    }

    /// A command for the plots: their view changes; a moment to show brings them to the
    /// middle of the window.
    fn apply_plot(&mut self, command: PlotCommand) {
        if matches!(command, PlotCommand::ShowMoment(_)) {
            self.window.settings.central = PLOTS.to_owned();
        }
        let newest = self.shown().scope.ring().last_time();
        let window_s = self.window.settings.plot.window_s;
        self.window.plot.apply(command, newest, window_s);
    }

    /// Empty a tab of the shown drive's log (as its registration says).
    fn clear_log(&mut self, tab: &str) {
        let clear = crate::ui::view::BOTTOM
            .iter()
            .find(|p| p.id == tab)
            .and_then(|p| p.clear);
        if let Some(clear) = clear {
            clear(self.shown_mut());
        }
    }

    /// Plot an object of the dictionary (typed as an address) on the shown drive: checked
    /// against its dictionary, then sampled by the worker every cycle. The plots say how
    /// it went.
    pub fn plot_object(&mut self, text: &str) -> Result<String, String> {
        let said = self.add_plotted(text);
        self.window.plot.say(said.clone());
        said
    }

    fn add_plotted(&mut self, text: &str) -> Result<String, String> {
        let drive = self.shown_mut();
        let (object, dtype) = watchable(drive.browser.catalog(), text)?;
        if drive
            .plotted
            .iter()
            .any(|(w, _)| w.address == object.address)
        {
            return Err(format!("{} is plotted already", object.address));
        }
        if drive.plotted.len() >= MAX_WATCHED {
            return Err(format!(
                "at most {MAX_WATCHED} objects can be plotted besides the built-in signals"
            ));
        }
        let said = format!("plotting {} {}", object.address, object.name);
        drive.plotted.push((object, dtype));
        drive.send_plotted();
        Ok(said)
    }

    /// Pin an object to the shown drive's watch panel, and show the panel.
    pub fn pin_to_watch(&mut self, address: crate::od::Address) -> Result<String, String> {
        let drive = self.shown_mut();
        let catalog = drive.browser.catalog();
        let name = catalog
            .get(address)
            .map(|e| e.name.clone())
            .unwrap_or_default();
        drive
            .settings
            .watch
            .pin(address, catalog)
            .map_err(|e| e.to_string())?;
        self.window.settings.watch_open = true;
        Ok(format!("watching {address} {name}: see the watch panel"))
    }

    /// Say how a command went in the panel it came from.
    fn say(&mut self, from: Said, said: Result<String, String>) {
        match from {
            Said::Plots => self.window.plot.say(said),
            Said::Dictionary => {
                let (tone, text) = match said {
                    Ok(text) if text.starts_with("plotting") => {
                        (Tone::Done, format!("{text}: see the Plots tab"))
                    }
                    Ok(text) => (Tone::Done, text),
                    Err(text) => (Tone::Failed, text),
                };
                self.shown_mut().browser.say(tone, text);
            }
            Said::Watch => {
                self.shown_mut().watch.message = said.err();
            }
        }
    }
}
