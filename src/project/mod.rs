//! A project: the set of drives a machine has (each a name such as "X axis", its
//! connection string and its per-connection options), the objects watched on each, each
//! drive's identity as last seen and optionally its settings backup, and the window's plot
//! layout. Saved as one JSON file (`"format": "drivedeck-project", "version": 1`), written
//! whole or not at all; a file that is not a valid project is refused with its cause.
//!
//! The model is plain data and does no I/O on a bus: the command line and the window open
//! the drives (through the worker) and hand what each drive answered to
//! [`check::check`], which says per drive whether it is still the device the project saw.
//!
//! The window's own setting types stay in `ui` (this layer may not import it): the plot
//! layout is kept as the JSON the window wrote (`plot`), checked only to be an object; the
//! watched objects ([`watch::Pin`]) are plain data and live here, the window uses them.

pub mod check;
pub mod file;
pub mod recent;
pub mod watch;

use serde::{Deserialize, Serialize};

use crate::link::LinkSpec;
use crate::od::backup::{Backup, DeviceIdentity};
use crate::text::shown;
use crate::worker::{LOST_AFTER, LinkLossAction, MAX_LOST_AFTER};

pub use file::{MAX_BYTES, open, save};
pub use watch::{Format, MAX_PINS, Pin};

/// The `format` field of every project file.
pub const FORMAT: &str = "drivedeck-project";
/// The file format's version.
pub const VERSION: u64 = 1;
/// A drive's name is at most this many characters.
pub const MAX_NAME: usize = 64;
/// At most this many drives in one project.
pub const MAX_DRIVES: usize = 64;
/// The poll rates a drive may be given, Hz (the worker's range).
pub const POLL_RATES: std::ops::RangeInclusive<f64> = 1.0..=2000.0;

/// Why a project cannot be read, checked or written.
#[derive(Debug, thiserror::Error)]
pub enum ProjectError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("cannot write {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
    #[error("{path} is {size} bytes: a project file is at most {MAX_BYTES} bytes")]
    TooLarge { path: String, size: u64 },
    /// A FIFO, a device, a directory: refused before anything waits on it.
    #[error("{0}")]
    NotAFile(String),
    #[error("not a drivedeck project: the file is not UTF-8 text (byte {0} is not)")]
    NotText(usize),
    #[error("not a drivedeck project: it is not JSON ({0})")]
    NotJson(String),
    #[error("not a drivedeck project: {0}")]
    NotProject(String),
    #[error(
        "not a drivedeck project: its format is \"{0}\", not \"{FORMAT}\" (a backup file is opened with `od diff`/`od restore`)"
    )]
    Format(String),
    #[error(
        "project version {0} is newer than this drivedeck reads (version {VERSION}): open it with a newer drivedeck"
    )]
    Newer(u64),
    #[error("project version {0} does not exist (the first is 1)")]
    BadVersion(String),
    #[error("the project's top level: {0}")]
    Top(String),
    #[error("the project's plot layout is a {0}, not an object (the window's plot settings)")]
    Plot(&'static str),
    #[error("the project has no drives (give at least one)")]
    NoDrives,
    #[error("the project has {0} drives; at most {MAX_DRIVES}")]
    TooManyDrives(usize),
    #[error("drive {index}: {reason}")]
    Drive { index: usize, reason: String },
    #[error("drive {index}'s name \"{}\" {reason}", shown(name))]
    BadName {
        index: usize,
        name: String,
        reason: String,
    },
    #[error(
        "two drives are named \"{}\" and \"{}\": names must differ, and not only in upper and lower case",
        shown(first),
        shown(second)
    )]
    Twice { first: String, second: String },
    #[error("drive \"{}\": {reason}", shown(name))]
    Setting { name: String, reason: String },
    #[error(
        "drives \"{}\" and \"{}\" both connect to {link}: that is one drive (and a Nanotec drive takes one Modbus TCP client); give each drive its own connection",
        shown(first),
        shown(second)
    )]
    SameDrive {
        first: String,
        second: String,
        link: String,
    },
    #[error(
        "no drive named \"{}\" in the project; its drives: {names}",
        shown(name)
    )]
    NoSuchDrive { name: String, names: String },
}

/// What the worker is told for one drive's link, beyond its connection string.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriveOptions {
    /// Polls (and samples) per second, Hz.
    pub poll_rate: f64,
    /// What the worker does when the link fails during a move.
    pub on_link_loss: LinkLossAction,
    /// Exchanges that must fail in a row before the link counts as lost.
    pub lost_after: u32,
}

impl Default for DriveOptions {
    fn default() -> Self {
        // The window's defaults (`ui::Settings`).
        Self {
            poll_rate: 100.0,
            on_link_loss: LinkLossAction::Halt,
            lost_after: LOST_AFTER,
        }
    }
}

/// One drive of a project.
#[derive(Clone, Debug, PartialEq)]
pub struct Drive {
    /// What the machine calls it: "X axis".
    pub name: String,
    pub link: LinkSpec,
    pub options: DriveOptions,
    /// The objects watched on it.
    pub watch: Vec<Pin>,
    /// 1018h and the names, as last seen; `None` until the drive was asked.
    pub identity: Option<DeviceIdentity>,
    /// Its settings, when the project keeps a backup of them.
    pub backup: Option<Backup>,
}

impl Drive {
    /// A drive with the default options and nothing watched, seen or saved yet.
    pub fn new(name: impl Into<String>, link: LinkSpec) -> Drive {
        Drive {
            name: name.into(),
            link,
            options: DriveOptions::default(),
            watch: vec![],
            identity: None,
            backup: None,
        }
    }

    /// A file name for things saved per drive: [`file_stem`] of its name.
    pub fn file_stem(&self) -> String {
        file_stem(&self.name)
    }
}

/// A file name for things saved per drive (`od dump DIR`, a procedure's `{drive}`): the
/// drive's name with every character but ASCII letters, digits, `-` and `_` made `_`,
/// never empty, never starting with a dot. "X axis" → `X_axis`.
pub fn file_stem(name: &str) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.chars().all(|c| c == '_') {
        format!("drive{stem}")
    } else {
        stem
    }
}

/// A whole project.
#[derive(Clone, Debug, PartialEq)]
pub struct Project {
    pub drives: Vec<Drive>,
    /// The window's plot layout as the window wrote it (its `PlotSettings`, a JSON
    /// object); `None` leaves the window's own.
    pub plot: Option<serde_json::Value>,
}

/// Whether two drive names are the same to a project: upper and lower case aside (a
/// file system, a person reading the record, `--drive` typed by hand would confuse them).
pub fn same_name(a: &str, b: &str) -> bool {
    a.to_lowercase() == b.to_lowercase()
}

/// Why a drive's name is not one: `None` when it is.
pub fn name_problem(name: &str) -> Option<String> {
    if name.trim().is_empty() {
        Some("is empty".into())
    } else if name.trim() != name {
        Some("starts or ends with a space".into())
    } else if name.chars().count() > MAX_NAME {
        Some(format!("is longer than {MAX_NAME} characters"))
    } else if name.chars().any(char::is_control) {
        Some("has a control character".into())
    } else if name.contains('=') {
        Some("has an '=' (the command line's --drive NAME=URL splits there)".into())
    } else {
        None
    }
}

impl Project {
    /// A project of these drives, checked as a file's would be.
    pub fn new(drives: Vec<Drive>) -> Result<Project, ProjectError> {
        let project = Project { drives, plot: None };
        project.check()?;
        Ok(project)
    }

    /// The drive named `name` (exactly), or an error listing the names there are.
    pub fn drive(&self, name: &str) -> Result<&Drive, ProjectError> {
        self.drives
            .iter()
            .find(|d| d.name == name)
            .ok_or_else(|| ProjectError::NoSuchDrive {
                name: name.to_owned(),
                names: self.names(),
            })
    }

    pub fn drive_mut(&mut self, name: &str) -> Result<&mut Drive, ProjectError> {
        let names = self.names();
        self.drives
            .iter_mut()
            .find(|d| d.name == name)
            .ok_or_else(|| ProjectError::NoSuchDrive {
                name: name.to_owned(),
                names,
            })
    }

    /// The drives' names, quoted, comma-separated.
    pub fn names(&self) -> String {
        self.drives
            .iter()
            .map(|d| format!("\"{}\"", d.name))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Everything a file is checked for, beyond its shape: at least one drive, names
    /// that are names and differ, options in range, pins known once each, the plot
    /// layout an object.
    pub fn check(&self) -> Result<(), ProjectError> {
        if self.drives.is_empty() {
            return Err(ProjectError::NoDrives);
        }
        if self.drives.len() > MAX_DRIVES {
            return Err(ProjectError::TooManyDrives(self.drives.len()));
        }
        for (i, drive) in self.drives.iter().enumerate() {
            if let Some(reason) = name_problem(&drive.name) {
                return Err(ProjectError::BadName {
                    index: i + 1,
                    name: drive.name.clone(),
                    reason,
                });
            }
            if let Some(first) = self.drives[..i]
                .iter()
                .find(|d| same_name(&d.name, &drive.name))
            {
                return Err(ProjectError::Twice {
                    first: first.name.clone(),
                    second: drive.name.clone(),
                });
            }
            if let Some(key) = reaches(&drive.link)
                && let Some(first) = self.drives[..i]
                    .iter()
                    .find(|d| reaches(&d.link).as_ref() == Some(&key))
            {
                return Err(ProjectError::SameDrive {
                    first: first.name.clone(),
                    second: drive.name.clone(),
                    link: key,
                });
            }
            check_drive(drive).map_err(|reason| ProjectError::Setting {
                name: drive.name.clone(),
                reason,
            })?;
        }
        match &self.plot {
            None | Some(serde_json::Value::Object(_)) => {}
            Some(other) => return Err(ProjectError::Plot(file::kind(other))),
        }
        Ok(())
    }
}

/// The drive a connection string reaches, in words, when two strings can reach the same
/// one (`None` for the simulated drives: each is one of its own).
fn reaches(link: &LinkSpec) -> Option<String> {
    Some(match link {
        LinkSpec::Sim | LinkSpec::CanopenSim { .. } => return None,
        LinkSpec::ModbusTcp {
            host, port, unit, ..
        } => format!(
            "Modbus TCP {}:{port} unit {unit}",
            host.to_ascii_lowercase()
        ),
        LinkSpec::ModbusRtu { path, slave, .. } => format!("Modbus RTU {path} slave {slave}"),
        LinkSpec::CanopenSocketcan { iface, can } => {
            format!("CANopen node {} on {iface}", can.node)
        }
        LinkSpec::CanopenSlcan { path, can, .. } => format!("CANopen node {} on {path}", can.node),
        LinkSpec::Enip { host, port, .. } => {
            format!("EtherNet/IP {}:{port}", host.to_ascii_lowercase())
        }
    })
}

/// A drive's options, pins and backup, checked.
fn check_drive(drive: &Drive) -> Result<(), String> {
    let options = &drive.options;
    if !POLL_RATES.contains(&options.poll_rate) {
        return Err(format!(
            "poll rate {} Hz is outside {} to {} Hz",
            options.poll_rate,
            POLL_RATES.start(),
            POLL_RATES.end()
        ));
    }
    if !(1..=MAX_LOST_AFTER).contains(&options.lost_after) {
        return Err(format!(
            "lost_after {} is outside 1 to {MAX_LOST_AFTER} exchanges",
            options.lost_after
        ));
    }
    if drive.watch.len() > MAX_PINS {
        return Err(format!(
            "{} watched objects; at most {MAX_PINS}",
            drive.watch.len()
        ));
    }
    for (i, pin) in drive.watch.iter().enumerate() {
        if drive.watch[..i].iter().any(|p| p.address == pin.address) {
            return Err(format!("{} is watched twice", pin.address));
        }
    }
    if let Some(backup) = &drive.backup {
        // The backup's own checks (format, version, every address and value).
        Backup::from_json(&backup.to_json()).map_err(|e| format!("its backup: {e}"))?;
    }
    Ok(())
}
