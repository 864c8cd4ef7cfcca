//! The last project opened, remembered so that it can reopen on the next start: its path
//! in `last-project.txt`, in the folder where the window keeps its settings (eframe's
//! storage folder for the app id `drivedeck`, e.g. `~/.local/share/drivedeck/` on Linux).

use std::path::{Path, PathBuf};

/// The window's app id: eframe's storage folder is named after it (`ui::run_window`).
pub const APP_ID: &str = "drivedeck";
/// The file in that folder that holds the last project's path.
pub const FILE_NAME: &str = "last-project.txt";

/// The folder where the window's settings are saved (`None` where the system has none).
pub fn settings_dir() -> Option<PathBuf> {
    eframe::storage_dir(APP_ID)
}

/// Why the last project cannot be remembered.
#[derive(Debug, thiserror::Error)]
pub enum RecentError {
    #[error("this system has no folder for drivedeck's settings")]
    NoFolder,
    #[error("the project's path cannot be kept as one line of UTF-8 text: {0}")]
    NotText(String),
    #[error("cannot make the settings folder {dir}: {source}")]
    Folder { dir: String, source: std::io::Error },
    #[error("cannot write {file}: {source}")]
    Write {
        file: String,
        source: std::io::Error,
    },
}

/// The last project's path, if one was remembered (whether the file is still there is
/// for the opener to find out, and to say).
pub fn last_project() -> Option<PathBuf> {
    last_project_in(&settings_dir()?)
}

/// [`last_project`] from the settings folder `dir`.
pub fn last_project_in(dir: &Path) -> Option<PathBuf> {
    let text = std::fs::read_to_string(dir.join(FILE_NAME)).ok()?;
    let line = text.lines().next()?.trim_end_matches('\r');
    (!line.is_empty()).then(|| PathBuf::from(line))
}

/// Remember `project` as the last one opened (made absolute, so a later start from
/// another folder finds it).
pub fn remember(project: &Path) -> Result<(), RecentError> {
    remember_in(&settings_dir().ok_or(RecentError::NoFolder)?, project)
}

/// [`remember`] in the settings folder `dir`.
pub fn remember_in(dir: &Path, project: &Path) -> Result<(), RecentError> {
    let absolute = std::path::absolute(project).unwrap_or_else(|_| project.to_path_buf());
    let text = absolute
        .to_str()
        .filter(|t| !t.contains(['\n', '\r']))
        .ok_or_else(|| RecentError::NotText(absolute.display().to_string()))?;
    std::fs::create_dir_all(dir).map_err(|source| RecentError::Folder {
        dir: dir.display().to_string(),
        source,
    })?;
    let file = dir.join(FILE_NAME);
    crate::file::write_whole(&file, format!("{text}\n")).map_err(|source| RecentError::Write {
        file: file.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_project_is_remembered_absolute_and_replaced() {
        let dir = tempfile::tempdir().expect("a temp dir");
        let settings = dir.path().join("settings");
        assert_eq!(last_project_in(&settings), None);
        remember_in(&settings, Path::new("machine.json")).expect("remembered");
        let first = last_project_in(&settings).expect("a path");
        assert!(first.is_absolute(), "{}", first.display());
        assert!(first.ends_with("machine.json"));
        let other = dir.path().join("other.json");
        remember_in(&settings, &other).expect("remembered");
        assert_eq!(last_project_in(&settings), Some(other));
    }

    #[test]
    fn a_path_with_a_line_break_is_refused() {
        let dir = tempfile::tempdir().expect("a temp dir");
        let error = remember_in(dir.path(), Path::new("/tmp/a\nb.json")).expect_err("refused");
        assert!(
            error.to_string().contains("one line of UTF-8 text"),
            "{error}"
        );
        assert_eq!(last_project_in(dir.path()), None);
    }
}
