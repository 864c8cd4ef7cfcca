//! What decimation folds a span of rows into: min/max points for traces, runs of bits for lanes.

use super::summary::{Summary, as_bits};

/// What a decimation gathers from the rows of one span.
pub(super) trait Fold: Default {
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
pub(super) struct MinMax {
    seen: bool,
    pub(super) first: usize,
    pub(super) last: usize,
    pub(super) min: f64,
    pub(super) imin: usize,
    pub(super) max: f64,
    pub(super) imax: usize,
}

impl MinMax {
    /// Fold in a span: the row of its first sample, its min and its max, each with the
    /// closure that finds its row. A closure runs only when its row is needed.
    #[inline]
    fn extend(
        &mut self,
        first: impl FnOnce() -> usize,
        (lo, imin): (f64, impl FnOnce() -> usize),
        (hi, imax): (f64, impl FnOnce() -> usize),
    ) {
        if !self.seen {
            self.seen = true;
            self.first = first();
            self.min = lo;
            self.imin = imin();
            self.max = hi;
            self.imax = imax();
        } else {
            if lo < self.min {
                self.min = lo;
                self.imin = imin();
            }
            if hi > self.max {
                self.max = hi;
                self.imax = imax();
            }
        }
    }
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
        self.extend(
            || base + values.iter().position(|v| !v.is_nan()).unwrap_or(0),
            (lo, || at(lo)),
            (hi, || at(hi)),
        );
        self.last = base + values.iter().rposition(|v| !v.is_nan()).unwrap_or(0);
    }

    #[inline]
    fn block(&mut self, base: usize, s: &Summary) {
        if s.is_empty() {
            return;
        }
        self.extend(
            || base + usize::from(s.first_off),
            (s.min, || base + usize::from(s.min_off)),
            (s.max, || base + usize::from(s.max_off)),
        );
        self.last = base + usize::from(s.last_off);
    }
}

/// A span's first and last samples and the OR and AND of its samples as bits.
pub(super) struct Bits {
    seen: bool,
    pub(super) first: usize,
    pub(super) last: usize,
    pub(super) any: u32,
    pub(super) all: u32,
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
