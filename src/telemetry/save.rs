//! Recordings as files: CSV, or JSON for a `.json` path, written whole.

use std::path::Path;

use super::Recording;
use crate::file::write_whole;

/// The recording as the file at `path` wants it: JSON for a `.json` path, CSV otherwise.
pub fn recording_text(recording: &Recording, path: &Path) -> String {
    let json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    if json {
        recording.to_json()
    } else {
        recording.to_csv()
    }
}

/// Write a recording as CSV, or JSON for a `.json` path, whole or not at all.
pub fn save_recording(recording: &Recording, path: &str) -> Result<String, String> {
    if recording.is_empty() {
        return Err("nothing to export: no samples in that span".into());
    }
    let file = Path::new(path);
    write_whole(file, recording_text(recording, file))
        .map_err(|e| format!("cannot write {path}: {e}"))?;
    Ok(format!(
        "saved {} samples of {} signals ({:.2} s) to {path}",
        recording.len(),
        recording.channels.len(),
        recording.duration()
    ))
}
