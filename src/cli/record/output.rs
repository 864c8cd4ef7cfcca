//! Where `record` writes as it goes: the file opened at its path (or, when that cannot
//! be, in the temporary directory, said at once), rows and markers streamed into it, and
//! what became of it at the end (kept where asked, copied out when its directory went).

use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use crate::telemetry::{ChannelInfo, Marker, Metadata, StreamWriter, Summary, stream_layout};

/// A path as the user can find it again: absolute where it can be made so.
pub(super) fn shown_path(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_path_buf())
        .display()
        .to_string()
}

/// Where a recording went.
pub(super) enum Saved {
    /// Where it was asked to go.
    Here { message: String, path: String },
    /// That place failed (`why`); the temporary directory took it.
    Elsewhere { why: String, path: String },
    /// No place took it.
    Lost { why: String },
    /// It is at `path`, but a write failed (`why`): the file holds what was written
    /// until then and does not end normally.
    Short { why: String, path: String },
}

/// The file of a recording being taken: written as the samples come, straight into the
/// place asked for (a crash leaves the samples under the name the user gave, and the
/// file says it was cut); where that place cannot take it, into the temporary directory.
pub(super) struct Output {
    pub(super) writer: Option<StreamWriter>,
    /// Where the file is being written.
    pub(super) path: PathBuf,
    /// Why the place asked for did not take it (`path` is in the temporary directory).
    pub(super) elsewhere: Option<String>,
    /// Why no place took it (`writer` is `None`).
    pub(super) lost: Option<String>,
    /// A write that failed, for the recording to end on.
    pub(super) error: Option<String>,
}

/// A file for a recording: created (or emptied), readable too where it may be (to copy
/// it elsewhere should its place go away).
pub(super) fn create(path: &Path) -> std::io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    match options.clone().read(true).open(path) {
        Ok(file) => Ok(file),
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => options.open(path),
        Err(e) => Err(e),
    }
}

/// The place of last resort: the temporary directory, a name of this run's.
pub(super) fn elsewhere_path(asked: &Path) -> PathBuf {
    let extension = asked
        .extension()
        .map_or("csv".into(), |e| e.to_string_lossy().into_owned());
    std::env::temp_dir().join(format!(
        "drivedeck-recording-{}-{}.{extension}",
        std::process::id(),
        SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
    ))
}

impl Output {
    /// The file at `path` with its header (`head`, the channels) written.
    pub(super) fn open(path: &Path, head: &Metadata, channels: &[(usize, ChannelInfo)]) -> Output {
        let layout = stream_layout(path);
        let infos: Vec<ChannelInfo> = channels.iter().map(|(_, info)| info.clone()).collect();
        let start = |at: &Path| {
            create(at).and_then(|file| StreamWriter::create(file, layout, head, &infos))
        };
        let why = match start(path) {
            Ok(writer) => {
                return Output {
                    writer: Some(writer),
                    path: path.to_path_buf(),
                    elsewhere: None,
                    lost: None,
                    error: None,
                };
            }
            Err(e) => format!("cannot write {}: {e}", shown_path(path)),
        };
        let other = elsewhere_path(path);
        match start(&other) {
            Ok(writer) => Output {
                writer: Some(writer),
                path: other,
                elsewhere: Some(why),
                lost: None,
                error: None,
            },
            Err(e) => Output {
                writer: None,
                path: other.clone(),
                elsewhere: None,
                lost: Some(format!("{why}; nor to {}: {e}", other.display())),
                error: None,
            },
        }
    }

    /// Run `write` on the writer; the first failure is kept for the recording to end on.
    pub(super) fn with(&mut self, write: impl FnOnce(&mut StreamWriter) -> std::io::Result<()>) {
        let Some(writer) = &mut self.writer else {
            return;
        };
        if let Err(e) = write(writer)
            && self.error.is_none()
        {
            self.error = Some(format!(
                "cannot write {}: {e}; the file holds the samples until then",
                shown_path(&self.path)
            ));
        }
    }

    pub(super) fn row(&mut self, t: f64, values: &[f64]) {
        self.with(|w| w.row(t, values));
    }

    pub(super) fn mark(&mut self, marker: &Marker) {
        self.with(|w| w.mark(marker));
    }

    pub(super) fn meta(&mut self, update: &Metadata) {
        self.with(|w| w.meta(update));
    }

    pub(super) fn flush(&mut self) {
        self.with(StreamWriter::flush);
    }

    /// End the file (`last`: the fields known at the end) and say where it is. A file
    /// whose place went away while it was written (its directory removed) is copied to
    /// the temporary directory.
    pub(super) fn finish(mut self, last: &Metadata, summary: &Summary, channels: usize) -> Saved {
        if let Some(why) = self.lost.take() {
            return Saved::Lost { why };
        }
        self.with(|w| w.finish(last, summary.rows));
        let shown = shown_path(&self.path);
        let path = self.path.to_string_lossy().into_owned();
        if let Some(why) = self.error.take() {
            return Saved::Short { why, path };
        }
        let Some(writer) = self.writer.take() else {
            return Saved::Lost {
                why: format!("cannot write {shown}"),
            };
        };
        let saved = |path: String| Saved::Here {
            message: format!(
                "saved {} samples of {channels} signals ({:.2} s) to {shown}",
                summary.rows,
                summary.duration()
            ),
            path,
        };
        let file = match writer.into_file() {
            Ok(file) => file,
            Err(e) => {
                return match self.elsewhere {
                    Some(why) => Saved::Elsewhere { why, path },
                    None => Saved::Short {
                        why: format!(
                            "cannot write {shown}: {e}; the file holds what was written until then"
                        ),
                        path,
                    },
                };
            }
        };
        if still_at(&file, &self.path) {
            return match self.elsewhere {
                Some(why) => Saved::Elsewhere { why, path },
                None => saved(path),
            };
        }
        // The place went away while the file was written: the samples are in the open
        // file only, and go to the temporary directory.
        let why = format!(
            "cannot write {shown}: it (or its directory) went away while the recording was taken"
        );
        let other = elsewhere_path(&self.path);
        match copy_out(file, &other) {
            Ok(()) => Saved::Elsewhere {
                why,
                path: other.display().to_string(),
            },
            Err(e) => Saved::Lost {
                why: format!("{why}; nor to {}: {e}", other.display()),
            },
        }
    }
}

/// Whether `path` still names the open `file` (not removed, not replaced).
pub(super) fn still_at(file: &File, path: &Path) -> bool {
    let (Ok(open), Ok(named)) = (file.metadata(), std::fs::metadata(path)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        open.dev() == named.dev() && open.ino() == named.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (open, named);
        true
    }
}

/// The whole of an open file into a new one at `to`.
pub(super) fn copy_out(mut file: File, to: &Path) -> std::io::Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    file.seek(SeekFrom::Start(0))?;
    let mut out = std::fs::File::create(to)?;
    std::io::copy(&mut file, &mut out)?;
    out.flush()?;
    out.sync_data()
}
