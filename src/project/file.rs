//! A project as a file: its JSON text, read and checked step by step so that a bad file
//! is refused with the step that failed (not text, not JSON, not a project, a newer
//! version, a field it does not know, a drive that is not one), and written whole or not
//! at all (`crate::file`).
//!
//! Unknown fields: refused at the top and in each drive and its options (a misspelt
//! `poll_rte` would otherwise be dropped without a word, and the next save would lose
//! it). The parts the project keeps for others follow their owners' rules: the embedded
//! backup is read as `od diff` reads a backup file, the plot layout as the window reads its
//! settings.

use std::path::Path;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::{Drive, DriveOptions, FORMAT, Pin, Project, ProjectError, VERSION};
use crate::link::LinkSpec;
use crate::od::backup::{Backup, DeviceIdentity};

/// A project file is at most this big (a project with a backup of every drive is some
/// hundreds of kilobytes).
pub const MAX_BYTES: u64 = 32 * 1024 * 1024;

/// One drive as written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveText {
    name: String,
    /// The connection string.
    link: String,
    #[serde(default)]
    options: DriveOptions,
    #[serde(default)]
    watch: Vec<Pin>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    identity: Option<DeviceIdentity>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    backup: Option<Value>,
}

/// The whole file as read, once its format and version are checked (and taken out): the
/// drives one by one after, so that an error names its drive.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProjectText {
    drives: Vec<Value>,
    #[serde(default)]
    plot: Option<Value>,
}

/// The whole file as written.
#[derive(Serialize)]
struct ProjectOut<'a> {
    format: &'static str,
    version: u64,
    drives: Vec<DriveText>,
    #[serde(skip_serializing_if = "Option::is_none")]
    plot: Option<&'a Value>,
}

impl Project {
    /// The file's text: pretty JSON, the drives in order.
    pub fn to_json(&self) -> String {
        let drives = self
            .drives
            .iter()
            .map(|d| DriveText {
                name: d.name.clone(),
                link: d.link.to_string(),
                options: d.options.clone(),
                watch: d.watch.clone(),
                identity: d.identity.clone(),
                backup: d.backup.as_ref().and_then(|b| serde_json::to_value(b).ok()),
            })
            .collect();
        let text = ProjectOut {
            format: FORMAT,
            version: VERSION,
            drives,
            plot: self.plot.as_ref(),
        };
        serde_json::to_string_pretty(&text).unwrap_or_default() + "\n"
    }

    /// A project from a file's bytes, checked.
    pub fn from_bytes(bytes: &[u8]) -> Result<Project, ProjectError> {
        let text =
            std::str::from_utf8(bytes).map_err(|e| ProjectError::NotText(e.valid_up_to()))?;
        Project::from_json(text)
    }

    /// A project from a file's text, checked.
    pub fn from_json(text: &str) -> Result<Project, ProjectError> {
        let value: Value =
            serde_json::from_str(text).map_err(|e| ProjectError::NotJson(e.to_string()))?;
        let Value::Object(mut top) = value else {
            return Err(ProjectError::NotProject(format!(
                "it is a JSON {}, not an object",
                kind(&value)
            )));
        };
        match top.get("format") {
            Some(Value::String(f)) if f == FORMAT => {}
            Some(Value::String(f)) => return Err(ProjectError::Format(f.clone())),
            Some(other) => {
                return Err(ProjectError::NotProject(format!(
                    "its format is a {}, not \"{FORMAT}\"",
                    kind(other)
                )));
            }
            None => {
                return Err(ProjectError::NotProject(
                    "it has no \"format\" field".into(),
                ));
            }
        }
        // The version before the rest: a newer file is refused for being newer, not for
        // a field this version does not know.
        match top.get("version") {
            Some(Value::Number(n)) => match n.as_u64() {
                Some(VERSION) => {}
                Some(v) if v > VERSION => return Err(ProjectError::Newer(v)),
                _ => return Err(ProjectError::BadVersion(n.to_string())),
            },
            Some(other) => return Err(ProjectError::BadVersion(other.to_string())),
            None => {
                return Err(ProjectError::NotProject(
                    "it has no \"version\" field".into(),
                ));
            }
        }
        top.remove("format");
        top.remove("version");
        let text: ProjectText = serde_json::from_value(Value::Object(top))
            .map_err(|e| ProjectError::Top(e.to_string()))?;
        let drives = text
            .drives
            .into_iter()
            .enumerate()
            .map(|(i, v)| {
                drive(v).map_err(|reason| ProjectError::Drive {
                    index: i + 1,
                    reason,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let project = Project {
            drives,
            plot: text.plot,
        };
        project.check()?;
        Ok(project)
    }
}

/// One drive from its JSON, or why it is not one.
fn drive(value: Value) -> Result<Drive, String> {
    let name = value
        .get("name")
        .and_then(Value::as_str)
        .map(|n| format!("(\"{n}\") "))
        .unwrap_or_default();
    let text: DriveText = serde_json::from_value(value).map_err(|e| format!("{name}{e}"))?;
    let link: LinkSpec = text
        .link
        .parse()
        .map_err(|e| format!("(\"{}\") {e}", text.name))?;
    let backup = match text.backup {
        None | Some(Value::Null) => None,
        Some(v) => Some(
            Backup::from_json(&v.to_string())
                .map_err(|e| format!("(\"{}\") its backup: {e}", text.name))?,
        ),
    };
    Ok(Drive {
        name: text.name,
        link,
        options: text.options,
        watch: text.watch,
        identity: text.identity,
        backup,
    })
}

pub(super) fn kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "boolean",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}

/// Open the project at `path`: read (at most [`MAX_BYTES`]) and checked; an error names
/// the file and the cause.
pub fn open(path: &Path) -> Result<Project, ProjectError> {
    let bytes =
        crate::file::read_given(path, MAX_BYTES, "a project file").map_err(|e| match e {
            crate::file::ReadError::Io { path, source } => ProjectError::Read { path, source },
            crate::file::ReadError::TooLarge { path, size, .. } => {
                ProjectError::TooLarge { path, size }
            }
            e @ crate::file::ReadError::NotAFile { .. } => ProjectError::NotAFile(e.to_string()),
        })?;
    Project::from_bytes(&bytes)
}

/// Save `project` to `path`, whole or not at all, after checking it (a project that
/// could not be opened again is not written).
pub fn save(project: &Project, path: &Path) -> Result<(), ProjectError> {
    project.check()?;
    crate::file::write_whole(path, project.to_json()).map_err(|source| ProjectError::Write {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests;
