//! Decimations kept from one frame to the next: a plot that has not moved (paused, zoomed
//! into the past, a still history) draws the points it drew last frame instead of
//! decimating again. Each is keyed by its ring, channel, time span and width in columns;
//! it is reused while the ring's contents are the same (its [`Version`]), or while the only
//! rows added since lie after the span and none of the rows it was made of has gone.
//!
//! What is not reused is made on a grid fixed in time ([`Grids`]), so that a view that
//! moves still reuses the columns the newest row has passed.

use super::grid::Grids;
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
    /// The points as kept (maybe thinned for drawing), and the times of the first and
    /// last point the decimation made.
    Points(Vec<[f64; 2]>, Option<(f64, f64)>),
    Bits(Vec<BitSpan>),
}

#[derive(Debug, Clone)]
struct Entry {
    key: Key,
    /// The ring's version and newest time when this was made.
    version: Version,
    last: f64,
    /// Rows before this time were in its columns (the grid's columns reach past the span).
    until: f64,
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
        // A row appended later must fall after the columns.
        if self.last < self.until {
            return false;
        }
        match &self.made {
            // The last point must be the sample after the columns: one appended later
            // could otherwise become it.
            Made::Points(_, ends) => {
                ends.is_some_and(|(head, tail)| head > first && tail >= self.until)
            }
            Made::Bits(spans) => spans.first().is_none_or(|s| s.t0 > first),
        }
    }
}

/// The decimations of the last frames, for reuse.
#[derive(Debug, Clone, Default)]
pub struct Decimations {
    entries: Vec<Entry>,
    grids: Grids,
    /// Decimations reused and made since this was created (for tests and measurements).
    pub reused: u64,
    pub made: u64,
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
        if let Some(Made::Points(points, _)) = self.find(ring, key) {
            return points.clone();
        }
        let (points, until) = self
            .grids
            .points(ring, channel, (from, to), columns)
            .unwrap_or_else(|| (ring.decimate(channel, from, to, columns), to.next_up()));
        let ends = points.first().zip(points.last()).map(|(a, b)| (a[0], b[0]));
        let points = finish(points);
        self.keep(ring, key, until, Made::Points(points.clone(), ends));
        points
    }

    /// Grid columns decimated since this was created (the rest were kept).
    pub fn columns_made(&self) -> u64 {
        self.grids.columns_made
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
        let (spans, until) = self
            .grids
            .bits(ring, channel, (from, to), columns)
            .unwrap_or_else(|| (ring.decimate_bits(channel, from, to, columns), to.next_up()));
        self.keep(ring, key, until, Made::Bits(spans.clone()));
        spans
    }

    /// A frame is over: forget what it did not ask for.
    pub fn end_frame(&mut self) {
        self.entries.retain(|e| e.used);
        for entry in &mut self.entries {
            entry.used = false;
        }
        self.grids.end_frame();
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

    fn keep(&mut self, ring: &Ring, key: Key, until: f64, made: Made) {
        self.made += 1;
        self.entries.retain(|e| e.key != key);
        self.entries.push(Entry {
            key,
            version: ring.version(),
            last: ring.last_time().unwrap_or(f64::NEG_INFINITY),
            until,
            made,
            used: true,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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

    /// The same for the bits of channel 1.
    fn afresh_bits(ring: &Ring, from: f64, to: f64, columns: usize) -> Vec<BitSpan> {
        Decimations::default().bits(ring, 1, from, to, columns)
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
                assert_eq!(bits, afresh_bits(&ring, from, to, 300), "row {i}");
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
        assert_eq!(cache.grids.len(), 0);
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
            // The bits of channel 1 on the same grid: first and last times, OR and AND.
            let mut bits = vec![];
            ring.decimate_bits_grid(1, (k0, k1), width, |k, span| bits.push((k, span)));
            let mut expected = vec![];
            for k in k0..=k1 {
                let (lo, hi) = (k as f64 * width, (k + 1) as f64 * width);
                let rows: Vec<(f64, u32)> = (0..ring.len())
                    .filter_map(|i| Some((ring.time(i)?, ring.value(i, 1)?)))
                    .filter(|(t, v)| *t >= lo && *t < hi && !v.is_nan())
                    .map(|(t, v)| (t, v as u32))
                    .collect();
                if let (Some(first), Some(last)) = (rows.first(), rows.last()) {
                    let span = BitSpan {
                        t0: first.0,
                        t1: last.0,
                        any: rows.iter().fold(0, |a, r| a | r.1),
                        all: rows.iter().fold(u32::MAX, |a, r| a & r.1),
                    };
                    expected.push((k, span));
                }
            }
            assert_eq!(bits, expected, "bits {k0}..={k1} by {width}");
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
                let bits = ((i / 700) % 4) as f64;
                ring.push(i as f64 * 0.001, &[v, bits]).expect("forward");
                i += 1;
            }
            let to = ring.last_time().expect("rows");
            // A view of 10 s (longer than the ring holds early on, shorter later).
            let from = to - 10.0;
            let points = cache.points(&ring, 0, from, to, 600);
            assert_eq!(points, afresh(&ring, from, to, 600), "frame {frames}");
            let bits = cache.bits(&ring, 1, from, to, 600);
            assert_eq!(bits, afresh_bits(&ring, from, to, 600), "frame {frames}");
            cache.end_frame();
            frames += 1;
        }
        // Most columns were kept, not made again: 37 ms of rows a frame fill about two
        // columns of 16.7 ms; the first frames and the ring's dropped rows add a few.
        assert_eq!(cache.grids.len(), 2);
        let per_frame = cache.columns_made() as f64 / frames as f64;
        assert!(
            per_frame < 24.0,
            "{per_frame} columns made a frame of ~2 × 600 in view"
        );
        // And every extreme is drawn: the spikes in view are there.
        let to = ring.last_time().expect("rows");
        let points = cache.points(&ring, 0, to - 10.0, to, 600);
        let spikes = points.iter().filter(|p| p[1] >= 900.0).count();
        assert!(spikes >= 1, "{spikes} spikes");
    }

    /// How the view moves from one frame to the next: panned by a fraction of its width,
    /// or zoomed by a factor about a point at a fraction of it.
    #[derive(Debug, Clone, Copy)]
    enum Move {
        Pan(f64),
        Zoom(f64, f64),
    }

    fn moved((from, to): (f64, f64), how: Move) -> (f64, f64) {
        let width = to - from;
        match how {
            Move::Pan(fraction) => (from + fraction * width, to + fraction * width),
            Move::Zoom(factor, at) => {
                let about = from + at * width;
                (
                    about - (about - from) / factor,
                    about + (to - about) / factor,
                )
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// A view panned or zoomed (maybe while rows come in and the ring wraps) draws what
        /// a cache that never saw the earlier spans draws: nothing kept for one span leaks
        /// into another. (Not `Ring::decimate` of the span itself: what is not reused is
        /// decimated on a grid fixed in time, whose columns are up to 1.6 % narrower and
        /// aligned to multiples of their width, not to the span's start.)
        #[test]
        fn a_panned_or_zoomed_view_draws_what_a_fresh_cache_draws(
            rows in 50usize..4_000,
            capacity in 500usize..5_000,
            step in 0.0005f64..0.02,
            start in -0.2f64..1.2,
            width in 0.01f64..1.5,
            columns in 1usize..900,
            moves in prop::collection::vec(
                (
                    prop_oneof![
                        (-1.5f64..1.5).prop_map(Move::Pan),
                        ((0.05f64..20.0), (0.0f64..1.0)).prop_map(|(z, a)| Move::Zoom(z, a)),
                    ],
                    0usize..300,
                ),
                1..6,
            ),
        ) {
            let mut ring = Ring::new(capacity, 2);
            let mut pushed = 0usize;
            let mut push = |ring: &mut Ring, n: usize| {
                for _ in 0..n {
                    let i = pushed;
                    let v = if i % 37 == 5 { f64::NAN } else { ((i * 7919) % 101) as f64 };
                    ring.push(i as f64 * step, &[v, (i / 13 % 4) as f64]).expect("forward");
                    pushed += 1;
                }
            };
            push(&mut ring, rows);
            let total = rows as f64 * step;
            let mut span = (start * total, (start + width) * total);
            let mut cache = Decimations::default();
            cache.points(&ring, 0, span.0, span.1, columns);
            cache.bits(&ring, 1, span.0, span.1, columns);
            cache.end_frame();
            for (how, new_rows) in moves {
                push(&mut ring, new_rows);
                span = moved(span, how);
                let (from, to) = span;
                prop_assume!(to > from);
                prop_assert_eq!(
                    cache.points(&ring, 0, from, to, columns),
                    afresh(&ring, from, to, columns),
                    "{:?} to {:?}", how, span
                );
                prop_assert_eq!(
                    cache.bits(&ring, 1, from, to, columns),
                    afresh_bits(&ring, from, to, columns),
                    "{:?} to {:?}", how, span
                );
                // The same span again in the next frame: kept, still the same.
                cache.end_frame();
                prop_assert_eq!(
                    cache.points(&ring, 0, from, to, columns),
                    afresh(&ring, from, to, columns)
                );
                cache.end_frame();
            }
        }
    }

    #[test]
    fn a_fresh_cache_draws_the_rings_rows_across_the_span_and_its_peaks() {
        // Ring::decimate and the grid agree on what matters on screen: the line reaches both
        // edges, the highest and lowest samples well inside the span are drawn, and every
        // point is a sample of the ring.
        let ring = ring(20_000, 30_000);
        for (from, to, columns) in [(2.0, 9.0, 300), (2.345, 2.9, 1000), (0.5, 19.0, 77)] {
            let grid = afresh(&ring, from, to, columns);
            let plain = ring.decimate(0, from, to, columns);
            // Both carry the line past the edges (the grid's outer columns may reach a
            // little further out).
            for line in [&grid, &plain] {
                let (first, last) = (line[0][0], line[line.len() - 1][0]);
                assert!(first <= from && last >= to, "{from}..{to}: {first} {last}");
            }
            let inner = |p: &[[f64; 2]]| {
                let margin = 2.0 * (to - from) / columns as f64;
                p.iter()
                    .filter(|q| q[0] >= from + margin && q[0] <= to - margin)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                        (lo.min(q[1]), hi.max(q[1]))
                    })
            };
            assert_eq!(inner(&grid), inner(&plain), "{from}..{to}");
            assert!(grid.iter().all(|p| {
                ring.index_at_or_before(p[0])
                    .is_some_and(|i| ring.time(i) == Some(p[0]))
            }));
        }
    }
}
