//! What the export buttons write and the open buttons read: the triggered recording or
//! the visible window to CSV or JSON (every other drive's signals beside it), the plots to
//! PNG, and a recording opened from its file; which file each proposes, and what a failed
//! write leaves to try again.
//!
//! A model: no egui here.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::model::{Image, PlotView, shown_scope, time_range};
use crate::telemetry::{Recording, Scope};
use crate::ui::drive::Drive;

/// Another drive's signals, drawn with the shown drive's on the same time axis: its
/// name (for the legend and the files), its history, and its colour.
pub struct Beside<'a> {
    pub name: &'a str,
    pub scope: &'a Scope,
    pub color: usize,
}

/// A dialog's title, the file's part of the proposed name, its extension, and the kinds
/// of file listed (description, extensions).
pub type Dialog = (
    &'static str,
    &'static str,
    &'static str,
    Vec<(String, Vec<String>)>,
);

/// What a file dialog's answer is for.
#[derive(Clone, Debug)]
pub enum Job {
    /// Write this recording (the triggered one, or the visible window).
    Save {
        kind: Export,
        recording: Arc<Recording>,
        /// The other drives' signals over the same span: each drive's name and its
        /// recording, written beside the file chosen (see [`beside_path`]).
        others: Vec<(String, Arc<Recording>)>,
    },
    /// Write this picture of the plots.
    Png(Arc<Image>),
    /// Open a recording, on its own or over the one on screen.
    Open { overlay: bool },
}

impl Job {
    pub fn save(kind: Export, recording: Recording) -> Job {
        Job::Save {
            kind,
            recording: Arc::new(recording),
            others: Vec::new(),
        }
    }

    /// This save with the other drives' recordings to write beside it.
    pub fn with(self, more: Vec<(String, Recording)>) -> Job {
        match self {
            Job::Save {
                kind,
                recording,
                mut others,
            } => {
                others.extend(more.into_iter().map(|(n, r)| (n, Arc::new(r))));
                Job::Save {
                    kind,
                    recording,
                    others,
                }
            }
            job => job,
        }
    }

    /// Every file this job writes at `path`: the chosen one first, then one per other
    /// drive beside it.
    pub fn paths(&self, path: &Path) -> Vec<PathBuf> {
        let mut paths = vec![path.to_path_buf()];
        if let Job::Save { others, .. } = self {
            paths.extend(others.iter().map(|(name, _)| beside_path(path, name)));
        }
        paths
    }

    pub fn export(&self) -> Option<Export> {
        match self {
            Job::Save { kind, .. } => Some(*kind),
            Job::Png(_) => Some(Export::Png),
            Job::Open { .. } => None,
        }
    }

    /// The dialog's title, the file's part of the proposed name, its extension and the
    /// kinds of file listed.
    pub fn dialog(&self) -> Dialog {
        let recordings = || {
            vec![
                ("CSV recording".to_owned(), vec!["csv".to_owned()]),
                ("JSON recording".to_owned(), vec!["json".to_owned()]),
            ]
        };
        let any = || {
            (
                "Recording (CSV or JSON)".to_owned(),
                vec!["csv".to_owned(), "json".to_owned()],
            )
        };
        match self {
            Job::Save {
                kind: Export::Visible,
                ..
            } => ("Export the visible window", "visible", "csv", recordings()),
            Job::Save { .. } => (
                "Save the triggered recording",
                "capture",
                "csv",
                recordings(),
            ),
            Job::Png(_) => (
                "Save a picture of the plots",
                "plots",
                "png",
                vec![("PNG picture".to_owned(), vec!["png".to_owned()])],
            ),
            Job::Open { overlay: false } => ("Open a recording", "", "", vec![any()]),
            Job::Open { overlay: true } => ("Overlay a recording", "", "", vec![any()]),
        }
    }
}

/// What an export button writes; each remembers the files it wrote this session, so
/// the question before replacing one says what it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Export {
    Recording,
    Visible,
    Png,
}

impl Export {
    pub fn button(self) -> &'static str {
        match self {
            Export::Recording => "Save recording",
            Export::Visible => "Export visible",
            Export::Png => "Save PNG",
        }
    }

    pub fn what(self) -> &'static str {
        match self {
            Export::Recording => "the triggered recording",
            Export::Visible => "an export of the visible window",
            Export::Png => "the picture of the plots",
        }
    }

    /// What to do after a failed write; nothing was lost.
    pub fn retry(self) -> &'static str {
        match self {
            Export::Recording => "the recording is still here — choose another place",
            Export::Visible => "the samples are still in the plots — choose another place",
            Export::Png => "the plots are unchanged — choose another place",
        }
    }
}

/// Remember that `kind` wrote `path`.
pub fn note_written(plot: &mut PlotView, path: PathBuf, kind: Export) {
    plot.written.retain(|(p, _)| *p != path);
    plot.written.push((path, kind));
}

/// The triggered recording, with the rates in its header; it stays in memory whatever
/// happens to the file.
pub fn triggered(drive: &Drive) -> Result<Recording, String> {
    let mut recording = drive
        .scope
        .recording()
        .cloned()
        .ok_or("no recording yet: arm the trigger, it records when it fires")?;
    recording.set_rates(drive.settings.poll_rate);
    Ok(recording)
}

/// The other drives' signals over `recording`'s span (only the shown ones when
/// `shown_only`), each with its drive's name; a drive with no sample in the span is left
/// out (its file would be empty), and said so in the saved message by its absence.
pub fn others_over(
    recording: &Recording,
    beside: &[Beside<'_>],
    shown_only: bool,
) -> Vec<(String, Recording)> {
    let (Some(&from), Some(&to)) = (recording.times.first(), recording.times.last()) else {
        return Vec::new();
    };
    beside
        .iter()
        .map(|other| {
            let mut meta = other.scope.meta.clone();
            meta.note = Some(format!(
                "drive \"{}\", over the same span as the file beside it{}",
                other.name,
                meta.note
                    .take()
                    .map(|n| format!("; {n}"))
                    .unwrap_or_default()
            ));
            (
                other.name.to_owned(),
                other.scope.export(from, to, meta, shown_only),
            )
        })
        .filter(|(_, r)| !r.is_empty())
        .collect()
}

/// Where another drive's recording goes beside `path`: the drive's name as a file name
/// (`project::file_stem`) added to the file's stem — `…_capture.csv` beside
/// `…_capture_Y_axis.csv`.
pub fn beside_path(path: &Path, drive: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = crate::project::file_stem(drive);
    let file = match path.extension() {
        Some(ext) => format!("{stem}_{name}.{}", ext.to_string_lossy()),
        None => format!("{stem}_{name}"),
    };
    path.with_file_name(file)
}

/// Write the other drives' recordings beside `path`, and say what was written after
/// `said` (the selected drive's file); a file that cannot be written is said, and the
/// others are still written.
pub fn save_others(said: String, path: &Path, others: &[(String, Arc<Recording>)]) -> String {
    let mut parts = vec![said];
    for (name, recording) in others {
        let at = beside_path(path, name);
        let text = at.to_string_lossy().into_owned();
        match crate::telemetry::save_recording(recording, &text) {
            Ok(_) => parts.push(format!("{name}'s signals to {text}")),
            Err(e) => parts.push(format!("{name}'s signals NOT saved: {e}")),
        }
    }
    parts.join("; ")
}

/// The visible time span of the shown signals (of the recording on screen, or live).
pub fn visible(plot: &PlotView, drive: &Drive, window_s: f64) -> Result<Recording, String> {
    let (from, to) = time_range(plot, drive, window_s).ok_or("nothing recorded yet")?;
    let scope = shown_scope(plot, drive);
    let mut meta = scope.meta.clone();
    let note = "the visible window of the plots";
    meta.note = Some(match (plot.review(), meta.note.take()) {
        (Some(_), Some(before)) => format!("{note}; {before}"),
        _ => note.into(),
    });
    let mut recording = scope.export(from, to, meta, true);
    if plot.review().is_none() {
        recording.set_rates(drive.settings.poll_rate);
    }
    if recording.is_empty() {
        return Err("nothing to export: no samples in that span".into());
    }
    Ok(recording)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_drive_s_file_is_named_after_it_beside_the_one_chosen() {
        let path = Path::new("/data/PD4_2026-12-03_0612_capture.csv");
        assert_eq!(
            beside_path(path, "Y axis"),
            Path::new("/data/PD4_2026-12-03_0612_capture_Y_axis.csv")
        );
        assert_eq!(
            beside_path(Path::new("run.json"), "Z/../../etc"),
            Path::new("run_Z_______etc.json")
        );
        assert_eq!(beside_path(Path::new("bare"), "A"), Path::new("bare_A"));
    }

    #[test]
    fn every_job_proposes_its_own_name_so_the_buttons_never_share_a_file() {
        let recording = || Recording {
            meta: crate::telemetry::Metadata::default(),
            channels: Vec::new(),
            times: Vec::new(),
            columns: Vec::new(),
            markers: Vec::new(),
        };
        let image = Arc::new(Image {
            size: [1, 1],
            rgba: vec![255, 0, 0, 255],
        });
        let names: Vec<(&str, &str)> = [
            Job::save(Export::Recording, recording()),
            Job::save(Export::Visible, recording()),
            Job::Png(image),
        ]
        .iter()
        .map(|job| {
            let (_, what, ext, _) = job.dialog();
            (what, ext)
        })
        .collect();
        assert_eq!(
            names,
            [("capture", "csv"), ("visible", "csv"), ("plots", "png")]
        );
    }
}
