//! The CPU backend's neighbour bookkeeping: a cell grid over the box, the counting sort of
//! the particles by cell (re-done at every list rebuild, so that neighbours are close in
//! memory), and a half Verlet list (each pair once, `j > i` in sorted order) stored per
//! fixed block of consecutive particles.
//!
//! The periodic image of every pair is fixed when the list is built: pairs that do not
//! cross a periodic boundary (almost all) are stored as bare indices, the few that do carry
//! their image shift. Between builds the positions are not wrapped, so the force loop never
//! tests for a minimum image.
//!
//! Blocks have a size that depends only on the particle count, never on the number of
//! threads: the force pass runs one task per block and reduces the cross-block reactions in
//! block order, so results are bit-identical for any thread count.

use rayon::prelude::*;

use simkit_backend::{Error, Real, Result};

/// Below this particle count the CPU passes run on the calling thread: for small systems
/// waking the rayon pool several times per step costs more than the work (the blocks, and
/// so the results, are the same either way).
pub(crate) const PARALLEL_MIN: usize = 4096;

/// Particles per block for `n` particles (independent of the thread count).
pub(crate) fn block_size(n: usize) -> usize {
    (n / 32).clamp(256, 4096)
}

/// One block of consecutive particles (in sorted order) with its half list, and the
/// reactions `(j, F)` it owes to particles of later blocks (`ghosts[t]` for block `t`).
pub(crate) struct Block<T, const D: usize> {
    pub start: usize,
    pub end: usize,
    /// `offsets[k]..offsets[k + 1]` index `idx` for particle `start + k`.
    pub offsets: Vec<u32>,
    /// Partners in the same periodic image: separation `x_i - x_j`.
    pub idx: Vec<u32>,
    /// `img_offsets[k]..img_offsets[k + 1]` index `img` for particle `start + k`.
    pub img_offsets: Vec<u32>,
    /// Partners across a periodic boundary with their shift: separation `(x_i - x_j) - s`.
    pub img: Vec<(u32, [T; D])>,
    /// `(k, w)`: particle `start + k` may touch wall `w` before the next list build
    /// (ascending `k`, walls in scene order); the others are too far away to be tested.
    pub walls: Vec<(u32, u32)>,
    pub ghosts: Vec<Vec<(u32, [T; D])>>,
}

/// A uniform grid of cells at least `range` wide, with periodic axes.
pub(crate) struct CellBins<const D: usize> {
    lo: [f64; D],
    len: [f64; D],
    periodic: [bool; D],
    cells: [usize; D],
    inv: [f64; D],
    range2: f64,
    cell_of: Vec<u32>,
    start: Vec<u32>,
}

impl<const D: usize> CellBins<D> {
    /// Cells of width at least `range` (the cutoff plus the skin) over `[lo, lo + len)`
    /// for `n` particles. A sparse box gets wider cells (at most about `8 n + 4096` cells),
    /// which only costs distance checks at list builds.
    pub fn new(
        lo: [f64; D],
        len: [f64; D],
        periodic: [bool; D],
        range: f64,
        n: usize,
    ) -> Result<Self> {
        if !(range.is_finite() && range > 0.0) {
            return Err(Error::invalid(
                "neighbour list range",
                range,
                "must be finite and > 0 (twice the largest radius plus the skin)",
            ));
        }
        if let Some(d) = (0..D).find(|&d| !(len[d].is_finite() && len[d] > 0.0)) {
            return Err(Error::invalid(
                format!("box length along axis {d}"),
                len[d],
                "must be finite and > 0",
            ));
        }
        let limit = (8 * n + 4096) as f64;
        let mut width = range;
        let (cells, total) = loop {
            let mut cells = [1usize; D];
            let mut total = 1.0f64;
            for d in 0..D {
                let c = (len[d] / width).floor().max(1.0);
                total *= c;
                cells[d] = c as usize;
            }
            if total <= limit {
                break (cells, total);
            }
            width *= 1.25;
        };
        Ok(Self {
            lo,
            len,
            periodic,
            cells,
            inv: std::array::from_fn(|d| cells[d] as f64 / len[d]),
            range2: range * range,
            cell_of: Vec::new(),
            start: vec![0; total as usize + 1],
        })
    }

    fn cell_coords<T: Real>(&self, x: &[T; D]) -> [usize; D] {
        std::array::from_fn(|d| {
            let t = ((x[d].to_f64() - self.lo[d]) * self.inv[d]).floor();
            // Below the box (or NaN) -> 0; above -> the last cell (monotone clamping keeps
            // neighbours in adjacent cells).
            if t >= 0.0 {
                (t as usize).min(self.cells[d] - 1)
            } else {
                0
            }
        })
    }

    fn linear(&self, c: [usize; D]) -> usize {
        let mut l = 0;
        for d in (0..D).rev() {
            l = l * self.cells[d] + c[d];
        }
        l
    }

    /// The permutation that sorts `pos` by cell (last axis slowest), stable within a cell:
    /// `order[k]` is the current index of the particle that goes to slot `k`.
    pub fn sort<T: Real>(&mut self, pos: &[[T; D]]) -> Vec<u32> {
        let nc = self.start.len() - 1;
        let mut cell_of = std::mem::take(&mut self.cell_of);
        cell_of.clear();
        cell_of.extend(pos.iter().map(|x| self.linear(self.cell_coords(x)) as u32));
        self.cell_of = cell_of;
        self.start.iter_mut().for_each(|s| *s = 0);
        for &c in &self.cell_of {
            self.start[c as usize + 1] += 1;
        }
        for c in 0..nc {
            self.start[c + 1] += self.start[c];
        }
        let mut cursor = self.start.clone();
        let mut order = vec![0u32; pos.len()];
        for (i, &c) in self.cell_of.iter().enumerate() {
            let s = &mut cursor[c as usize];
            order[*s as usize] = i as u32;
            *s += 1;
        }
        order
    }

    /// Distinct neighbour coordinates of `c` along axis `d` (periodic wrap, no duplicates).
    fn axis_neighbors(&self, d: usize, c: usize) -> ([usize; 3], usize) {
        let n = self.cells[d];
        if self.periodic[d] {
            match n {
                1 => ([c, 0, 0], 1),
                2 => ([c, 1 - c, 0], 2),
                _ => ([(c + n - 1) % n, c, (c + 1) % n], 3),
            }
        } else {
            let mut out = [0; 3];
            let mut k = 0;
            for t in [c.wrapping_sub(1), c, c + 1] {
                if t < n {
                    out[k] = t;
                    k += 1;
                }
            }
            (out, k)
        }
    }

    /// Rebuilds the half list of every block from the sorted positions `pos` (wrapped into
    /// the box and sorted with [`sort`](Self::sort) just before): pairs `j > i` within the
    /// list range, each with the minimum image it has now. Blocks are built on the rayon
    /// pool when `parallel`.
    pub fn build_lists<T: Real>(&self, pos: &[[T; D]], blocks: &mut [Block<T, D>], parallel: bool) {
        let half: [f64; D] = std::array::from_fn(|d| 0.5 * self.len[d]);
        let build = |b: &mut Block<T, D>| {
            b.offsets.clear();
            b.idx.clear();
            b.offsets.push(0);
            b.img_offsets.clear();
            b.img.clear();
            b.img_offsets.push(0);
            for (i, xi) in pos.iter().enumerate().take(b.end).skip(b.start) {
                let c = self.cell_coords(xi);
                let axes: [([usize; 3], usize); D] =
                    std::array::from_fn(|d| self.axis_neighbors(d, c[d]));
                let mut k = [0usize; D];
                'cells: loop {
                    let nc = self.linear(std::array::from_fn(|d| axes[d].0[k[d]]));
                    let (s, e) = (self.start[nc] as usize, self.start[nc + 1] as usize);
                    for (j, xj) in pos.iter().enumerate().take(e).skip(s.max(i + 1)) {
                        let mut r2 = 0.0;
                        let mut shift = [T::ZERO; D];
                        let mut crosses = false;
                        for d in 0..D {
                            let mut s = xi[d].to_f64() - xj[d].to_f64();
                            if self.periodic[d] {
                                if s > half[d] {
                                    s -= self.len[d];
                                    shift[d] = T::from_f64(self.len[d]);
                                    crosses = true;
                                } else if s < -half[d] {
                                    s += self.len[d];
                                    shift[d] = T::from_f64(-self.len[d]);
                                    crosses = true;
                                }
                            }
                            r2 += s * s;
                        }
                        if r2 < self.range2 {
                            if crosses {
                                b.img.push((j as u32, shift));
                            } else {
                                b.idx.push(j as u32);
                            }
                        }
                    }
                    // Next cell of the stencil (odometer over the axes).
                    let mut d = 0;
                    loop {
                        if d == D {
                            break 'cells;
                        }
                        k[d] += 1;
                        if k[d] < axes[d].1 {
                            break;
                        }
                        k[d] = 0;
                        d += 1;
                    }
                }
                b.offsets.push(b.idx.len() as u32);
                b.img_offsets.push(b.img.len() as u32);
            }
        };
        if parallel {
            blocks.par_iter_mut().for_each(build);
        } else {
            blocks.iter_mut().for_each(build);
        }
    }
}

/// Fixed blocks of `block_size(n)` particles.
pub(crate) fn make_blocks<T, const D: usize>(n: usize) -> Vec<Block<T, D>> {
    let bs = block_size(n);
    let count = n.div_ceil(bs).max(1);
    (0..count)
        .map(|b| Block {
            start: (b * bs).min(n),
            end: ((b + 1) * bs).min(n),
            offsets: Vec::new(),
            idx: Vec::new(),
            img_offsets: Vec::new(),
            img: Vec::new(),
            walls: Vec::new(),
            ghosts: (0..count).map(|_| Vec::new()).collect(),
        })
        .collect()
}
