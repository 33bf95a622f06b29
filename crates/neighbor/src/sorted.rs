//! Sorted ("data-locality") cell lists: counting sort of the particles by cell.

use rayon::prelude::*;

use backend::{Error, Result};

use crate::CellGrid;
use crate::traverse::{Scratch, View, visit_cells, visit_particle};

/// Cells handed to one rayon task in parallel traversals.
const CELLS_PER_TASK: usize = 64;

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
    coords: [Vec<f64>; D],
    wrapped: Vec<[f64; D]>,
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
            coords: std::array::from_fn(|_| Vec::new()),
            wrapped: Vec::new(),
        }
    }

    /// Sorts `positions` into cells (wrapping periodic axes, validating every coordinate).
    ///
    /// The cell assignment and the gather of positions run in parallel on the rayon pool;
    /// the counting sort itself is serial (it is a small part of the cost). The result does
    /// not depend on the number of threads.
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
        self.wrapped.resize(n, [0.0; D]);
        self.cell_of.resize(n, 0);
        self.wrapped
            .par_iter_mut()
            .zip(self.cell_of.par_iter_mut())
            .enumerate()
            .with_min_len(4096)
            .try_for_each(|(i, (w, c))| {
                *w = g.wrap(i, positions[i])?;
                *c = g.cell_of(*w) as u32;
                Ok::<(), Error>(())
            })?;
        // Counting sort: counts, exclusive prefix sum, scatter (ascending ids per cell).
        let nc = g.n_cells();
        self.cell_start.clear();
        self.cell_start.resize(nc + 1, 0);
        for &c in &self.cell_of {
            self.cell_start[c as usize] += 1;
        }
        backend::prefix::exclusive_scan(&mut self.cell_start);
        self.order.resize(n, 0);
        self.rank.resize(n, 0);
        let mut cursor: Vec<u32> = self.cell_start[..nc].to_vec();
        for (i, &c) in self.cell_of.iter().enumerate() {
            let slot = &mut cursor[c as usize];
            self.order[*slot as usize] = i as u32;
            self.rank[i] = *slot;
            *slot += 1;
        }
        let order = &self.order;
        let wrapped = &self.wrapped;
        for (d, col) in self.coords.iter_mut().enumerate() {
            col.resize(n, 0.0);
            col.par_iter_mut()
                .zip(order.par_iter())
                .with_min_len(8192)
                .for_each(|(x, &i)| *x = wrapped[i as usize][d]);
        }
        Ok(())
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

    /// Wrapped coordinate `d` of every particle in sorted order (structure of arrays).
    pub fn sorted_coords(&self, d: usize) -> &[f64] {
        &self.coords[d]
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
            coords: std::array::from_fn(|d| self.coords[d].as_slice()),
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

    /// Neighbours of particle `i` (full shell), each with separation and squared distance.
    pub fn for_each_neighbor_of<F: FnMut(usize, [f64; D], f64)>(&self, i: usize, mut f: F) {
        if i >= self.len() {
            return;
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
