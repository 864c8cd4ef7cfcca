//! Recordings to look back at: a recording opened from its file (ours, CSV or JSON) drawn
//! in the plots with no drive connected, a second one overlaid on it aligned on the
//! triggers or at a chosen offset, and a triggered capture frozen on screen until the
//! user dismisses it or arms again.
//!
//! A model: no egui here.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use super::files::{Wake, take};
use super::model::PlotView;
use crate::telemetry::{Recording, Scope};

/// One recording on screen.
#[derive(Clone, Debug)]
pub struct Shown {
    /// What it is, in words: the file's name, or "triggered capture at 12.345 s".
    pub title: String,
    pub scope: Scope,
    /// The trigger's moment in its time base, if it was triggered.
    pub trigger: Option<f64>,
}

impl Shown {
    pub fn new(title: String, recording: &Recording) -> Result<Shown, String> {
        Ok(Shown {
            title,
            scope: Scope::from_recording(recording)?,
            trigger: recording.meta.trigger_time_s.filter(|t| t.is_finite()),
        })
    }

    pub fn span(&self) -> Option<(f64, f64)> {
        let ring = self.scope.ring();
        Some((ring.first_time()?, ring.last_time()?))
    }
}

/// What the plots show instead of the live history.
#[derive(Clone, Debug)]
pub struct Review {
    pub base: Shown,
    /// Drawn over the base, dashed, its times moved by `offset_s`.
    pub overlay: Option<Shown>,
    /// Seconds added to the overlay's times.
    pub offset_s: f64,
    /// The base is the triggered capture (not a file): dismissed, or gone on re-arming.
    pub capture: bool,
}

impl Review {
    /// The base's span and the overlay's (moved), together.
    pub fn span(&self) -> Option<(f64, f64)> {
        let (mut from, mut to) = self.base.span()?;
        if let Some((a, b)) = self.overlay.as_ref().and_then(Shown::span) {
            from = from.min(a + self.offset_s);
            to = to.max(b + self.offset_s);
        }
        Some((from, to.max(from + 0.001)))
    }

    /// The offset that lays the overlay on the base: trigger on trigger when both have
    /// one, start on start otherwise; and which.
    pub fn aligned(&self) -> (f64, &'static str) {
        let Some(overlay) = &self.overlay else {
            return (0.0, "");
        };
        match (self.base.trigger, overlay.trigger) {
            (Some(base), Some(other)) => (base - other, "on the triggers"),
            _ => match (self.base.span(), overlay.span()) {
                (Some((base, _)), Some((other, _))) => (base - other, "on the starts"),
                _ => (0.0, "as recorded"),
            },
        }
    }
}

/// What reading a recording's file came to: the file and the recording, or why not.
pub type Read = Result<(PathBuf, Recording), String>;

/// A recording being read, for the overlay (true) or on its own, and where the reading
/// thread leaves it.
pub type Loading = (bool, Arc<Mutex<Option<Read>>>);

/// Read `path` on a thread of its own (a large file does not stall the window); `poll`
/// puts it on screen.
pub fn load(plot: &mut PlotView, wake: Wake, path: PathBuf, overlay: bool) {
    let slot: Arc<Mutex<Option<Read>>> = Arc::default();
    let reply = slot.clone();
    let spawned = std::thread::Builder::new()
        .name("open recording".into())
        .spawn(move || {
            let read =
                crate::telemetry::load_recording(&path, crate::telemetry::MAX_RECORDING_BYTES)
                    .map(|recording| (path, recording));
            if let Ok(mut slot) = reply.lock() {
                *slot = Some(read);
            }
            wake();
        });
    match spawned {
        Ok(_) => {
            plot.loading = Some((overlay, slot));
            plot.message = Some(Ok("reading the recording…".into()));
        }
        Err(e) => plot.message = Some(Err(format!("cannot read the recording: {e}"))),
    }
}

/// A recording read: on screen (or over the one there), or why not.
pub fn poll(plot: &mut PlotView) {
    let Some(read) = plot.loading.as_ref().and_then(|(_, slot)| take(slot)) else {
        return;
    };
    let Some((overlay, _)) = plot.loading.take() else {
        return;
    };
    let shown = read.and_then(|(path, recording)| {
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        match Shown::new(name, &recording) {
            Ok(shown) => Ok((path, recording, shown)),
            Err(e) => Err(format!(
                "{} is not a recording we can show: {e}",
                path.display()
            )),
        }
    });
    match shown {
        Ok((path, recording, shown)) => {
            let mut text = format!(
                "opened {}: {} samples of {} signals ({:.2} s)",
                path.display(),
                recording.len(),
                recording.channels.len(),
                recording.duration()
            );
            // A file a crash cut short says so (it holds every sample until then).
            if let Some(cut) = &recording.meta.cut {
                text.push_str(&format!("; {cut}"));
            }
            if let Some(gaps) = &recording.meta.gaps {
                text.push_str(&format!("; {gaps}"));
            }
            show(plot, shown, overlay);
            plot.message = Some(Ok(text));
        }
        Err(e) => plot.message = Some(Err(e)),
    }
}

/// `shown` on screen: over the recording there (aligned), or on its own.
fn show(plot: &mut PlotView, shown: Shown, overlay: bool) {
    match &mut plot.review {
        Some(review) if overlay => {
            review.overlay = Some(shown);
            review.offset_s = review.aligned().0;
        }
        _ => {
            plot.review = Some(Review {
                base: shown,
                overlay: None,
                offset_s: 0.0,
                capture: false,
            });
            plot.cursors = [None; 2];
        }
    }
    plot.follow = true;
    plot.shown_range = None;
}

/// Back to the live plots.
pub fn close(plot: &mut PlotView) {
    plot.review = None;
    plot.follow = true;
    plot.paused_at = None;
    plot.shown_range = None;
    plot.cursors = [None; 2];
}

/// A triggered recording is complete: frozen on screen (the signals drawn as live) until
/// the user dismisses it or arms again. A recording opened from a file stays; the
/// capture waits behind Save recording.
pub fn freeze_capture(plot: &mut PlotView, live: &Scope) {
    if plot.review.as_ref().is_some_and(|r| !r.capture) {
        return;
    }
    let Some(recording) = live.recording() else {
        return;
    };
    let at = recording.meta.trigger_time_s.unwrap_or(0.0);
    let Ok(mut shown) = Shown::new(format!("triggered capture at {at:.3} s"), recording) else {
        return;
    };
    for signal in shown.scope.signals_mut() {
        if let Some(own) = live.signal(&signal.info.id) {
            signal.shown = live.is_drawn(own);
            signal.auto = false;
        }
    }
    plot.review = Some(Review {
        base: shown,
        overlay: None,
        offset_s: 0.0,
        capture: true,
    });
    plot.follow = true;
    plot.shown_range = None;
}
