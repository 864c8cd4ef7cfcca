//! The CSV form of a recording: comment lines, header, rows; written and read back exactly.

use std::borrow::Cow;
use std::fmt::{self, Write as _};

use super::{ChannelInfo, Marker, Metadata, Recording, RecordingError, csv_error};

impl Recording {
    /// The recording as CSV (see the module documentation for the layout). A value missing
    /// from a too-short column is written as no sample.
    pub fn to_csv(&self) -> String {
        let mut out = String::with_capacity(64 + self.len() * (12 + 10 * self.channels.len()));
        out.push_str("# drivedeck recording\n");
        meta_lines(&mut out, &self.meta);
        channel_lines(&mut out, &self.channels);
        for m in &self.markers {
            marker_line(&mut out, m);
        }
        header_row(&mut out, &self.channels);
        let mut values = vec![f64::NAN; self.channels.len()];
        for (i, t) in self.times.iter().enumerate() {
            for (c, value) in values.iter_mut().enumerate() {
                *value = self
                    .columns
                    .get(c)
                    .and_then(|column| column.get(i))
                    .copied()
                    .unwrap_or(f64::NAN);
            }
            row_line(&mut out, *t, &values);
        }
        out
    }

    /// Read what [`Recording::to_csv`] writes, or plain CSV with a header row.
    pub fn from_csv(text: &str) -> Result<Recording, RecordingError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        // A file written as taken may end in the middle of a line (the process was killed
        // while writing it): that part line goes, the rows before it stay.
        let streamed = is_streamed(text);
        let text = match text.rfind('\n') {
            Some(n) if streamed => &text[..=n],
            None if streamed => "",
            _ => text,
        };
        let mut ended = false;
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
                Item::Comment(comment) if comment.starts_with(END) => ended = true,
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
                        check_header(&cells, line, &mut channels)?;
                        columns = vec![Vec::new(); channels.len()];
                        header = Some(cells.len());
                    }
                    Some(width) => push_row(&cells, line, width, &mut times, &mut columns)?,
                },
            }
        }
        if header.is_none() {
            return Err(csv_error(reader.line, "no header row"));
        }
        if streamed && !ended {
            meta.cut = Some(super::cut_text(times.len(), times.last().copied()));
        }
        let mut recording = Recording {
            meta,
            channels,
            times,
            columns,
            markers,
        };
        recording.non_finite_as_gaps();
        Ok(recording)
    }
}

/// The line that says a file is written as it is taken (`drivedeck record`): a complete
/// one ends with an [`END`] line, one without was cut.
pub(super) const STREAMED: &str =
    "# streamed: rows written as taken; a complete file ends with an \"# end:\" line";
/// The last line of a complete file written as taken.
pub(super) const END: &str = "# end:";

/// Whether the comment lines before the header say the file is written as taken.
fn is_streamed(text: &str) -> bool {
    text.lines()
        .take_while(|line| line.starts_with('#'))
        .any(|line| line.starts_with("# streamed:"))
}

/// The `# key: value` lines of every field `meta` sets.
pub(super) fn meta_lines(out: &mut String, meta: &Metadata) {
    for (key, value) in meta.text_fields() {
        if let Some(value) = value {
            put(out, format_args!("# {key}: {}\n", escape(value)));
        }
    }
    for (key, value) in meta.number_fields() {
        if let Some(value) = value {
            put(out, format_args!("# {key}: {value}\n"));
        }
    }
}

/// One `# channel: id | name | unit` line per channel.
pub(super) fn channel_lines(out: &mut String, channels: &[ChannelInfo]) {
    for c in channels {
        put(
            out,
            format_args!(
                "# channel: {} | {} | {}\n",
                escape(&c.id),
                escape(&c.name),
                escape(&c.unit)
            ),
        );
    }
}

/// A `# marker: t | text` line.
pub(super) fn marker_line(out: &mut String, m: &Marker) {
    put(
        out,
        format_args!("# marker: {} | {}\n", m.t, escape(&m.text)),
    );
}

/// The header row: `t [s]` and a cell per channel.
pub(super) fn header_row(out: &mut String, channels: &[ChannelInfo]) {
    out.push_str("t [s]");
    for c in channels {
        out.push(',');
        let cell = if c.unit.is_empty() {
            Cow::Borrowed(c.id.as_str())
        } else {
            Cow::Owned(format!("{} [{}]", c.id, c.unit))
        };
        out.push_str(&quote(&cell));
    }
    out.push('\n');
}

/// One sample row: the time and a cell per value (empty for NaN).
pub(super) fn row_line(out: &mut String, t: f64, values: &[f64]) {
    put(out, format_args!("{t}"));
    for v in values {
        out.push(',');
        if !v.is_nan() {
            put(out, format_args!("{v}"));
        }
    }
    out.push('\n');
}

/// The header row: it must match the channels the comments declared, or else declares
/// them itself.
fn check_header(
    cells: &[Cow<'_, str>],
    line: usize,
    channels: &mut Vec<ChannelInfo>,
) -> Result<(), RecordingError> {
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
        *channels = cells
            .iter()
            .skip(1)
            .map(|c| channel_from_header(c))
            .collect();
    }
    Ok(())
}

/// One row of `width` cells: its time (finite, not before the last row's) and a value
/// for each column.
fn push_row(
    cells: &[Cow<'_, str>],
    line: usize,
    width: usize,
    times: &mut Vec<f64>,
    columns: &mut [Vec<f64>],
) -> Result<(), RecordingError> {
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
    Ok(())
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
