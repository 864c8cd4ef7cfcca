//! Recordings as files: CSV, or JSON for a `.json` path, written whole; and read back
//! as data from outside (any size, any bytes: a clear refusal, never a panic).

use std::path::Path;

use super::Recording;
use super::recording::stream::Layout;
use crate::file::write_whole;

/// The largest recording file opened: ten minutes of every signal at 1 kHz is about
/// 60 MB of CSV; what is far beyond is no recording of ours.
pub const MAX_RECORDING_BYTES: u64 = 512 * 1024 * 1024;

fn is_json(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// The layout of a recording written as taken to `path`: JSON for a `.json` path, CSV
/// otherwise.
pub fn stream_layout(path: &Path) -> Layout {
    if is_json(path) {
        Layout::Json
    } else {
        Layout::Csv
    }
}

/// The recording as the file at `path` wants it: JSON for a `.json` path, CSV otherwise.
pub fn recording_text(recording: &Recording, path: &Path) -> String {
    if is_json(path) {
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

/// Read a recording written by [`save_recording`] (or plain CSV with a header row): JSON
/// for a `.json` path or text that starts as JSON, CSV otherwise. Every refusal names the
/// file and what is wrong with it.
pub fn load_recording(path: &Path, limit: u64) -> Result<Recording, String> {
    let shown = path.display();
    let bytes = crate::file::read_given(path, limit, "a recording").map_err(|e| match e {
        crate::file::ReadError::TooLarge { .. } => format!(
            "{shown} is {:.0} MB: more than the {:.0} MB a recording may have",
            std::fs::metadata(path).map_or(0, |m| m.len()) as f64 / 1e6,
            limit as f64 / 1e6
        ),
        crate::file::ReadError::Io { source, .. } => format!("cannot open {shown}: {source}"),
        e @ crate::file::ReadError::NotAFile { .. } => e.to_string(),
    })?;
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        // A file cut by a crash may end inside a character: the part line it is on goes
        // anyway (see `Recording::from_csv`), so the bytes before it are read.
        Err(e) if e.utf8_error().error_len().is_none() && e.utf8_error().valid_up_to() > 0 => {
            let valid = e.utf8_error().valid_up_to();
            let mut bytes = e.into_bytes();
            bytes.truncate(valid);
            String::from_utf8(bytes).map_err(|e| format!("{shown}: {e}"))?
        }
        Err(e) => {
            return Err(format!(
                "{shown} is not a recording: not text (byte {} is not UTF-8)",
                e.utf8_error().valid_up_to()
            ));
        }
    };
    let json = is_json(path) || text.trim_start().starts_with('{');
    let recording = if json {
        Recording::from_json(&text)
    } else {
        Recording::from_csv(&text)
    }
    .map_err(|e| format!("{shown} is not a recording we can read: {e}"))?;
    if recording.is_empty() {
        return Err(format!("{shown} holds no samples"));
    }
    Ok(recording)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn file_with(name: &str, bytes: &[u8]) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("written");
        (dir, path)
    }

    #[test]
    fn crafted_files_are_refused_with_the_file_and_the_reason() {
        let nested = "[".repeat(100_000);
        let cases: [(&str, &[u8], &str); 7] = [
            (
                "binary.csv",
                b"\x89PNG\r\n\x1a\n\0\0\xff",
                "is not a recording: not text (byte 0 is not UTF-8)",
            ),
            ("empty.csv", b"", "line 1: no header row"),
            ("header-only.csv", b"t [s],position\n", "holds no samples"),
            (
                "ragged.json",
                br#"{"channels":[{"id":"a"}],"t":[0,1],"columns":[[1]]}"#,
                "column 0 has 1 values for 2 times",
            ),
            (
                "backwards.json",
                br#"{"channels":[],"t":[1,0],"columns":[]}"#,
                "is before the previous one",
            ),
            (
                "nested.json",
                nested.as_bytes(),
                "is not a recording we can read: JSON",
            ),
            (
                "words.csv",
                b"t [s],position\nnot a number,1\n",
                "is not a recording we can read: line 2",
            ),
        ];
        for (name, bytes, expected) in cases {
            let (_dir, path) = file_with(name, bytes);
            let error = load_recording(&path, MAX_RECORDING_BYTES).expect_err(name);
            assert!(error.starts_with(&path.display().to_string()), "{error}");
            assert!(error.contains(expected), "{name}: {error}");
        }
        let (_dir, path) = file_with("big.csv", &[b'1'; 2000]);
        let error = load_recording(&path, 1000).expect_err("too big");
        assert!(
            error.contains("more than the 0 MB a recording may have"),
            "{error}"
        );
        let missing = std::env::temp_dir().join("drivedeck-no-such-recording.csv");
        let error = load_recording(&missing, MAX_RECORDING_BYTES).expect_err("missing");
        assert!(
            error.starts_with(&format!("cannot open {}: ", missing.display())),
            "{error}"
        );
    }

    #[test]
    fn our_own_files_read_back_whatever_their_name_says() {
        let recording = Recording {
            meta: crate::telemetry::Metadata {
                trigger_time_s: Some(0.5),
                ..Default::default()
            },
            channels: vec![crate::telemetry::ChannelInfo {
                id: "position".into(),
                name: "Position 6064h".into(),
                unit: "0.1°".into(),
            }],
            times: vec![0.0, 0.5, 1.0],
            columns: vec![vec![0.0, 5.0, 10.0]],
            markers: Vec::new(),
        };
        // JSON under a name without .json: told by its first character.
        let (_dir, path) = file_with("run.txt", recording.to_json().as_bytes());
        assert_eq!(
            load_recording(&path, MAX_RECORDING_BYTES),
            Ok(recording.clone())
        );
        let (_dir, path) = file_with("run.CSV", recording.to_csv().as_bytes());
        assert_eq!(load_recording(&path, MAX_RECORDING_BYTES), Ok(recording));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Any bytes at all: a recording that makes a history, or a refusal; never a panic.
        #[test]
        fn any_file_opens_or_is_refused(bytes in proptest::collection::vec(any::<u8>(), 0..400), json in any::<bool>()) {
            let (_dir, path) = file_with(if json { "x.json" } else { "x.csv" }, &bytes);
            if let Ok(recording) = load_recording(&path, MAX_RECORDING_BYTES) {
                let _ = crate::telemetry::Scope::from_recording(&recording);
            }
        }

        /// Text shaped like our CSV with random cells: the same.
        #[test]
        fn csv_like_text_opens_or_is_refused(rows in proptest::collection::vec(proptest::collection::vec("[-0-9.eE,naNinf ]{0,6}", 0..4), 0..12)) {
            let mut text = String::from("# drivedeck recording\n# channel: position | P | 0.1°\nt [s],position\n");
            for row in rows {
                text.push_str(&row.join(","));
                text.push('\n');
            }
            let (_dir, path) = file_with("x.csv", text.as_bytes());
            if let Ok(recording) = load_recording(&path, MAX_RECORDING_BYTES) {
                let _ = crate::telemetry::Scope::from_recording(&recording);
            }
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_given_as_a_recording_is_refused_at_once() {
        let dir = tempfile::tempdir().expect("temp dir");
        let fifo = dir.path().join("x");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("SKIPPED LOUDLY: mkfifo is not available, a FIFO recording is not tested");
            return;
        }
        assert_eq!(
            load_recording(&fifo, MAX_RECORDING_BYTES),
            Err(format!(
                "{} is a FIFO (named pipe), not a file: give a recording",
                fifo.display()
            ))
        );
    }
}
