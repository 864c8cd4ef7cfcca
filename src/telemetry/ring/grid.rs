//! Decimations of a moving view on a grid of columns fixed in time: column `k` holds the
//! rows with `k·w <= t < (k+1)·w`. A view that follows the newest samples moves every
//! frame, so its whole decimation cannot be reused, but the columns the newest row has
//! passed cannot change (rows only come after it) until the ring drops their rows: those
//! are kept, and a frame decimates only the columns that came into view or were filling.

use std::collections::VecDeque;

use super::{BitSpan, Ring};

/// The width of a grid column for spans `width` wide: rounded down to a multiple of 1/64 of
/// its power of two, so that a view of the same length (its ends moving, their difference
/// changing in the last bits) keeps the same grid. At most 1.6 % narrower: a few more
/// columns than asked for.
pub(super) fn grid_width(width: f64) -> f64 {
    if !(width > 0.0 && width.is_finite()) {
        return f64::NAN;
    }
    let step = 2f64.powi(width.log2().floor() as i32) / 64.0;
    ((width / step).floor() * step).max(step)
}

/// What one column holds: the first, lowest, highest and last samples of a trace (up to
/// four points, none when it has no sample), or the bits of a lane.
#[derive(Debug, Clone, Copy)]
enum Content {
    Points { len: u8, points: [[f64; 2]; 4] },
    Bits(Option<BitSpan>),
}

/// A column as made, and whether the newest row had passed its end then (only then can
/// nothing change it but the ring dropping its rows).
#[derive(Debug, Clone, Copy)]
struct Cell {
    content: Content,
    complete: bool,
}

/// The columns of a moving view of one channel.
#[derive(Debug, Clone)]
struct Grid {
    ring: u64,
    epoch: u64,
    channel: usize,
    bits: bool,
    width: f64,
    /// Column `first + i` is `cells[i]` (`None`: not made).
    first: i64,
    cells: VecDeque<Option<Cell>>,
    /// The ring's oldest row time when last used: rows dropped since lie before the oldest
    /// now, and the columns they were in are made again.
    oldest: f64,
    used: bool,
}

/// The grids of the views drawn lately.
#[derive(Debug, Clone, Default)]
pub(super) struct Grids {
    grids: Vec<Grid>,
    /// Columns decimated since this was created (the rest were kept).
    pub(super) columns_made: u64,
}

/// The columns `k0..=k1` of `width` covering `from..=to` in `columns`, if a grid can hold
/// them (a finite span, not many more columns than asked for).
fn columns_of(from: f64, to: f64, columns: usize) -> Option<(f64, i64, i64)> {
    let width = grid_width((to - from) / columns.max(1) as f64);
    let (k0, k1) = ((from / width).floor(), (to / width).floor());
    (k0.is_finite() && k1.is_finite() && k1 - k0 <= 4.0 * columns as f64 + 4.0)
        .then_some((width, k0 as i64, k1 as i64))
}

impl Grids {
    /// [`Ring::decimate`] of `from..=to` on the grid, with the neighbours that carry the
    /// line to the edges; and the time the columns reach to. `None` when no grid fits.
    pub(super) fn points(
        &mut self,
        ring: &Ring,
        channel: usize,
        (from, to): (f64, f64),
        columns: usize,
    ) -> Option<(Vec<[f64; 2]>, f64)> {
        let (width, k0, k1) = columns_of(from, to, columns)?;
        let grid = self.made(ring, channel, false, width, (k0, k1));
        let until = (k1 + 1) as f64 * width;
        let (before, after) = ring.neighbours(channel, k0 as f64 * width, until);
        let mut out = Vec::with_capacity(4 * grid.cells.len() + 2);
        out.extend(before);
        for cell in grid.cells.iter().flatten() {
            if let Content::Points { len, points } = &cell.content {
                out.extend_from_slice(&points[..usize::from(*len)]);
            }
        }
        out.extend(after);
        Some((out, until))
    }

    /// [`Ring::decimate_bits`] of `from..=to` on the grid; and the time the columns reach
    /// to. `None` when no grid fits.
    pub(super) fn bits(
        &mut self,
        ring: &Ring,
        channel: usize,
        (from, to): (f64, f64),
        columns: usize,
    ) -> Option<(Vec<BitSpan>, f64)> {
        let (width, k0, k1) = columns_of(from, to, columns)?;
        let grid = self.made(ring, channel, true, width, (k0, k1));
        let spans = grid
            .cells
            .iter()
            .flatten()
            .filter_map(|cell| match cell.content {
                Content::Bits(span) => span,
                Content::Points { .. } => None,
            })
            .collect();
        Some((spans, (k1 + 1) as f64 * width))
    }

    /// The grid of `channel` holding columns `k0..=k1` exactly, each made or kept.
    fn made(
        &mut self,
        ring: &Ring,
        channel: usize,
        bits: bool,
        width: f64,
        (k0, k1): (i64, i64),
    ) -> &Grid {
        let version = ring.version();
        let at = self.grids.iter().position(|g| {
            g.ring == version.id && g.channel == channel && g.bits == bits && g.width == width
        });
        let at = at.unwrap_or_else(|| {
            self.grids.push(Grid {
                ring: version.id,
                epoch: version.epoch,
                channel,
                bits,
                width,
                first: k0,
                cells: VecDeque::new(),
                oldest: f64::NEG_INFINITY,
                used: true,
            });
            self.grids.len() - 1
        });
        let grid = &mut self.grids[at];
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
        if grid.cells.is_empty() {
            grid.first = k0;
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
            let empty = if bits {
                Content::Bits(None)
            } else {
                Content::Points {
                    len: 0,
                    points: [[0.0; 2]; 4],
                }
            };
            for j in start..k {
                grid.cells[(j - grid.first) as usize] = Some(Cell {
                    content: empty,
                    complete: (j + 1) as f64 * width <= newest,
                });
            }
            self.columns_made += (k - start) as u64;
            let first = grid.first;
            let cells = &mut grid.cells;
            let mut put = |j: i64, content: Content| {
                if let Some(Some(cell)) = cells.get_mut((j - first) as usize) {
                    cell.content = content;
                }
            };
            if bits {
                ring.decimate_bits_grid(channel, (start, k - 1), width, |j, span| {
                    put(j, Content::Bits(Some(span)));
                });
            } else {
                ring.decimate_grid(channel, (start, k - 1), width, |j, points| {
                    let mut kept = [[0.0; 2]; 4];
                    kept[..points.len()].copy_from_slice(points);
                    put(
                        j,
                        Content::Points {
                            len: points.len() as u8,
                            points: kept,
                        },
                    );
                });
            }
        }
        &self.grids[at]
    }

    /// A frame is over: forget the grids it did not use.
    pub(super) fn end_frame(&mut self) {
        self.grids.retain(|g| g.used);
        for grid in &mut self.grids {
            grid.used = false;
        }
    }

    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.grids.len()
    }
}
