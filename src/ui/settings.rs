//! What the window keeps between runs, and how it splits into what belongs to the window
//! ([`WindowSettings`]: layout, plot and dictionary choices, where exports go) and what
//! belongs to one drive ([`DriveSettings`]: its link, its boxes as typed, its pinned
//! objects). The file eframe keeps holds one [`Settings`]: the window's choices and the
//! first drive's; a project holds each drive's link, options and pins itself.
//!
//! A model: no egui here.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::browser::DictionarySettings;
use super::connection_form::ConnectionForm;
use super::plots::model::PlotSettings;
use super::watch::WatchSettings;
use crate::pdi::Opcode;

/// The id of the plots, the panel the window opens on.
pub const PLOTS: &str = "plots";
/// The id of the object dictionary.
pub const DICTIONARY: &str = "dictionary";
use crate::worker::{LOST_AFTER, LinkLossAction};

/// What persists between runs, as eframe stores it: the window's choices and the first
/// drive's, side by side in one record (the shape older versions saved, so their files
/// still load). [`Settings::split`] and [`Settings::join`] turn it into the two halves
/// the window works with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    pub connection: ConnectionForm,
    /// The text of every command's input boxes, by opcode name.
    pub inputs: BTreeMap<String, Vec<String>>,
    pub poll_rate: f64,
    /// Torque slope suggested when 6087h is 0, ‰/s.
    pub torque_slope: String,
    pub show_log: bool,
    /// Record every bus frame in the frame log.
    pub record_frames: bool,
    /// The "any object" row: address and value as typed.
    pub object_address: String,
    pub object_value: String,
    /// Where "Export" writes the frame log (candump format for CAN).
    pub frame_log_path: String,
    /// What the middle of the window shows.
    pub central: Central,
    /// The plot panel's choices.
    pub plot: PlotSettings,
    /// The object dictionary's choices.
    pub dictionary: DictionarySettings,
    /// The jog speed as typed, rpm.
    pub jog_speed: String,
    /// Where the fault timeline's export goes.
    pub timeline_path: String,
    /// What the worker does when the link fails during a move.
    pub on_link_loss: LinkLossAction,
    /// Exchanges that must fail in a row before the link counts as lost.
    pub lost_after: u32,
    /// The watch panel: pinned objects, their formats, the refresh rate, and whether the
    /// panel is shown.
    pub watch: SavedWatch,
    /// The command panel folded to a narrow strip (more room for the plots).
    pub commands_collapsed: bool,
}

/// The watch panel as saved: the drive's pins, rate and address box, and the window's
/// choice to show it, side by side (no `serde(flatten)`: eframe keeps its file as RON,
/// where a flattened struct is written as a map and an older file no longer reads).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SavedWatch {
    pub pins: Vec<super::watch::Pin>,
    /// Refreshes per second.
    pub rate: f64,
    /// The panel is shown.
    pub open: bool,
    /// The address box as typed.
    pub address: String,
}

impl Default for SavedWatch {
    fn default() -> Self {
        SavedWatch::of(WatchSettings::default(), false)
    }
}

impl SavedWatch {
    fn of(drive: WatchSettings, open: bool) -> Self {
        SavedWatch {
            pins: drive.pins,
            rate: drive.rate,
            open,
            address: drive.address,
        }
    }

    /// The drive's half.
    pub fn drive(&self) -> WatchSettings {
        WatchSettings {
            pins: self.pins.clone(),
            rate: self.rate,
            address: self.address.clone(),
        }
    }
}

/// The panel in the middle of the window, as saved: the plots, the object dictionary (as
/// the first versions saved them), or another panel by its id.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Central {
    #[default]
    Plots,
    Dictionary,
    Panel(String),
}

impl Central {
    /// The id of its panel (`ui::view::CENTRAL`).
    pub fn id(&self) -> String {
        match self {
            Central::Plots => PLOTS.to_owned(),
            Central::Dictionary => DICTIONARY.to_owned(),
            Central::Panel(id) => id.clone(),
        }
    }

    /// The panel with this id.
    pub fn of(id: &str) -> Central {
        match id {
            PLOTS => Central::Plots,
            DICTIONARY => Central::Dictionary,
            other => Central::Panel(other.to_owned()),
        }
    }
}

/// What belongs to the window whatever drive it shows: the layout, the plots' and the
/// dictionary's choices, where exports go. One for the window, never copied per drive.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowSettings {
    /// The id of the panel in the middle (`ui::view::CENTRAL`).
    pub central: String,
    pub plot: PlotSettings,
    pub dictionary: DictionarySettings,
    pub commands_collapsed: bool,
    pub show_log: bool,
    /// The watch panel is shown.
    pub watch_open: bool,
    pub frame_log_path: String,
    pub timeline_path: String,
}

/// What belongs to one drive: its link, its boxes as typed, its options and pinned objects.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveSettings {
    pub connection: ConnectionForm,
    /// The text of every command's input boxes, by opcode name.
    pub inputs: BTreeMap<String, Vec<String>>,
    pub poll_rate: f64,
    /// Torque slope suggested when 6087h is 0, ‰/s.
    pub torque_slope: String,
    /// Record every bus frame in the frame log.
    pub record_frames: bool,
    /// The "any object" row: address and value as typed.
    pub object_address: String,
    pub object_value: String,
    /// The jog speed as typed, rpm.
    pub jog_speed: String,
    pub on_link_loss: LinkLossAction,
    pub lost_after: u32,
    pub watch: WatchSettings,
}

impl Default for Settings {
    fn default() -> Self {
        Settings::join(WindowSettings::default(), DriveSettings::default())
    }
}

impl Default for WindowSettings {
    fn default() -> Self {
        Self {
            central: PLOTS.to_owned(),
            plot: PlotSettings::default(),
            dictionary: DictionarySettings::default(),
            commands_collapsed: false,
            show_log: true,
            watch_open: false,
            frame_log_path: "drivedeck-frames.log".into(),
            timeline_path: "drivedeck-faults.csv".into(),
        }
    }
}

impl Default for DriveSettings {
    fn default() -> Self {
        let mut inputs = BTreeMap::new();
        let mut put = |op: Opcode, values: &[&str]| {
            inputs.insert(
                op.name().to_owned(),
                values.iter().map(|v| (*v).to_owned()).collect(),
            );
        };
        put(Opcode::MoveAbsolute, &["2000", "200"]);
        put(Opcode::MoveRelative, &["3600", "200"]);
        put(Opcode::Velocity, &["300"]);
        put(Opcode::Torque, &["500", "100"]);
        put(Opcode::Homing, &["19"]);
        put(Opcode::HomeHere, &["0"]);
        put(Opcode::OdRead, &["1018", "01"]);
        put(Opcode::OdWrite, &["203B", "01", "1000"]);
        Self {
            connection: ConnectionForm::default(),
            inputs,
            poll_rate: 100.0,
            torque_slope: "1000".into(),
            record_frames: false,
            object_address: "1008".into(),
            object_value: String::new(),
            jog_speed: "100".into(),
            on_link_loss: LinkLossAction::Halt,
            lost_after: LOST_AFTER,
            watch: WatchSettings::default(),
        }
    }
}

impl DriveSettings {
    /// A new drive's settings on `connection`: the defaults, nothing pinned.
    pub fn on(connection: ConnectionForm) -> Self {
        Self {
            connection,
            ..Self::default()
        }
    }
}

impl Settings {
    /// The window's half and the drive's half.
    pub fn split(self) -> (WindowSettings, DriveSettings) {
        let window = WindowSettings {
            central: self.central.id(),
            plot: self.plot,
            dictionary: self.dictionary,
            commands_collapsed: self.commands_collapsed,
            show_log: self.show_log,
            watch_open: self.watch.open,
            frame_log_path: self.frame_log_path,
            timeline_path: self.timeline_path,
        };
        let drive = DriveSettings {
            connection: self.connection,
            inputs: self.inputs,
            poll_rate: self.poll_rate,
            torque_slope: self.torque_slope,
            record_frames: self.record_frames,
            object_address: self.object_address,
            object_value: self.object_value,
            jog_speed: self.jog_speed,
            on_link_loss: self.on_link_loss,
            lost_after: self.lost_after,
            watch: self.watch.drive(),
        };
        (window, drive)
    }

    /// One record of the window's choices and one drive's.
    pub fn join(window: WindowSettings, drive: DriveSettings) -> Settings {
        Settings {
            connection: drive.connection,
            inputs: drive.inputs,
            poll_rate: drive.poll_rate,
            torque_slope: drive.torque_slope,
            show_log: window.show_log,
            record_frames: drive.record_frames,
            object_address: drive.object_address,
            object_value: drive.object_value,
            frame_log_path: window.frame_log_path,
            central: Central::of(&window.central),
            plot: window.plot,
            dictionary: window.dictionary,
            jog_speed: drive.jog_speed,
            timeline_path: window.timeline_path,
            on_link_loss: drive.on_link_loss,
            lost_after: drive.lost_after,
            watch: SavedWatch::of(drive.watch, window.watch_open),
            commands_collapsed: window.commands_collapsed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_saved_record_splits_and_joins_back_unchanged() {
        let mut settings = Settings {
            central: Central::Dictionary,
            poll_rate: 250.0,
            jog_speed: "42".into(),
            ..Settings::default()
        };
        settings.plot.window_s = 3.0;
        settings.watch.open = true;
        settings.watch.rate = 5.0;
        let (window, drive) = settings.clone().split();
        assert!(window.watch_open && window.central == DICTIONARY);
        assert_eq!((drive.poll_rate, drive.watch.rate), (250.0, 5.0));
        assert_eq!(Settings::join(window, drive), settings);
    }

    #[test]
    fn a_file_saved_by_an_earlier_version_still_loads() {
        // The watch panel's fields side by side, as they always were.
        let json = r#"{"poll_rate": 50.0, "watch": {"pins": [], "rate": 10.0, "open": true, "address": "6041"}}"#;
        let settings: Settings = serde_json::from_str(json).expect("loads");
        assert_eq!(settings.poll_rate, 50.0);
        assert!(settings.watch.open);
        assert_eq!(settings.watch.rate, 10.0);
        assert_eq!(settings.watch.address, "6041");
        let text = serde_json::to_string(&settings).expect("saves");
        let again: Settings = serde_json::from_str(&text).expect("loads again");
        assert_eq!(again, settings);
    }
}
