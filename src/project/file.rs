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
            Some(other) => {
                return Err(ProjectError::NotProject(format!(
                    "its \"version\" is a {} ({}), not a number: write it as {VERSION}, \
                     without quotes",
                    kind(other),
                    shorten(&other.to_string())
                )));
            }
            None => {
                return Err(ProjectError::NotProject(
                    "it has no \"version\" field".into(),
                ));
            }
        }
        top.remove("format");
        top.remove("version");
        let text: ProjectText = serde_path_to_error::deserialize(Value::Object(top))
            .map_err(|e| ProjectError::Top(field_error(&e)))?;
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
    let text: DriveText = serde_path_to_error::deserialize(value)
        .map_err(|e| format!("{name}{}", field_error(&e)))?;
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

/// A field that could not be read, by its path in the file ("watch[1].address: …"), in
/// the file's words: the program's own type names (`struct Pin`, `enum LinkLossAction`)
/// are no help to whoever edits the file.
fn field_error(error: &serde_path_to_error::Error<serde_json::Error>) -> String {
    let mut path = error.path().to_string();
    let reason = plain_reason(&error.inner().to_string());
    // "unknown field `plots`" names the field itself: the path is where it stands.
    if reason.starts_with("unknown field") {
        path = path
            .rsplit_once('.')
            .map_or(String::new(), |(parent, _)| parent.to_owned());
    }
    if path.is_empty() || path == "." {
        reason
    } else {
        format!("{path}: {reason}")
    }
}

/// serde's reason with the program's type names put in the file's words.
fn plain_reason(reason: &str) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut words = reason.split(' ').peekable();
    while let Some(word) = words.next() {
        // The word without the punctuation after it, which is kept.
        let bare = word.trim_end_matches([',', '.', ';', ':']);
        let tail = &word[bare.len()..];
        let plain = match bare {
            "struct" | "enum" if words.peek().is_some() => {
                let name = words.next().unwrap_or_default();
                let name_tail = &name[name.trim_end_matches([',', '.', ';', ':']).len()..];
                let what = if bare == "struct" {
                    "an object"
                } else {
                    "one of its names"
                };
                format!("{what}{name_tail}")
            }
            "sequence" => format!("array{tail}"),
            "map" => format!("object{tail}"),
            _ => word.to_owned(),
        };
        // "a sequence" / "a map": "an array" / "an object".
        if plain.starts_with("array") || plain.starts_with("object") {
            if out.last().is_some_and(|w| w == "a") {
                out.pop();
            }
            out.push(format!("an {plain}"));
        } else {
            out.push(plain);
        }
    }
    out.join(" ")
}

/// A value from the file, shortened for a message.
fn shorten(text: &str) -> String {
    const MOST: usize = 60;
    match text.char_indices().nth(MOST) {
        Some((cut, _)) => format!("{}… ({} characters)", &text[..cut], text.chars().count()),
        None => text.to_owned(),
    }
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
