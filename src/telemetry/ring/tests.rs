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

fn reference_decimate(rows: &[(f64, f64)], from: f64, to: f64, columns: usize) -> Vec<[f64; 2]> {
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
