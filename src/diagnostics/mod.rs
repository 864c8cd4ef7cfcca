//! Diagnostics: the fault timeline.

mod timeline;

pub use timeline::{Entry, Origin, Severity, TIMELINE_LIMIT, Timeline};
