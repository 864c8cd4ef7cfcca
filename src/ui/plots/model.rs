//! The plot panel's model: its choices kept between runs ([`PlotSettings`]), and its view
//! in this run ([`PlotView`]): paused or following, the span shown, the cursors, the moment
//! marked, a recording under review, what the last export said. One for the window: every
//! drive is drawn on its one time axis. Its fields are the plot panel's own; anything else
//! changes it through a [`PlotCommand`].
//!
//! A model: no egui here.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use super::exports::{Export, Job};
use super::files::{Answer, FilePicker};
use super::review::{Loading, Review};
use super::trigger::TriggerForm;
use crate::telemetry::ring::Decimations;
use crate::telemetry::{DEFAULT_HISTORY_ROWS, Scope};
use crate::ui::command::PlotCommand;
use crate::ui::drive::Drive;

/// The unit of positions in the factory-default user units (6064h and its kin).
pub const FACTORY_POSITION_UNIT: &str = "0.1°";

/// How positions in the factory units are drawn: as the drive counts them, in degrees or
/// in revolutions of the motor shaft.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PositionUnit {
    #[default]
    Tenths,
    Degrees,
    Revolutions,
}

impl PositionUnit {
    pub const ALL: [PositionUnit; 3] = [
        PositionUnit::Tenths,
        PositionUnit::Degrees,
        PositionUnit::Revolutions,
    ];

    /// What a value in 0.1° is multiplied by.
    pub fn scale(self) -> f64 {
        match self {
            PositionUnit::Tenths => 1.0,
            PositionUnit::Degrees => 0.1,
            PositionUnit::Revolutions => 1.0 / 3600.0,
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            PositionUnit::Tenths => FACTORY_POSITION_UNIT,
            PositionUnit::Degrees => "°",
            PositionUnit::Revolutions => "rev",
        }
    }

    /// The scale and unit a signal in `unit` is drawn with: positions in the factory unit
    /// in this one, anything else as it is.
    pub fn drawn(self, unit: &str) -> (f64, String) {
        if unit == FACTORY_POSITION_UNIT {
            (self.scale(), self.unit().to_owned())
        } else {
            (1.0, unit.to_owned())
        }
    }
}

/// A position in the factory unit said in degrees and revolutions too: "3600 0.1° = 360.0°
/// = 1.000 rev"; any other value with its unit.
pub fn with_turns(value: f64, unit: &str) -> String {
    let number = crate::telemetry::format_number(value);
    if unit == FACTORY_POSITION_UNIT {
        format!(
            "{number} {unit} = {:.1}° = {:.3} rev",
            value * PositionUnit::Degrees.scale(),
            value * PositionUnit::Revolutions.scale()
        )
    } else {
        format!("{number} {unit}").trim_end().to_owned()
    }
}

/// The live plots' redraw rate unless the user chose another.
pub const DEFAULT_REDRAW_HZ: f64 = 30.0;
/// The rates the setting accepts.
pub const REDRAW_HZ_MIN: f64 = 1.0;
pub const REDRAW_HZ_MAX: f64 = 240.0;
/// How often samples wake the window while the plots stand still.
pub const STILL_REDRAW_HZ: f64 = 1.0;
/// The redraw rate as asked, within the accepted range (a bad value in a settings file
/// gives the default).
pub fn redraw_hz(asked: f64) -> f64 {
    if asked.is_finite() {
        asked.clamp(REDRAW_HZ_MIN, REDRAW_HZ_MAX)
    } else {
        DEFAULT_REDRAW_HZ
    }
}

/// What the plot panel remembers between runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlotSettings {
    /// Seconds shown while following the newest samples; 0 shows the whole history.
    pub window_s: f64,
    /// Samples kept per signal.
    pub history_rows: usize,
    /// The folder the save and open dialogs start in (the last one used).
    pub export_dir: String,
    pub trigger: TriggerForm,
    /// The ids of the signals drawn.
    pub shown: Vec<String>,
    /// How positions in the factory unit are drawn.
    pub position_unit: PositionUnit,
    /// The picture of the plots at the screen's resolution (1) or up to twice it (2: as
    /// large as the window holds the plots at their size on screen).
    pub picture_scale: f32,
    /// Frames per second at most while the live plots move (new samples wake the window
    /// no more often).
    pub redraw_hz: f64,
    /// Signals drawn in another signal's plot (a scope's channels): the id of the signal
    /// that joins, and the id of the one whose plot it joins. Each keeps its colour and a
    /// y axis of its own there.
    pub together: BTreeMap<String, String>,
    /// The digital lanes the user hid, as "signal id:bit" (see [`lane_key`]).
    pub hidden_lanes: Vec<String>,
}

/// The plots' layout when the user has chosen none: the signals that appear by
/// themselves when the drive delivers them share a plot with the one they go with, each
/// on a y axis of its own, so that position, velocity, torque and the status lanes read
/// at 1366×768 without scrolling: the following error (a small value in the position's
/// unit) in the position's plot, the analog input (often the speed's set value) in the
/// velocity's.
pub fn default_together() -> BTreeMap<String, String> {
    BTreeMap::from([
        ("following_error".to_owned(), "position".to_owned()),
        ("analog_input".to_owned(), "velocity".to_owned()),
    ])
}

/// How a lane is named in the settings: its signal's id and its bit ("pdi_status:10").
pub fn lane_key(signal: &str, bit: u8) -> String {
    format!("{signal}:{bit}")
}

impl Default for PlotSettings {
    fn default() -> Self {
        Self {
            window_s: 10.0,
            history_rows: DEFAULT_HISTORY_ROWS,
            export_dir: String::new(),
            trigger: TriggerForm::default(),
            shown: Vec::new(),
            position_unit: PositionUnit::default(),
            picture_scale: 1.0,
            redraw_hz: DEFAULT_REDRAW_HZ,
            together: default_together(),
            hidden_lanes: Vec::new(),
        }
    }
}

/// Where the plots were drawn in the last frame, and the room they had there (what a
/// picture of them lays them out in again).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DrawnAt {
    /// The plots, every axis included, in points: left, top, right, bottom.
    pub area: Option<[f32; 4]>,
    /// The room they were given in the last frame drawn as usual (width, height).
    pub room: Option<[f32; 2]>,
    /// The height they needed to show whole, none scrolled out of view (points).
    pub need: f32,
}

/// A picture in RGBA, 8 bits a channel, row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width and height in pixels.
    pub size: [usize; 2],
    pub rgba: Vec<u8>,
}

/// Where a screenshot's picture (or why there is none) arrives.
pub type PngResult = Arc<Mutex<Option<Result<Image, String>>>>;

/// A picture of the plots being taken.
#[derive(Clone, Debug)]
pub struct Picture {
    /// The title band is drawn (from the frame that asks for the screenshot until it
    /// comes: the screenshot is of a frame after the one that asked).
    pub due: bool,
    /// The screenshot was asked for.
    pub sent: bool,
    /// The cut picture, from the screenshot callback.
    pub result: PngResult,
    /// Taken at this many times the screen's resolution (1 or 2).
    pub scale: f32,
    /// While a picture is taken at a higher resolution: the window's zoom to return to,
    /// and the size (in points) the plots are drawn at for it.
    pub enlarged: Option<Enlarged>,
    /// Frames drawn since the picture was asked for (one that never comes is given up).
    pub frames: u32,
}

impl Default for Picture {
    fn default() -> Self {
        Picture {
            due: false,
            sent: false,
            result: PngResult::default(),
            scale: 1.0,
            enlarged: None,
            frames: 0,
        }
    }
}

/// A picture of the plots taken at a higher resolution: for its frames the window's zoom
/// is raised by the scale and the title and plots are drawn over the window, as many
/// points as they had on screen (at most the whole window), so they come out as many
/// times larger in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Enlarged {
    pub zoom_before: f32,
    /// The title band's and the plots' room, in points.
    pub size: [f32; 2],
    /// The title band's height in it.
    pub band: f32,
}

/// One plot as drawn in the last frame: where, on which span of the time axis, and what
/// it drew there; the read-out reads the pointer's time from where the plots were.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnPlot {
    /// The signal's id (the first one's where several share the plot); "lanes" for the
    /// digital lanes, "time" for the time axis's labels under the plots.
    pub id: String,
    /// Its data area (axes left out), in points: left, top, right, bottom.
    pub frame: [f32; 4],
    /// The part of it in view (the plots scroll): the pointer reads times there only.
    pub visible: [f32; 4],
    /// The span its time axis showed, as egui_plot drew it (the items and the labels).
    pub axis: (f64, f64),
    /// The span its points were decimated for.
    pub decimated: (f64, f64),
    /// Its own line (not the overlay's or another drive's): none for the lanes, or with
    /// no samples near the span. Of the first signal where several share the plot.
    pub line: Option<LineExtent>,
    /// Every signal drawn in it (the first is `id`; several when signals share a plot),
    /// each with its own line's extent in its true values.
    pub lines: Vec<(String, Option<LineExtent>)>,
}

/// Where a line drawn reaches and what it holds in view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineExtent {
    /// The first and last point's time (the neighbours that carry it to the edges
    /// included).
    pub first: f64,
    pub last: f64,
    /// The lowest and highest value among its points inside the axis's span (NaN: none).
    pub low: f64,
    pub high: f64,
}

impl LineExtent {
    /// The extent of `points` (in time order), the values looked at inside `from..=to`.
    pub fn of(points: &[[f64; 2]], (from, to): (f64, f64)) -> Option<LineExtent> {
        let (first, last) = (points.first()?[0], points.last()?[0]);
        let (low, high) = points
            .iter()
            .filter(|p| p[0] >= from && p[0] <= to)
            .fold((f64::NAN, f64::NAN), |(lo, hi), p| {
                (lo.min(p[1]), hi.max(p[1]))
            });
        Some(LineExtent {
            first,
            last,
            low,
            high,
        })
    }
}

/// The time at the point (`x`, `y`) on one of the plots `drawn` (where they were in the last
/// frame), when they show `span`: the time their axis puts there.
pub fn time_under(drawn: &[DrawnPlot], (x, y): (f32, f32), (from, to): (f64, f64)) -> Option<f64> {
    let [left, _, right, _] = drawn
        .iter()
        .find(|p| {
            let [left, top, right, bottom] = p.visible;
            (left..=right).contains(&x) && (top..=bottom).contains(&y)
        })?
        .frame;
    (right > left).then(|| from + f64::from(x - left) / f64::from(right - left) * (to - from))
}

/// The plot panel's view in this run.
#[derive(Clone, Debug)]
pub struct PlotView {
    /// The plots are frozen at this time (recording goes on).
    pub(super) paused_at: Option<f64>,
    /// The time axis follows the newest sample; zooming or panning turns it off.
    pub(super) follow: bool,
    /// A moment to mark (a timeline entry shown on the plots).
    pub(super) highlight: Option<f64>,
    /// The time range drawn in the last frame.
    pub(super) shown_range: Option<(f64, f64)>,
    /// The outcome of the last export or trigger action.
    pub(super) message: Option<Result<String, String>>,
    /// The address of an object to plot, and the history size, being typed.
    pub(super) watch_text: String,
    pub(super) rows_text: String,
    /// Where the plots were drawn in the last frame and the room they had.
    pub(super) drawn_at: DrawnAt,
    /// The picture of the plots being taken.
    pub(super) picture: Picture,
    /// The files the export buttons wrote this session, and which button (the newest
    /// writer of each path).
    pub(super) written: Vec<(PathBuf, Export)>,
    /// The file saved last, for "Open folder".
    pub(super) saved: Option<PathBuf>,
    /// The open and save dialogs (the system's; a script's in tests).
    pub(super) files: Arc<dyn FilePicker>,
    /// A dialog open now, and what its answer is for.
    pub(super) asking: Option<(Job, Answer)>,
    /// A file that exists, waiting for the user's word before it is replaced.
    pub(super) confirm: Option<(PathBuf, Job)>,
    /// A recording (or a frozen capture) on screen instead of the live history.
    pub(super) review: Option<Review>,
    /// A recording being read from its file.
    pub(super) loading: Option<Loading>,
    /// The two cursors (A, B) placed on the time axis: a click places A, a right click B.
    pub(super) cursors: [Option<f64>; 2],
    /// The last frames' decimations, drawn again while the plots have not moved.
    pub(super) decimations: Decimations,
    /// The plots drawn in the last frame, top to bottom.
    pub(super) drawn: Vec<DrawnPlot>,
    /// The lanes there were to draw in the last frame (hidden ones too): each one's key
    /// and name, for the Signals menu.
    pub(super) lanes_seen: Vec<(String, String)>,
}

impl Default for PlotView {
    fn default() -> Self {
        Self {
            paused_at: None,
            follow: true,
            shown_range: None,
            highlight: None,
            message: None,
            watch_text: String::new(),
            rows_text: String::new(),
            drawn_at: DrawnAt::default(),
            picture: Picture::default(),
            written: Vec::new(),
            saved: None,
            files: super::files::picker(),
            asking: None,
            confirm: None,
            review: None,
            loading: None,
            cursors: [None; 2],
            decimations: Decimations::default(),
            drawn: Vec::new(),
            lanes_seen: Vec::new(),
        }
    }
}

impl PlotView {
    /// The one place the plots' view changes on a command. `newest` is the newest sample's
    /// time of the drive shown, `window_s` the span followed.
    pub fn apply(&mut self, command: PlotCommand, newest: Option<f64>, window_s: f64) {
        match command {
            PlotCommand::Pause => self.paused_at = newest,
            PlotCommand::Resume => {
                self.paused_at = None;
                self.follow = true;
                self.highlight = None;
            }
            PlotCommand::Follow(follow) => {
                self.follow = follow;
                if follow {
                    self.paused_at = None;
                }
            }
            PlotCommand::FollowAgain => self.follow = true,
            PlotCommand::ShowSpan { from, to } => {
                self.follow = false;
                self.shown_range = Some((from, to));
            }
            PlotCommand::ShowMoment(t) => {
                let half = if window_s > 0.0 { window_s / 2.0 } else { 5.0 };
                let last = newest.unwrap_or(t);
                self.paused_at = Some((t + half).min(last));
                self.follow = true;
                self.highlight = Some(t);
            }
            PlotCommand::ClearCursors => self.cursors = [None; 2],
            PlotCommand::CloseReview => super::review::close(self),
            PlotCommand::MoveOverlay(seconds) => {
                if let Some(review) = self.review.as_mut() {
                    review.offset_s = seconds;
                }
            }
        }
    }

    pub fn is_paused(&self) -> bool {
        self.paused_at.is_some()
    }

    /// Where the plots are frozen, if they are.
    pub fn paused_at(&self) -> Option<f64> {
        self.paused_at
    }

    pub fn follows(&self) -> bool {
        self.follow
    }

    /// The moment marked on the plots (a timeline entry, another drive's trigger).
    pub fn highlight(&self) -> Option<f64> {
        self.highlight
    }

    /// The time range drawn in the last frame.
    pub fn shown_range(&self) -> Option<(f64, f64)> {
        self.shown_range
    }

    /// What the last export, trigger or plotting action said (`Err`: it failed).
    pub fn message(&self) -> Option<&Result<String, String>> {
        self.message.as_ref()
    }

    /// Say how something about the plots went.
    pub fn say(&mut self, message: Result<String, String>) {
        self.message = Some(message);
    }

    /// The cursors A and B placed on the time axis.
    pub fn cursors(&self) -> [Option<f64>; 2] {
        self.cursors
    }

    /// The recording (or frozen capture) on screen instead of the live history.
    pub fn review(&self) -> Option<&Review> {
        self.review.as_ref()
    }

    /// Where the plots were drawn in the last frame (left, top, right, bottom, in points).
    pub fn plots_area(&self) -> Option<[f32; 4]> {
        self.drawn_at.area
    }

    /// The plots drawn in the last frame, top to bottom: where, on which span, what.
    pub fn drawn(&self) -> &[DrawnPlot] {
        &self.drawn
    }

    /// The open and save dialogs the plots (and the project menu) use.
    pub fn files(&self) -> Arc<dyn FilePicker> {
        self.files.clone()
    }

    /// Use these dialogs (a script's, in tests and demos).
    pub fn set_files(&mut self, files: Arc<dyn FilePicker>) {
        self.files = files;
    }

    /// The plots stand still at `newest` (the newest sample of the drive shown): paused,
    /// a recording under review, or moved away from the newest samples; new samples change
    /// nothing in them.
    pub fn stands_still(&self, newest: Option<f64>) -> bool {
        if self.is_paused() || self.review.is_some() {
            return true;
        }
        !self.follow
            && self
                .shown_range
                .zip(newest)
                .is_some_and(|((_, to), newest)| to < newest)
    }

    /// A triggered capture of the drive shown is complete: frozen on screen, said.
    pub fn captured(&mut self, text: String, live: &Scope) {
        self.message = Some(Ok(text));
        super::review::freeze_capture(self, live);
    }

    /// Another drive's trigger fired (`name`, at `at`): the plots pause at the end of its
    /// capture (`from` to `to`), the trigger marked, every drive's signals drawn; "Resume
    /// plot" follows again. A capture or recording on screen is left alone.
    pub fn frozen_by(&mut self, name: &str, at: f64, (from, to): (f64, f64)) {
        if self.review.is_some() {
            return;
        }
        self.paused_at = Some(to);
        self.follow = true;
        self.highlight = Some(at);
        self.message = Some(Ok(format!(
            "{name}'s trigger fired at {at:.3} s: the plots pause at the end of its capture ({from:.3} to {to:.3} s) with every drive's signals; Resume plot follows again"
        )));
    }

    /// A history cleared: the plots run live again.
    pub fn cleared(&mut self) {
        self.paused_at = None;
        self.follow = true;
    }
}

/// The history the plots draw: the recording under review, or the drive's live one.
pub fn shown_scope<'a>(plot: &'a PlotView, drive: &'a Drive) -> &'a Scope {
    plot.review
        .as_ref()
        .map_or(&drive.scope, |review| &review.base.scope)
}

/// The time span to draw: the newest `window_s` seconds (or the whole history) up to the
/// newest sample or the pause, while following; the whole recording under review (and
/// its overlay); what the user zoomed to otherwise.
pub fn time_range(plot: &PlotView, drive: &Drive, window_s: f64) -> Option<(f64, f64)> {
    if let Some(review) = &plot.review {
        if !plot.follow
            && let Some(range) = plot.shown_range
        {
            return Some(range);
        }
        return review.span();
    }
    let ring = drive.scope.ring();
    let first = ring.first_time()?;
    let end = plot.paused_at.or_else(|| live_end(drive))?;
    if !plot.follow
        && let Some(range) = plot.shown_range
    {
        return Some(range);
    }
    let start = if window_s > 0.0 {
        end - window_s
    } else {
        first
    };
    Some((start.min(end - 0.001), end.max(start + 0.001)))
}

/// The newest moment on the samples' clock: the newest sample's time, or while the link
/// is lost, later by the wall-clock time since that sample came, so an outage grows in
/// view as it lasts.
pub fn live_end(drive: &Drive) -> Option<f64> {
    let last = drive.scope.ring().last_time()?;
    let lost = drive.scope.open_gap().filter(|gap| gap.lost);
    Some(match lost {
        Some(gap) => {
            let age = drive
                .link
                .sample_age(std::time::SystemTime::now())
                .unwrap_or(0.0);
            last.max(gap.from + age)
        }
        None => last,
    })
}

/// The triggered capture a drive's plots show frozen: its trigger time and its span.
pub fn capture_span(drive: &Drive) -> Option<(f64, (f64, f64))> {
    let recording = drive.scope.recording()?;
    let (from, to) = (*recording.times.first()?, *recording.times.last()?);
    Some((
        recording.meta.trigger_time_s.unwrap_or(f64::NAN),
        (from, to),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pause_follow_and_a_span_are_one_place_each() {
        let mut view = PlotView::default();
        view.apply(PlotCommand::Pause, Some(12.0), 10.0);
        assert_eq!(view.paused_at(), Some(12.0));
        assert!(view.stands_still(Some(13.0)));
        view.apply(PlotCommand::Resume, Some(13.0), 10.0);
        assert!(!view.is_paused() && view.follows());
        view.apply(
            PlotCommand::ShowSpan { from: 2.0, to: 4.0 },
            Some(13.0),
            10.0,
        );
        assert!(!view.follows());
        assert_eq!(view.shown_range(), Some((2.0, 4.0)));
        assert!(view.stands_still(Some(13.0)));
        view.apply(PlotCommand::ShowMoment(3.0), Some(13.0), 10.0);
        assert_eq!((view.paused_at(), view.highlight()), (Some(8.0), Some(3.0)));
        view.apply(PlotCommand::Follow(true), Some(13.0), 10.0);
        assert!(!view.is_paused());
    }

    #[test]
    fn the_time_under_the_pointer_is_the_axis_time_there() {
        let plot = |top: f32| DrawnPlot {
            id: String::new(),
            frame: [100.0, top, 1100.0, top + 90.0],
            visible: [100.0, top.max(20.0), 1100.0, top + 90.0],
            axis: (0.0, 1.0),
            decimated: (0.0, 1.0),
            line: None,
            lines: Vec::new(),
        };
        let drawn = [plot(0.0), plot(100.0)];
        // On the span drawn now, wherever the plots were.
        assert_eq!(time_under(&drawn, (350.0, 150.0), (20.0, 30.0)), Some(22.5));
        assert_eq!(time_under(&drawn, (100.0, 30.0), (20.0, 30.0)), Some(20.0));
        assert_eq!(time_under(&drawn, (1100.0, 30.0), (20.0, 30.0)), Some(30.0));
        // On the y axis or between two plots: none.
        assert_eq!(time_under(&drawn, (90.0, 10.0), (20.0, 30.0)), None);
        // Over the part of a plot scrolled out of view: none.
        assert_eq!(time_under(&drawn, (350.0, 15.0), (20.0, 30.0)), None);
        assert_eq!(time_under(&drawn, (350.0, 95.0), (20.0, 30.0)), None);
    }
}
