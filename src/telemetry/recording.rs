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
//! # JSON layout
//!
//! An object `{"meta": {..}, "channels": [..], "markers": [..], "t": [..], "columns": [[..]]}`
//! with one array per channel in `columns`; NaN (no sample) is written as `null`. JSON has no
//! infinities, so an infinite value also comes back as NaN.

use std::borrow::Cow;
use std::fmt::{self, Write as _};

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

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

impl Metadata {
    /// The text fields with their CSV keys, in file order.
    fn text_fields(&self) -> [(&'static str, &Option<String>); 10] {
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

    /// The recording as CSV (see the module documentation for the layout). A value missing
    /// from a too-short column is written as no sample.
    pub fn to_csv(&self) -> String {
        let mut out = String::with_capacity(64 + self.len() * (12 + 10 * self.channels.len()));
        out.push_str("# drivedeck recording\n");
        for (key, value) in self.meta.text_fields() {
            if let Some(value) = value {
                put(&mut out, format_args!("# {key}: {}\n", escape(value)));
            }
        }
        for (key, value) in self.meta.number_fields() {
            if let Some(value) = value {
                put(&mut out, format_args!("# {key}: {value}\n"));
            }
        }
        for c in &self.channels {
            put(
                &mut out,
                format_args!(
                    "# channel: {} | {} | {}\n",
                    escape(&c.id),
                    escape(&c.name),
                    escape(&c.unit)
                ),
            );
        }
        for m in &self.markers {
            put(
                &mut out,
                format_args!("# marker: {} | {}\n", m.t, escape(&m.text)),
            );
        }
        out.push_str("t [s]");
        for c in &self.channels {
            out.push(',');
            let cell = if c.unit.is_empty() {
                Cow::Borrowed(c.id.as_str())
            } else {
                Cow::Owned(format!("{} [{}]", c.id, c.unit))
            };
            out.push_str(&quote(&cell));
        }
        out.push('\n');
        for (i, t) in self.times.iter().enumerate() {
            put(&mut out, format_args!("{t}"));
            for c in 0..self.channels.len() {
                out.push(',');
                match self.columns.get(c).and_then(|column| column.get(i)) {
                    Some(v) if !v.is_nan() => put(&mut out, format_args!("{v}")),
                    _ => {}
                }
            }
            out.push('\n');
        }
        out
    }

    /// Read what [`Recording::to_csv`] writes, or plain CSV with a header row.
    pub fn from_csv(text: &str) -> Result<Recording, RecordingError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut reader = CsvReader::new(text);
        let mut meta = Metadata::default();
        let mut channels = Vec::new();
        let mut markers = Vec::new();
        let mut cells = Vec::new();
        let mut header: Option<usize> = None; // cells per row once the header is read
        let mut times = Vec::new();
        let mut columns: Vec<Vec<f64>> = Vec::new();
        while let Some((line, item)) = reader.next(&mut cells)? {
            match item {
                Item::Comment(comment) => {
                    parse_comment(
                        comment,
                        line,
                        header.is_some(),
                        &mut meta,
                        &mut channels,
                        &mut markers,
                    )?;
                }
                Item::Record => match header {
                    None => {
                        let first = cells.first().map_or("", |c| c.trim());
                        if first.parse::<f64>().is_ok() {
                            return Err(csv_error(line, "expected the header row, found numbers"));
                        }
                        let declared = !channels.is_empty();
                        if declared && cells.len() != channels.len() + 1 {
                            return Err(csv_error(
                                line,
                                format!(
                                    "the header has {} channel columns but {} channels are declared",
                                    cells.len() - 1,
                                    channels.len()
                                ),
                            ));
                        }
                        if !declared {
                            channels = cells
                                .iter()
                                .skip(1)
                                .map(|c| channel_from_header(c))
                                .collect();
                        }
                        columns = vec![Vec::new(); channels.len()];
                        header = Some(cells.len());
                    }
                    Some(width) => {
                        if cells.len() != width {
                            return Err(csv_error(
                                line,
                                format!("{} cells, expected {width}", cells.len()),
                            ));
                        }
                        let t = parse_number(&cells[0], line)?;
                        if !t.is_finite() {
                            return Err(csv_error(line, "the time is missing or not finite"));
                        }
                        if let Some(&last) = times.last()
                            && t < last
                        {
                            return Err(csv_error(
                                line,
                                format!("time {t} is before the previous row's ({last})"),
                            ));
                        }
                        times.push(t);
                        for (column, cell) in columns.iter_mut().zip(&cells[1..]) {
                            column.push(parse_number(cell, line)?);
                        }
                    }
                },
            }
        }
        if header.is_none() {
            return Err(csv_error(reader.line, "no header row"));
        }
        Ok(Recording {
            meta,
            channels,
            times,
            columns,
            markers,
        })
    }

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

/// Append formatted text (writing into a `String` cannot fail).
fn put(out: &mut String, args: fmt::Arguments<'_>) {
    let _ = out.write_fmt(args);
}

// --- CSV comment lines ---

/// Escape a comment value: backslash, `|`, line feed and carriage return.
fn escape(text: &str) -> Cow<'_, str> {
    if !text.contains(['\\', '|', '\n', '\r']) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 4);
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '|' => out.push_str("\\|"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

/// Undo [`escape`]; an unknown escape is kept as written.
fn unescape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('\\') => out.push('\\'),
            Some('|') => out.push('|'),
            Some('n') => out.push('\n'),
            Some('r') => out.push('\r'),
            Some(other) => {
                out.push('\\');
                out.push(other);
            }
            None => out.push('\\'),
        }
    }
    out
}

/// Split `a | b | c` at the unescaped `|`s and unescape the fields. The single spaces around
/// each `|` are separators; any further spaces belong to the field.
fn split_fields(text: &str) -> Vec<String> {
    let mut raw = Vec::new();
    let mut start = 0;
    let mut escaped = false;
    for (i, c) in text.char_indices() {
        if escaped {
            escaped = false;
        } else if c == '\\' {
            escaped = true;
        } else if c == '|' {
            raw.push(&text[start..i]);
            start = i + 1;
        }
    }
    raw.push(&text[start..]);
    let last = raw.len() - 1;
    raw.iter()
        .enumerate()
        .map(|(n, field)| {
            let mut field = *field;
            if n > 0 {
                field = field.strip_prefix(' ').unwrap_or(field);
            }
            if n < last {
                field = field.strip_suffix(' ').unwrap_or(field);
            }
            unescape(field)
        })
        .collect()
}

/// Take in one `# ...` line.
fn parse_comment(
    comment: &str,
    line: usize,
    after_header: bool,
    meta: &mut Metadata,
    channels: &mut Vec<ChannelInfo>,
    markers: &mut Vec<Marker>,
) -> Result<(), RecordingError> {
    let body = comment.strip_prefix('#').unwrap_or(comment);
    let body = body.strip_prefix(' ').unwrap_or(body);
    let Some((key, value)) = body.split_once(':') else {
        return Ok(()); // "# drivedeck recording" or a remark
    };
    let key = key.trim();
    let value = value.strip_prefix(' ').unwrap_or(value);
    match key {
        "channel" => {
            if after_header {
                return Err(csv_error(line, "a channel line after the header row"));
            }
            let mut fields = split_fields(value).into_iter();
            let id = fields.next().unwrap_or_default();
            let name = fields.next().unwrap_or_else(|| id.clone());
            let unit = fields.next().unwrap_or_default();
            if fields.next().is_some() {
                return Err(csv_error(line, "a channel line needs `id | name | unit`"));
            }
            channels.push(ChannelInfo { id, name, unit });
        }
        "marker" => {
            let mut fields = split_fields(value).into_iter();
            let t = fields.next().unwrap_or_default();
            let text = fields.next().unwrap_or_default();
            if fields.next().is_some() {
                return Err(csv_error(line, "a marker line needs `t | text`"));
            }
            let t = t.trim();
            let t = t
                .parse::<f64>()
                .map_err(|_| csv_error(line, format!("bad marker time {t:?}")))?;
            markers.push(Marker { t, text });
        }
        _ => {
            if let Some(field) = meta.text_field(key) {
                *field = Some(unescape(value));
            } else if let Some(field) = meta.number_field(key) {
                let v = value.trim();
                let v = v
                    .parse::<f64>()
                    .map_err(|_| csv_error(line, format!("bad number {v:?} for {key}")))?;
                *field = Some(v);
            }
        }
    }
    Ok(())
}

/// A channel described by a header cell alone: `id [unit]` or `id`.
fn channel_from_header(cell: &str) -> ChannelInfo {
    let cell = cell.trim();
    let (id, unit) = match cell.strip_suffix(']').and_then(|c| c.rsplit_once(" [")) {
        Some((id, unit)) => (id.trim_end(), unit),
        None => (cell, ""),
    };
    ChannelInfo {
        id: id.to_string(),
        name: id.to_string(),
        unit: unit.to_string(),
    }
}

// --- CSV cells ---

/// Quote a cell per RFC 4180 when it needs it.
fn quote(cell: &str) -> Cow<'_, str> {
    let needs = cell.contains([',', '"', '\n', '\r'])
        || cell.starts_with(char::is_whitespace)
        || cell.ends_with(char::is_whitespace);
    if needs {
        Cow::Owned(format!("\"{}\"", cell.replace('"', "\"\"")))
    } else {
        Cow::Borrowed(cell)
    }
}

/// A number cell: empty is NaN.
fn parse_number(cell: &str, line: usize) -> Result<f64, RecordingError> {
    let cell = cell.trim();
    if cell.is_empty() {
        return Ok(f64::NAN);
    }
    cell.parse()
        .map_err(|_| csv_error(line, format!("bad number {cell:?}")))
}

/// What the reader found at a line.
enum Item<'a> {
    /// A `#` line (without its line break).
    Comment(&'a str),
    /// A record, its cells in the buffer given to [`CsvReader::next`].
    Record,
}

/// Reads CSV records (RFC 4180 quoting, LF or CRLF line ends) and `#` comment lines, skipping
/// blank lines and counting lines.
struct CsvReader<'a> {
    text: &'a str,
    pos: usize,
    /// The line `pos` is on (1-based).
    line: usize,
}

impl<'a> CsvReader<'a> {
    fn new(text: &'a str) -> CsvReader<'a> {
        CsvReader {
            text,
            pos: 0,
            line: 1,
        }
    }

    /// The next comment or record and the line it starts on.
    fn next(
        &mut self,
        cells: &mut Vec<Cow<'a, str>>,
    ) -> Result<Option<(usize, Item<'a>)>, RecordingError> {
        let text = self.text;
        loop {
            if self.pos >= text.len() {
                return Ok(None);
            }
            let line = self.line;
            let rest = &text[self.pos..];
            let (this_line, next_pos) = match rest.find('\n') {
                Some(n) => (&rest[..n], self.pos + n + 1),
                None => (rest, text.len()),
            };
            let this_line = this_line.strip_suffix('\r').unwrap_or(this_line);
            if this_line.trim().is_empty() || this_line.starts_with('#') {
                self.pos = next_pos;
                self.line += 1;
                if this_line.starts_with('#') {
                    return Ok(Some((line, Item::Comment(this_line))));
                }
                continue;
            }
            cells.clear();
            loop {
                let bytes = text.as_bytes();
                if bytes.get(self.pos) == Some(&b'"') {
                    cells.push(Cow::Owned(self.quoted(line)?));
                    // Only a separator may follow the closing quote.
                    let rest = &text[self.pos..];
                    if rest == "\r" || rest.starts_with("\r\n") {
                        self.pos += 1;
                    } else if !(rest.is_empty() || rest.starts_with([',', '\n'])) {
                        return Err(csv_error(self.line, "text after a closing quote"));
                    }
                } else {
                    let rest = &text[self.pos..];
                    let n = rest.find([',', '\n']).unwrap_or(rest.len());
                    let cell = &rest[..n];
                    let ends_line = !rest[n..].starts_with(',');
                    let cell = if ends_line {
                        cell.strip_suffix('\r').unwrap_or(cell)
                    } else {
                        cell
                    };
                    cells.push(Cow::Borrowed(cell));
                    self.pos += n;
                }
                match text.as_bytes().get(self.pos) {
                    Some(b',') => self.pos += 1,
                    Some(_) => {
                        self.pos += 1; // the line feed
                        self.line += 1;
                        break;
                    }
                    None => break,
                }
            }
            return Ok(Some((line, Item::Record)));
        }
    }

    /// A quoted cell starting at `pos`; leaves `pos` after the closing quote.
    fn quoted(&mut self, record_line: usize) -> Result<String, RecordingError> {
        let text = self.text;
        let mut cell = String::new();
        self.pos += 1;
        loop {
            let rest = &text[self.pos..];
            let Some(n) = rest.find('"') else {
                return Err(csv_error(record_line, "a quoted cell is not closed"));
            };
            let part = &rest[..n];
            self.line += part.matches('\n').count();
            cell.push_str(part);
            self.pos += n + 1;
            if text.as_bytes().get(self.pos) == Some(&b'"') {
                cell.push('"');
                self.pos += 1;
            } else {
                return Ok(cell);
            }
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn same_f64(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn same_opt(a: Option<f64>, b: Option<f64>) -> bool {
        match (a, b) {
            (Some(a), Some(b)) => same_f64(a, b),
            (a, b) => a.is_none() && b.is_none(),
        }
    }

    /// Equal, bit for bit, with NaN equal to NaN.
    fn assert_same(a: &Recording, b: &Recording) {
        let (ma, mb) = (&a.meta, &b.meta);
        assert_eq!(ma.text_fields(), mb.text_fields());
        assert!(
            same_opt(ma.trigger_time_s, mb.trigger_time_s),
            "{ma:?} {mb:?}"
        );
        assert!(same_opt(ma.rate_hz, mb.rate_hz), "{ma:?} {mb:?}");
        assert_eq!(a.channels, b.channels);
        assert_eq!(a.markers.len(), b.markers.len());
        for (x, y) in a.markers.iter().zip(&b.markers) {
            assert!(same_f64(x.t, y.t) && x.text == y.text, "{x:?} {y:?}");
        }
        assert_eq!(a.times.len(), b.times.len());
        for (x, y) in a.times.iter().zip(&b.times) {
            assert!(same_f64(*x, *y), "time {x} != {y}");
        }
        assert_eq!(a.columns.len(), b.columns.len());
        for (ca, cb) in a.columns.iter().zip(&b.columns) {
            assert_eq!(ca.len(), cb.len());
            for (x, y) in ca.iter().zip(cb) {
                assert!(same_f64(*x, *y), "value {x} != {y}");
            }
        }
    }

    fn sample() -> Recording {
        Recording {
            meta: Metadata {
                vendor: Some("Nanotec".into()),
                product: Some("PD4-E601L42-E-65-2".into()),
                revision: Some("FIR-v2213".into()),
                serial: Some("1234, \"5678\"".into()),
                device_name: Some("axis | left\nline two".into()),
                link: Some("Modbus TCP 192.168.2.10:502".into()),
                started: Some("2025-01-31 14:03:07".into()),
                trigger: Some("position rises through 1000".into()),
                trigger_time_s: Some(12.5),
                rate_hz: Some(1000.0),
                rate_asked_hz: Some(2000.0),
                note: Some(" back\\slash ".into()),
                ended_early: Some("the link was lost: no answer | at t = 3.5 s".into()),
            },
            channels: vec![
                ChannelInfo {
                    id: "position".into(),
                    name: "Position 6064h".into(),
                    unit: "0.1°".into(),
                },
                ChannelInfo {
                    id: "torque".into(),
                    name: "Torque 6077h".into(),
                    unit: "‰".into(),
                },
                ChannelInfo {
                    id: "status".into(),
                    name: "Status word 6041h".into(),
                    unit: String::new(),
                },
                ChannelInfo {
                    id: "odd, \"one\"".into(),
                    name: "a | b".into(),
                    unit: "m/s [x]".into(),
                },
            ],
            times: vec![12.2, 12.201, 12.201, 12.2 + 0.1, 1e6],
            columns: vec![
                vec![998.0, 999.0, f64::NAN, -0.0, 1e300],
                vec![0.1, f64::NAN, 5e-324, -12.75, 0.0],
                vec![4663.0, 4663.0, 1591.0, f64::NAN, f64::NAN],
                vec![f64::NAN; 5],
            ],
            markers: vec![
                Marker {
                    t: 12.5,
                    text: "trigger".into(),
                },
                Marker {
                    t: 12.3,
                    text: "a | marker\r\nwith, everything \"\\\"".into(),
                },
            ],
        }
    }

    #[test]
    fn csv_round_trip_is_exact() {
        let recording = sample();
        let text = recording.to_csv();
        assert!(text.starts_with("# drivedeck recording\n# vendor: Nanotec\n"));
        assert!(text.contains("# channel: position | Position 6064h | 0.1°\n"));
        assert!(text.contains("# channel: status | Status word 6041h | \n"));
        assert!(text.contains("# device_name: axis \\| left\\nline two\n"));
        assert!(
            text.contains(
                "t [s],position [0.1°],torque [‰],status,\"odd, \"\"one\"\" [m/s [x]]\"\n"
            )
        );
        assert!(text.contains("\n12.2,998,0.1,4663,\n"));
        assert!(text.contains("\n12.201,999,,4663,\n"));
        assert_same(&Recording::from_csv(&text).unwrap(), &recording);
        // Windows line ends and a byte-order mark.
        let crlf = format!("\u{feff}{}", text.replace('\n', "\r\n"));
        assert_same(&Recording::from_csv(&crlf).unwrap(), &recording);
    }

    #[test]
    fn json_round_trip_is_exact() {
        let recording = sample();
        let text = recording.to_json();
        assert!(text.contains("\"t\":[12.2,12.201,"));
        assert!(text.contains("[998.0,999.0,null,-0.0,"));
        assert_same(&Recording::from_json(&text).unwrap(), &recording);
    }

    #[test]
    fn empty_recordings_round_trip() {
        let empty = Recording {
            meta: Metadata::default(),
            channels: Vec::new(),
            times: Vec::new(),
            columns: Vec::new(),
            markers: Vec::new(),
        };
        assert_eq!(empty.to_csv(), "# drivedeck recording\nt [s]\n");
        assert_same(&Recording::from_csv(&empty.to_csv()).unwrap(), &empty);
        assert_same(&Recording::from_json(&empty.to_json()).unwrap(), &empty);
        assert!(empty.is_empty());
        assert_eq!(empty.duration(), 0.0);
        let mut one = empty.clone();
        one.times = vec![1.0, 2.0];
        assert_same(&Recording::from_csv(&one.to_csv()).unwrap(), &one);
        assert_eq!(one.len(), 2);
        assert_eq!(one.duration(), 1.0);
    }

    #[test]
    fn plain_csv_names_channels_from_the_header() {
        let text = "time,position [0.1°], torque [‰] ,status\n0,1,2,3\n0.5,,,\n1,4,5,6";
        let r = Recording::from_csv(text).unwrap();
        let ids: Vec<_> = r.channels.iter().map(|c| c.id.as_str()).collect();
        let units: Vec<_> = r.channels.iter().map(|c| c.unit.as_str()).collect();
        assert_eq!(ids, ["position", "torque", "status"]);
        assert_eq!(units, ["0.1°", "‰", ""]);
        assert_eq!(r.channels[0].name, "position");
        assert_eq!(r.times, [0.0, 0.5, 1.0]);
        assert_eq!(r.columns[2][2], 6.0);
        assert!(r.columns[0][1].is_nan());
        assert_eq!(r.meta, Metadata::default());
    }

    fn error_line(text: &str) -> (usize, String) {
        match Recording::from_csv(text) {
            Err(RecordingError::Csv { line, what }) => (line, what),
            other => panic!("expected a CSV error, got {other:?}"),
        }
    }

    #[test]
    fn malformed_csv_names_the_line() {
        let head =
            "# drivedeck recording\n# channel: a | A | m\n# channel: b | B |\nt [s],a [m],b\n";
        // A bad number.
        let (line, what) = error_line(&format!("{head}0,1,2\n1,x,2\n"));
        assert_eq!((line, what.as_str()), (6, "bad number \"x\""));
        // Wrong cell counts.
        assert_eq!(
            error_line(&format!("{head}0,1,2\n1,2\n")),
            (6, "2 cells, expected 3".into())
        );
        assert_eq!(error_line(&format!("{head}0,1,2,3\n")).0, 5);
        // Missing and backwards times.
        assert_eq!(error_line(&format!("{head}0,1,2\n,1,2\n")).0, 6);
        assert_eq!(error_line(&format!("{head}1,1,2\n\n0.5,1,2\n")).0, 7);
        // The header does not match the channel lines.
        assert_eq!(error_line("# channel: a | A | m\nt [s],a,b\n0,1,2\n").0, 2);
        // No header: numbers first, or nothing but comments.
        assert_eq!(error_line("0,1\n1,2\n").0, 1);
        assert_eq!(error_line("# drivedeck recording\n\n0,1\n").0, 3);
        assert_eq!(
            error_line("# drivedeck recording\n# vendor: x\n"),
            (3, "no header row".into())
        );
        assert_eq!(error_line("").0, 1);
        // Bad metadata and marker lines.
        assert_eq!(
            error_line("# drivedeck recording\n# rate_hz: fast\nt [s]\n").0,
            2
        );
        assert_eq!(error_line("# marker: soon | go\nt [s]\n").0, 1);
        assert_eq!(error_line("# channel: a | b | c | d\nt [s],a\n").0, 1);
        assert_eq!(error_line("t [s],a\n# channel: a | b | c\n").0, 2);
        // Quoting: an unclosed quote names the record's line; a quoted line break counts.
        assert_eq!(error_line("t [s],\"a\n0,1\n").0, 1);
        assert_eq!(error_line("t [s],\"a\"x\n").0, 1);
        assert_eq!(error_line("t [s],\"a\nb\"\n0,1\n1,?\n").0, 4);
    }

    #[test]
    fn errors_read_well() {
        let e = Recording::from_csv("t [s],a\n0,1,2\n").unwrap_err();
        assert_eq!(e.to_string(), "line 2: 3 cells, expected 2");
        assert!(matches!(
            Recording::from_json("{"),
            Err(RecordingError::Json(_))
        ));
        let bad = r#"{"channels":[{"id":"a"}],"t":[0,1],"columns":[[1]]}"#;
        assert!(matches!(
            Recording::from_json(bad),
            Err(RecordingError::Invalid(_))
        ));
        let bad = r#"{"channels":[],"t":[1,0],"columns":[]}"#;
        assert!(matches!(
            Recording::from_json(bad),
            Err(RecordingError::Invalid(_))
        ));
        let bad = r#"{"channels":[],"t":[0,null],"columns":[]}"#;
        assert!(matches!(
            Recording::from_json(bad),
            Err(RecordingError::Invalid(_))
        ));
        // meta and markers may be left out; a channel needs only its id.
        let ok = r#"{"channels":[{"id":"a"}],"t":[0,1],"columns":[[1,null]]}"#;
        let r = Recording::from_json(ok).unwrap();
        assert_eq!(r.channels[0].unit, "");
        assert!(r.columns[0][1].is_nan());
    }

    fn odd_text() -> impl Strategy<Value = String> {
        prop_oneof![any::<String>(), "[ a-z0-9,;\"|\\\\\n\r\t#:\\[\\]°‰µ]{0,12}",]
    }

    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(f64::NAN),
            Just(0.0),
            Just(-0.0),
            prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
            (-1e6..1e6f64),
        ]
    }

    fn finite() -> impl Strategy<Value = f64> {
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO
    }

    fn recording() -> impl Strategy<Value = Recording> {
        let meta = (
            prop::collection::vec(prop::option::of(odd_text()), 10),
            prop::option::of(finite()),
            prop::option::of(finite()),
            prop::option::of(finite()),
        )
            .prop_map(|(text, trigger_time_s, rate_hz, rate_asked_hz)| {
                let mut meta = Metadata {
                    trigger_time_s,
                    rate_hz,
                    rate_asked_hz,
                    ..Metadata::default()
                };
                let fields = [
                    &mut meta.vendor,
                    &mut meta.product,
                    &mut meta.revision,
                    &mut meta.serial,
                    &mut meta.device_name,
                    &mut meta.link,
                    &mut meta.started,
                    &mut meta.trigger,
                    &mut meta.note,
                    &mut meta.ended_early,
                ];
                for (field, value) in fields.into_iter().zip(text) {
                    *field = value;
                }
                meta
            });
        let channel = (odd_text(), odd_text(), odd_text())
            .prop_map(|(id, name, unit)| ChannelInfo { id, name, unit });
        let marker = (finite(), odd_text()).prop_map(|(t, text)| Marker { t, text });
        (
            meta,
            prop::collection::vec(channel, 0..4),
            prop::collection::vec(marker, 0..3),
            0usize..12,
        )
            .prop_flat_map(|(meta, channels, markers, rows)| {
                let n = channels.len();
                (
                    Just(meta),
                    Just(channels),
                    Just(markers),
                    prop::collection::vec(finite(), rows),
                    prop::collection::vec(prop::collection::vec(value(), rows), n),
                )
            })
            .prop_map(|(meta, channels, markers, mut times, columns)| {
                times.sort_by(f64::total_cmp);
                Recording {
                    meta,
                    channels,
                    times,
                    columns,
                    markers,
                }
            })
    }

    proptest! {
        #[test]
        fn round_trips_are_exact(recording in recording()) {
            assert_same(&Recording::from_csv(&recording.to_csv()).unwrap(), &recording);
            assert_same(&Recording::from_json(&recording.to_json()).unwrap(), &recording);
        }

        #[test]
        fn reading_arbitrary_text_does_not_panic(text in any::<String>()) {
            let _ = Recording::from_csv(&text);
            let _ = Recording::from_json(&text);
        }
    }
}
