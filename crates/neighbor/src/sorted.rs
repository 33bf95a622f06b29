//! Sorted ("data-locality") cell lists: counting sort of the particles by cell.

use rayon::prelude::*;

use simkit_backend::{Error, Result};

use crate::CellGrid;
use crate::grid::OutOfBox;
use crate::traverse::{
    COORD_PAD, Coords32, Scratch, TraversalKernel, View, f32_band, visit_cells, visit_particle,
};

/// Cells handed to one rayon task in parallel traversals.
const CELLS_PER_TASK: usize = 64;

/// Particles per rayon task when positions are wrapped and assigned to cells.
const WRAP_BLOCK: usize = 4096;

/// How many particles ahead the scatter prefetches its destination.
const AHEAD: usize = 16;

/// Below this many particles the counting sort runs as one chunk.
const PAR_SORT_MIN: usize = 1 << 15;

/// A slice that several rayon tasks write at distinct indices.
pub(crate) struct SharedSlice<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: only used for writes at indices that no two tasks share (see `write`).
unsafe impl<T: Send> Send for SharedSlice<T> {}
// SAFETY: as above; no reads go through it.
unsafe impl<T: Send> Sync for SharedSlice<T> {}

impl<T> SharedSlice<T> {
    pub(crate) fn new(data: &mut [T]) -> Self {
        Self {
            ptr: data.as_mut_ptr(),
            len: data.len(),
        }
    }

    /// Asks the CPU to fetch the cache line of `index` (a hint: nothing if out of range or
    /// not on x86-64).
    #[inline]
    pub(crate) fn prefetch(&self, index: usize) {
        #[cfg(target_arch = "x86_64")]
        if index < self.len {
            // SAFETY: in bounds; a prefetch neither reads nor writes memory.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    self.ptr.add(index).cast(),
                )
            };
        }
    }

    /// Writes `value` at `index`.
    ///
    /// # Safety
    /// No other write or read of `index` may happen concurrently, and the slice it was made
    /// from must outlive the call without being otherwise accessed.
    #[inline]
    pub(crate) unsafe fn write(&self, index: usize, value: T) {
        assert!(index < self.len, "scatter index out of range");
        // SAFETY: in bounds (checked above); exclusive per the caller's contract.
        unsafe { self.ptr.add(index).write(value) };
    }
}

/// Particles sorted by cell with a counting sort: counts per cell, exclusive prefix sum
/// (`cell_start`), then a scatter of the particle ids into cell order (`order`, ascending
/// ids inside each cell). The wrapped positions are kept in that order as structure of
/// arrays, so a traversal streams through memory.
///
/// Build it once with [`SortedCells::new`] and call [`SortedCells::build`] every step; the
/// buffers are reused. Traversals report original particle indices.
#[derive(Clone, Debug)]
pub struct SortedCells<const D: usize> {
    grid: CellGrid<D>,
    cell_of: Vec<u32>,
    cell_start: Vec<u32>,
    order: Vec<u32>,
    rank: Vec<u32>,
    kernel: TraversalKernel,
    coords: [Vec<f64>; D],
    /// `coords` rounded to `f32`, built only where the AVX-512 kernel runs with a
    /// single-precision first pass (see [`SortedCells::build`]); empty otherwise.
    coords32: [Vec<f32>; D],
    wrapped: Vec<[f64; D]>,
    /// The buffers the next build fills before they replace `cell_of` and `wrapped` (the
    /// last build's, kept for reuse): a build that fails midway leaves the live ones whole.
    spare_cell_of: Vec<u32>,
    spare_wrapped: Vec<[f64; D]>,
    /// The counting sort's scatter target (see [`Slot`]), in sorted order.
    slots: Vec<Slot<D>>,
}

/// One particle as the counting sort scatters it: its wrapped position and id in one
/// 32-byte-aligned record, so that placing a particle writes one cache line; a streaming
/// pass then splits the records into the sorted columns. (Scattering the id and each
/// coordinate to its own column touched four random lines per particle, and the scatter
/// was most of the build.)
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Slot<const D: usize> {
    x: [f64; D],
    id: u32,
}

impl<const D: usize> SortedCells<D> {
    /// An empty cell list over `grid`.
    pub fn new(grid: &CellGrid<D>) -> Self {
        Self {
            grid: grid.clone(),
            cell_of: Vec::new(),
            cell_start: vec![0; grid.n_cells() + 1],
            order: Vec::new(),
            rank: Vec::new(),
            kernel: TraversalKernel::Auto,
            coords: std::array::from_fn(|_| Vec::new()),
            coords32: std::array::from_fn(|_| Vec::new()),
            wrapped: Vec::new(),
            spare_cell_of: Vec::new(),
            spare_wrapped: Vec::new(),
            slots: Vec::new(),
        }
    }

    /// The decision band of the single-precision first pass, where this list runs one: the
    /// AVX-512 kernel, wrapped coordinates bounded by the box (not [`OutOfBox::Clamp`]),
    /// and a box small enough against the cutoff for `f32` to decide most candidates.
    fn band32(&self) -> Option<(f32, f32)> {
        let kernel = match self.kernel {
            TraversalKernel::Auto => TraversalKernel::best(),
            k => k,
        };
        if kernel != TraversalKernel::PackedAvx512
            || !kernel.is_supported()
            || self.grid.out_of_box() == OutOfBox::Clamp
        {
            return None;
        }
        let longest = self.grid.lengths().into_iter().fold(0.0, f64::max);
        f32_band(longest, self.grid.cutoff(), D)
    }

    /// Sorts `positions` into cells (wrapping periodic axes, validating every coordinate).
    /// A build that fails changes nothing: queries answer for the last successful build
    /// (the wrapped positions and cells are written into a second set of buffers, kept
    /// between builds: `n (8 D + 4)` bytes beside the live ones).
    ///
    /// Parallel on the rayon pool: the cell assignment, then a two-pass counting sort over
    /// contiguous chunks of particles (each chunk counts its particles per cell; a prefix
    /// sum over cells and chunks gives every chunk its own write cursor per cell; each chunk
    /// scatters a record of id and position per particle), then a streaming pass that splits
    /// the sorted records into the id and coordinate columns. Ids stay ascending inside a
    /// cell, so the result does not depend on the number of threads.
    pub fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        let n = positions.len();
        if n > u32::MAX as usize - 1 {
            return Err(Error::invalid(
                "particle count",
                n,
                "must be below 2^32 - 1 (indices are stored as u32)",
            ));
        }
        let g = &self.grid;
        // Every coordinate is wrapped and assigned its cell in the spare buffers, which
        // replace the live ones only when all are valid: a failed build leaves the list as
        // the last successful one made it (one pass over the particles: a checking pass
        // before the writing one made the whole build about 1.5x slower at 10^6 particles
        // and 1.7x at 10^5, measured on 2 cores).
        let mut wrapped = std::mem::take(&mut self.spare_wrapped);
        let mut cell_of = std::mem::take(&mut self.spare_cell_of);
        wrapped.resize(n, [0.0; D]);
        cell_of.resize(n, 0);
        // Blocks of particles per task, a plain loop inside (no per-particle closure call).
        let assigned = wrapped
            .par_chunks_mut(WRAP_BLOCK)
            .zip(cell_of.par_chunks_mut(WRAP_BLOCK))
            .enumerate()
            .try_for_each(|(b, (ws, cs))| {
                let first = b * WRAP_BLOCK;
                for (k, (w, c)) in ws.iter_mut().zip(cs.iter_mut()).enumerate() {
                    *w = g.wrap(first + k, positions[first + k])?;
                    *c = g.cell_of(*w) as u32;
                }
                Ok::<(), Error>(())
            });
        if let Err(e) = assigned {
            (self.spare_wrapped, self.spare_cell_of) = (wrapped, cell_of);
            return Err(e);
        }
        self.spare_wrapped = std::mem::replace(&mut self.wrapped, wrapped);
        self.spare_cell_of = std::mem::replace(&mut self.cell_of, cell_of);
        // Pass 1: counts per cell of every chunk. Chunk-private counts cost `n_cells` words
        // each, so sparse grids (many more cells than particles) use one chunk.
        let nc = g.n_cells();
        let threads = rayon::current_num_threads().max(1);
        let chunks = if n >= PAR_SORT_MIN && nc.saturating_mul(threads) <= 4 * n {
            threads
        } else {
            1
        };
        let chunk_len = n.div_ceil(chunks).max(1);
        let mut cursors: Vec<Vec<u32>> = self
            .cell_of
            .par_chunks(chunk_len)
            .map(|cells| {
                let mut count = vec![0u32; nc];
                for &c in cells {
                    count[c as usize] += 1;
                }
                count
            })
            .collect();
        // Prefix sum over (cell, chunk): chunk t writes cell c from cursors[t][c] on.
        self.cell_start.clear();
        self.cell_start.resize(nc + 1, 0);
        let mut acc = 0u32;
        for c in 0..nc {
            self.cell_start[c] = acc;
            for cur in cursors.iter_mut() {
                let k = cur[c];
                cur[c] = acc;
                acc += k;
            }
        }
        self.cell_start[nc] = acc;
        // Pass 2: every chunk scatters its particles (id and position, one record each) into
        // cell order and notes their ranks.
        self.rank.resize(n, 0);
        self.slots.resize(n, Slot { x: [0.0; D], id: 0 });
        let slots = SharedSlice::new(&mut self.slots);
        let (wrapped, cell_of) = (&self.wrapped, &self.cell_of);
        self.rank
            .par_chunks_mut(chunk_len)
            .zip(cursors.par_iter_mut())
            .enumerate()
            .for_each(|(t, (ranks, cursor))| {
                let first = t * chunk_len;
                let last = first + ranks.len();
                for (k, r) in ranks.iter_mut().enumerate() {
                    let i = first + k;
                    if i + AHEAD < last {
                        slots.prefetch(cursor[cell_of[i + AHEAD] as usize] as usize);
                    }
                    let slot = &mut cursor[cell_of[i] as usize];
                    let s = *slot as usize;
                    *slot += 1;
                    *r = s as u32;
                    // SAFETY: the cursors of all chunks and cells cover 0..n without overlap
                    // (prefix sum of the counts), and every particle takes one slot, so each
                    // index `s` is written by exactly one particle of one task.
                    unsafe {
                        slots.write(
                            s,
                            Slot {
                                x: wrapped[i],
                                id: i as u32,
                            },
                        )
                    };
                }
            });
        // Pass 3, streaming: the records into the id column and the coordinate columns (and
        // their single-precision copies where the AVX-512 kernel's first pass runs).
        self.order.resize(n, 0);
        let single = self.band32().is_some();
        for (col, c32) in self.coords.iter_mut().zip(&mut self.coords32) {
            // The padding is read by the distance pass (and masked off), never reported.
            col.resize(n + COORD_PAD, 0.0);
            c32.resize(if single { n + COORD_PAD } else { 0 }, 0.0);
        }
        let order = SharedSlice::new(&mut self.order);
        let coords: [SharedSlice<f64>; D] =
            std::array::from_fn(|d| SharedSlice::new(&mut self.coords[d]));
        let coords32: [SharedSlice<f32>; D] =
            std::array::from_fn(|d| SharedSlice::new(&mut self.coords32[d]));
        self.slots
            .par_chunks(WRAP_BLOCK)
            .enumerate()
            .for_each(|(b, chunk)| {
                for (k, slot) in chunk.iter().enumerate() {
                    let s = b * WRAP_BLOCK + k;
                    // SAFETY: every task writes its own range of sorted positions, below `n`.
                    unsafe {
                        order.write(s, slot.id);
                        for d in 0..D {
                            coords[d].write(s, slot.x[d]);
                            if single {
                                coords32[d].write(s, slot.x[d] as f32);
                            }
                        }
                    }
                }
            });
        Ok(())
    }

    /// The same cell list with another traversal kernel (default [`TraversalKernel::Auto`]: the
    /// fastest this CPU supports). All kernels report the same pairs bit for bit; choosing one
    /// is for measuring or for ruling a kernel out while debugging. Above 2^27 particles the
    /// packed kernels step aside for the portable one.
    ///
    /// Errors: a kernel this CPU cannot run.
    pub fn with_kernel(mut self, kernel: TraversalKernel) -> Result<Self> {
        if !kernel.is_supported() {
            return Err(Error::Unsupported(format!(
                "traversal kernel {kernel:?}: this CPU lacks its instruction set; use \
                 TraversalKernel::Auto (picks {:?} here)",
                TraversalKernel::best()
            )));
        }
        self.kernel = kernel;
        Ok(self)
    }

    /// The traversal kernel (see [`with_kernel`](Self::with_kernel)).
    pub fn kernel(&self) -> TraversalKernel {
        self.kernel
    }

    /// The grid.
    pub fn grid(&self) -> &CellGrid<D> {
        &self.grid
    }

    /// Number of particles of the last build.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether the last build had no particles.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// `cell_start[c]..cell_start[c + 1]` are the sorted positions of cell `c`'s particles
    /// (length `n_cells + 1`).
    pub fn cell_start(&self) -> &[u32] {
        &self.cell_start
    }

    /// The permutation: `order()[k]` is the original index of the particle at sorted
    /// position `k`.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The inverse permutation: `rank()[i]` is the sorted position of particle `i`.
    pub fn rank(&self) -> &[u32] {
        &self.rank
    }

    /// Cell index of every particle (by original index).
    pub fn cell_of(&self) -> &[u32] {
        &self.cell_of
    }

    /// Wrapped positions (relative to the origin) by original index.
    pub fn wrapped(&self) -> &[[f64; D]] {
        &self.wrapped
    }

    /// Wrapped coordinate `d` of every particle in sorted order (structure of arrays), or
    /// `None` for an axis `d >= D`.
    pub fn sorted_coords(&self, d: usize) -> Option<&[f64]> {
        self.coords.get(d).map(|c| &c[..self.order.len()])
    }

    /// Copies `data` (one value per particle, original order) into sorted order, so that a
    /// force loop over sorted particles reads memory sequentially.
    pub fn reorder<T: Clone + Send + Sync>(&self, data: &[T]) -> Result<Vec<T>> {
        self.check_len("reorder", data.len())?;
        Ok(self
            .order
            .par_iter()
            .map(|&i| data[i as usize].clone())
            .collect())
    }

    /// The inverse of [`reorder`](Self::reorder): back from sorted to original order.
    pub fn restore<T: Clone + Send + Sync>(&self, sorted: &[T]) -> Result<Vec<T>> {
        self.check_len("restore", sorted.len())?;
        Ok(self
            .rank
            .par_iter()
            .map(|&k| sorted[k as usize].clone())
            .collect())
    }

    fn check_len(&self, what: &str, len: usize) -> Result<()> {
        if len != self.order.len() {
            return Err(Error::invalid(
                format!("{what}: data length"),
                len,
                format!(
                    "must equal the particle count of the last build ({})",
                    self.len()
                ),
            ));
        }
        Ok(())
    }

    pub(crate) fn view(&self) -> View<'_, D> {
        View {
            grid: &self.grid,
            cell_start: &self.cell_start,
            order: &self.order,
            kernel: self.kernel,
            coords: std::array::from_fn(|d| self.coords[d].as_slice()),
            coords32: self.band32().and_then(|(lo, hi)| {
                // Built by the last `build` (not when the kernel was changed after it).
                (self.coords32[0].len() == self.coords[0].len()).then(|| Coords32 {
                    cols: std::array::from_fn(|d| self.coords32[d].as_slice()),
                    lo,
                    hi,
                })
            }),
        }
    }

    /// Calls `f(i, j, sep, r2)` once for every unordered pair within the cutoff (half-shell
    /// traversal), with `sep = r_i - r_j` (minimum image) and `r2 = |sep|^2`. Which of the
    /// two particles is `i` is unspecified.
    pub fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&self, mut f: F) {
        let mut s = Scratch::new();
        visit_cells(&self.view(), 0..self.grid.n_cells(), true, &mut s, &mut f);
    }

    /// Calls `f(i, j, sep, r2)` for every ordered pair within the cutoff (full-shell
    /// traversal: each pair twice, once from each end, in sorted order of `i`).
    pub fn for_each_neighbor<F: FnMut(usize, usize, [f64; D], f64)>(&self, mut f: F) {
        let mut s = Scratch::new();
        visit_cells(&self.view(), 0..self.grid.n_cells(), false, &mut s, &mut f);
    }

    /// Parallel half-shell traversal: cells are split over rayon tasks, each task folds the
    /// pairs it visits into its own accumulator made by `init`; returns the accumulators
    /// (combine them: e.g. sum per-task force arrays). Race-free without atomics.
    pub fn par_fold_pairs<T, I, F>(&self, init: I, f: F) -> Vec<T>
    where
        T: Send,
        I: Fn() -> T + Sync + Send,
        F: Fn(&mut T, usize, usize, [f64; D], f64) + Sync + Send,
    {
        let v = self.view();
        let nc = self.grid.n_cells();
        (0..nc.div_ceil(CELLS_PER_TASK))
            .into_par_iter()
            .fold(
                || (init(), Scratch::new()),
                |(mut acc, mut s), t| {
                    let cells = t * CELLS_PER_TASK..((t + 1) * CELLS_PER_TASK).min(nc);
                    visit_cells(&v, cells, true, &mut s, &mut |i, j, sep, r2| {
                        f(&mut acc, i, j, sep, r2)
                    });
                    (acc, s)
                },
            )
            .map(|(acc, _)| acc)
            .collect()
    }

    /// Number of unordered pairs within the cutoff (parallel).
    pub fn par_pair_count(&self) -> usize {
        self.par_fold_pairs(|| 0usize, |n, _, _, _, _| *n += 1)
            .into_iter()
            .sum()
    }

    /// Parallel gather (full shell): for every particle `i` (original index) calls
    /// `f(&mut out[i], i, j, sep, r2)` for each of its neighbours `j`. Each task writes only
    /// its own `out[i]`, so a force loop needs no atomics. Fastest when the particle data
    /// has been put in sorted order (see [`reorder`](Self::reorder)).
    pub fn par_for_each_particle<T, F>(&self, out: &mut [T], f: F) -> Result<()>
    where
        T: Send,
        F: Fn(&mut T, usize, usize, [f64; D], f64) + Sync + Send,
    {
        self.check_len("par_for_each_particle: output", out.len())?;
        let v = self.view();
        out.par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each_init(Scratch::new, |s, (i, o)| {
                let rank = self.rank[i] as usize;
                let cell = self.cell_of[i] as usize;
                visit_particle(&v, rank, cell, false, s, &mut |a, j, sep, r2| {
                    f(o, a, j, sep, r2)
                });
            });
        Ok(())
    }

    /// Calls `f(j, sep, r2)` for every neighbour `j` of particle `i` (full shell), with
    /// `sep = r_i - r_j` (minimum image) and `r2 = |sep|^2`.
    ///
    /// Errors: no particle `i` in the last build (`i >= len()`).
    pub fn for_each_neighbor_of<F: FnMut(usize, [f64; D], f64)>(
        &self,
        i: usize,
        mut f: F,
    ) -> Result<()> {
        if i >= self.len() {
            return Err(Error::invalid(
                "particle index",
                i,
                format!("the last build has {} particles", self.len()),
            ));
        }
        let mut s = Scratch::new();
        let (rank, cell) = (self.rank[i] as usize, self.cell_of[i] as usize);
        visit_particle(
            &self.view(),
            rank,
            cell,
            false,
            &mut s,
            &mut |_, j, sep, r2| f(j, sep, r2),
        );
        Ok(())
    }
}

impl<const D: usize> crate::NeighborSearch<D> for SortedCells<D> {
    fn name(&self) -> String {
        "sorted cells".into()
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        SortedCells::build(self, positions)
    }

    fn particle_count(&self) -> usize {
        self.len()
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, f: F) -> Result<()> {
        SortedCells::for_each_pair(self, f);
        Ok(())
    }
}
