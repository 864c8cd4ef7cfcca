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
