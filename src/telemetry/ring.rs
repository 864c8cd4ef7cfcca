//! A bounded, columnar history of sample rows for the live plots.
//!
//! Each row is a time (seconds since connect) and one `f64` per channel; NaN means "no
//! sample of this channel in this row". The [`Ring`] keeps at most `capacity` rows and drops
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

/// Summary of one block of one channel, ignoring NaN samples. Offsets are row offsets from
/// the block's first row, so the points they name keep their exact times.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Summary {
    min: f64,
    max: f64,
    any: u32,
    all: u32,
    min_off: u16,
    max_off: u16,
    first_off: u16,
    last_off: u16,
}

impl Summary {
    /// A block without samples: `min > max`, and the identities of OR and AND.
    const EMPTY: Summary = Summary {
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
        any: 0,
        all: u32::MAX,
        min_off: 0,
        max_off: 0,
        first_off: 0,
        last_off: 0,
    };

    fn is_empty(&self) -> bool {
        self.min > self.max
    }

    /// Summary of raw rows (given as up to two slices because the ring may wrap).
    fn of_rows(parts: [&[f64]; 2]) -> Summary {
        let mut s = Summary::EMPTY;
        let mut seen = false;
        let values = parts[0].iter().chain(parts[1]);
        for (off, &v) in values.enumerate() {
            if v.is_nan() {
                continue;
            }
            let off = off as u16;
            if !seen {
                seen = true;
                s.min = v;
                s.max = v;
                s.min_off = off;
                s.max_off = off;
                s.first_off = off;
            } else if v < s.min {
                s.min = v;
                s.min_off = off;
            } else if v > s.max {
                s.max = v;
                s.max_off = off;
            }
            s.last_off = off;
            let bits = as_bits(v);
            s.any |= bits;
            s.all &= bits;
        }
        s
    }

    /// Summary of consecutive sub-blocks of `sub_len` rows each.
    fn of_blocks(subs: impl Iterator<Item = Summary>, sub_len: u64) -> Summary {
        let mut s = Summary::EMPTY;
        for (k, sub) in subs.enumerate() {
            if sub.is_empty() {
                continue;
            }
            let base = (k as u64 * sub_len) as u16;
            if s.is_empty() {
                s = sub;
                s.min_off += base;
                s.max_off += base;
                s.first_off += base;
            } else {
                if sub.min < s.min {
                    s.min = sub.min;
                    s.min_off = base + sub.min_off;
                }
                if sub.max > s.max {
                    s.max = sub.max;
                    s.max_off = base + sub.max_off;
                }
                s.any |= sub.any;
                s.all &= sub.all;
            }
            s.last_off = base + sub.last_off;
        }
        s
    }
}

/// A channel value read as an integer word (status word, digital inputs). The cast saturates:
/// negative values read as 0.
fn as_bits(v: f64) -> u32 {
    v as u32
}

/// One channel: its values (physically laid out like the time column) and block summaries.
#[derive(Clone)]
struct Column {
    values: Vec<f64>,
    small: Vec<Summary>,
    big: Vec<Summary>,
}

impl Column {
    fn new(rows: usize, reserved: usize, capacity: usize) -> Column {
        let mut values = Vec::with_capacity(reserved.max(rows));
        values.resize(rows, f64::NAN);
        Column {
            values,
            small: vec![Summary::EMPTY; small_slots(capacity)],
            big: vec![Summary::EMPTY; big_slots(capacity)],
        }
    }
}

/// Summary slots: enough that a block is not overwritten while any of it is retained.
fn small_slots(capacity: usize) -> usize {
    capacity / BLOCK as usize + 2
}

fn big_slots(capacity: usize) -> usize {
    capacity / BIG_BLOCK as usize + 2
}

/// The slot of a block among `slots`.
#[inline]
fn slot_of(block: u64, slots: usize) -> usize {
    (block % slots as u64) as usize
}

/// The bounded sample history: a shared time column and one value column per channel.
#[derive(Clone)]
pub struct Ring {
    capacity: usize,
    times: Vec<f64>,
    columns: Vec<Column>,
    /// Physical slot of the oldest row (0 until the ring is full).
    head: usize,
    len: usize,
    /// Absolute number of the oldest row; block summaries are keyed by it.
    start: u64,
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

/// What a decimation gathers from the rows of one span.
trait Fold: Default {
    /// Whether any non-NaN sample was folded in.
    fn seen(&self) -> bool;
    /// Fold in raw consecutive rows; `values[k]` is logical row `base + k`.
    fn raw(&mut self, base: usize, values: &[f64]);
    fn block(&mut self, base: usize, s: &Summary);
}

/// Min and max of `values` ignoring NaN (`min > max` when there are none). Four lanes of
/// `if v < lo { v } else { lo }`, which compiles to packed min/max instructions.
#[inline]
fn min_max(values: &[f64]) -> (f64, f64) {
    let mut lo = [f64::INFINITY; 4];
    let mut hi = [f64::NEG_INFINITY; 4];
    let chunks = values.chunks_exact(4);
    let rest = chunks.remainder();
    for chunk in chunks {
        for k in 0..4 {
            lo[k] = if chunk[k] < lo[k] { chunk[k] } else { lo[k] };
            hi[k] = if chunk[k] > hi[k] { chunk[k] } else { hi[k] };
        }
    }
    for (k, &v) in rest.iter().enumerate() {
        lo[k] = if v < lo[k] { v } else { lo[k] };
        hi[k] = if v > hi[k] { v } else { hi[k] };
    }
    let lo = lo
        .into_iter()
        .fold(f64::INFINITY, |a, b| if b < a { b } else { a });
    let hi = hi
        .into_iter()
        .fold(f64::NEG_INFINITY, |a, b| if b > a { b } else { a });
    (lo, hi)
}

/// Where a span's first, min, max and last samples are (logical row indices).
#[derive(Default)]
struct MinMax {
    seen: bool,
    first: usize,
    last: usize,
    min: f64,
    imin: usize,
    max: f64,
    imax: usize,
}

impl Fold for MinMax {
    fn seen(&self) -> bool {
        self.seen
    }

    #[inline]
    fn raw(&mut self, base: usize, values: &[f64]) {
        let (lo, hi) = min_max(values);
        if lo > hi {
            return; // only NaN
        }
        // Positions of the earliest min and max; the scans stop early.
        let at = |x: f64| base + values.iter().position(|&v| v == x).unwrap_or(0);
        if !self.seen {
            self.seen = true;
            self.first = base + values.iter().position(|v| !v.is_nan()).unwrap_or(0);
            self.min = lo;
            self.imin = at(lo);
            self.max = hi;
            self.imax = at(hi);
        } else {
            if lo < self.min {
                self.min = lo;
                self.imin = at(lo);
            }
            if hi > self.max {
                self.max = hi;
                self.imax = at(hi);
            }
        }
        self.last = base + values.iter().rposition(|v| !v.is_nan()).unwrap_or(0);
    }

    #[inline]
    fn block(&mut self, base: usize, s: &Summary) {
        if s.is_empty() {
            return;
        }
        if !self.seen {
            self.seen = true;
            self.first = base + usize::from(s.first_off);
            self.min = s.min;
            self.imin = base + usize::from(s.min_off);
            self.max = s.max;
            self.imax = base + usize::from(s.max_off);
        } else {
            if s.min < self.min {
                self.min = s.min;
                self.imin = base + usize::from(s.min_off);
            }
            if s.max > self.max {
                self.max = s.max;
                self.imax = base + usize::from(s.max_off);
            }
        }
        self.last = base + usize::from(s.last_off);
    }
}

/// A span's first and last samples and the OR and AND of its samples as bits.
struct Bits {
    seen: bool,
    first: usize,
    last: usize,
    any: u32,
    all: u32,
}

impl Default for Bits {
    fn default() -> Bits {
        Bits {
            seen: false,
            first: 0,
            last: 0,
            any: 0,
            all: u32::MAX,
        }
    }
}

impl Fold for Bits {
    fn seen(&self) -> bool {
        self.seen
    }

    #[inline]
    fn raw(&mut self, base: usize, values: &[f64]) {
        for (k, &v) in values.iter().enumerate() {
            if v.is_nan() {
                continue;
            }
            if !self.seen {
                self.seen = true;
                self.first = base + k;
            }
            self.last = base + k;
            let bits = as_bits(v);
            self.any |= bits;
            self.all &= bits;
        }
    }

    #[inline]
    fn block(&mut self, base: usize, s: &Summary) {
        if s.is_empty() {
            return;
        }
        if !self.seen {
            self.seen = true;
            self.first = base + usize::from(s.first_off);
        }
        self.last = base + usize::from(s.last_off);
        self.any |= s.any;
        self.all &= s.all;
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
        for block in 0..keep as u64 / BLOCK {
            self.summarize_small(block);
        }
        for block in 0..keep as u64 / BIG_BLOCK {
            self.summarize_big(block);
        }
    }

    /// Add a channel; existing rows hold NaN in it. Returns its index.
    pub fn add_channel(&mut self) -> usize {
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

    // --- internals ---

    /// Absolute number of the row after the newest.
    fn end(&self) -> u64 {
        self.start + self.len as u64
    }

    /// Physical slot of logical row `i` (0 = oldest).
    #[inline]
    fn slot(&self, i: usize) -> usize {
        let s = self.head + i;
        if s >= self.capacity {
            s - self.capacity
        } else {
            s
        }
    }

    #[inline]
    fn t(&self, i: usize) -> f64 {
        self.times[self.slot(i)]
    }

    /// Logical rows `lo..hi` of a physical buffer as up to two slices.
    fn parts<'a>(&self, buffer: &'a [f64], lo: usize, hi: usize) -> [&'a [f64]; 2] {
        if lo >= hi {
            return [&[], &[]];
        }
        let a = self.slot(lo);
        let n = hi - lo;
        if a + n <= buffer.len() {
            [&buffer[a..a + n], &[]]
        } else {
            let first = buffer.len() - a;
            [&buffer[a..], &buffer[..n - first]]
        }
    }

    /// The first logical row in `lo..hi` whose time does not satisfy `pred` (times sorted).
    fn partition(&self, mut lo: usize, mut hi: usize, pred: impl Fn(f64) -> bool) -> usize {
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if pred(self.t(mid)) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The first row in `lo..hi` with time `>= bound`, searching outwards from `lo` (cheap
    /// when it is near, as for the next span's first row).
    fn gallop(&self, lo: usize, hi: usize, bound: f64) -> usize {
        let mut low = lo;
        let mut step = 1;
        while low < hi {
            let probe = (low + step).min(hi) - 1;
            if self.t(probe) < bound {
                low = probe + 1;
                step *= 2;
            } else {
                return self.partition(low, probe, |t| t < bound);
            }
        }
        low
    }

    /// Like [`Ring::gallop`], searching outwards from a guess in `lo..=hi` (the previous
    /// span's row count predicts the next one's well when the rate is steady).
    fn gallop_near(&self, lo: usize, hi: usize, guess: usize, bound: f64) -> usize {
        let guess = guess.clamp(lo, hi);
        if guess < hi && self.t(guess) < bound {
            return self.gallop(guess + 1, hi, bound);
        }
        // The answer is at or before `guess`.
        let mut high = guess;
        let mut step = 1;
        while high > lo {
            let probe = high.saturating_sub(step).max(lo);
            if self.t(probe) >= bound {
                high = probe;
                step *= 2;
            } else {
                return self.partition(probe + 1, high, |t| t < bound);
            }
        }
        high
    }

    /// Grow the buffers (while filling) by doubling, never past the capacity.
    fn grow(&mut self) {
        let len = self.times.len();
        let more = (self.capacity - len).min(len.max(1024));
        self.times.reserve_exact(more);
        for column in &mut self.columns {
            let extra = self.times.capacity() - column.values.len();
            column.values.reserve_exact(extra);
        }
    }

    /// Summarize small block `block` (absolute), which must be complete and retained.
    fn summarize_small(&mut self, block: u64) {
        let lo = (block * BLOCK - self.start) as usize;
        let hi = lo + BLOCK as usize;
        for c in 0..self.columns.len() {
            let summary = Summary::of_rows(self.parts(&self.columns[c].values, lo, hi));
            let column = &mut self.columns[c];
            let slot = slot_of(block, column.small.len());
            column.small[slot] = summary;
        }
    }

    /// Summarize big block `block` (absolute) from its small blocks.
    fn summarize_big(&mut self, block: u64) {
        let per = BIG_BLOCK / BLOCK;
        for column in &mut self.columns {
            let slots = column.small.len();
            let small = &column.small;
            let subs = (block * per..(block + 1) * per).map(|b| small[slot_of(b, slots)]);
            let summary = Summary::of_blocks(subs, BLOCK);
            let slot = slot_of(block, column.big.len());
            column.big[slot] = summary;
        }
    }

    /// Fold logical rows `i0..i1` of `column` into `acc`, using the summaries of the whole
    /// blocks inside and scanning the rest raw.
    #[inline]
    fn fold<A: Fold>(&self, column: &Column, i0: usize, i1: usize, acc: &mut A) {
        let a0 = self.start + i0 as u64;
        let a1 = self.start + i1 as u64;
        let head_end = a1.min(a0.next_multiple_of(BLOCK));
        self.fold_raw(column, i0, (head_end - self.start) as usize, acc);
        let mut a = head_end;
        // The small block's slot, stepped along rather than divided out each time.
        let slots = column.small.len();
        let mut slot = slot_of(a / BLOCK, slots);
        while a + BLOCK <= a1 {
            let base = (a - self.start) as usize;
            if a.is_multiple_of(BIG_BLOCK) && a + BIG_BLOCK <= a1 {
                acc.block(base, &column.big[slot_of(a / BIG_BLOCK, column.big.len())]);
                a += BIG_BLOCK;
                slot = slot_of(a / BLOCK, slots);
            } else {
                acc.block(base, &column.small[slot]);
                a += BLOCK;
                slot += 1;
                if slot == slots {
                    slot = 0;
                }
            }
        }
        self.fold_raw(column, (a - self.start) as usize, i1, acc);
    }

    #[inline]
    fn fold_raw<A: Fold>(&self, column: &Column, lo: usize, hi: usize, acc: &mut A) {
        let [p0, p1] = self.parts(&column.values, lo, hi);
        if !p0.is_empty() {
            acc.raw(lo, p0);
        }
        if !p1.is_empty() {
            acc.raw(lo + p0.len(), p1);
        }
    }

    /// The newest non-NaN row of `column` in `lo..hi`.
    fn prev_sample(&self, column: &Column, hi: usize, lo: usize) -> Option<usize> {
        let low = self.start + lo as u64;
        let mut a = self.start + hi as u64;
        while a > low {
            let summary = if a.is_multiple_of(BIG_BLOCK) && a - BIG_BLOCK >= low {
                Some((
                    BIG_BLOCK,
                    column.big[slot_of(a / BIG_BLOCK - 1, column.big.len())],
                ))
            } else if a.is_multiple_of(BLOCK) && a - BLOCK >= low {
                Some((
                    BLOCK,
                    column.small[slot_of(a / BLOCK - 1, column.small.len())],
                ))
            } else {
                None
            };
            if let Some((size, s)) = summary {
                a -= size;
                if !s.is_empty() {
                    return Some((a - self.start) as usize + usize::from(s.last_off));
                }
            } else {
                a -= 1;
                let i = (a - self.start) as usize;
                if !column.values[self.slot(i)].is_nan() {
                    return Some(i);
                }
            }
        }
        None
    }

    /// The oldest non-NaN row of `column` in `lo..hi`.
    fn next_sample(&self, column: &Column, lo: usize, hi: usize) -> Option<usize> {
        let high = self.start + hi as u64;
        let mut a = self.start + lo as u64;
        while a < high {
            let i = (a - self.start) as usize;
            let summary = if a.is_multiple_of(BIG_BLOCK) && a + BIG_BLOCK <= high {
                Some((
                    BIG_BLOCK,
                    column.big[slot_of(a / BIG_BLOCK, column.big.len())],
                ))
            } else if a.is_multiple_of(BLOCK) && a + BLOCK <= high {
                Some((BLOCK, column.small[slot_of(a / BLOCK, column.small.len())]))
            } else {
                None
            };
            if let Some((size, s)) = summary {
                if !s.is_empty() {
                    return Some(i + usize::from(s.first_off));
                }
                a += size;
            } else {
                if !column.values[self.slot(i)].is_nan() {
                    return Some(i);
                }
                a += 1;
            }
        }
        None
    }

    /// The time window to decimate, with infinite ends clamped to the rows held; `None` when
    /// it is empty or NaN.
    fn window(&self, from: f64, to: f64) -> Option<Window> {
        let (first, last) = (self.first_time()?, self.last_time()?);
        let from = if from == f64::NEG_INFINITY {
            first
        } else {
            from
        };
        let to = if to == f64::INFINITY { last } else { to };
        (from.is_finite() && to.is_finite() && from <= to).then_some(Window { from, to })
    }

    /// Split rows (all inside `window`) into `columns` equal time spans and call `emit` with
    /// what each non-empty span held. Span `k` holds `edge(k) <= t < edge(k + 1)`; the last
    /// one also holds `t == to`.
    fn for_each_span<A: Fold>(
        &self,
        column: &Column,
        rows: Range<usize>,
        window: Window,
        columns: usize,
        mut emit: impl FnMut(&A),
    ) {
        let width = window.to - window.from;
        // A zero-width window is a single span.
        let columns = if width > 0.0 { columns } else { 1 };
        let n = columns as f64;
        let edge = |k: usize| window.from + width * (k as f64 / n);
        let mut i = rows.start;
        let mut previous = 1;
        while i < rows.end {
            let t = self.t(i);
            let guess = if width > 0.0 {
                ((t - window.from) / width * n) as usize
            } else {
                0
            };
            let mut k = guess.min(columns - 1);
            while k + 1 < columns && t >= edge(k + 1) {
                k += 1;
            }
            while k > 0 && t < edge(k) {
                k -= 1;
            }
            let end = if k + 1 < columns {
                self.gallop_near(i + 1, rows.end, i + previous, edge(k + 1))
            } else {
                rows.end
            };
            let mut acc = A::default();
            self.fold(column, i, end, &mut acc);
            // Spans of only NaN fold to nothing.
            if acc.seen() {
                emit(&acc);
            }
            previous = end - i;
            i = end;
        }
    }
}

/// The (finite) time window of a decimation.
#[derive(Clone, Copy)]
struct Window {
    from: f64,
    to: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A small deterministic generator for test data (xorshift64*).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }

        /// Uniform in [0, 1).
        fn unit(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }

        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    /// The retained rows as a plain list, for reference answers.
    fn model(ring: &Ring, channel: usize) -> Vec<(f64, f64)> {
        (0..ring.len())
            .map(|i| (ring.time(i).unwrap(), ring.value(i, channel).unwrap()))
            .collect()
    }

    fn reference_window(rows: &[(f64, f64)], from: f64, to: f64) -> Option<(f64, f64)> {
        let first = rows.first()?.0;
        let last = rows.last()?.0;
        let from = if from == f64::NEG_INFINITY {
            first
        } else {
            from
        };
        let to = if to == f64::INFINITY { last } else { to };
        (from.is_finite() && to.is_finite() && from <= to).then_some((from, to))
    }

    /// Which span each sample in [from, to] falls in, by comparing against every edge.
    fn reference_spans(rows: &[(f64, f64)], from: f64, to: f64, columns: usize) -> Vec<Vec<usize>> {
        let width = to - from;
        let columns = if width > 0.0 { columns } else { 1 };
        let edge = |k: usize| from + width * (k as f64 / columns as f64);
        let mut spans = vec![Vec::new(); columns];
        for (i, &(t, v)) in rows.iter().enumerate() {
            if t < from || t > to || v.is_nan() {
                continue;
            }
            let k = (0..columns)
                .rev()
                .find(|&k| t >= edge(k))
                .expect("t >= from = edge(0)");
            if k + 1 < columns {
                assert!(t < edge(k + 1));
            }
            spans[k].push(i);
        }
        spans
    }

    fn reference_decimate(
        rows: &[(f64, f64)],
        from: f64,
        to: f64,
        columns: usize,
    ) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        let Some((from, to)) = reference_window(rows, from, to) else {
            return out;
        };
        if columns == 0 {
            return out;
        }
        if let Some(&(t, v)) = rows.iter().rev().find(|(t, v)| *t < from && !v.is_nan()) {
            out.push([t, v]);
        }
        for span in reference_spans(rows, from, to, columns) {
            let Some(&first) = span.first() else {
                continue;
            };
            let last = *span.last().unwrap();
            let mut imin = first;
            let mut imax = first;
            for &i in &span {
                if rows[i].1 < rows[imin].1 {
                    imin = i;
                }
                if rows[i].1 > rows[imax].1 {
                    imax = i;
                }
            }
            let mut idx = vec![first, imin, imax, last];
            idx.sort_unstable();
            idx.dedup();
            out.extend(idx.iter().map(|&i| [rows[i].0, rows[i].1]));
        }
        if let Some(&(t, v)) = rows.iter().find(|(t, v)| *t > to && !v.is_nan()) {
            out.push([t, v]);
        }
        out
    }

    fn reference_bits(rows: &[(f64, f64)], from: f64, to: f64, columns: usize) -> Vec<BitSpan> {
        let Some((from, to)) = reference_window(rows, from, to) else {
            return Vec::new();
        };
        if columns == 0 {
            return Vec::new();
        }
        reference_spans(rows, from, to, columns)
            .into_iter()
            .filter(|span| !span.is_empty())
            .map(|span| BitSpan {
                t0: rows[span[0]].0,
                t1: rows[*span.last().unwrap()].0,
                any: span.iter().fold(0, |a, &i| a | rows[i].1 as u32),
                all: span.iter().fold(u32::MAX, |a, &i| a & rows[i].1 as u32),
            })
            .collect()
    }

    /// Fill a 2-channel ring: channel 0 analog (sine, noise, spikes, NaN gaps), channel 1 an
    /// integer word. `nan` is the chance a value is missing; `repeat` the chance t repeats.
    fn fill(ring: &mut Ring, rng: &mut Rng, rows: usize, nan: f64, repeat: f64) {
        let mut t = ring.last_time().unwrap_or(0.0);
        for _ in 0..rows {
            if rng.unit() >= repeat {
                t += 0.001 * (1.0 + rng.unit());
            }
            let mut v = (t * 3.0).sin() * 100.0 + rng.unit();
            if rng.below(500) == 0 {
                v = 1e4 * (rng.unit() - 0.5);
            }
            let word = rng.below(16) as f64;
            let a = if rng.unit() < nan { f64::NAN } else { v };
            let b = if rng.unit() < nan { f64::NAN } else { word };
            ring.push(t, &[a, b]).unwrap();
        }
    }

    fn check_queries(ring: &Ring, rng: &mut Rng) {
        let rows = model(ring, 0);
        let words = model(ring, 1);
        let (first, last) = (
            ring.first_time().unwrap_or(0.0),
            ring.last_time().unwrap_or(1.0),
        );
        let span = (last - first).max(1e-3);
        let mut out = Vec::new();
        for q in 0..12 {
            let (from, to) = match q {
                0 => (f64::NEG_INFINITY, f64::INFINITY),
                1 => (first, last),
                2 => (first, first),
                _ => {
                    let a = first - 0.1 * span + rng.unit() * 1.2 * span;
                    let b = a + rng.unit() * span;
                    (a, b)
                }
            };
            let columns = [1, 3, 17, 200, 1600][rng.below(5) as usize];
            let got = ring.decimate(0, from, to, columns);
            assert_eq!(
                got,
                reference_decimate(&rows, from, to, columns),
                "{from}..{to} /{columns}"
            );
            ring.decimate_into(0, from, to, columns, &mut out);
            assert_eq!(out, got);
            assert!(got.windows(2).all(|w| w[0][0] <= w[1][0]));
            assert_eq!(
                ring.decimate_bits(1, from, to, columns),
                reference_bits(&words, from, to, columns)
            );
            let range = ring.range(from, to);
            let expected: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i].0 >= from && rows[i].0 <= to)
                .collect();
            assert_eq!(range.collect::<Vec<_>>(), expected);
            let before = rows.iter().rposition(|r| r.0 <= from);
            assert_eq!(ring.index_at_or_before(from), before);
        }
        let latest = rows
            .iter()
            .rev()
            .take(LATEST_LOOKBACK)
            .find(|r| !r.1.is_nan())
            .copied();
        assert_eq!(ring.latest(0), latest);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn decimation_matches_a_plain_scan(
            seed in 1u64..u64::MAX,
            capacity in prop_oneof![1usize..200, 200usize..9000],
            fill_factor in 0.0f64..3.0,
            resize in prop::option::of(1usize..9000),
            nan in prop_oneof![Just(0.0), Just(0.3), Just(0.97), Just(1.0)],
            repeat in prop_oneof![Just(0.0), Just(0.2)],
        ) {
            let mut rng = Rng(seed);
            let mut ring = Ring::new(capacity, 2);
            fill(&mut ring, &mut rng, (capacity as f64 * fill_factor) as usize, nan, repeat);
            check_queries(&ring, &mut rng);
            if let Some(c) = resize {
                ring.set_capacity(c);
                check_queries(&ring, &mut rng);
                fill(&mut ring, &mut rng, (c as f64 * fill_factor) as usize, nan, repeat);
                check_queries(&ring, &mut rng);
            }
        }
    }

    #[test]
    fn a_big_wrapped_ring_decimates_like_a_plain_scan() {
        let mut rng = Rng(7);
        // Not a multiple of the block sizes, wrapped several times.
        let mut ring = Ring::new(50_001, 2);
        fill(&mut ring, &mut rng, 173_333, 0.01, 0.01);
        check_queries(&ring, &mut rng);
        // Sparse channel: whole blocks without samples.
        fill(&mut ring, &mut rng, 30_000, 0.999, 0.0);
        check_queries(&ring, &mut rng);
    }

    #[test]
    fn sparse_samples_inside_big_blocks() {
        // Samples only now and then, so big blocks start with empty small blocks; values run
        // up or down through each big block, so its min or max is its first sample.
        let mut rng = Rng(3);
        let mut ring = Ring::new(30_000, 2);
        let mut offset = 0.0;
        for i in 0..45_000 {
            if i % 4096 == 0 {
                offset = rng.unit() * 5000.0;
            }
            let slope = if (i / 4096) % 2 == 0 { 1.0 } else { -1.0 };
            let (a, b) = if i % 700 == 650 {
                (
                    offset + slope * f64::from(i % 4096),
                    rng.below(1 << 12) as f64,
                )
            } else {
                (f64::NAN, f64::NAN)
            };
            ring.push(f64::from(i), &[a, b]).unwrap();
        }
        let rows = model(&ring, 0);
        let words = model(&ring, 1);
        let mut windows = vec![(15_000.0, 45_000.0), (20_480.0, 40_960.0)];
        for _ in 0..100 {
            let from = 14_000.0 + rng.unit() * 20_000.0;
            windows.push((from, from + 5_000.0 + rng.unit() * 25_000.0));
        }
        for columns in [1, 2, 3, 5] {
            for &(from, to) in &windows {
                assert_eq!(
                    ring.decimate(0, from, to, columns),
                    reference_decimate(&rows, from, to, columns)
                );
                assert_eq!(
                    ring.decimate_bits(1, from, to, columns),
                    reference_bits(&words, from, to, columns)
                );
            }
        }
        assert_eq!(
            ring.latest(0),
            rows.iter().rev().find(|r| !r.1.is_nan()).copied()
        );
    }

    #[test]
    fn push_keeps_rows_in_order_and_drops_the_oldest() {
        let mut ring = Ring::new(3, 2);
        assert!(ring.is_empty());
        assert_eq!(ring.first_time(), None);
        for i in 0..5 {
            ring.push(f64::from(i), &[f64::from(i * 10), f64::NAN])
                .unwrap();
        }
        assert_eq!(ring.len(), 3);
        assert_eq!(ring.capacity(), 3);
        assert_eq!(ring.channels(), 2);
        assert_eq!(ring.time(0), Some(2.0));
        assert_eq!(ring.time(2), Some(4.0));
        assert_eq!(ring.time(3), None);
        assert_eq!(ring.value(1, 0), Some(30.0));
        assert!(ring.value(1, 1).unwrap().is_nan());
        assert_eq!(ring.value(1, 2), None);
        assert_eq!(ring.value(3, 0), None);
        assert_eq!(
            (ring.first_time(), ring.last_time()),
            (Some(2.0), Some(4.0))
        );
        // Equal times are fine.
        ring.push(4.0, &[1.0, 2.0]).unwrap();
        assert_eq!(ring.time(2), Some(4.0));
    }

    #[test]
    fn push_refuses_bad_rows() {
        let mut ring = Ring::new(10, 1);
        ring.push(1.0, &[0.0]).unwrap();
        assert_eq!(
            ring.push(0.5, &[0.0]),
            Err(PushError::Backwards { t: 0.5, last: 1.0 })
        );
        assert!(matches!(ring.push(f64::NAN, &[0.0]), Err(PushError::NotFinite(t)) if t.is_nan()));
        assert_eq!(
            ring.push(f64::INFINITY, &[0.0]),
            Err(PushError::NotFinite(f64::INFINITY))
        );
        assert_eq!(
            ring.push(2.0, &[0.0, 1.0]),
            Err(PushError::Width {
                got: 2,
                expected: 1
            })
        );
        assert_eq!(ring.len(), 1);
        assert_eq!(
            PushError::Backwards { t: 0.5, last: 1.0 }.to_string(),
            "sample time 0.5 s is before the newest one (1 s)"
        );
    }

    #[test]
    fn capacity_is_at_least_one() {
        let mut ring = Ring::new(0, 1);
        assert_eq!(ring.capacity(), 1);
        ring.push(1.0, &[1.0]).unwrap();
        ring.push(2.0, &[2.0]).unwrap();
        assert_eq!(ring.len(), 1);
        assert_eq!(ring.latest(0), Some((2.0, 2.0)));
        ring.set_capacity(0);
        assert_eq!(ring.capacity(), 1);
    }

    #[test]
    fn memory_stops_growing_once_full() {
        let capacity = 10_000;
        let mut ring = Ring::new(capacity, 4);
        let mut full_bytes = None;
        for i in 0..10 * capacity {
            let t = i as f64 * 0.001;
            ring.push(t, &[t, -t, f64::NAN, 1.0]).unwrap();
            if ring.len() == capacity {
                let bytes = ring.memory_bytes();
                assert_eq!(*full_bytes.get_or_insert(bytes), bytes, "row {i}");
            }
        }
        assert_eq!(ring.len(), capacity);
        assert_eq!(ring.time(0), Some((9 * capacity) as f64 * 0.001));
        assert_eq!(ring.value(0, 0), ring.time(0));
        // Values, and summaries of about 1 byte per row and channel.
        let raw = capacity * 5 * 8;
        let bytes = ring.memory_bytes();
        assert!(bytes >= raw && bytes < raw + raw / 8, "{bytes}");
    }

    #[test]
    fn clear_keeps_channels_and_capacity() {
        let mut ring = Ring::new(100, 2);
        for i in 0..250 {
            ring.push(f64::from(i), &[1.0, 2.0]).unwrap();
        }
        let bytes = ring.memory_bytes();
        ring.clear();
        assert!(ring.is_empty());
        assert_eq!((ring.capacity(), ring.channels()), (100, 2));
        assert_eq!(ring.memory_bytes(), bytes);
        assert_eq!(ring.latest(0), None);
        assert!(ring.decimate(0, 0.0, 1e9, 10).is_empty());
        // A time before the old rows is fine after clearing.
        ring.push(0.5, &[3.0, 4.0]).unwrap();
        assert_eq!(ring.latest(1), Some((0.5, 4.0)));
    }

    #[test]
    fn set_capacity_keeps_the_newest_rows() {
        let mut ring = Ring::new(100, 1);
        for i in 0..150 {
            ring.push(f64::from(i), &[f64::from(i)]).unwrap();
        }
        ring.set_capacity(10);
        assert_eq!(ring.len(), 10);
        assert_eq!(ring.time(0), Some(140.0));
        ring.set_capacity(1000);
        assert_eq!(ring.len(), 10);
        ring.push(150.0, &[150.0]).unwrap();
        assert_eq!((ring.time(0), ring.time(10)), (Some(140.0), Some(150.0)));
        assert_eq!(ring.value(10, 0), Some(150.0));
    }

    #[test]
    fn add_channel_fills_existing_rows_with_nan() {
        let mut ring = Ring::new(200, 1);
        for i in 0..150 {
            ring.push(f64::from(i), &[1.0]).unwrap();
        }
        assert_eq!(ring.add_channel(), 1);
        assert!(ring.value(0, 1).unwrap().is_nan());
        assert_eq!(ring.latest(1), None);
        assert!(ring.decimate(1, 0.0, 200.0, 5).is_empty());
        assert_eq!(
            ring.push(150.0, &[1.0]),
            Err(PushError::Width {
                got: 1,
                expected: 2
            })
        );
        for i in 150..300 {
            ring.push(f64::from(i), &[1.0, f64::from(i)]).unwrap();
        }
        assert_eq!(ring.latest(1), Some((299.0, 299.0)));
        let rows = model(&ring, 1);
        assert_eq!(
            ring.decimate(1, 0.0, 300.0, 7),
            reference_decimate(&rows, 0.0, 300.0, 7)
        );
    }

    #[test]
    fn latest_looks_back_a_bounded_number_of_rows() {
        let mut ring = Ring::new(LATEST_LOOKBACK + 10, 1);
        ring.push(0.0, &[5.0]).unwrap();
        for i in 1..LATEST_LOOKBACK {
            ring.push(i as f64, &[f64::NAN]).unwrap();
        }
        assert_eq!(ring.latest(0), Some((0.0, 5.0)));
        ring.push(1e6, &[f64::NAN]).unwrap();
        assert_eq!(ring.latest(0), None);
        assert_eq!(ring.latest(1), None);
    }

    #[test]
    fn range_and_cursor_lookup() {
        let mut ring = Ring::new(10, 1);
        for t in [1.0, 2.0, 2.0, 3.0, 5.0] {
            ring.push(t, &[t]).unwrap();
        }
        assert_eq!(ring.range(2.0, 3.0), 1..4);
        assert_eq!(ring.range(0.0, 0.5), 0..0);
        assert_eq!(ring.range(4.0, 3.0).len(), 0);
        assert_eq!(ring.range(f64::NAN, 3.0).len(), 0);
        assert_eq!(ring.range(f64::NEG_INFINITY, f64::INFINITY), 0..5);
        assert_eq!(ring.index_at_or_before(0.5), None);
        assert_eq!(ring.index_at_or_before(2.0), Some(2));
        assert_eq!(ring.index_at_or_before(4.9), Some(3));
        assert_eq!(ring.index_at_or_before(9.0), Some(4));
    }

    #[test]
    fn decimation_keeps_a_single_sample_spike_and_reaches_the_edges() {
        let mut ring = Ring::new(100_000, 1);
        for i in 0..100_000 {
            let v = if i == 54_321 { 1e6 } else { 0.0 };
            ring.push(f64::from(i), &[v]).unwrap();
        }
        let points = ring.decimate(0, 1000.0, 90_000.0, 100);
        assert!(points.contains(&[54_321.0, 1e6]));
        assert_eq!(points.first(), Some(&[999.0, 0.0]));
        assert_eq!(points.last(), Some(&[90_001.0, 0.0]));
        assert!(points.len() <= 100 * 4 + 2);
        assert!(ring.decimate(0, 0.0, 10.0, 0).is_empty());
        assert!(ring.decimate(1, 0.0, 10.0, 10).is_empty());
        assert!(ring.decimate(0, 10.0, 0.0, 10).is_empty());
    }

    #[test]
    fn bits_report_any_and_all() {
        let mut ring = Ring::new(100, 1);
        for (i, w) in [0b01, 0b11, 0b01, 0b100].into_iter().enumerate() {
            ring.push(i as f64, &[f64::from(w)]).unwrap();
        }
        ring.push(4.0, &[f64::NAN]).unwrap();
        let spans = ring.decimate_bits(0, 0.0, 4.0, 2);
        assert_eq!(
            spans,
            vec![
                BitSpan {
                    t0: 0.0,
                    t1: 1.0,
                    any: 0b11,
                    all: 0b01
                },
                BitSpan {
                    t0: 2.0,
                    t1: 3.0,
                    any: 0b101,
                    all: 0
                },
            ]
        );
    }

    /// `cargo test --release -- --ignored --nocapture decimate_speed`
    #[test]
    #[ignore]
    fn decimate_speed() {
        let rows = 600_000;
        let channels = 8;
        let mut ring = Ring::new(rows, channels);
        let mut rng = Rng(42);
        let mut row = vec![0.0; channels];
        for i in 0..rows + 12_345 {
            let t = i as f64 * 0.001;
            for (c, v) in row.iter_mut().enumerate() {
                *v = (t * (1.0 + c as f64)).sin() * 1000.0 + rng.unit() * 10.0;
                if rng.below(100_000) == 0 {
                    *v = 1e5;
                }
            }
            ring.push(t, &row).unwrap();
        }
        let (from, to) = (ring.first_time().unwrap(), ring.last_time().unwrap());
        let mut out = Vec::new();
        let rounds = 50;
        let started = std::time::Instant::now();
        let mut points = 0;
        for _ in 0..rounds {
            for c in 0..channels {
                ring.decimate_into(c, from, to, 1600, &mut out);
                points += out.len();
            }
        }
        let per = started.elapsed().as_secs_f64() * 1e3 / (rounds * channels) as f64;
        let started = std::time::Instant::now();
        for _ in 0..rounds {
            for c in 0..channels {
                points += ring.decimate_bits(c, from, to, 1600).len();
            }
        }
        let per_bits = started.elapsed().as_secs_f64() * 1e3 / (rounds * channels) as f64;
        println!(
            "decimate: {per:.3} ms per channel ({rows} rows -> 1600 columns), \
             decimate_bits: {per_bits:.3} ms; {} MB held; {points} points",
            ring.memory_bytes() / 1_000_000
        );
    }
}
