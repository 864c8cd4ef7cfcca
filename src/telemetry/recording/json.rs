//! The JSON form of a recording, NaN as null.

use std::fmt;

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{ChannelInfo, Marker, Metadata, Recording, RecordingError};

impl Recording {
    /// The recording as JSON (see the module documentation for the layout).
    pub fn to_json(&self) -> String {
        let json = JsonOut {
            meta: &self.meta,
            channels: &self.channels,
            markers: &self.markers,
            t: NanAsNull(&self.times),
            columns: self.columns.iter().map(|c| NanAsNull(c)).collect(),
        };
        // Serializing plain structs, strings and numbers into a string cannot fail.
        serde_json::to_string(&json).unwrap_or_default()
    }

    /// Read what [`Recording::to_json`] writes. `meta` and `markers` may be left out.
    pub fn from_json(text: &str) -> Result<Recording, RecordingError> {
        if text.starts_with(ROWS_FORMAT_START) {
            return from_rows(text);
        }
        let json: JsonIn = serde_json::from_str(text)?;
        if json.columns.len() != json.channels.len() {
            return Err(RecordingError::Invalid(format!(
                "{} columns for {} channels",
                json.columns.len(),
                json.channels.len()
            )));
        }
        let times = json.t.0;
        for (n, column) in json.columns.iter().enumerate() {
            if column.0.len() != times.len() {
                return Err(RecordingError::Invalid(format!(
                    "column {n} has {} values for {} times",
                    column.0.len(),
                    times.len()
                )));
            }
        }
        for (i, pair) in times.windows(2).enumerate() {
            if pair[1] < pair[0] {
                return Err(RecordingError::Invalid(format!(
                    "time {} (row {}) is before the previous one ({})",
                    pair[1],
                    i + 1,
                    pair[0]
                )));
            }
        }
        if let Some(i) = times.iter().position(|t| !t.is_finite()) {
            return Err(RecordingError::Invalid(format!(
                "time of row {i} is missing or not finite"
            )));
        }
        Ok(Recording {
            meta: json.meta,
            channels: json.channels,
            times,
            columns: json.columns.into_iter().map(|c| c.0).collect(),
            markers: json.markers,
        })
    }
}

// --- JSON written as taken ---

/// How a JSON recording written as taken starts: its first line is
/// `{"format":"drivedeck recording, rows","meta":{..},"channels":[..],"rows":[`.
pub(super) const ROWS_FORMAT: &str = "drivedeck recording, rows";
const ROWS_FORMAT_START: &str = "{\"format\":\"drivedeck recording, rows\"";

/// The first line of a JSON recording written as taken, `]}` added.
#[derive(Serialize, Deserialize)]
pub(super) struct RowsHead {
    pub format: String,
    #[serde(default)]
    pub meta: Metadata,
    pub channels: Vec<ChannelInfo>,
    #[serde(default)]
    pub rows: Vec<serde_json::Value>,
}

/// An item of the `rows` array: a sample row `[t, v, …]` (null for no sample), a marker
/// `{"t": …, "mark": "…"}`, or fields of the metadata learned on the way `{"meta": {…}}`.
#[derive(Deserialize)]
#[serde(untagged)]
enum RowItem {
    Row(Vec<Option<f64>>),
    Mark { t: f64, mark: String },
    Meta { meta: Box<Metadata> },
}

/// The last line of a complete JSON recording written as taken, as `{"end": …}`.
#[derive(Serialize, Deserialize)]
pub(super) struct RowsEnd {
    #[serde(default)]
    pub meta: Metadata,
    #[serde(default)]
    pub samples: usize,
}

#[derive(Deserialize)]
struct RowsEndLine {
    end: RowsEnd,
}

/// Read a JSON recording written as taken: one item per line, the whole a JSON document
/// once the last line (`],"end":{..}}`) is written. A file without that line was cut: what
/// it holds up to its last whole line is read, and `meta.cut` says so.
fn from_rows(text: &str) -> Result<Recording, RecordingError> {
    let line_error = |n: usize, what: String| RecordingError::Invalid(format!("line {n}: {what}"));
    // A part line at the end (killed while writing it) goes.
    let whole = match text.rfind('\n') {
        Some(n) => &text[..=n],
        None => "",
    };
    let mut lines = whole.lines();
    let first = lines
        .next()
        .ok_or_else(|| line_error(1, "the first line is not whole".into()))?;
    let head: RowsHead = serde_json::from_str(&format!("{first}]}}"))
        .map_err(|e| line_error(1, format!("not the head of a recording: {e}")))?;
    let width = head.channels.len();
    let mut meta = head.meta;
    let mut times: Vec<f64> = Vec::new();
    let mut columns = vec![Vec::new(); width];
    let mut markers = Vec::new();
    let mut ended = false;
    for (i, line) in lines.enumerate() {
        let n = i + 2;
        if ended {
            if line.trim().is_empty() {
                continue;
            }
            return Err(line_error(n, "text after the end".into()));
        }
        if let Some(end) = line.strip_prefix("],") {
            let end: RowsEndLine = serde_json::from_str(&format!("{{{end}"))
                .map_err(|e| line_error(n, format!("not the end of a recording: {e}")))?;
            meta.merge(&end.end.meta);
            ended = true;
            continue;
        }
        let item = line.strip_prefix(',').unwrap_or(line);
        let item: RowItem = serde_json::from_str(item)
            .map_err(|e| line_error(n, format!("not a row, marker or metadata: {e}")))?;
        match item {
            RowItem::Row(row) => {
                if row.len() != width + 1 {
                    return Err(line_error(
                        n,
                        format!("{} values, expected {}", row.len(), width + 1),
                    ));
                }
                let t = row[0].unwrap_or(f64::NAN);
                if !t.is_finite() {
                    return Err(line_error(n, "the time is missing or not finite".into()));
                }
                if let Some(&last) = times.last()
                    && t < last
                {
                    return Err(line_error(
                        n,
                        format!("time {t} is before the previous row's ({last})"),
                    ));
                }
                times.push(t);
                for (column, v) in columns.iter_mut().zip(&row[1..]) {
                    column.push(v.unwrap_or(f64::NAN));
                }
            }
            RowItem::Mark { t, mark } => markers.push(Marker { t, text: mark }),
            RowItem::Meta { meta: update } => meta.merge(&update),
        }
    }
    if !ended {
        meta.cut = Some(super::cut_text(times.len(), times.last().copied()));
    }
    Ok(Recording {
        meta,
        channels: head.channels,
        times,
        columns,
        markers,
    })
}

// --- JSON ---

#[derive(Serialize)]
struct JsonOut<'a> {
    meta: &'a Metadata,
    channels: &'a [ChannelInfo],
    markers: &'a [Marker],
    t: NanAsNull<'a>,
    columns: Vec<NanAsNull<'a>>,
}

#[derive(Deserialize)]
struct JsonIn {
    #[serde(default)]
    meta: Metadata,
    channels: Vec<ChannelInfo>,
    #[serde(default)]
    markers: Vec<Marker>,
    t: NullAsNan,
    columns: Vec<NullAsNan>,
}

/// Numbers written with NaN as `null`.
struct NanAsNull<'a>(&'a [f64]);

impl Serialize for NanAsNull<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.0.len()))?;
        for v in self.0 {
            seq.serialize_element(&(!v.is_nan()).then_some(v))?;
        }
        seq.end()
    }
}

/// Numbers read with `null` as NaN.
struct NullAsNan(Vec<f64>);

impl<'de> Deserialize<'de> for NullAsNan {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<NullAsNan, D::Error> {
        struct Numbers;
        impl<'de> Visitor<'de> for Numbers {
            type Value = NullAsNan;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an array of numbers or nulls")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<NullAsNan, A::Error> {
                let mut values = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 20));
                while let Some(v) = seq.next_element::<Option<f64>>()? {
                    values.push(v.unwrap_or(f64::NAN));
                }
                Ok(NullAsNan(values))
            }
        }
        deserializer.deserialize_seq(Numbers)
    }
}
