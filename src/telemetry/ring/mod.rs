//! A bounded, columnar history of sample rows for the live plots.
//!
//! Each row is a time (the worker's clock, in seconds) and one `f64` per channel; NaN means
//! "no sample of this channel in this row". The [`Ring`] keeps at most `capacity` rows and drops
//! the oldest when full, so its memory never grows past what the capacity needs.
//!
//! The UI draws the whole history every frame, so [`Ring::decimate`] has to be fast. Each
//! channel keeps block summaries (min, max, OR, AND, and the row offsets of the min, max,
//! first and last samples, so points taken from a summary keep their exact times) for every
//! aligned block of 32 rows and of 4096 rows: about 1 byte per row and channel on top of the
//! 8 of the value. Blocks are keyed by the absolute row number (rows pushed since the last
//! [`Ring::clear`] or [`Ring::set_capacity`]), so they stay valid while the ring wraps; a
//! summary is only used when its whole block is retained, and rows in blocks that are partly
//! evicted or not yet complete, or only partly inside a span, are scanned raw. Decimating
//! 600 000 rows into 1 600 columns takes about 0.25 ms per channel.

use std::fmt;
use std::ops::Range;

mod cache;
mod fold;
mod grid;
mod scan;
mod summary;

pub use cache::Decimations;
use fold::{Bits, Fold, MinMax};
use summary::{Column, Summary};

#[cfg(test)]
mod tests;

/// Rows per small block summary.
const BLOCK: u64 = 32;
/// Rows per big block summary (a whole number of small blocks; offsets fit in `u16`).
const BIG_BLOCK: u64 = 4096;
/// How far back [`Ring::latest`] looks for a sample of a channel, in rows.
pub const LATEST_LOOKBACK: usize = 100_000;

/// Why [`Ring::push`] refused a row.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PushError {
    #[error("sample time {t} s is before the newest one ({last} s)")]
    Backwards { t: f64, last: f64 },
    #[error("sample time {0} is not a finite number")]
    NotFinite(f64),
    #[error("{got} values for {expected} channels")]
    Width { got: usize, expected: usize },
}

/// What one pixel column of a bit channel held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BitSpan {
    /// Time of the first sample in the column.
    pub t0: f64,
    /// Time of the last sample in the column.
    pub t1: f64,
    /// Bits that were 1 in at least one sample (OR of the samples as `u32`).
    pub any: u32,
    /// Bits that were 1 in every sample (AND of the samples as `u32`).
    pub all: u32,
}

/// Which ring, and which of its contents: rows are only ever appended between two changes
/// of `epoch` (a clear, a new capacity, a new channel), and `end` counts the rows appended.
/// Equal versions, equal contents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Version {
    /// The ring (a clone is another ring).
    pub id: u64,
    pub epoch: u64,
    pub end: u64,
}

/// The source of the rings' ids.
static NEXT_RING: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

fn ring_id() -> u64 {
    NEXT_RING.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// The bounded sample history: a shared time column and one value column per channel.
pub struct Ring {
    capacity: usize,
    times: Vec<f64>,
    columns: Vec<Column>,
    /// Physical slot of the oldest row (0 until the ring is full).
    head: usize,
    len: usize,
    /// Absolute number of the oldest row; block summaries are keyed by it.
    start: u64,
    /// This ring's id, and the changes other than appending so far (see [`Version`]).
    id: u64,
    epoch: u64,
}

impl Clone for Ring {
    /// The same rows in another ring (with an id of its own).
    fn clone(&self) -> Self {
        Ring {
            capacity: self.capacity,
            times: self.times.clone(),
            columns: self.columns.clone(),
            head: self.head,
            len: self.len,
            start: self.start,
            id: ring_id(),
            epoch: 0,
        }
    }
}

impl fmt::Debug for Ring {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Ring")
            .field("capacity", &self.capacity)
            .field("len", &self.len)
            .field("channels", &self.columns.len())
            .field("first_time", &self.first_time())
            .field("last_time", &self.last_time())
            .finish()
    }
}

impl Ring {
    /// An empty ring for `capacity` rows (at least 1) of `channels` channels. The value
    /// buffers grow with the rows pushed, up to the capacity; the block summaries (about 1
    /// byte per row and channel) are allocated at once.
    pub fn new(capacity: usize, channels: usize) -> Ring {
        let capacity = capacity.max(1);
        Ring {
            capacity,
            times: Vec::new(),
            columns: (0..channels).map(|_| Column::new(0, 0, capacity)).collect(),
            head: 0,
            len: 0,
            start: 0,
            id: ring_id(),
            epoch: 0,
        }
    }

    /// Which ring and which of its contents (see [`Version`]).
    pub fn version(&self) -> Version {
        Version {
            id: self.id,
            epoch: self.epoch,
            end: self.end(),
        }
    }

    /// The most rows the ring keeps.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Rows retained.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn channels(&self) -> usize {
        self.columns.len()
    }

    /// Forget all rows; channels, capacity and buffers stay.
    pub fn clear(&mut self) {
        self.times.clear();
        for column in &mut self.columns {
            column.values.clear();
        }
        self.head = 0;
        self.len = 0;
        self.start = 0;
        self.epoch += 1;
    }

    /// Change the capacity (at least 1), keeping the newest rows that fit.
    pub fn set_capacity(&mut self, capacity: usize) {
        let capacity = capacity.max(1);
        if capacity == self.capacity {
            return;
        }
        let keep = self.len.min(capacity);
        let skip = self.len - keep;
        let times: Vec<f64> = (skip..self.len).map(|i| self.times[self.slot(i)]).collect();
        let columns: Vec<Column> = self
            .columns
            .iter()
            .map(|c| {
                let mut column = Column::new(0, keep, capacity);
                column
                    .values
                    .extend((skip..self.len).map(|i| c.values[self.slot(i)]));
                column
            })
            .collect();
        self.capacity = capacity;
        self.times = times;
        self.columns = columns;
        self.head = 0;
        self.len = keep;
        self.start = 0;
        self.epoch += 1;
        for block in 0..keep as u64 / BLOCK {
            self.summarize_small(block);
        }
        for block in 0..keep as u64 / BIG_BLOCK {
            self.summarize_big(block);
        }
    }

    /// Add a channel; existing rows hold NaN in it. Returns its index.
    pub fn add_channel(&mut self) -> usize {
        self.epoch += 1;
        self.columns.push(Column::new(
            self.times.len(),
            self.times.capacity(),
            self.capacity,
        ));
        self.columns.len() - 1
    }

    /// Append a row (one value per channel, NaN for none). Times must not go backwards
    /// (equal times are fine). When the ring is full the oldest row goes.
    pub fn push(&mut self, t: f64, values: &[f64]) -> Result<(), PushError> {
        if !t.is_finite() {
            return Err(PushError::NotFinite(t));
        }
        if values.len() != self.columns.len() {
            return Err(PushError::Width {
                got: values.len(),
                expected: self.columns.len(),
            });
        }
        if let Some(last) = self.last_time()
            && t < last
        {
            return Err(PushError::Backwards { t, last });
        }
        if self.len < self.capacity {
            // Filling: `head` is 0 and the buffers hold exactly `len` rows.
            if self.times.len() == self.times.capacity() {
                self.grow();
            }
            self.times.push(t);
            for (column, &v) in self.columns.iter_mut().zip(values) {
                column.values.push(v);
            }
            self.len += 1;
        } else {
            let slot = self.head;
            self.times[slot] = t;
            for (column, &v) in self.columns.iter_mut().zip(values) {
                column.values[slot] = v;
            }
            self.head += 1;
            if self.head == self.capacity {
                self.head = 0;
            }
            self.start += 1;
        }
        let end = self.end();
        if end.is_multiple_of(BLOCK) && end - BLOCK >= self.start {
            self.summarize_small(end / BLOCK - 1);
        }
        if end.is_multiple_of(BIG_BLOCK) && end - BIG_BLOCK >= self.start {
            self.summarize_big(end / BIG_BLOCK - 1);
        }
        Ok(())
    }

    /// Time of row `i` (0 = oldest retained row).
    pub fn time(&self, i: usize) -> Option<f64> {
        (i < self.len).then(|| self.t(i))
    }

    /// Value of `channel` in row `i` (0 = oldest); NaN when the row has no sample of it.
    pub fn value(&self, i: usize, channel: usize) -> Option<f64> {
        let column = self.columns.get(channel)?;
        (i < self.len).then(|| column.values[self.slot(i)])
    }

    pub fn first_time(&self) -> Option<f64> {
        self.time(0)
    }

    pub fn last_time(&self) -> Option<f64> {
        self.len.checked_sub(1).map(|i| self.t(i))
    }

    /// The rows with `from <= t <= to`.
    pub fn range(&self, from: f64, to: f64) -> Range<usize> {
        if from.is_nan() || to.is_nan() {
            return 0..0;
        }
        let lo = self.partition(0, self.len, |t| t < from);
        let hi = self.partition(lo, self.len, |t| t <= to);
        lo..hi
    }

    /// The newest row with a time at or before `t` (for a cursor read-out).
    pub fn index_at_or_before(&self, t: f64) -> Option<usize> {
        self.partition(0, self.len, |x| x <= t).checked_sub(1)
    }

    /// The newest sample `(t, v)` of `channel`, looking back at most [`LATEST_LOOKBACK`] rows.
    pub fn latest(&self, channel: usize) -> Option<(f64, f64)> {
        let column = self.columns.get(channel)?;
        let i = self.prev_sample(column, self.len, self.len.saturating_sub(LATEST_LOOKBACK))?;
        Some((self.t(i), column.values[self.slot(i)]))
    }

    /// Bytes held by the buffers (their capacity, summaries included).
    pub fn memory_bytes(&self) -> usize {
        let f = size_of::<f64>();
        let s = size_of::<Summary>();
        self.times.capacity() * f
            + self
                .columns
                .iter()
                .map(|c| c.values.capacity() * f + (c.small.capacity() + c.big.capacity()) * s)
                .sum::<usize>()
    }

    /// Min/max decimation of one channel over [from, to] into `columns` equal time spans: for
    /// each span with samples, its first, min, max and last samples in time order (duplicates
    /// removed), plus the last sample before `from` and the first after `to` where they exist
    /// (so a line reaches the edges). NaN samples are skipped. Points are `[t, v]` in
    /// non-decreasing time order and each lies inside its span. Every span's true min and max
    /// value appear exactly (the earliest sample holding it).
    pub fn decimate(&self, channel: usize, from: f64, to: f64, columns: usize) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        self.decimate_into(channel, from, to, columns, &mut out);
        out
    }

    /// [`Ring::decimate`] into `out` (cleared first), reusing its allocation.
    pub fn decimate_into(
        &self,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
        out: &mut Vec<[f64; 2]>,
    ) {
        out.clear();
        let Some(column) = self.columns.get(channel) else {
            return;
        };
        let Some(window) = self.window(from, to) else {
            return;
        };
        if columns == 0 {
            return;
        }
        let point = |i: usize| [self.t(i), column.values[self.slot(i)]];
        let rows = self.range(window.from, window.to);
        if let Some(i) = self.prev_sample(column, rows.start, 0) {
            out.push(point(i));
        }
        self.for_each_span(column, rows.clone(), window, columns, |m: &MinMax| {
            let mut idx = [m.first, m.imin, m.imax, m.last];
            idx.sort_unstable();
            let mut previous = None;
            for i in idx {
                if previous != Some(i) {
                    out.push(point(i));
                    previous = Some(i);
                }
            }
        });
        if let Some(i) = self.next_sample(column, rows.end, self.len) {
            out.push(point(i));
        }
    }

    /// Decimation on a grid that does not move with the view: column `k` holds the rows
    /// with `k·width <= t < (k+1)·width`. For each non-empty column in `k0..=k1`,
    /// `emit(k, points)` with its first, lowest, highest and last samples in time order, as
    /// [`Ring::decimate`] gives a span's. A view that slides keeps its columns, so only
    /// the new ones need decimating ([`Decimations`] keeps the others).
    pub fn decimate_grid(
        &self,
        channel: usize,
        columns: (i64, i64),
        width: f64,
        mut emit: impl FnMut(i64, &[[f64; 2]]),
    ) {
        let Some(column) = self.columns.get(channel) else {
            return;
        };
        let point = |i: usize| [self.t(i), column.values[self.slot(i)]];
        self.grid_spans(column, columns, width, |k, m: &MinMax| {
            let mut idx = [m.first, m.imin, m.imax, m.last];
            idx.sort_unstable();
            let mut points = [[0.0; 2]; 4];
            let mut n = 0;
            for (j, i) in idx.into_iter().enumerate() {
                if j == 0 || idx[j - 1] != i {
                    points[n] = point(i);
                    n += 1;
                }
            }
            emit(k, &points[..n]);
        });
    }

    /// [`Ring::decimate_bits`] on the grid of [`Ring::decimate_grid`]: each non-empty
    /// column's bits, with its number.
    pub fn decimate_bits_grid(
        &self,
        channel: usize,
        columns: (i64, i64),
        width: f64,
        mut emit: impl FnMut(i64, BitSpan),
    ) {
        let Some(column) = self.columns.get(channel) else {
            return;
        };
        self.grid_spans(column, columns, width, |k, b: &Bits| {
            emit(
                k,
                BitSpan {
                    t0: self.t(b.first),
                    t1: self.t(b.last),
                    any: b.any,
                    all: b.all,
                },
            );
        });
    }

    /// What each non-empty grid column `k0..=k1` of `width` held, with its number.
    fn grid_spans<A: Fold>(
        &self,
        column: &Column,
        (k0, k1): (i64, i64),
        width: f64,
        mut emit: impl FnMut(i64, &A),
    ) {
        if !(width > 0.0 && width.is_finite()) || k1 < k0 {
            return;
        }
        let count = (k1 - k0 + 1) as usize;
        let edge = |k: usize| (k0 + k as i64) as f64 * width;
        let lo = self.partition(0, self.len, |t| t < edge(0));
        let hi = self.partition(lo, self.len, |t| t < edge(count));
        self.spans(
            column,
            lo..hi,
            count,
            edge,
            |t| ((t / width).floor() as i64 - k0).max(0) as usize,
            |k, acc: &A| emit(k0 + k as i64, acc),
        );
    }

    /// The newest sample of `channel` before time `t`, and the oldest at or after `u`: the
    /// neighbours that carry a decimated line to the edges of its span.
    pub fn neighbours(
        &self,
        channel: usize,
        t: f64,
        u: f64,
    ) -> (Option<[f64; 2]>, Option<[f64; 2]>) {
        let Some(column) = self.columns.get(channel) else {
            return (None, None);
        };
        let point = |i: usize| [self.t(i), column.values[self.slot(i)]];
        let before = self.partition(0, self.len, |x| x < t);
        let after = self.partition(0, self.len, |x| x < u);
        (
            self.prev_sample(column, before, 0).map(point),
            self.next_sample(column, after, self.len).map(point),
        )
    }

    /// Per span of a bit channel (status word, digital inputs), which bits were ever 1
    /// (`any`) and always 1 (`all`) among its non-NaN samples. Spans without samples are left
    /// out; values are read as `u32` (saturating, so negative values read as 0).
    pub fn decimate_bits(
        &self,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
    ) -> Vec<BitSpan> {
        let mut out = Vec::new();
        let Some(column) = self.columns.get(channel) else {
            return out;
        };
        let Some(window) = self.window(from, to) else {
            return out;
        };
        if columns == 0 {
            return out;
        }
        let rows = self.range(window.from, window.to);
        self.for_each_span(column, rows, window, columns, |b: &Bits| {
            out.push(BitSpan {
                t0: self.t(b.first),
                t1: self.t(b.last),
                any: b.any,
                all: b.all,
            });
        });
        out
    }
}

/// The (finite) time window of a decimation.
#[derive(Clone, Copy)]
struct Window {
    from: f64,
    to: f64,
}
