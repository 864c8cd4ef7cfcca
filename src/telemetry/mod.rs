//! Recorded signals: the bounded history of the live plots (`Ring`, with min/max
//! decimation per pixel column), triggers, recordings and their files, and the plot model
//! that ties them to the worker's samples (`Scope`); the figures of a test move's steps
//! (`figures`), a test run's plan and its sequence of steps (`test_run`,
//! `test_sequence`); the amplitude spectrum of a recorded signal (`spectrum`).

pub mod figures;
pub mod recording;
pub mod ring;
mod save;
mod scope;
pub mod spectrum;
pub mod test_run;
pub mod test_sequence;
pub mod trigger;

pub use recording::stream::{Layout, StreamWriter, Summary};
pub use recording::{
    ChannelInfo, Marker, Metadata, Recording, RecordingError, cut_text, link_mark,
};
pub use ring::{BitSpan, PushError, Ring};
pub use save::{
    MAX_RECORDING_BYTES, load_recording, recording_text, save_recording, stream_layout,
};
pub use scope::{
    Builtin, DEFAULT_HISTORY_ROWS, Gap, Kind, Scope, ScopeEvent, SignalDef, Source, WatchedObject,
    bit_name, format_number, metadata, utc_text, watchable,
};
pub use trigger::{Capture, CaptureEvent, CaptureState, Condition, Edge, Trigger};
