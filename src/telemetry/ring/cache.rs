//! Decimations kept from one frame to the next: a plot that has not moved (paused, zoomed
//! into the past, a still history) draws the points it drew last frame instead of
//! decimating again. Each is keyed by its ring, channel, time span and width in columns;
//! it is reused while the ring's contents are the same (its [`Version`]), or while the only
//! rows added since lie after the span and none of the rows it was made of has gone.

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
            // The last point must be the sample after the span: one appended later could
            // otherwise become it.
            Made::Points(_, ends) => {
                ends.is_some_and(|(head, tail)| head > first && tail > self.key.to)
            }
            Made::Bits(spans) => spans.first().is_none_or(|s| s.t0 > first),
        }
    }
}

/// The decimations of the last frames, for reuse.
#[derive(Debug, Clone, Default)]
pub struct Decimations {
    entries: Vec<Entry>,
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
        let points = ring.decimate(channel, from, to, columns);
        let ends = points.first().zip(points.last()).map(|(a, b)| (a[0], b[0]));
        let points = finish(points);
        self.keep(ring, key, Made::Points(points.clone(), ends));
        points
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

    #[test]
    fn a_span_that_has_not_moved_is_decimated_once_and_always_as_afresh() {
        let mut ring = ring(20_000, 30_000);
        let mut cache = Decimations::default();
        let (from, to) = (2.0, 9.0);
        let first = cache.points(&ring, 0, from, to, 300);
        assert_eq!(first, ring.decimate(0, from, to, 300));
        assert_eq!(cache.points(&ring, 0, from, to, 300), first);
        assert_eq!((cache.made, cache.reused), (1, 1));
        // Rows appended after the span, then the ring wrapping (the oldest rows go):
        // still the same, reused, until the rows it was made of go.
        for i in 20_000..45_000 {
            ring.push(i as f64 * 0.001, &[1.0, 2.0]).expect("forward");
            if i % 997 == 0 {
                let now = cache.points(&ring, 0, from, to, 300);
                assert_eq!(now, ring.decimate(0, from, to, 300), "row {i}");
                let bits = cache.bits(&ring, 1, from, to, 300);
                assert_eq!(bits, ring.decimate_bits(1, from, to, 300), "row {i}");
            }
        }
        assert!(cache.reused > 10, "{cache:?}");
        // Another width, span or ring is another decimation.
        let other = ring.clone();
        assert_eq!(
            cache.points(&other, 0, from, to, 300),
            other.decimate(0, from, to, 300)
        );
        assert_eq!(
            cache.points(&ring, 0, from, to, 299),
            ring.decimate(0, from, to, 299)
        );
        // A span reaching the newest row is made again when a row comes.
        let last = ring.last_time().expect("rows");
        let made = cache.made;
        cache.points(&ring, 0, last - 5.0, last, 300);
        ring.push(last + 0.001, &[500.0, 0.0]).expect("forward");
        assert_eq!(
            cache.points(&ring, 0, last - 5.0, last, 300),
            ring.decimate(0, last - 5.0, last, 300)
        );
        assert_eq!(cache.made, made + 2);
        // Cleared and filled again: made afresh.
        ring.clear();
        for i in 0..20_000 {
            ring.push(i as f64 * 0.001, &[-1.0, 0.0]).expect("forward");
        }
        assert_eq!(
            cache.points(&ring, 0, from, to, 300),
            ring.decimate(0, from, to, 300)
        );
        // What a frame did not ask for is forgotten at its end.
        cache.end_frame();
        cache.end_frame();
        assert!(cache.entries.is_empty());
    }
}
