//! A cell-sorted half Verlet list stored per fixed block of consecutive particles, for
//! particle codes that evaluate each pair once (Newton's third law) in parallel over blocks.

use rayon::prelude::*;

use simkit_backend::{Error, Real, Result};

use crate::MAX_CELLS;

/// A half Verlet list (each pair once, `j > i` in cell-sorted order) within a fixed list
/// range, split into fixed blocks of consecutive particles, each with its own CSR list.
///
/// Made for force loops that run one task per block and use Newton's third law: a block
/// owns the forces on its own particles and queues the reactions it owes to later blocks.
/// The block boundaries depend only on the particle count ([`block_size`](Self::block_size)),
/// never on the number of threads, so such a loop (reducing the queued reactions in block
/// order) gives bit-identical results for any thread count; the list itself is the same
/// whether it is built serially or on the rayon pool.
///
/// Use, at every list rebuild:
/// 1. wrap the periodic coordinates into the box `[lo, lo + len)`;
/// 2. [`sort`](Self::sort) the positions by cell and apply the returned permutation to every
///    per-particle array (so that neighbours are close in memory);
/// 3. [`build`](Self::build) the per-block lists from the sorted positions.
///
/// The periodic image of every pair is fixed at the build: a pair whose minimum image does
/// not cross a periodic face (almost all) is stored as a bare partner index, separation
/// `x_i - x_j`; one that does is stored apart with its image shift `s` (each component `0`
/// or `±len[d]`), separation `(x_i - x_j) - s`. Between builds positions need not be wrapped
/// and the force loop needs no minimum-image test; the code using the list decides when to
/// rebuild (typically when a particle has moved by more than half the skin).
///
/// Cells are at least the list range wide (the cutoff plus the skin); a sparse box gets
/// wider cells, at most about `8 n + 4096` of them (and never more than [`MAX_CELLS`]),
/// which only costs distance checks at builds. Cells are ordered with the last axis
/// slowest; within a cell the sort is stable. Distances are computed in `f64` whatever the
/// precision `T` of the positions.
///
/// ```
/// use simkit_neighbor::BlockedHalfList;
/// # fn main() -> simkit_backend::Result<()> {
/// // Box [0, 10)^2, periodic in x; list range 1.2.
/// let mut list = BlockedHalfList::<f64, 2>::new([0.0; 2], [10.0; 2], [true, false], 1.2, 3)?;
/// let pos = vec![[5.0, 5.0], [9.6, 2.0], [0.3, 2.0]];
/// let order = list.sort(&pos)?;
/// let sorted: Vec<[f64; 2]> = order.iter().map(|&k| pos[k as usize]).collect();
/// list.build(&sorted, false)?;
/// // Particles 1 and 2 meet across the periodic x face: one cross-image pair.
/// let mut pairs = Vec::new();
/// for b in list.blocks() {
///     for k in 0..b.len() {
///         let i = b.start() + k;
///         assert_eq!(b.partners_of(k), Some(&[][..]));
///         for &(j, s) in b.image_partners_of(k).unwrap() {
///             let j = j as usize;
///             let sep = [sorted[i][0] - sorted[j][0] - s[0], sorted[i][1] - sorted[j][1] - s[1]];
///             pairs.push((order[i].min(order[j]), sep[0].abs()));
///         }
///     }
/// }
/// assert_eq!(pairs.len(), 1);
/// assert_eq!(pairs[0].0, 1);
/// assert!((pairs[0].1 - 0.7).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct BlockedHalfList<T, const D: usize> {
    lo: [f64; D],
    len: [f64; D],
    periodic: [bool; D],
    range: f64,
    range2: f64,
    cells: [usize; D],
    inv: [f64; D],
    n: usize,
    block_size: usize,
    /// Linear cell of every particle at the last sort (in its order before the sort).
    cell_of: Vec<u32>,
    /// `start[c]..start[c + 1]`: the sorted slots of cell `c`.
    start: Vec<u32>,
    blocks: Vec<HalfListBlock<T, D>>,
    /// The sorted positions in `f64`, one column per axis (scratch of `build`).
    coords: [Vec<f64>; D],
}

/// One block of consecutive particles (in sorted order) of a [`BlockedHalfList`] with its
/// half list in CSR form: for local particle `k` (sorted slot `start + k`), the partners in
/// the same periodic image and, apart, the partners across a periodic face with the shift.
///
/// Every partner `j` is a sorted slot greater than `start + k` (it may lie in a later block).
#[derive(Clone, Debug, Default)]
pub struct HalfListBlock<T, const D: usize> {
    start: usize,
    end: usize,
    offsets: Vec<u32>,
    partners: Vec<u32>,
    image_offsets: Vec<u32>,
    image_partners: Vec<(u32, [T; D])>,
}

impl<T, const D: usize> HalfListBlock<T, D> {
    /// First sorted slot of the block.
    #[inline]
    pub fn start(&self) -> usize {
        self.start
    }

    /// One past the last sorted slot of the block.
    #[inline]
    pub fn end(&self) -> usize {
        self.end
    }

    /// Number of particles in the block.
    #[inline]
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// Whether the block holds no particle (only for an empty system).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// CSR offsets into [`partners`](Self::partners): `offsets[k]..offsets[k + 1]` for local
    /// particle `k` (`len() + 1` entries once built).
    #[inline]
    pub fn offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// Same-image partners of all the block's particles (sorted slots), separation
    /// `x_i - x_j`.
    #[inline]
    pub fn partners(&self) -> &[u32] {
        &self.partners
    }

    /// Same-image partners of local particle `k` (sorted slot `start + k`), or `None` if
    /// `k >= len()` or the list was never built.
    #[inline]
    pub fn partners_of(&self, k: usize) -> Option<&[u32]> {
        let (a, b) = (*self.offsets.get(k)?, *self.offsets.get(k.checked_add(1)?)?);
        self.partners.get(a as usize..b as usize)
    }

    /// CSR offsets into [`image_partners`](Self::image_partners), as
    /// [`offsets`](Self::offsets).
    #[inline]
    pub fn image_offsets(&self) -> &[u32] {
        &self.image_offsets
    }

    /// Cross-image partners `(j, s)` of all the block's particles: separation
    /// `(x_i - x_j) - s`, with `s[d]` one of `0`, `len[d]`, `-len[d]`.
    #[inline]
    pub fn image_partners(&self) -> &[(u32, [T; D])] {
        &self.image_partners
    }

    /// Cross-image partners of local particle `k` (sorted slot `start + k`), or `None` if
    /// `k >= len()` or the list was never built.
    #[inline]
    pub fn image_partners_of(&self, k: usize) -> Option<&[(u32, [T; D])]> {
        let (a, b) = (
            *self.image_offsets.get(k)?,
            *self.image_offsets.get(k.checked_add(1)?)?,
        );
        self.image_partners.get(a as usize..b as usize)
    }

    /// Number of pairs listed by the block (both kinds).
    pub fn pair_count(&self) -> usize {
        self.partners.len() + self.image_partners.len()
    }
}

impl<T: Real, const D: usize> BlockedHalfList<T, D> {
    /// Particles per block for `n` particles: `clamp(n / 32, 256, 4096)` (independent of
    /// the thread count; about 32 blocks for large systems).
    pub fn block_size_for(n: usize) -> usize {
        (n / 32).clamp(256, 4096)
    }

    /// A list over the box `[lo, lo + len)` with the given periodic axes, for pairs closer
    /// than `range` (the interaction cutoff plus the skin), for `n` particles.
    ///
    /// Errors: `D` other than 2 or 3; a non-finite `lo`; a non-finite or non-positive length
    /// or `range`; a `range` whose square is not a normal `f64`; a periodic length below
    /// `2 range` (a pair could then be within range in two images); more than `u32::MAX`
    /// particles.
    pub fn new(
        lo: [f64; D],
        len: [f64; D],
        periodic: [bool; D],
        range: f64,
        n: usize,
    ) -> Result<Self> {
        if D != 2 && D != 3 {
            return Err(Error::Unsupported(format!(
                "BlockedHalfList<_, {D}>: only 2D and 3D boxes exist"
            )));
        }
        if !(range.is_finite() && range > 0.0) {
            return Err(Error::invalid(
                "neighbour list range",
                range,
                "must be finite and > 0 (the cutoff plus the skin)",
            ));
        }
        // Pairs are selected by comparing squared distances with range^2.
        if !(range * range).is_normal() {
            return Err(Error::invalid(
                "neighbour list range",
                range,
                "its square must be a normal f64 (a range between about 1.5e-154 and \
                 1.3e154); rescale the length unit",
            ));
        }
        for d in 0..D {
            if !lo[d].is_finite() {
                return Err(Error::invalid(
                    format!("box origin along axis {d}"),
                    lo[d],
                    "must be finite",
                ));
            }
            if !(len[d].is_finite() && len[d] > 0.0) {
                return Err(Error::invalid(
                    format!("box length along axis {d}"),
                    len[d],
                    "must be finite and > 0",
                ));
            }
            if periodic[d] && len[d] < 2.0 * range {
                return Err(Error::invalid(
                    format!("periodic box length along axis {d}"),
                    len[d],
                    format!("must be at least twice the list range (2 x {range})"),
                ));
            }
        }
        if u32::try_from(n).is_err() {
            return Err(Error::invalid(
                "particle count",
                n,
                "must fit in 32 bits (partners are stored as u32)",
            ));
        }
        // The cell offsets are allocated here, before any position is seen: their number
        // is bounded whatever the particle count.
        let limit = n.saturating_mul(8).saturating_add(4096).min(MAX_CELLS) as f64;
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
        let block_size = Self::block_size_for(n);
        let count = n.div_ceil(block_size).max(1);
        let blocks = (0..count)
            .map(|b| HalfListBlock {
                start: (b * block_size).min(n),
                end: ((b + 1) * block_size).min(n),
                offsets: Vec::new(),
                partners: Vec::new(),
                image_offsets: Vec::new(),
                image_partners: Vec::new(),
            })
            .collect();
        Ok(Self {
            lo,
            len,
            periodic,
            range,
            range2: range * range,
            cells,
            inv: std::array::from_fn(|d| cells[d] as f64 / len[d]),
            n,
            block_size,
            cell_of: Vec::new(),
            start: vec![0; total as usize + 1],
            blocks,
            coords: std::array::from_fn(|_| Vec::new()),
        })
    }

    /// The number of particles the list was made for.
    pub fn particle_count(&self) -> usize {
        self.n
    }

    /// The list range: pairs closer than this are listed.
    pub fn range(&self) -> f64 {
        self.range
    }

    /// Cells per axis.
    pub fn cells(&self) -> [usize; D] {
        self.cells
    }

    /// Particles per block (the last block may hold fewer); see
    /// [`block_size_for`](Self::block_size_for).
    pub fn block_size(&self) -> usize {
        self.block_size
    }

    /// The blocks, in sorted-slot order (one empty block for an empty system).
    pub fn blocks(&self) -> &[HalfListBlock<T, D>] {
        &self.blocks
    }

    /// Number of pairs listed at the last build.
    pub fn pair_count(&self) -> usize {
        self.blocks.iter().map(HalfListBlock::pair_count).sum()
    }

    #[inline]
    fn cell_coords(&self, x: &[T; D]) -> [usize; D] {
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

    #[inline]
    fn linear(&self, c: [usize; D]) -> usize {
        let mut l = 0;
        for d in (0..D).rev() {
            l = l * self.cells[d] + c[d];
        }
        l
    }

    fn check_len(&self, what: &str, got: usize) -> Result<()> {
        if got == self.n {
            Ok(())
        } else {
            Err(Error::invalid(
                format!("{what} position count"),
                got,
                format!("must equal the particle count of the list ({})", self.n),
            ))
        }
    }

    /// Counting sort of `pos` by cell (last axis slowest, stable within a cell): returns
    /// `order`, where `order[k]` is the current index of the particle that goes to sorted
    /// slot `k`. A coordinate outside the box goes to the nearest boundary cell; periodic
    /// coordinates must have been wrapped into the box. A NaN coordinate goes to the first
    /// cell, and such a particle is within range of no other (a NaN distance is not below
    /// the range): check positions for non-finite values before the list is used (the
    /// simulation crates' blow-up guards do).
    ///
    /// Errors: `pos.len()` differs from the particle count.
    pub fn sort(&mut self, pos: &[[T; D]]) -> Result<Vec<u32>> {
        self.check_len("sort:", pos.len())?;
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
        Ok(order)
    }

    /// Distinct neighbour coordinates of `c` along axis `d` (periodic wrap, no duplicates).
    #[inline]
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

    /// Rebuilds the half list of every block from `pos`, the positions in sorted order
    /// (the permutation of the last [`sort`](Self::sort) applied): every pair `j > i`
    /// closer than the range, with the minimum image it has now. Blocks are built on the
    /// rayon pool when `parallel`; the lists are the same either way.
    ///
    /// The periodic image of a pair is taken from the cells it is found in (a neighbour
    /// cell reached across a periodic face gives the shift of that face), which is its
    /// minimum image for positions in the box; along a periodic axis of one or two cells,
    /// where one neighbour cell is reached across both faces, it is the minimum image of
    /// every pair. The partners of a particle are listed in an order that depends only on
    /// the positions.
    ///
    /// Errors: `pos.len()` differs from the particle count.
    pub fn build(&mut self, pos: &[[T; D]], parallel: bool) -> Result<()> {
        self.check_len("build:", pos.len())?;
        let mut blocks = std::mem::take(&mut self.blocks);
        let mut coords = std::mem::replace(&mut self.coords, std::array::from_fn(|_| Vec::new()));
        for (d, col) in coords.iter_mut().enumerate() {
            col.clear();
            col.extend(pos.iter().map(|x| x[d].to_f64()));
            col.extend([f64::NAN; CHUNK]);
        }
        let this = &*self;
        let per_cell = (0..D).all(|d| !this.periodic[d] || this.cells[d] >= 3);
        let build = |b: &mut HalfListBlock<T, D>| {
            b.offsets.clear();
            b.partners.clear();
            b.offsets.push(0);
            b.image_offsets.clear();
            b.image_partners.clear();
            b.image_offsets.push(0);
            if per_cell {
                this.build_block_per_cell_dispatch(b, pos, &coords);
            } else {
                this.build_block_min_image(b, pos);
            }
        };
        if parallel {
            blocks.par_iter_mut().for_each(build);
        } else {
            blocks.iter_mut().for_each(build);
        }
        self.blocks = blocks;
        self.coords = coords;
        Ok(())
    }

    /// The slot ranges (with their image shifts) of the stencil of cell `c`: the rows of
    /// neighbour cells along axis 0, each one contiguous range unless it wraps across a
    /// periodic face of axis 0. Needs at least three cells along every periodic axis.
    /// Returns the number of ranges written to `out`.
    fn stencil_ranges(&self, c: [usize; D], out: &mut [SlotRange<D>; MAX_RANGES]) -> usize {
        // Neighbour coordinates along each axis with the shift of the face crossed.
        let axis = |d: usize| -> ([(usize, f64); 3], usize) {
            let n = self.cells[d];
            let mut o = [(0usize, 0.0f64); 3];
            let mut k = 0;
            for t in [c[d].wrapping_sub(1), c[d], c[d] + 1] {
                if t < n {
                    o[k] = (t, 0.0);
                } else if self.periodic[d] {
                    // t = -1: the last cell, whose image next to cell 0 is at x_j - len, so
                    // the separation is (x_i - x_j) - (-len); t = n: the first cell, + len.
                    o[k] = if t == n {
                        (0, self.len[d])
                    } else {
                        (n - 1, -self.len[d])
                    };
                } else {
                    continue;
                }
                k += 1;
            }
            (o, k)
        };
        let axes: [([(usize, f64); 3], usize); D] = std::array::from_fn(axis);
        let mut count = 0;
        // Odometer over the axes 1..D; axis 0 is merged into runs.
        let mut k = [0usize; D];
        loop {
            let mut base = 0;
            let mut shift = [0.0f64; D];
            for d in (1..D).rev() {
                let (t, s) = axes[d].0[k[d]];
                base = base * self.cells[d] + t;
                shift[d] = s;
            }
            base *= self.cells[0];
            // Axis 0: consecutive unshifted cells form one slot range.
            let (ax, na) = axes[0];
            let mut m = 0;
            while m < na {
                let (t0, s0) = ax[m];
                let mut t1 = t0;
                if s0 == 0.0 {
                    while m + 1 < na && ax[m + 1].1 == 0.0 && ax[m + 1].0 == t1 + 1 {
                        m += 1;
                        t1 += 1;
                    }
                }
                let mut sh = shift;
                sh[0] = s0;
                out[count] = SlotRange {
                    start: self.start[base + t0] as usize,
                    end: self.start[base + t1 + 1] as usize,
                    shift: sh,
                };
                count += 1;
                m += 1;
            }
            let mut d = 1;
            loop {
                if d >= D {
                    return count;
                }
                k[d] += 1;
                if k[d] < axes[d].1 {
                    break;
                }
                k[d] = 0;
                d += 1;
            }
        }
    }

    /// [`build_block_per_cell`](Self::build_block_per_cell), compiled for AVX2 when the CPU
    /// has it (AVX-512 measured no faster). The list is the same on every path: the
    /// distances are rounded the same way (no fused multiply-add).
    fn build_block_per_cell_dispatch(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked above).
                unsafe { self.build_block_per_cell_avx2(b, pos, coords) };
                return;
            }
        }
        self.build_block_per_cell(b, pos, coords);
    }

    /// [`build_block_per_cell`](Self::build_block_per_cell) with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn build_block_per_cell_avx2(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
    ) {
        self.build_block_per_cell(b, pos, coords);
    }

    /// Builds block `b` cell by cell: the stencil ranges and their image shifts are found
    /// once per run of particles in the same cell, the distances of each particle to a
    /// range are computed in chunks the compiler vectorises.
    #[inline(always)]
    fn build_block_per_cell(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
    ) {
        let mut ranges = [SlotRange {
            start: 0,
            end: 0,
            shift: [0.0; D],
        }; MAX_RANGES];
        let mut i = b.start;
        while i < b.end {
            let c = self.cell_coords(&pos[i]);
            let mut group_end = i + 1;
            while group_end < b.end && self.cell_coords(&pos[group_end]) == c {
                group_end += 1;
            }
            let nr = self.stencil_ranges(c, &mut ranges);
            // Ranges wholly before the run of particles never hold a partner.
            let mut live = 0;
            for q in 0..nr {
                if ranges[q].end > i + 1 {
                    ranges[live] = ranges[q];
                    live += 1;
                }
            }
            for i in i..group_end {
                let xi: [f64; D] = std::array::from_fn(|d| coords[d][i]);
                for r in &ranges[..live] {
                    let from = r.start.max(i + 1);
                    if r.shift.iter().all(|&s| s == 0.0) {
                        scan::<D, false>(coords, xi, r.shift, self.range2, from, r.end, |j| {
                            b.partners.push(j)
                        });
                    } else {
                        let shift: [T; D] = std::array::from_fn(|d| T::from_f64(r.shift[d]));
                        scan::<D, true>(coords, xi, r.shift, self.range2, from, r.end, |j| {
                            b.image_partners.push((j, shift))
                        });
                    }
                }
                b.offsets.push(b.partners.len() as u32);
                b.image_offsets.push(b.image_partners.len() as u32);
            }
            i = group_end;
        }
    }

    /// Builds block `b` pair by pair with the minimum image of each pair (any number of
    /// cells per periodic axis).
    fn build_block_min_image(&self, b: &mut HalfListBlock<T, D>, pos: &[[T; D]]) {
        let half: [f64; D] = std::array::from_fn(|d| 0.5 * self.len[d]);
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
                            b.image_partners.push((j as u32, shift));
                        } else {
                            b.partners.push(j as u32);
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
            b.offsets.push(b.partners.len() as u32);
            b.image_offsets.push(b.image_partners.len() as u32);
        }
    }
}

/// Calls `hit(j)` for every slot `j` in `from..to` with `|(x_i - x_j) - shift|^2 < range2`
/// (the shift is left out when not `SHIFTED`: it is zero then), in increasing `j`; the
/// distances are computed `CHUNK` candidates at a time in a loop the compiler vectorises.
/// The columns of `coords` hold `CHUNK` padding entries past the last particle.
#[inline(always)]
fn scan<const D: usize, const SHIFTED: bool>(
    coords: &[Vec<f64>; D],
    xi: [f64; D],
    shift: [f64; D],
    range2: f64,
    from: usize,
    to: usize,
    mut hit: impl FnMut(u32),
) {
    let mut j0 = from;
    while j0 < to {
        let m = (to - j0).min(CHUNK);
        let cols: [&[f64]; D] = std::array::from_fn(|d| &coords[d][j0..j0 + CHUNK]);
        let mut mask = 0 as Mask;
        #[allow(
            clippy::needless_range_loop,
            reason = "k indexes the D columns and the mask bits"
        )]
        for k in 0..CHUNK {
            let mut v = 0.0;
            for d in 0..D {
                // (x_i - x_j) - s, rounded as the minimum-image path rounds it.
                let mut t = xi[d] - cols[d][k];
                if SHIFTED {
                    t -= shift[d];
                }
                v += t * t;
            }
            mask |= Mask::from(v < range2) << k;
        }
        mask &= Mask::MAX >> (CHUNK - m);
        while mask != 0 {
            hit((j0 + mask.trailing_zeros() as usize) as u32);
            mask &= mask - 1;
        }
        j0 += m;
    }
}

/// A bit per candidate of a chunk.
type Mask = u64;

/// Candidates whose distances are computed in one go by the per-cell build.
const CHUNK: usize = Mask::BITS as usize;

/// Most slot ranges in a stencil: two per row of neighbour cells along axis 0, 3^(D-1) rows.
const MAX_RANGES: usize = 18;

/// Sorted slots `start..end` of a run of neighbour cells along axis 0, all in the periodic
/// image `shift` (separation `(x_i - x_j) - shift`).
#[derive(Clone, Copy, Debug)]
struct SlotRange<const D: usize> {
    start: usize,
    end: usize,
    shift: [f64; D],
}
