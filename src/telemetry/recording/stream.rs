//! A recording written as it is taken (`drivedeck record`): the header first, then each
//! row and marker as it comes, handed to the system at least every [`FLUSH_EVERY`], and an
//! end line once the recording is complete. A file cut by a crash holds every row up to
//! its last flush, and its reader says it was cut (see the module above for both layouts).
//!
//! Nothing per sample is kept: only the [`Summary`] (counts and the first and last times).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::time::{Duration, Instant};

use serde::Serialize;

use super::csv::{END, STREAMED, channel_lines, header_row, marker_line, meta_lines, row_line};
use super::json::{ROWS_FORMAT, RowsEnd, RowsHead};
use super::{ChannelInfo, Marker, Metadata};

/// The longest a row waits in memory before it is handed to the system.
pub const FLUSH_EVERY: Duration = Duration::from_millis(500);

/// How the file is laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    Csv,
    /// One JSON item per line, a JSON document once complete.
    Json,
}

/// What was written: enough for the report at the end, the same size after a million
/// rows as after one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    pub rows: usize,
    pub first_t: Option<f64>,
    pub last_t: Option<f64>,
    /// Per channel, the rows that carry a value of it.
    pub counts: Vec<usize>,
}

impl Summary {
    pub fn new(channels: usize) -> Summary {
        Summary {
            counts: vec![0; channels],
            ..Summary::default()
        }
    }

    /// Count one row.
    pub fn add(&mut self, t: f64, values: &[f64]) {
        self.rows += 1;
        self.first_t.get_or_insert(t);
        self.last_t = Some(t);
        for (count, v) in self.counts.iter_mut().zip(values) {
            if !v.is_nan() {
                *count += 1;
            }
        }
    }

    /// Seconds from the first row to the last (0 with fewer than two rows).
    pub fn duration(&self) -> f64 {
        match (self.first_t, self.last_t) {
            (Some(first), Some(last)) => last - first,
            _ => 0.0,
        }
    }

    /// Samples per second the rows were taken at (0 with fewer than two rows).
    pub fn achieved_rate(&self) -> f64 {
        let seconds = self.duration();
        if seconds > 0.0 {
            (self.rows - 1) as f64 / seconds
        } else {
            0.0
        }
    }
}

/// A recording file being written as it is taken.
pub struct StreamWriter {
    out: BufWriter<File>,
    layout: Layout,
    /// Items of the JSON `rows` array written (each after the first starts with a comma).
    items: u64,
    last_flush: Instant,
    line: String,
    ended: bool,
    /// The metadata in the file so far (the header's, then each update): the end says
    /// only what is new, so no field appears twice.
    written: Metadata,
}

/// Serializing plain structs, strings and numbers cannot fail.
fn json_text<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_default()
}

impl StreamWriter {
    /// Write the header (`meta` as known at the start, the channels) into `file` and hand
    /// it to the system.
    pub fn create(
        file: File,
        layout: Layout,
        meta: &Metadata,
        channels: &[ChannelInfo],
    ) -> std::io::Result<StreamWriter> {
        let mut head = String::new();
        match layout {
            Layout::Csv => {
                head.push_str("# drivedeck recording\n");
                meta_lines(&mut head, meta);
                head.push_str(STREAMED);
                head.push('\n');
                channel_lines(&mut head, channels);
                header_row(&mut head, channels);
            }
            Layout::Json => {
                let text = json_text(&RowsHead {
                    format: ROWS_FORMAT.into(),
                    meta: meta.clone(),
                    channels: channels.to_vec(),
                    rows: Vec::new(),
                });
                // `…,"rows":[]}` is the head and the end of the array: the items follow.
                head.push_str(text.strip_suffix("]}").unwrap_or(&text));
                head.push('\n');
            }
        }
        let mut writer = StreamWriter {
            out: BufWriter::with_capacity(64 * 1024, file),
            layout,
            items: 0,
            last_flush: Instant::now(),
            line: String::new(),
            ended: false,
            written: meta.clone(),
        };
        writer.out.write_all(head.as_bytes())?;
        writer.flush()?;
        Ok(writer)
    }

    /// One sample row; handed to the system when the last flush is [`FLUSH_EVERY`] old.
    pub fn row(&mut self, t: f64, values: &[f64]) -> std::io::Result<()> {
        self.line.clear();
        match self.layout {
            Layout::Csv => row_line(&mut self.line, t, values),
            Layout::Json => {
                let row: Vec<Option<f64>> = std::iter::once(t)
                    .chain(values.iter().copied())
                    .map(|v| v.is_finite().then_some(v))
                    .collect();
                self.item(json_text(&row));
            }
        }
        self.out.write_all(self.line.as_bytes())?;
        self.flush_if_due()
    }

    /// A marker at its time, handed to the system at once.
    pub fn mark(&mut self, marker: &Marker) -> std::io::Result<()> {
        self.line.clear();
        match self.layout {
            Layout::Csv => marker_line(&mut self.line, marker),
            Layout::Json => {
                #[derive(Serialize)]
                struct Mark<'a> {
                    t: f64,
                    mark: &'a str,
                }
                self.item(json_text(&Mark {
                    t: marker.t,
                    mark: &marker.text,
                }));
            }
        }
        self.out.write_all(self.line.as_bytes())?;
        self.flush()
    }

    /// Fields of the metadata learned on the way (the trigger's time), at once.
    pub fn meta(&mut self, update: &Metadata) -> std::io::Result<()> {
        self.written.merge(update);
        self.line.clear();
        match self.layout {
            Layout::Csv => meta_lines(&mut self.line, update),
            Layout::Json => {
                #[derive(Serialize)]
                struct Meta<'a> {
                    meta: &'a Metadata,
                }
                self.item(json_text(&Meta { meta: update }));
            }
        }
        self.out.write_all(self.line.as_bytes())?;
        self.flush()
    }

    /// The recording is complete: the fields known only now (those of `last` the file
    /// does not hold yet: the rate achieved, why it ended early) and the end line, on
    /// the disk.
    pub fn finish(&mut self, last: &Metadata, samples: usize) -> std::io::Result<()> {
        if self.ended {
            return Ok(());
        }
        let last = &last.news_since(&self.written);
        self.line.clear();
        match self.layout {
            Layout::Csv => {
                meta_lines(&mut self.line, last);
                self.line
                    .push_str(&format!("{END} {samples} samples, complete\n"));
            }
            Layout::Json => {
                #[derive(Serialize)]
                struct End<'a> {
                    end: &'a RowsEnd,
                }
                let end = json_text(&End {
                    end: &RowsEnd {
                        meta: last.clone(),
                        samples,
                    },
                });
                // `{"end":…}` → `],"end":…}`: closes the array and the document.
                self.line.push_str("],");
                self.line.push_str(end.strip_prefix('{').unwrap_or(&end));
                self.line.push('\n');
            }
        }
        self.out.write_all(self.line.as_bytes())?;
        self.flush()?;
        self.ended = true;
        self.out.get_ref().sync_data()
    }

    /// Hand what waits to the system (it survives the process then, not a power cut).
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.last_flush = Instant::now();
        self.out.flush()
    }

    /// [`StreamWriter::flush`] when the last one is [`FLUSH_EVERY`] old.
    pub fn flush_if_due(&mut self) -> std::io::Result<()> {
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            self.flush()
        } else {
            Ok(())
        }
    }

    /// The file, everything written handed to the system.
    pub fn into_file(self) -> std::io::Result<File> {
        self.out.into_inner().map_err(|e| e.into_error())
    }

    /// A JSON item of the `rows` array into `line`, after a comma unless it is the first.
    fn item(&mut self, json: String) {
        if self.items > 0 {
            self.line.push(',');
        }
        self.items += 1;
        self.line.push_str(&json);
        self.line.push('\n');
    }
}
