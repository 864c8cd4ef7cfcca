//! What the user can do in the window, as data. A view reads the models and pushes
//! `Command`s; the window applies them in one place (`App::apply_command`, beside
//! `App::apply_event` for the workers' news), after the frame is drawn. A view may edit
//! its own panel's model (the text in its boxes); what changes another panel, the list
//! of drives or a drive's link goes through here.
//!
//! A model: no egui here.

use crate::injection::Injection;
use crate::link::LinkSpec;
use crate::od::Address;
use crate::pdi::Action;
use crate::worker::Request;

/// Where the outcome of a command is said: the panel it came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Said {
    Plots,
    Dictionary,
    Watch,
}

/// Something the user asked of the window.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    // The list of drives.
    /// Show drive `index` in the panels.
    Select(usize),
    /// Add a drive by its connection string as typed (the list's "+ Add drive").
    AddDrive(String),
    /// Add a drive on this link (a scan's or a discovery's "Add as drive").
    AddDriveOn(LinkSpec),
    /// Take drive `index` out of the list.
    RemoveDrive(usize),
    /// Rename drive `index` (as typed: a name half typed may be empty or taken).
    Rename(usize, String),
    /// Draw drive `index` in the plots beside the drive shown, or not.
    PlotBeside(usize, bool),

    // The drive shown.
    /// Connect to this link.
    Connect(LinkSpec),
    /// Disconnect, asking first what to leave behind when the drive is energised or
    /// objects were changed.
    Disconnect,
    /// Send the user's request (a command, an object access, a halt, a fault to inject).
    Request(Request),
    /// Send a PDI command, warning first about a torque command without a torque slope.
    SendCommand(Request),
    /// Write back every old value the tool changed.
    RestoreChanges,
    /// Inject or withdraw a fault on the simulated drive.
    Inject {
        injection: Injection,
        active: bool,
    },
    /// A jog button (or arrow key) is held in `direction` (-1, +1; 0: none) at `speed`
    /// rpm this frame.
    Jog {
        direction: i32,
        speed: i32,
    },
    /// The window lost the focus while a jog was held.
    JogFocusLost,

    // Every drive.
    /// Quickstop or switch off every connected drive, ahead of everything queued.
    StopAll(Action),

    /// Empty the log's tab `tab` (its id) of the drive shown.
    ClearLog(&'static str),
    /// Open a project in place of the drives (asks which file).
    OpenProject,
    /// Save the drives to the project's file (asks where the first time).
    SaveProject,
    /// Save the drives to a project file the user picks.
    SaveProjectAs,
    /// Open the user guide in the browser (the "?" button, F1).
    OpenGuide,

    // The plots.
    Plot(PlotCommand),
    /// Forget the shown drive's history and markers.
    ClearPlots,
    /// Keep this many samples per signal, on every drive.
    SetHistory(usize),
    /// Plot an object of the dictionary (its address as typed), sampled every cycle; the
    /// outcome is said where asked.
    PlotObject {
        text: String,
        from: Said,
    },
    /// Stop plotting an object.
    UnplotObject(Address),
    /// Pin an object to the watch panel (and open it); the outcome is said where asked.
    PinToWatch {
        address: Address,
        from: Said,
    },
}

/// What the user (or another panel) asks of the plots.
#[derive(Clone, Debug, PartialEq)]
pub enum PlotCommand {
    /// Freeze the plots at the newest sample; sampling and recording go on.
    Pause,
    /// Run live again, following the newest samples.
    Resume,
    /// Keep the newest samples in view, paused no longer (or stop following).
    Follow(bool),
    /// Follow the newest samples again after a zoom or pan (a double click), the pause
    /// kept.
    FollowAgain,
    /// Show this span of the time axis (a zoom or a pan): the plots stop following.
    ShowSpan { from: f64, to: f64 },
    /// Show the moment `t` (a timeline entry): the window around it, marked.
    ShowMoment(f64),
    /// Take the cursors away.
    ClearCursors,
    /// Back to the live plots from a recording or a frozen capture.
    CloseReview,
    /// Move the recording overlaid by this many seconds.
    MoveOverlay(f64),
}
