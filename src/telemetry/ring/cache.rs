//! Decimations kept from one frame to the next: a plot that has not moved (paused, zoomed
//! into the past, a still history) draws the points it drew last frame instead of
//! decimating again. Each is keyed by its ring, channel, time span and width in columns;
//! it is reused while the ring's contents are the same (its [`Version`]), or while the only
//! rows added since lie after the span and none of the rows it was made of has gone.
//!
//! A view that moves (following the newest samples) is decimated on a grid of columns
//! fixed in time ([`Ring::decimate_grid`], the column width rounded down to a step of 1/64
//! of its power of two so that it stays the same from frame to frame) and the columns
//! the newest row has passed are kept: each frame decimates only the columns that came
//! into view or were still filling, not the whole span.

use std::collections::VecDeque;

use super::{BitSpan, Ring, Version};

/// What one decimation was asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Key {
    ring: u64,
    channel: usize,
    bits: bool,
    from: f64,
    to: f64,
    columns: usize,
}

#[derive(Debug, Clone)]
enum Made {
    /// The points as kept (maybe thinned for drawing), the times of the first and last
    /// point the decimation made, and the time up to which its columns reached (at or
    /// after the span's end).
    Points(Vec<[f64; 2]>, Option<(f64, f64)>, f64),
    Bits(Vec<BitSpan>),
}

#[derive(Debug, Clone)]
struct Entry {
    key: Key,
    /// The ring's version and newest time when this was made.
    version: Version,
    last: f64,
    made: Made,
    /// Asked for since the last [`Decimations::end_frame`].
    used: bool,
}

impl Entry {
    /// What was made is what `ring` would make now.
    fn still_holds(&self, ring: &Ring) -> bool {
        let now = ring.version();
        if now == self.version {
            return true;
        }
        if now.id != self.version.id || now.epoch != self.version.epoch {
            return false;
        }
        // Rows were appended (and maybe the oldest dropped): the new ones lie after the
        // span. The first point made (the sample before the span, or the span's first)
        // must still be there, with an older row before it (so no row of equal time went).
        let first = ring.first_time().unwrap_or(f64::INFINITY);
        if self.key.to >= self.last {
            return false;
        }
        match &self.made {
            // The last point must be the sample after the columns: one appended later
            // could otherwise become it, or fall into the last column.
            Made::Points(_, ends, until) => {
                ends.is_some_and(|(head, tail)| head > first && tail >= *until)
            }
            Made::Bits(spans) => spans.first().is_none_or(|s| s.t0 > first),
        }
    }
}

/// One column of a grid decimation: up to four points (none: the column has no sample),
/// and whether the newest row had passed the column's end when it was made (only then can
/// nothing change it but the ring dropping its rows).
#[derive(Debug, Clone, Copy)]
struct Cell {
    len: u8,
    points: [[f64; 2]; 4],
    complete: bool,
}

/// The columns of a moving view of one channel, on a fixed grid.
#[derive(Debug, Clone)]
struct Grid {
    ring: u64,
    epoch: u64,
    channel: usize,
    width: f64,
    /// Column `first + i` is `cells[i]` (`None`: not made).
    first: i64,
    cells: VecDeque<Option<Cell>>,
    /// The ring's oldest row time when last used: rows dropped since lie before the oldest
    /// now, and the columns they were in must be made again.
    oldest: f64,
    used: bool,
}

/// The width of a grid column for spans `width` wide: rounded down to a multiple of 1/64 of
/// its power of two, so that a view of the same length (its ends moving, their difference
/// changing in the last bits) keeps the same grid. At most 1.6 % narrower: a few more
/// columns than asked for.
fn grid_width(width: f64) -> f64 {
    if !(width > 0.0 && width.is_finite()) {
        return f64::NAN;
    }
    let step = 2f64.powi(width.log2().floor() as i32) / 64.0;
    ((width / step).floor() * step).max(step)
}

/// The decimations of the last frames, for reuse.
#[derive(Debug, Clone, Default)]
pub struct Decimations {
    entries: Vec<Entry>,
    grids: Vec<Grid>,
    /// Decimations reused and made since this was created (for tests and measurements).
    pub reused: u64,
    pub made: u64,
    /// Grid columns decimated since this was created (the rest were kept).
    pub columns_made: u64,
}

impl Decimations {
    /// [`Ring::decimate`], reused when it still holds.
    pub fn points(
        &mut self,
        ring: &Ring,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
    ) -> Vec<[f64; 2]> {
        self.points_with(ring, channel, from, to, columns, |points| points)
    }

    /// [`Ring::decimate`] as `finish` leaves it (thinned for drawing, say), both kept and
    /// reused while the decimation still holds.
    pub fn points_with(
        &mut self,
        ring: &Ring,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
        finish: impl FnOnce(Vec<[f64; 2]>) -> Vec<[f64; 2]>,
    ) -> Vec<[f64; 2]> {
        let key = Key {
            ring: ring.version().id,
            channel,
            bits: false,
            from,
            to,
            columns,
        };
        if let Some(Made::Points(points, _, _)) = self.find(ring, key) {
            return points.clone();
        }
        let (points, until) = self.on_grid(ring, channel, from, to, columns);
        let ends = points.first().zip(points.last()).map(|(a, b)| (a[0], b[0]));
        let points = finish(points);
        self.keep(ring, key, Made::Points(points.clone(), ends, until));
        points
    }

    /// The decimation of `from..=to` on the grid of its column width, the columns kept from
    /// earlier frames reused; and the time its columns reach to. A span that cannot have a
    /// grid (empty, not finite) is decimated as asked.
    fn on_grid(
        &mut self,
        ring: &Ring,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
    ) -> (Vec<[f64; 2]>, f64) {
        let width = grid_width((to - from) / columns.max(1) as f64);
        let (k0, k1) = ((from / width).floor(), (to / width).floor());
        if !(k0.is_finite() && k1.is_finite()) || k1 - k0 > 4.0 * columns as f64 + 4.0 {
            return (ring.decimate(channel, from, to, columns), to);
        }
        let (k0, k1) = (k0 as i64, k1 as i64);
        let version = ring.version();
        let at = self
            .grids
            .iter()
            .position(|g| g.ring == version.id && g.channel == channel && g.width == width);
        let grid = match at {
            Some(at) => &mut self.grids[at],
            None => {
                self.grids.push(Grid {
                    ring: version.id,
                    epoch: version.epoch,
                    channel,
                    width,
                    first: k0,
                    cells: VecDeque::new(),
                    oldest: f64::NEG_INFINITY,
                    used: true,
                });
                let last = self.grids.len() - 1;
                &mut self.grids[last]
            }
        };
        grid.used = true;
        // Another epoch (cleared, resized), or the view went back before what is kept.
        if grid.epoch != version.epoch || k0 < grid.first {
            grid.epoch = version.epoch;
            grid.cells.clear();
            grid.first = k0;
        }
        // The columns left behind go; those that held rows the ring dropped since the last
        // frame (between the oldest row then and the oldest now) are made again.
        while !grid.cells.is_empty() && grid.first < k0 {
            grid.cells.pop_front();
            grid.first += 1;
        }
        let oldest = ring.first_time().unwrap_or(f64::INFINITY);
        for (j, cell) in grid.cells.iter_mut().enumerate() {
            let k = grid.first + j as i64;
            if (k as f64) * width >= oldest {
                break;
            }
            if ((k + 1) as f64) * width > grid.oldest {
                *cell = None;
            }
        }
        grid.oldest = oldest;
        if grid.cells.is_empty() {
            grid.first = k0;
        }
        // Columns in view before those kept (the ring's oldest rows were dropped from
        // them): made afresh below.
        while grid.first > k0 {
            grid.cells.push_front(None);
            grid.first -= 1;
        }
        let wanted = (k1 - grid.first + 1) as usize;
        grid.cells.truncate(wanted);
        grid.cells.resize(wanted, None);
        // Make the columns not kept, a run at a time.
        let newest = ring.last_time().unwrap_or(f64::NEG_INFINITY);
        let mut k = k0;
        while k <= k1 {
            let kept = |k: i64| grid.cells[(k - grid.first) as usize].is_some_and(|c| c.complete);
            if kept(k) {
                k += 1;
                continue;
            }
            let start = k;
            while k <= k1 && !kept(k) {
                k += 1;
            }
            for j in start..k {
                grid.cells[(j - grid.first) as usize] = Some(Cell {
                    len: 0,
                    points: [[0.0; 2]; 4],
                    complete: (j + 1) as f64 * width <= newest,
                });
            }
            self.columns_made += (k - start) as u64;
            let first = grid.first;
            ring.decimate_grid(channel, (start, k - 1), width, |j, points| {
                if let Some(Some(cell)) = grid.cells.get_mut((j - first) as usize) {
                    cell.len = points.len() as u8;
                    cell.points[..points.len()].copy_from_slice(points);
                }
            });
        }
        let until = (k1 + 1) as f64 * width;
        let (before, after) = ring.neighbours(channel, k0 as f64 * width, until);
        let mut out = Vec::with_capacity(4 * (k1 - k0 + 1) as usize + 2);
        out.extend(before);
        for cell in grid.cells.iter().flatten() {
            out.extend_from_slice(&cell.points[..usize::from(cell.len)]);
        }
        out.extend(after);
        (out, until)
    }

    /// [`Ring::decimate_bits`], reused when it still holds.
    pub fn bits(
        &mut self,
        ring: &Ring,
        channel: usize,
        from: f64,
        to: f64,
        columns: usize,
    ) -> Vec<BitSpan> {
        let key = Key {
            ring: ring.version().id,
            channel,
            bits: true,
            from,
            to,
            columns,
        };
        if let Some(Made::Bits(spans)) = self.find(ring, key) {
            return spans.clone();
        }
        let spans = ring.decimate_bits(channel, from, to, columns);
        self.keep(ring, key, Made::Bits(spans.clone()));
        spans
    }

    /// A frame is over: forget what it did not ask for.
    pub fn end_frame(&mut self) {
        self.entries.retain(|e| e.used);
        for entry in &mut self.entries {
            entry.used = false;
        }
        self.grids.retain(|g| g.used);
        for grid in &mut self.grids {
            grid.used = false;
        }
    }

    fn find(&mut self, ring: &Ring, key: Key) -> Option<&Made> {
        let at = self.entries.iter().position(|e| e.key == key)?;
        if !self.entries[at].still_holds(ring) {
            self.entries.swap_remove(at);
            return None;
        }
        self.reused += 1;
        let entry = &mut self.entries[at];
        entry.used = true;
        Some(&entry.made)
    }

    fn keep(&mut self, ring: &Ring, key: Key, made: Made) {
        self.made += 1;
        self.entries.retain(|e| e.key != key);
        self.entries.push(Entry {
            key,
            version: ring.version(),
            last: ring.last_time().unwrap_or(f64::NEG_INFINITY),
            made,
            used: true,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(rows: usize, capacity: usize) -> Ring {
        let mut ring = Ring::new(capacity, 2);
        for i in 0..rows {
            let v = ((i * 7919) % 101) as f64;
            ring.push(i as f64 * 0.001, &[v, (i / 50 % 4) as f64])
                .expect("times go forward");
        }
        ring
    }

    /// What a cache with no history makes of the span.
    fn afresh(ring: &Ring, from: f64, to: f64, columns: usize) -> Vec<[f64; 2]> {
        Decimations::default().points(ring, 0, from, to, columns)
    }

    #[test]
    fn a_span_that_has_not_moved_is_decimated_once_and_always_as_afresh() {
        let mut ring = ring(20_000, 30_000);
        let mut cache = Decimations::default();
        let (from, to) = (2.0, 9.0);
        let first = cache.points(&ring, 0, from, to, 300);
        assert_eq!(first, afresh(&ring, from, to, 300));
        assert_eq!(cache.points(&ring, 0, from, to, 300), first);
        assert_eq!((cache.made, cache.reused), (1, 1));
        // Rows appended after the span, then the ring wrapping (the oldest rows go):
        // still the same, reused, until the rows it was made of go.
        for i in 20_000..45_000 {
            ring.push(i as f64 * 0.001, &[1.0, 2.0]).expect("forward");
            if i % 997 == 0 {
                let now = cache.points(&ring, 0, from, to, 300);
                assert_eq!(now, afresh(&ring, from, to, 300), "row {i}");
                let bits = cache.bits(&ring, 1, from, to, 300);
                assert_eq!(bits, ring.decimate_bits(1, from, to, 300), "row {i}");
            }
        }
        assert!(cache.reused > 10, "{cache:?}");
        // Another width, span or ring is another decimation.
        let other = ring.clone();
        assert_eq!(
            cache.points(&other, 0, from, to, 300),
            afresh(&other, from, to, 300)
        );
        assert_eq!(
            cache.points(&ring, 0, from, to, 299),
            afresh(&ring, from, to, 299)
        );
        // A span reaching the newest row is made again when a row comes.
        let last = ring.last_time().expect("rows");
        let made = cache.made;
        cache.points(&ring, 0, last - 5.0, last, 300);
        ring.push(last + 0.001, &[500.0, 0.0]).expect("forward");
        assert_eq!(
            cache.points(&ring, 0, last - 5.0, last, 300),
            afresh(&ring, last - 5.0, last, 300)
        );
        assert_eq!(cache.made, made + 2);
        // Cleared and filled again: made afresh.
        ring.clear();
        for i in 0..20_000 {
            ring.push(i as f64 * 0.001, &[-1.0, 0.0]).expect("forward");
        }
        assert_eq!(
            cache.points(&ring, 0, from, to, 300),
            afresh(&ring, from, to, 300)
        );
        // What a frame did not ask for is forgotten at its end.
        cache.end_frame();
        cache.end_frame();
        assert!(cache.entries.is_empty());
        assert!(cache.grids.is_empty());
    }

    /// Per grid column, its first, lowest, highest and last samples, found by looking at
    /// every row (the lowest and highest the first of equals, as the summaries keep them).
    fn brute_grid(ring: &Ring, k0: i64, k1: i64, width: f64) -> Vec<(i64, Vec<[f64; 2]>)> {
        let rows: Vec<[f64; 2]> = (0..ring.len())
            .filter_map(|i| Some([ring.time(i)?, ring.value(i, 0)?]))
            .filter(|p| !p[1].is_nan())
            .collect();
        let mut out = vec![];
        for k in k0..=k1 {
            let (lo, hi) = (k as f64 * width, (k + 1) as f64 * width);
            let in_column: Vec<usize> = (0..rows.len())
                .filter(|&i| rows[i][0] >= lo && rows[i][0] < hi)
                .collect();
            let (Some(&first), Some(&last)) = (in_column.first(), in_column.last()) else {
                continue;
            };
            let pick = |better: fn(f64, f64) -> bool| {
                in_column.iter().copied().fold(first, |b, i| {
                    if better(rows[i][1], rows[b][1]) { i } else { b }
                })
            };
            let mut idx = vec![first, pick(|a, b| a < b), pick(|a, b| a > b), last];
            idx.sort_unstable();
            idx.dedup();
            out.push((k, idx.into_iter().map(|i| rows[i]).collect()));
        }
        out
    }

    #[test]
    fn a_grid_column_holds_its_first_lowest_highest_and_last_samples() {
        let mut ring = ring(20_000, 30_000);
        // Some samples missing, and a row exactly on a column edge.
        for i in 0..500 {
            let t = 20.0 + i as f64 * 0.0125;
            let v = if i % 7 == 0 {
                f64::NAN
            } else {
                ((i * 31) % 17) as f64
            };
            ring.push(t, &[v, 0.0]).expect("forward");
        }
        for (k0, k1, width) in [(0, 40, 0.5), (37, 210, 0.1), (1_590, 1_650, 0.0125)] {
            let mut made = vec![];
            ring.decimate_grid(0, (k0, k1), width, |k, points| {
                made.push((k, points.to_vec()))
            });
            assert_eq!(
                made,
                brute_grid(&ring, k0, k1, width),
                "{k0}..={k1} by {width}"
            );
        }
    }

    #[test]
    fn a_sliding_view_reuses_its_columns_and_draws_what_a_fresh_one_would() {
        // A ring that wraps while the view follows its newest rows, 600 columns.
        let mut ring = Ring::new(12_000, 2);
        let mut cache = Decimations::default();
        let mut i = 0usize;
        let mut frames = 0;
        while i < 40_000 {
            for _ in 0..37 {
                let v =
                    ((i * 7919) % 101) as f64 + if i.is_multiple_of(5_003) { 900.0 } else { 0.0 };
                ring.push(i as f64 * 0.001, &[v, 0.0]).expect("forward");
                i += 1;
            }
            let to = ring.last_time().expect("rows");
            // A view of 10 s (longer than the ring holds early on, shorter later).
            let from = to - 10.0;
            let points = cache.points(&ring, 0, from, to, 600);
            assert_eq!(points, afresh(&ring, from, to, 600), "frame {frames}");
            cache.end_frame();
            frames += 1;
        }
        // Most columns were kept, not made again: 37 ms of rows a frame fill about two
        // columns of 16.7 ms; the first frames and the ring's dropped rows add a few.
        assert_eq!(cache.grids.len(), 1);
        let per_frame = cache.columns_made as f64 / frames as f64;
        assert!(
            per_frame < 12.0,
            "{per_frame} columns made a frame of ~600 in view"
        );
        // And every extreme is drawn: the spikes in view are there.
        let to = ring.last_time().expect("rows");
        let points = cache.points(&ring, 0, to - 10.0, to, 600);
        let spikes = points.iter().filter(|p| p[1] >= 900.0).count();
        assert!(spikes >= 1, "{spikes} spikes");
    }
}
