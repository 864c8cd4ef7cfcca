//! Row addressing, time search and the folding of spans from summaries and raw rows.

use std::ops::Range;

use super::fold::Fold;
use super::summary::{Column, Summary, slot_of};
use super::{BIG_BLOCK, BLOCK, Ring, Window};

impl Ring {
    // --- internals ---

    /// Absolute number of the row after the newest.
    pub(super) fn end(&self) -> u64 {
        self.start + self.len as u64
    }

    /// Physical slot of logical row `i` (0 = oldest).
    #[inline]
    pub(super) fn slot(&self, i: usize) -> usize {
        let s = self.head + i;
        if s >= self.capacity {
            s - self.capacity
        } else {
            s
        }
    }

    #[inline]
    pub(super) fn t(&self, i: usize) -> f64 {
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
    pub(super) fn partition(
        &self,
        mut lo: usize,
        mut hi: usize,
        pred: impl Fn(f64) -> bool,
    ) -> usize {
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
    pub(super) fn grow(&mut self) {
        let len = self.times.len();
        let more = (self.capacity - len).min(len.max(1024));
        self.times.reserve_exact(more);
        for column in &mut self.columns {
            let extra = self.times.capacity() - column.values.len();
            column.values.reserve_exact(extra);
        }
    }

    /// Summarize small block `block` (absolute), which must be complete and retained.
    pub(super) fn summarize_small(&mut self, block: u64) {
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
    pub(super) fn summarize_big(&mut self, block: u64) {
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
    pub(super) fn prev_sample(&self, column: &Column, hi: usize, lo: usize) -> Option<usize> {
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
    pub(super) fn next_sample(&self, column: &Column, lo: usize, hi: usize) -> Option<usize> {
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
    pub(super) fn window(&self, from: f64, to: f64) -> Option<Window> {
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
    pub(super) fn for_each_span<A: Fold>(
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
        self.spans(
            column,
            rows,
            columns,
            |k| window.from + width * (k as f64 / n),
            |t| {
                if width > 0.0 {
                    ((t - window.from) / width * n) as usize
                } else {
                    0
                }
            },
            |_, acc: &A| emit(acc),
        );
    }

    /// Split rows into `columns` spans at `edge(k)` (increasing; the rows lie within
    /// `edge(0)..edge(columns)`, the last span also takes any row at or past its end) and
    /// call `emit(k, what span k held)` for each non-empty span, in order. `guess` is a
    /// first guess of a time's span, corrected against the edges, so that a row on an edge
    /// always goes to the span the edges say.
    pub(super) fn spans<A: Fold>(
        &self,
        column: &Column,
        rows: Range<usize>,
        columns: usize,
        edge: impl Fn(usize) -> f64,
        guess: impl Fn(f64) -> usize,
        mut emit: impl FnMut(usize, &A),
    ) {
        if columns == 0 {
            return;
        }
        let mut i = rows.start;
        let mut previous = 1;
        while i < rows.end {
            let t = self.t(i);
            let mut k = guess(t).min(columns - 1);
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
                emit(k, &acc);
            }
            previous = end - i;
            i = end;
        }
    }
}
