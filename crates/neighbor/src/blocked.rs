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
/// The block boundaries depend only on the particle count and the box
/// ([`block_size`](Self::block_size)), never on the number of threads, so such a loop
/// (reducing the queued reactions in block order) gives bit-identical results for any
/// thread count; the list itself is the same whether it is built serially or on the rayon
/// pool.
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
/// slowest; within a cell the particles are ordered by their first coordinate (ties keep
/// their order, so sorting sorted positions again keeps them in place). Distances are
/// computed in `f64` whatever the precision `T` of the positions.
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
    reach: usize,
    near_reach: usize,
}

impl<T, const D: usize> HalfListBlock<T, D> {
    /// Sets [`reach`](Self::reach) and [`near_reach`](Self::near_reach) from the lists
    /// (loops the compiler vectorises; inlined into the vector builds).
    #[inline(always)]
    fn set_reach(&mut self) {
        let past = |max: u32, empty: bool| if empty { 0 } else { max as usize + 1 };
        let same = self.partners.iter().fold(0, |m, &j| m.max(j));
        let image = self.image_partners.iter().fold(0, |m, &(j, _)| m.max(j));
        self.near_reach = self.end.max(past(same, self.partners.is_empty()));
        self.reach = self
            .near_reach
            .max(past(image, self.image_partners.is_empty()));
    }

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

    /// One past the largest sorted slot the block's pairs touch: the greatest of
    /// [`end`](Self::end) and every partner (of both kinds) plus one, found at the build
    /// (`end()` before the first). A force loop that writes the reactions of the block's
    /// pairs into a buffer of its own needs slots `start()..reach()`.
    #[inline]
    pub fn reach(&self) -> usize {
        self.reach
    }

    /// One past the largest sorted slot among [`end`](Self::end) and the same-image
    /// partners (`end()` before the first build): the slots `start()..near_reach()` hold
    /// the block and, with cells ordered last axis slowest, about one layer of cells
    /// beyond it. Cross-image partners may lie far beyond it: a block in the first layer
    /// of a box periodic along its last axis pairs with the last layer, so
    /// [`reach`](Self::reach) is then about the whole system. A force loop can keep a
    /// dense reaction buffer over `start()..near_reach()` and queue the few cross-image
    /// reactions beyond it apart, holding memory proportional to the block and one layer
    /// instead of the system.
    #[inline]
    pub fn near_reach(&self) -> usize {
        self.near_reach
    }

    /// Number of pairs listed by the block (both kinds).
    pub fn pair_count(&self) -> usize {
        self.partners.len() + self.image_partners.len()
    }
}

impl<T: Real, const D: usize> BlockedHalfList<T, D> {
    /// Particles per block for `n` particles in a grid of `cells` cells per axis:
    /// `max(clamp(n / 16, 256, 4096), min(layer, n / 16))`, where `layer = ceil(n /
    /// cells[D - 1])` is the mean count in one layer of cells along the slowest axis. It
    /// depends on the particle count and the box, never on the thread count.
    ///
    /// Up to 65,536 particles that is 16 blocks (256 particles at least); beyond, blocks of
    /// 4,096 particles or of one layer, whichever is longer, as long as 16 blocks remain.
    /// A force loop that keeps a reaction buffer per block over the block and its
    /// same-image partners ([`HalfListBlock::near_reach`], about one layer beyond the
    /// block) holds and clears `block + layer` entries per block per pass, so blocks of a
    /// layer move about twice the particle count where blocks of 4,096 move `1 + layer /
    /// 4096` times it (7.6 at a million `in.lj` atoms). Fewer, longer blocks cost
    /// parallelism on many cores for small systems: on the 32,000-atom `in.lj` liquid 16
    /// blocks ran 6-7 % faster than 32 on 1 and 2 threads of a 2-core machine.
    pub fn block_size_for(n: usize, cells: [usize; D]) -> usize {
        let layer = n.div_ceil(cells[D - 1].max(1));
        (n / 16).clamp(256, 4096).max(layer.min(n / 16))
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
        let (cells, total) = crate::grid::fit_cells(&len, range, limit);
        let block_size = Self::block_size_for(n, cells);
        let count = n.div_ceil(block_size).max(1);
        let blocks = (0..count)
            .map(|b| {
                let end = ((b + 1) * block_size).min(n);
                HalfListBlock {
                    start: (b * block_size).min(n),
                    end,
                    offsets: Vec::new(),
                    partners: Vec::new(),
                    image_offsets: Vec::new(),
                    image_partners: Vec::new(),
                    reach: end,
                    near_reach: end,
                }
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
    /// [`block_size_for`](Self::block_size_for) (called with [`cells`](Self::cells)).
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

    /// Counting sort of `pos` by cell (last axis slowest), then within each cell by the
    /// first coordinate (`f64` value; NaN last; a stable sort, so ties keep their current
    /// order and the result depends only on the positions and their current order): returns
    /// `order`, where `order[k]` is the current index of the particle that goes to sorted
    /// slot `k`. Positions already in this order are left in place (identity `order`). A
    /// coordinate outside the box goes to the nearest boundary cell; periodic coordinates
    /// must have been wrapped into the box. A NaN coordinate goes to the first
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
        // Small systems stay off the rayon pool (a hand-over costs more than the work).
        let parallel = pos.len() >= 2 * SORT_MIN_LEN;
        let cell = |x: &[T; D]| self.linear(self.cell_coords(x)) as u32;
        if parallel {
            cell_of.par_extend(pos.par_iter().with_min_len(SORT_MIN_LEN).map(cell));
        } else {
            cell_of.extend(pos.iter().map(cell));
        }
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
        // Within a cell by the first coordinate (stable: ties keep their current order), so
        // that `build` finds the candidates of a particle in a slice of each cell; the cells
        // are sorted on the rayon pool in large systems (the same order either way).
        let by_x = |cell: &mut &mut [u32]| {
            if cell.len() > 1 {
                cell.sort_by_key(|&p| x_key(pos[p as usize][0].to_f64()));
            }
        };
        let mut cells: Vec<&mut [u32]> = Vec::with_capacity(nc);
        let mut rest = &mut order[..];
        for c in 0..nc {
            let (cell, tail) = rest.split_at_mut((self.start[c + 1] - self.start[c]) as usize);
            cells.push(cell);
            rest = tail;
        }
        if parallel {
            cells
                .par_iter_mut()
                .with_min_len(SORT_MIN_LEN / 16)
                .for_each(by_x);
        } else {
            cells.iter_mut().for_each(by_x);
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
    /// Each particle checks, in each row of neighbour cells along the first axis, only the
    /// slots whose first coordinate is within the range of its own (a slice of the row,
    /// since `sort` orders every cell by the first coordinate); the distances are then
    /// computed 8 candidates at a time with AVX-512F or AVX2 where the CPU has them, in a
    /// portable vectorised loop otherwise, all rounded alike (no fused multiply-add), so
    /// every path gives the same list. Positions whose cells are not in the order of `sort`
    /// are noticed and take a slower build that checks every slot of the rows.
    ///
    /// Errors: `pos.len()` differs from the particle count.
    pub fn build(&mut self, pos: &[[T; D]], parallel: bool) -> Result<()> {
        self.check_len("build:", pos.len())?;
        let mut blocks = std::mem::take(&mut self.blocks);
        let mut coords = std::mem::replace(&mut self.coords, std::array::from_fn(|_| Vec::new()));
        for (d, col) in coords.iter_mut().enumerate() {
            col.clear();
            if parallel {
                col.par_extend(
                    pos.par_iter()
                        .with_min_len(SORT_MIN_LEN)
                        .map(|x| x[d].to_f64()),
                );
            } else {
                col.extend(pos.iter().map(|x| x[d].to_f64()));
            }
            col.extend([f64::NAN; CHUNK]);
        }
        let this = &*self;
        let per_cell = (0..D).all(|d| !this.periodic[d] || this.cells[d] >= 3);
        // Returns false if the block found a cell whose particles are not in the order of
        // `sort` (first coordinate): the windows would then miss pairs.
        let build = |windowed: bool, b: &mut HalfListBlock<T, D>| -> bool {
            b.offsets.clear();
            b.partners.clear();
            b.offsets.push(0);
            b.image_offsets.clear();
            b.image_partners.clear();
            b.image_offsets.push(0);
            if per_cell {
                this.build_block_per_cell_dispatch(b, pos, &coords, windowed)
            } else {
                this.build_block_min_image(b, pos);
                b.set_reach();
                true
            }
        };
        let build_all = |blocks: &mut [HalfListBlock<T, D>], windowed: bool| -> bool {
            if parallel {
                blocks
                    .par_iter_mut()
                    .map(|b| build(windowed, b))
                    .reduce(|| true, |x, y| x & y)
            } else {
                blocks
                    .iter_mut()
                    .fold(true, |ok, b| build(windowed, b) & ok)
            }
        };
        if !build_all(&mut blocks, true) {
            // Positions not in the order of the last sort within some cell (not the
            // documented use): every candidate of the stencil cells is checked instead.
            build_all(&mut blocks, false);
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
                    first_end: self.start[base + t0 + 1] as usize,
                    last_start: self.start[base + t1] as usize,
                    end: self.start[base + t1 + 1] as usize,
                    shift: sh,
                    shifted: sh.iter().any(|&s| s != 0.0),
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

    /// [`build_block_per_cell`](Self::build_block_per_cell) with the AVX-512F scan where the
    /// CPU has it (with POPCNT), else the AVX2 one, else the portable one. The list is the
    /// same on every path: the distances are rounded the same way (no fused multiply-add).
    fn build_block_per_cell_dispatch(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
        windowed: bool,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            let popcnt = std::arch::is_x86_feature_detected!("popcnt");
            let avx2 = std::arch::is_x86_feature_detected!("avx2");
            if popcnt && avx2 && std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512F, AVX2 and POPCNT (checked above).
                return unsafe { self.build_block_per_cell_avx512(b, pos, coords, windowed) };
            }
            if popcnt && avx2 {
                // SAFETY: the CPU supports AVX2 and POPCNT (checked above).
                return unsafe { self.build_block_per_cell_avx2(b, pos, coords, windowed) };
            }
        }
        self.build_block_per_cell::<PORTABLE>(b, pos, coords, windowed)
    }

    /// [`build_block_per_cell`](Self::build_block_per_cell) with AVX-512F (and AVX2 and
    /// POPCNT, which its hit stores use).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,popcnt")]
    fn build_block_per_cell_avx512(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
        windowed: bool,
    ) -> bool {
        self.build_block_per_cell::<AVX512>(b, pos, coords, windowed)
    }

    /// [`build_block_per_cell`](Self::build_block_per_cell) with AVX2 (and POPCNT).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,popcnt")]
    fn build_block_per_cell_avx2(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
        windowed: bool,
    ) -> bool {
        self.build_block_per_cell::<AVX2>(b, pos, coords, windowed)
    }

    /// Builds block `b` cell by cell: the stencil ranges and their image shifts are found
    /// once per run of particles in the same cell, the distances of each particle to a
    /// range are computed in chunks the compiler vectorises.
    ///
    /// When `windowed`, only the slots of a range whose first coordinate can be within the
    /// list range are checked: `sort` orders every cell by the first coordinate, so these
    /// are a slice from the first cell of the range to its last, and as the particles of a
    /// cell are visited in that order the ends of each slice only move forward. Returns
    /// false if a cell of the block is not in that order (the windowed list is then
    /// incomplete and the caller builds again without windows).
    #[inline(always)]
    fn build_block_per_cell<const ISA: u8>(
        &self,
        b: &mut HalfListBlock<T, D>,
        pos: &[[T; D]],
        coords: &[Vec<f64>; D],
        windowed: bool,
    ) -> bool {
        let mut ranges = [SlotRange::<D>::default(); MAX_RANGES];
        // Cross-image hits of one range before their shifts are attached.
        let mut image = Vec::new();
        let x = &coords[0];
        let mut in_order = true;
        if b.start > 0 && b.start < b.end {
            // The block may begin inside a cell: its predecessor there belongs to the check.
            let k = b.start;
            if self.cell_coords(&pos[k - 1]) == self.cell_coords(&pos[k]) {
                in_order &= x_key(x[k - 1]) <= x_key(x[k]);
            }
        }
        let mut i = b.start;
        while i < b.end {
            let c = self.cell_coords(&pos[i]);
            // The particles of the block in cell `c`, from the sort.
            let group_end = (self.start[self.linear(c) + 1] as usize).clamp(i + 1, b.end);
            let mut amax = x[i].abs();
            for k in i + 1..group_end {
                in_order &= x_key(x[k - 1]) <= x_key(x[k]);
                amax = amax.max(x[k].abs());
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
            // Half width of the windows: the range, widened far beyond the rounding of the
            // separations and of the window ends (relative 2^-52 of the coordinates); one
            // width for the run keeps the window ends monotone in x_i.
            let half = self.range + WINDOW_SLACK * (self.range + amax + self.len[0]);
            // The slice of every live range, `from` in its first cell, `to` in its last.
            let mut windows = [Window::default(); MAX_RANGES];
            for (w, r) in windows.iter_mut().zip(&ranges[..live]) {
                *w = Window {
                    from: r.start,
                    to: if windowed { r.last_start } else { r.end },
                };
            }
            for i in i..group_end {
                let xi: [f64; D] = std::array::from_fn(|d| coords[d][i]);
                for (w, r) in windows.iter_mut().zip(&ranges[..live]) {
                    if windowed {
                        let xs = xi[0] - r.shift[0];
                        let (lo, hi) = (xs - half, xs + half);
                        while w.from < r.first_end && x[w.from] < lo {
                            w.from += 1;
                        }
                        while w.to < r.end && x[w.to] <= hi {
                            w.to += 1;
                        }
                    }
                    let (lo, hi) = (w.from.max(i + 1), w.to);
                    if lo >= hi {
                        continue;
                    }
                    let (sh, r2) = (r.shift, self.range2);
                    if !r.shifted {
                        let out = &mut b.partners;
                        scan_into::<D, false, ISA>(out, coords, xi, sh, r2, lo, hi);
                    } else {
                        image.clear();
                        scan_into::<D, true, ISA>(&mut image, coords, xi, sh, r2, lo, hi);
                        let shift: [T; D] = std::array::from_fn(|d| T::from_f64(sh[d]));
                        b.image_partners.extend(image.iter().map(|&j| (j, shift)));
                    }
                }
                b.offsets.push(b.partners.len() as u32);
                b.image_offsets.push(b.image_partners.len() as u32);
            }
            i = group_end;
        }
        b.set_reach();
        in_order
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

/// Appends to `out` every slot `j` of `from..to` with `|(x_i - x_j) - shift|^2 < range2`,
/// in increasing `j` (see [`scan`]).
#[inline(always)]
#[allow(
    clippy::too_many_arguments,
    reason = "the arguments of scan and the output"
)]
fn scan_into<const D: usize, const SHIFTED: bool, const ISA: u8>(
    out: &mut Vec<u32>,
    coords: &[Vec<f64>; D],
    xi: [f64; D],
    shift: [f64; D],
    range2: f64,
    from: usize,
    to: usize,
) {
    // The bounds the unsafe scan relies on, checked in every build (one comparison per
    // candidate cell, against tens of distance tests).
    assert!(
        from < to && (0..D).all(|d| to + CHUNK <= coords[d].len()),
        "scan_into: candidates {from}..{to} with columns of {} (padding {CHUNK})",
        coords[0].len()
    );
    out.reserve(to - from + STORE_SLACK);
    let len = out.len();
    // SAFETY: `scan` writes below `to - from + STORE_SLACK` entries past `len`, room reserved
    // above, and returns how many of them hold hits; `from < to` and the columns hold
    // `CHUNK` padding entries (the build's contract).
    unsafe {
        let n = scan::<D, SHIFTED, ISA>(
            coords,
            xi,
            shift,
            range2,
            from,
            to,
            out.as_mut_ptr().add(len),
        );
        out.set_len(len + n);
    }
}

/// Writes to `dst[0..]` every slot `j` in `from..to` with `|(x_i - x_j) - shift|^2 < range2`
/// (the shift is left out when not `SHIFTED`: it is zero then), in increasing `j`, and
/// returns their number; the distances are computed several candidates at a time, with
/// the vector instructions `ISA` ([`PORTABLE`]: a loop the compiler vectorises, `CHUNK`
/// candidates at a time). Every path rounds as the minimum-image path does: `((x_i - x_j) -
/// s)^2` summed over the axes in order, no fused multiply-add.
///
/// # Safety
/// `dst` must be valid for writes of `to - from + STORE_SLACK` entries (the vector paths
/// store 8 entries at a time, the hits first); `from < to`; the columns of `coords` hold
/// `CHUNK` padding entries past `to`; the CPU has the features of `ISA`.
#[inline(always)]
unsafe fn scan<const D: usize, const SHIFTED: bool, const ISA: u8>(
    coords: &[Vec<f64>; D],
    xi: [f64; D],
    shift: [f64; D],
    range2: f64,
    from: usize,
    to: usize,
    dst: *mut u32,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        if ISA == AVX2 {
            // SAFETY: passed on from the caller.
            return unsafe { scan_avx2::<D, SHIFTED>(coords, xi, shift, range2, from, to, dst) };
        }
        if ISA == AVX512 {
            // SAFETY: passed on from the caller.
            return unsafe { scan_avx512::<D, SHIFTED>(coords, xi, shift, range2, from, to, dst) };
        }
    }
    let mut n = 0;
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
        mask &= Mask::MAX >> (Mask::BITS as usize - m);
        while mask != 0 {
            // SAFETY: at most one entry per slot of `from..to` (the caller's contract).
            unsafe {
                dst.add(n)
                    .write((j0 + mask.trailing_zeros() as usize) as u32)
            };
            n += 1;
            mask &= mask - 1;
        }
        j0 += m;
    }
    n
}

/// Byte `k` of `COMPRESS[m]` is the position of the `k`-th set bit of the 8-bit mask `m`
/// (then zeros): the lanes a step of 8 candidates stores.
const COMPRESS: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let (mut k, mut bit) = (0, 0);
        while bit < 8 {
            if (m >> bit) & 1 == 1 {
                table[m] |= (bit as u64) << (8 * k);
                k += 1;
            }
            bit += 1;
        }
        m += 1;
    }
    table
};

/// Entries past the hits that a vector path of [`scan`] may overwrite.
const STORE_SLACK: usize = 8;

/// Stores `j + k` for every bit `k` set in the 8-bit `mask` at `dst[n..]` (8 entries
/// written, the hits first, without branches) and returns the new `n`.
///
/// # Safety
/// The CPU supports AVX2 and POPCNT; `dst[n..n + 8]` is valid for writes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
#[inline]
unsafe fn compress_store(mask: u32, j: usize, dst: *mut u32, n: usize) -> usize {
    use std::arch::x86_64::*;
    let lanes = _mm_cvtsi64_si128(COMPRESS[mask as usize & 0xff] as i64);
    // Slots fit in 32 bits (the particle count does); lanes are read back as u32.
    let slots = _mm256_add_epi32(
        _mm256_cvtepu8_epi32(lanes),
        _mm256_set1_epi32(j as u32 as i32),
    );
    // SAFETY: `dst[n..n + 8]` is valid for writes (the caller's contract).
    unsafe { _mm256_storeu_si256(dst.add(n).cast(), slots) };
    n + (mask & 0xff).count_ones() as usize
}

/// [`scan`] with AVX2: 8 candidates (two vectors of 4) per step, the hits stored with
/// [`compress_store`].
///
/// # Safety
/// As [`scan`], on a CPU with AVX2 and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
#[inline]
unsafe fn scan_avx2<const D: usize, const SHIFTED: bool>(
    coords: &[Vec<f64>; D],
    xi: [f64; D],
    shift: [f64; D],
    range2: f64,
    from: usize,
    to: usize,
    dst: *mut u32,
) -> usize {
    use std::arch::x86_64::*;
    let x: [__m256d; D] = std::array::from_fn(|d| _mm256_set1_pd(xi[d]));
    let s: [__m256d; D] = std::array::from_fn(|d| _mm256_set1_pd(shift[d]));
    let r2 = _mm256_set1_pd(range2);
    let ptr: [*const f64; D] = std::array::from_fn(|d| coords[d].as_ptr());
    // The bits of the candidates j0..j0 + 4 H within the range (H = 1 or 2 vectors).
    let step = |j0: usize, vectors: usize| -> u32 {
        let mut v = [_mm256_setzero_pd(); 2];
        for d in 0..D {
            for (h, v) in v.iter_mut().enumerate().take(vectors) {
                // SAFETY: j0 < to, so j0 + 8 <= to + 7 < coords[d].len() (the caller's
                // contract).
                let xj = unsafe { _mm256_loadu_pd(ptr[d].add(j0 + 4 * h)) };
                let mut t = _mm256_sub_pd(x[d], xj);
                if SHIFTED {
                    t = _mm256_sub_pd(t, s[d]);
                }
                let t2 = _mm256_mul_pd(t, t);
                // 0 + t^2 is t^2 (t^2 is never -0), so the first axis needs no add.
                *v = if d == 0 { t2 } else { _mm256_add_pd(*v, t2) };
            }
        }
        let lo = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(v[0], r2)) as u32;
        if vectors == 1 {
            return lo;
        }
        let hi = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(v[1], r2)) as u32;
        lo | hi << 4
    };
    let (mut n, mut j) = (0, from);
    while j + 8 <= to {
        // SAFETY: n <= j - from, so dst[n..n + 8] lies within the caller's room.
        n = unsafe { compress_store(step(j, 2), j, dst, n) };
        j += 8;
    }
    // The rest (fewer than 8) in one step of one or two vectors.
    if j < to {
        let vectors = if to - j > 4 { 2 } else { 1 };
        let mask = step(j, vectors) & (0xff >> (8 - (to - j)));
        // SAFETY: as above.
        n = unsafe { compress_store(mask, j, dst, n) };
    }
    n
}

/// [`scan`] with AVX-512F: 8 candidates (one vector) per step, compared into a mask
/// register, the hits stored with [`compress_store`].
///
/// # Safety
/// As [`scan`], on a CPU with AVX-512F, AVX2 and POPCNT (it stores the hits with the AVX2
/// [`compress_store`]: AVX-512F does not imply AVX2 as a CPU feature bit).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,popcnt")]
#[inline]
unsafe fn scan_avx512<const D: usize, const SHIFTED: bool>(
    coords: &[Vec<f64>; D],
    xi: [f64; D],
    shift: [f64; D],
    range2: f64,
    from: usize,
    to: usize,
    dst: *mut u32,
) -> usize {
    use std::arch::x86_64::*;
    let x: [__m512d; D] = std::array::from_fn(|d| _mm512_set1_pd(xi[d]));
    let s: [__m512d; D] = std::array::from_fn(|d| _mm512_set1_pd(shift[d]));
    let r2 = _mm512_set1_pd(range2);
    let ptr: [*const f64; D] = std::array::from_fn(|d| coords[d].as_ptr());
    // The bits of the candidates j0..j0 + 8 within the range.
    let step = |j0: usize| -> u32 {
        let mut v = _mm512_setzero_pd();
        for d in 0..D {
            // SAFETY: j0 < to, so j0 + 8 <= to + 7 < coords[d].len() (the caller's
            // contract).
            let xj = unsafe { _mm512_loadu_pd(ptr[d].add(j0)) };
            let mut t = _mm512_sub_pd(x[d], xj);
            if SHIFTED {
                t = _mm512_sub_pd(t, s[d]);
            }
            let t2 = _mm512_mul_pd(t, t);
            // 0 + t^2 is t^2 (t^2 is never -0), so the first axis needs no add.
            v = if d == 0 { t2 } else { _mm512_add_pd(v, t2) };
        }
        u32::from(_mm512_cmp_pd_mask::<_CMP_LT_OQ>(v, r2))
    };
    let (mut n, mut j) = (0, from);
    while j + 8 <= to {
        // SAFETY: n <= j - from, so dst[n..n + 8] lies within the caller's room; the CPU
        // has AVX2 and POPCNT (this function's contract).
        n = unsafe { compress_store(step(j), j, dst, n) };
        j += 8;
    }
    if j < to {
        let mask = step(j) & (0xff >> (8 - (to - j)));
        // SAFETY: as above.
        n = unsafe { compress_store(mask, j, dst, n) };
    }
    n
}

/// [`scan`] instruction sets: a loop the compiler vectorises for the target.
const PORTABLE: u8 = 0;
/// [`scan`] instruction sets: AVX2 intrinsics.
const AVX2: u8 = 1;
/// [`scan`] instruction sets: AVX-512F intrinsics.
const AVX512: u8 = 2;

/// Particles per rayon task in the per-particle passes of [`BlockedHalfList::sort`] and
/// [`BlockedHalfList::build`] (cells: a sixteenth of it).
const SORT_MIN_LEN: usize = 4096;

/// A bit per candidate of a chunk of the portable scan.
type Mask = u64;

/// Candidates whose distances the portable scan computes in one go, and the padding past
/// the last particle in the build's coordinate columns (at least the 8 of a vector step).
const CHUNK: usize = Mask::BITS as usize;

/// Most slot ranges in a stencil: two per row of neighbour cells along axis 0, 3^(D-1) rows.
const MAX_RANGES: usize = 18;

/// Sorted slots `start..end` of a run of neighbour cells along axis 0, all in the periodic
/// image `shift` (separation `(x_i - x_j) - shift`).
#[derive(Clone, Copy, Debug)]
struct SlotRange<const D: usize> {
    start: usize,
    /// End of the first cell of the run.
    first_end: usize,
    /// Start of the last cell of the run.
    last_start: usize,
    end: usize,
    shift: [f64; D],
    /// Whether `shift` is not zero.
    shifted: bool,
}

impl<const D: usize> Default for SlotRange<D> {
    fn default() -> Self {
        Self {
            start: 0,
            first_end: 0,
            last_start: 0,
            end: 0,
            shift: [0.0; D],
            shifted: false,
        }
    }
}

/// The slots `from..to` of a [`SlotRange`] that a particle checks (see
/// `build_block_per_cell`).
#[derive(Clone, Copy, Debug, Default)]
struct Window {
    from: usize,
    to: usize,
}

/// Relative widening of the per-particle windows of the per-cell build (see
/// `build_block_per_cell`): far above the rounding error of a separation, far below any
/// width that matters.
const WINDOW_SLACK: f64 = 1e-9;

/// The key of the order of particles within a cell: increasing first coordinate (`-0.0`
/// before `0.0`), every NaN last and equal to the others.
#[inline]
fn x_key(x: f64) -> u64 {
    if x.is_nan() {
        return u64::MAX;
    }
    let bits = x.to_bits();
    // Negative values in reverse bit order below the positive ones (+inf < u64::MAX).
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};

    use super::*;

    /// The per-cell lists of every block of `list` over the sorted `pos` with the scan
    /// `isa`, with or without the windows; `None` if this CPU lacks `isa`. The second item
    /// is whether every cell was in the order of `sort`.
    fn per_cell<const D: usize>(
        list: &BlockedHalfList<f64, D>,
        pos: &[[f64; D]],
        isa: u8,
        windowed: bool,
    ) -> Option<(Vec<HalfListBlock<f64, D>>, bool)> {
        let coords: [Vec<f64>; D] = std::array::from_fn(|d| {
            let mut c: Vec<f64> = pos.iter().map(|x| x[d]).collect();
            c.extend([f64::NAN; CHUNK]);
            c
        });
        let mut blocks = list.blocks.clone();
        let mut in_order = true;
        for b in &mut blocks {
            for v in [&mut b.offsets, &mut b.image_offsets] {
                v.clear();
                v.push(0);
            }
            b.partners.clear();
            b.image_partners.clear();
            in_order &= match isa {
                PORTABLE => list.build_block_per_cell::<PORTABLE>(b, pos, &coords, windowed),
                #[cfg(target_arch = "x86_64")]
                AVX2 if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("popcnt") =>
                {
                    // SAFETY: the CPU supports AVX2 (checked above).
                    unsafe { list.build_block_per_cell_avx2(b, pos, &coords, windowed) }
                }
                #[cfg(target_arch = "x86_64")]
                AVX512
                    if std::arch::is_x86_feature_detected!("avx512f")
                        && std::arch::is_x86_feature_detected!("avx2")
                        && std::arch::is_x86_feature_detected!("popcnt") =>
                {
                    // SAFETY: the CPU supports AVX-512F, AVX2 and POPCNT (checked above).
                    unsafe { list.build_block_per_cell_avx512(b, pos, &coords, windowed) }
                }
                _ => return None,
            };
        }
        Some((blocks, in_order))
    }

    /// Positions in `[lo, lo + len)` (a few outside along closed axes, some non-finite),
    /// dense or sparse, in clusters and on a jittered lattice.
    fn system<const D: usize>(
        rng: &mut rand_pcg::Pcg64,
        len: [f64; D],
        periodic: [bool; D],
        n: usize,
    ) -> Vec<[f64; D]> {
        let side = (n as f64).powf(1.0 / D as f64).ceil() as usize;
        (0..n)
            .map(|k| match k % 5 {
                // A jittered lattice: many equal first coordinates before the jitter.
                0 | 1 => std::array::from_fn(|d| {
                    let site = (k / side.pow(d as u32)) % side;
                    let x = (site as f64 + 0.5) * len[d] / side as f64;
                    (x + rng.random_range(-0.01..0.01)).rem_euclid(len[d])
                }),
                4 if k % 97 == 4 => std::array::from_fn(|d| {
                    [f64::NAN, -f64::NAN, f64::INFINITY, 1.0][(k / 97 + d) % 4]
                }),
                _ => std::array::from_fn(|d| {
                    let out = if periodic[d] { 0.0 } else { 0.1 * len[d] };
                    rng.random_range(-out..len[d] + out)
                }),
            })
            .collect()
    }

    /// Every scan path, with and without the windows, gives the same lists (same order),
    /// on dense and sparse 2D and 3D systems with every mix of periodic axes.
    fn paths_agree<const D: usize>(seed: u64) -> Vec<u8> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut ran = Vec::new();
        for case in 0..12usize {
            let periodic: [bool; D] = std::array::from_fn(|d| (case >> d) & 1 == 1);
            let range = rng.random_range(0.5..1.5);
            let len: [f64; D] = std::array::from_fn(|_| range * rng.random_range(3.0..9.0));
            let n = if case < 6 { 3000 } else { 200 };
            let pos = system(&mut rng, len, periodic, n);
            let mut list = BlockedHalfList::<f64, D>::new([0.0; D], len, periodic, range, n)
                .expect("a valid list");
            let order = list.sort(&pos).expect("sort");
            let sorted: Vec<[f64; D]> = order.iter().map(|&k| pos[k as usize]).collect();
            let (reference, in_order) =
                per_cell(&list, &sorted, PORTABLE, false).expect("portable");
            assert!(in_order, "sort left a cell out of order");
            let pairs: usize = reference.iter().map(HalfListBlock::pair_count).sum();
            assert!(pairs > 0, "case {case}: no pairs");
            for isa in [PORTABLE, AVX2, AVX512] {
                for windowed in [false, true] {
                    let Some((blocks, _)) = per_cell(&list, &sorted, isa, windowed) else {
                        continue;
                    };
                    ran.push(isa);
                    for (b, r) in blocks.iter().zip(&reference) {
                        assert_eq!(b.offsets, r.offsets, "case {case} isa {isa} {windowed}");
                        assert_eq!(b.partners, r.partners, "case {case} isa {isa} {windowed}");
                        assert_eq!(b.image_offsets, r.image_offsets);
                        assert_eq!(b.image_partners, r.image_partners);
                        assert_eq!(b.reach, r.reach);
                        assert_eq!(b.near_reach, r.near_reach);
                    }
                }
            }
        }
        ran
    }

    fn report(test: &str, ran: &[u8]) {
        for (isa, feature) in [(AVX2, "avx2"), (AVX512, "avx512f")] {
            simkit_backend::testing::simd_exercised(test, feature, ran.contains(&isa));
        }
    }

    #[test]
    fn scan_paths_and_windows_give_the_same_lists_2d() {
        report("blocked 2d", &paths_agree::<2>(11));
    }

    #[test]
    fn scan_paths_and_windows_give_the_same_lists_3d() {
        report("blocked 3d", &paths_agree::<3>(12));
    }

    #[test]
    fn the_cell_order_key_is_the_order_of_the_numbers_with_nan_last() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            5e-324,
            1.0,
            1e300,
            f64::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(x_key(w[0]) < x_key(w[1]), "{} {}", w[0], w[1]);
        }
        assert_eq!(x_key(f64::NAN), x_key(-f64::NAN));
        assert!(x_key(f64::INFINITY) < x_key(f64::NAN));
    }

    #[test]
    fn cells_out_of_order_are_found() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(13);
        let pos = system(&mut rng, [6.0; 3], [true; 3], 2000);
        let mut list = BlockedHalfList::<f64, 3>::new([0.0; 3], [6.0; 3], [true; 3], 1.0, 2000)
            .expect("a valid list");
        let order = list.sort(&pos).expect("sort");
        let mut sorted: Vec<[f64; 3]> = order.iter().map(|&k| pos[k as usize]).collect();
        assert!(
            per_cell(&list, &sorted, PORTABLE, true)
                .expect("portable")
                .1
        );
        // Swap two particles of one cell with different first coordinates.
        let k = (0..sorted.len() - 1)
            .find(|&k| {
                list.cell_coords(&sorted[k]) == list.cell_coords(&sorted[k + 1])
                    && sorted[k][0] < sorted[k + 1][0]
            })
            .expect("a cell with two particles");
        sorted.swap(k, k + 1);
        assert!(
            !per_cell(&list, &sorted, PORTABLE, true)
                .expect("portable")
                .1
        );
    }

    #[test]
    fn sort_orders_each_cell_by_the_first_coordinate() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(14);
        let pos = system(&mut rng, [7.0, 5.0], [false, true], 1500);
        let mut list =
            BlockedHalfList::<f64, 2>::new([0.0; 2], [7.0, 5.0], [false, true], 1.1, 1500)
                .expect("a valid list");
        let order = list.sort(&pos).expect("sort");
        let sorted: Vec<[f64; 2]> = order.iter().map(|&k| pos[k as usize]).collect();
        for c in 0..list.start.len() - 1 {
            let (a, b) = (list.start[c] as usize, list.start[c + 1] as usize);
            for k in a + 1..b {
                assert!(x_key(sorted[k - 1][0]) <= x_key(sorted[k][0]));
                if x_key(sorted[k - 1][0]) == x_key(sorted[k][0]) {
                    assert!(order[k - 1] < order[k], "ties must keep their order");
                }
            }
        }
    }
}
