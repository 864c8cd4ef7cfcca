//! Recordings: a window of sample rows cut out of the ring, with what they are and where they
//! came from, saved as CSV (for spreadsheets and scripts) or JSON.
//!
//! # CSV layout
//!
//! ```text
//! # drivedeck recording
//! # vendor: Nanotec
//! # product: PD4-E
//! # trigger: position rises through 1000
//! # trigger_time_s: 12.5
//! # channel: position | Position 6064h | 0.1°
//! # channel: status | Status word 6041h |
//! # marker: 12.5 | trigger
//! t [s],position [0.1°],status
//! 12.2,998,
//! 12.201,999,4663
//! ```
//!
//! - The first line is `# drivedeck recording`; then one `# key: value` line per metadata field
//!   that is set (keys as in [`Metadata`]: `vendor`, `product`, `revision`, `serial`,
//!   `device_name`, `link`, `started`, `trigger`, `trigger_time_s`, `rate_hz`, `note`), one
//!   `# channel: id | name | unit` line per channel and one `# marker: t | text` line per marker.
//!   In these comment values a backslash, `|`, line feed and carriage return are written
//!   `\\`, `\|`, `\n` and `\r`.
//! - Then the header row: `t [s]` and one cell per channel, `<id> [<unit>]`, or just `<id>`
//!   when the unit is empty.
//! - Then one row per sample: the time and one cell per channel. Numbers are written with
//!   Rust's shortest round-trip formatting, so reading them back gives the same `f64`; an
//!   empty cell is NaN (no sample). Cells are quoted as in RFC 4180 when they hold a comma,
//!   quote, line break or leading or trailing space.
//!
//! [`Recording::from_csv`] reads that back exactly, and also reads plain CSV without the
//! comment lines: the first column is then the time and the channels are named from the
//! header (`id [unit]` or `id`). Unknown `# key:` lines are ignored. Errors name the line.
//!
//! A file written as taken ([`stream::StreamWriter`], `drivedeck record`) has the line
//! `# streamed: …` among its first comments, `# marker:` lines among the rows at their time,
//! `# key: value` lines learned on the way or at the end after them, and `# end: …` last.
//! Without that last line it was cut: the reader drops a part line at its end and sets
//! [`Metadata::cut`].
//!
//! # JSON layout
//!
//! An object `{"meta": {..}, "channels": [..], "markers": [..], "t": [..], "columns": [[..]]}`
//! with one array per channel in `columns`; NaN (no sample) is written as `null`. JSON has no
//! infinities, so an infinite value also comes back as NaN.
//!
//! Written as taken, JSON goes row-wise, one item per line, a JSON document once complete:
//!
//! ```text
//! {"format":"drivedeck recording, rows","meta":{..},"channels":[..],"rows":[
//! [0.0,998,null]
//! ,{"t":0.5,"mark":"outage: an exchange with the drive failed: …"}
//! ,{"meta":{"trigger_time_s":0.7}}
//! ,[0.005,999,4663]
//! ],"end":{"meta":{"rate_hz":200.0},"samples":2}}
//! ```
//!
//! Without its last line it was cut: the reader takes every whole line and sets
//! [`Metadata::cut`].

use serde::{Deserialize, Serialize};

mod csv;
mod json;
pub mod stream;
#[cfg(test)]
mod tests;

/// What the recording is of: the device, the link and the trigger. Text fields are shown and
/// saved as given.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    pub vendor: Option<String>,
    pub product: Option<String>,
    pub revision: Option<String>,
    pub serial: Option<String>,
    pub device_name: Option<String>,
    pub link: Option<String>,
    /// Wall-clock start, as text given by the caller.
    pub started: Option<String>,
    /// Description of the trigger, e.g. "position rises through 1000".
    pub trigger: Option<String>,
    /// Time of the trigger, in the recording's time base.
    pub trigger_time_s: Option<f64>,
    /// Sampling rate achieved (samples per second).
    pub rate_hz: Option<f64>,
    /// Sampling rate asked for, where it differs in meaning from the one achieved.
    #[serde(default)]
    pub rate_asked_hz: Option<f64>,
    pub note: Option<String>,
    /// Why and when the recording ended before its time (a lost link, Ctrl-C, …): the
    /// file holds every sample taken until then.
    #[serde(default)]
    pub ended_early: Option<String>,
    /// Set by the reader of a recording written as it was taken (`drivedeck record`) that
    /// has no end: "cut after N samples at t = … s (the recording did not end normally)".
    #[serde(default)]
    pub cut: Option<String>,
    /// Set by the reader when values in the file were not finite (`inf`, `-inf`): they
    /// are gaps now, and this says how many and where. Never written.
    #[serde(default, skip_serializing)]
    pub gaps: Option<String>,
}

/// One recorded channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelInfo {
    /// Short machine name, e.g. "position".
    pub id: String,
    /// Name for people, e.g. "Position 6064h".
    #[serde(default)]
    pub name: String,
    /// Unit, e.g. "0.1°"; may be empty.
    #[serde(default)]
    pub unit: String,
}

/// A note at a moment of the recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    pub t: f64,
    pub text: String,
}

/// A window of sample rows with its description.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    pub meta: Metadata,
    pub channels: Vec<ChannelInfo>,
    /// Sample times in seconds, non-decreasing.
    pub times: Vec<f64>,
    /// One column per channel, each as long as `times`; NaN = no sample in that row.
    pub columns: Vec<Vec<f64>>,
    pub markers: Vec<Marker>,
}

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The CSV text is malformed at a line (1-based).
    #[error("line {line}: {what}")]
    Csv { line: usize, what: String },
    #[error("JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// Well-formed JSON that is not a consistent recording.
    #[error("{0}")]
    Invalid(String),
}

fn csv_error(line: usize, what: impl Into<String>) -> RecordingError {
    RecordingError::Csv {
        line,
        what: what.into(),
    }
}

impl Recording {
    /// Values that are not finite (an `inf` in a file: no drive reports one) become gaps
    /// like empty cells, and `meta.gaps` says how many, in which signals.
    pub fn non_finite_as_gaps(&mut self) {
        let mut found = Vec::new();
        for (channel, column) in self.channels.iter().zip(self.columns.iter_mut()) {
            let mut count = 0usize;
            for value in column.iter_mut().filter(|v| v.is_infinite()) {
                *value = f64::NAN;
                count += 1;
            }
            if count > 0 {
                found.push(format!("{} {count}", channel.id));
            }
        }
        if !found.is_empty() {
            self.meta.gaps = Some(format!(
                "values that are not numbers a drive reports (inf) are drawn as gaps: {}",
                found.join(", ")
            ));
        }
    }
}

impl Metadata {
    /// The text fields with their CSV keys, in file order.
    fn text_fields(&self) -> [(&'static str, &Option<String>); 11] {
        [
            ("vendor", &self.vendor),
            ("product", &self.product),
            ("revision", &self.revision),
            ("serial", &self.serial),
            ("device_name", &self.device_name),
            ("link", &self.link),
            ("started", &self.started),
            ("trigger", &self.trigger),
            ("note", &self.note),
            ("ended_early", &self.ended_early),
            ("cut", &self.cut),
        ]
    }

    /// The number fields with their CSV keys, in file order.
    fn number_fields(&self) -> [(&'static str, Option<f64>); 3] {
        [
            ("trigger_time_s", self.trigger_time_s),
            ("rate_hz", self.rate_hz),
            ("rate_asked_hz", self.rate_asked_hz),
        ]
    }

    fn text_field(&mut self, key: &str) -> Option<&mut Option<String>> {
        Some(match key {
            "vendor" => &mut self.vendor,
            "product" => &mut self.product,
            "revision" => &mut self.revision,
            "serial" => &mut self.serial,
            "device_name" => &mut self.device_name,
            "link" => &mut self.link,
            "started" => &mut self.started,
            "trigger" => &mut self.trigger,
            "note" => &mut self.note,
            "ended_early" => &mut self.ended_early,
            "cut" => &mut self.cut,
            _ => return None,
        })
    }

    fn number_field(&mut self, key: &str) -> Option<&mut Option<f64>> {
        Some(match key {
            "trigger_time_s" => &mut self.trigger_time_s,
            "rate_hz" => &mut self.rate_hz,
            "rate_asked_hz" => &mut self.rate_asked_hz,
            _ => return None,
        })
    }

    /// The fields this sets that `earlier` does not hold with the same value.
    pub fn news_since(&self, earlier: &Metadata) -> Metadata {
        let mut news = Metadata::default();
        for (key, value) in self.text_fields() {
            let held = earlier.text_fields().into_iter().find(|(k, _)| *k == key);
            if let (Some(value), Some(field)) = (value, news.text_field(key))
                && held.is_none_or(|(_, v)| v.as_ref() != Some(value))
            {
                *field = Some(value.clone());
            }
        }
        for (key, value) in self.number_fields() {
            let held = earlier.number_fields().into_iter().find(|(k, _)| *k == key);
            if let (Some(value), Some(field)) = (value, news.number_field(key))
                && held.is_none_or(|(_, v)| v != Some(value))
            {
                *field = Some(value);
            }
        }
        news
    }

    /// Take every field `update` sets (a file written as taken says some only at its end).
    pub fn merge(&mut self, update: &Metadata) {
        for (key, value) in update.text_fields() {
            if let (Some(value), Some(field)) = (value, self.text_field(key)) {
                *field = Some(value.clone());
            }
        }
        for (key, value) in update.number_fields() {
            if let (Some(value), Some(field)) = (value, self.number_field(key)) {
                *field = Some(value);
            }
        }
    }
}

/// The marker a notice of the worker's about the link makes in a recording, where it is
/// one: an exchange that failed or a connection that closed or reset (an outage begins;
/// the worker tries again, or opens it again), the link back after failed exchanges or
/// the connection opened again, a trouble got over by sending again. `None` for any other
/// notice. (The worker's words: `worker::loss`.)
pub fn link_mark(notice: &str) -> Option<String> {
    if notice.starts_with("an exchange with the drive failed")
        || notice.starts_with("the connection to the drive failed")
    {
        Some(format!("outage: {notice}"))
    } else if notice.starts_with("the link recovered after")
        || notice.starts_with("the connection to the drive was opened again")
    {
        Some(format!("recovered: {notice}"))
    } else {
        notice
            .strip_prefix("link: ")
            .map(|trouble| format!("retry: {trouble}"))
    }
}

/// What a recording written as it was taken (`drivedeck record`) says when it did not
/// end: how many samples it holds and the last one's time.
pub fn cut_text(samples: usize, last_t: Option<f64>) -> String {
    match last_t {
        Some(t) => format!(
            "cut after {samples} samples at t = {t:.3} s (the recording did not end normally)"
        ),
        None => format!("cut after {samples} samples (the recording did not end normally)"),
    }
}

impl Recording {
    /// Rows of the ring with `from <= t <= to`, for the ring columns listed (ring column
    /// index, its description). A column index the ring does not have records NaN.
    pub fn from_ring(
        ring: &super::ring::Ring,
        columns: &[(usize, ChannelInfo)],
        from: f64,
        to: f64,
        meta: Metadata,
    ) -> Recording {
        let rows = ring.range(from, to);
        Recording {
            meta,
            channels: columns.iter().map(|(_, info)| info.clone()).collect(),
            times: rows.clone().filter_map(|i| ring.time(i)).collect(),
            columns: columns
                .iter()
                .map(|&(c, _)| {
                    rows.clone()
                        .map(|i| ring.value(i, c).unwrap_or(f64::NAN))
                        .collect()
                })
                .collect(),
            markers: Vec::new(),
        }
    }

    /// Rows recorded.
    pub fn len(&self) -> usize {
        self.times.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// Seconds from the first row to the last (0 with fewer than two rows).
    pub fn duration(&self) -> f64 {
        match (self.times.first(), self.times.last()) {
            (Some(first), Some(last)) => last - first,
            _ => 0.0,
        }
    }

    /// Samples per second its rows were taken at (0 with fewer than two rows).
    pub fn achieved_rate(&self) -> f64 {
        let seconds = self.duration();
        if seconds > 0.0 {
            (self.len() - 1) as f64 / seconds
        } else {
            0.0
        }
    }

    /// Write into the header the rate achieved (to 0.1 Hz) beside the rate `asked` for: an
    /// I/O connection that delivers one image per RPI, a link slower than asked, show in
    /// the file as what they are.
    pub fn set_rates(&mut self, asked: f64) {
        let achieved = self.achieved_rate();
        self.meta.rate_hz = (self.len() > 1).then_some((achieved * 10.0).round() / 10.0);
        self.meta.rate_asked_hz = Some(asked);
    }
}
