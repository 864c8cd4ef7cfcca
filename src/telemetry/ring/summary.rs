//! Block summaries of one channel: min, max, OR, AND and the offsets that keep their points' times.

use super::{BIG_BLOCK, BLOCK};

/// Summary of one block of one channel, ignoring NaN samples. Offsets are row offsets from
/// the block's first row, so the points they name keep their exact times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Summary {
    pub(super) min: f64,
    pub(super) max: f64,
    pub(super) any: u32,
    pub(super) all: u32,
    pub(super) min_off: u16,
    pub(super) max_off: u16,
    pub(super) first_off: u16,
    pub(super) last_off: u16,
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

    pub(super) fn is_empty(&self) -> bool {
        self.min > self.max
    }

    /// Summary of raw rows (given as up to two slices because the ring may wrap).
    pub(super) fn of_rows(parts: [&[f64]; 2]) -> Summary {
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
    pub(super) fn of_blocks(subs: impl Iterator<Item = Summary>, sub_len: u64) -> Summary {
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
pub(super) fn as_bits(v: f64) -> u32 {
    v as u32
}

/// One channel: its values (physically laid out like the time column) and block summaries.
#[derive(Clone)]
pub(super) struct Column {
    pub(super) values: Vec<f64>,
    pub(super) small: Vec<Summary>,
    pub(super) big: Vec<Summary>,
}

impl Column {
    pub(super) fn new(rows: usize, reserved: usize, capacity: usize) -> Column {
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
pub(super) fn slot_of(block: u64, slots: usize) -> usize {
    (block % slots as u64) as usize
}
