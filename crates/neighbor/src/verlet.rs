//! Verlet neighbour lists with a skin, built from sorted cells.

use rayon::prelude::*;

use simkit_backend::{Error, Result};

use std::ops::Range;

use crate::sorted::SharedSlice;
use crate::traverse::{Scratch, visit_cells};
use crate::{CellGrid, NeighborSearch, SortedCells};

/// Cells handed to one rayon task when building a list.
const CELLS_PER_BLOCK: usize = 64;

/// Which pairs a [`VerletList`] stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ListKind {
    /// Each unordered pair once (Newton's third law force loops).
    Half,
    /// Each pair in both particles' lists (gather loops with no write conflicts).
    Full,
}

/// A Verlet neighbour list in CSR form: every pair closer than `cutoff + skin` at build time.
///
/// While no particle has moved more than `skin / 2` (minimum image) since the build, the list
/// still holds every pair within `cutoff`, so enumeration only filters it with the current
/// positions. [`needs_rebuild`](Self::needs_rebuild) tests that condition and
/// [`update`](Self::update) rebuilds when it fails. The build is parallel: a count pass per
/// particle, a prefix sum, and a fill pass.
#[derive(Clone, Debug)]
pub struct VerletList<const D: usize> {
    grid: CellGrid<D>,
    skin: f64,
    kind: ListKind,
    cells: SortedCells<D>,
    offsets: Vec<usize>,
    neighbors: Vec<u32>,
    reference: Vec<[f64; D]>,
    current: Vec<[f64; D]>,
    builds: u64,
}

impl<const D: usize> VerletList<D> {
    /// A list for pairs within `grid.cutoff()`, stored up to `cutoff + skin`.
    ///
    /// Errors: a negative or non-finite skin, or a list range `cutoff + skin` that is not a
    /// valid cutoff of `grid`'s box (see [`CellGrid::new`]).
    pub fn new(grid: &CellGrid<D>, skin: f64, kind: ListKind) -> Result<Self> {
        if !(skin.is_finite() && skin >= 0.0) {
            return Err(Error::invalid("skin", skin, "must be finite and >= 0"));
        }
        let range = grid.cutoff() + skin;
        let list_grid = grid.with_cutoff(range).map_err(|e| {
            Error::invalid(
                "skin",
                skin,
                format!(
                    "the list range cutoff + skin = {range} is refused ({e}); use a smaller skin"
                ),
            )
        })?;
        Ok(Self {
            grid: grid.clone(),
            skin,
            kind,
            cells: SortedCells::new(&list_grid),
            offsets: vec![0],
            neighbors: Vec::new(),
            reference: Vec::new(),
            current: Vec::new(),
            builds: 0,
        })
    }

    /// Builds the list from `positions`.
    ///
    /// Parallel over blocks of cells (each block owns the contiguous sorted range of its
    /// particles): a count pass, a prefix sum in particle order, and a fill pass; the entries
    /// of every particle are then sorted ascending, so the list does not depend on the
    /// number of threads.
    pub fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        self.cells.build(positions)?;
        let n = positions.len();
        let half = self.kind == ListKind::Half;
        let cells = &self.cells;
        let v = cells.view();
        let nc = cells.grid().n_cells();
        let cs = cells.cell_start();
        let rank = cells.rank();
        let blocks: Vec<Range<usize>> = (0..nc.div_ceil(CELLS_PER_BLOCK))
            .map(|b| b * CELLS_PER_BLOCK..((b + 1) * CELLS_PER_BLOCK).min(nc))
            .collect();
        // Count pass: entries per particle, indexed by sorted rank.
        let mut counts = vec![0usize; n];
        let mut parts: Vec<(Range<usize>, &mut [usize])> = Vec::with_capacity(blocks.len());
        let mut rest = counts.as_mut_slice();
        for b in &blocks {
            let len = (cs[b.end] - cs[b.start]) as usize;
            let (a, r) = rest.split_at_mut(len);
            parts.push((b.clone(), a));
            rest = r;
        }
        parts
            .into_par_iter()
            .for_each_init(Scratch::new, |s, (b, out)| {
                let base = cs[b.start] as usize;
                visit_cells(&v, b, half, s, &mut |i, _, _, _| {
                    out[rank[i] as usize - base] += 1;
                });
            });
        // Offsets in particle order.
        self.offsets.clear();
        self.offsets.reserve(n + 1);
        let mut acc = 0usize;
        for &r in rank {
            self.offsets.push(acc);
            acc += counts[r as usize];
        }
        self.offsets.push(acc);
        // Fill pass: every block writes the lists of its own particles.
        self.neighbors.clear();
        self.neighbors.resize(acc, 0);
        let offsets = &self.offsets;
        let order = cells.order();
        let entries = SharedSlice::new(&mut self.neighbors);
        blocks.into_par_iter().for_each_init(Scratch::new, |s, b| {
            let (first, last) = (cs[b.start] as usize, cs[b.end] as usize);
            let mut cursor: Vec<usize> = order[first..last]
                .iter()
                .map(|&i| offsets[i as usize])
                .collect();
            visit_cells(&v, b, half, s, &mut |i, j, _, _| {
                let slot = &mut cursor[rank[i] as usize - first];
                // SAFETY: particle i's entries offsets[i]..offsets[i + 1] belong to this
                // block alone (i is in one of its cells), and the count pass gave exactly
                // that many entries, so every slot is written once by one task.
                unsafe { entries.write(*slot, j as u32) };
                *slot += 1;
            });
        });
        let mut lists: Vec<&mut [u32]> = Vec::with_capacity(n);
        let mut rest = self.neighbors.as_mut_slice();
        for w in self.offsets.windows(2) {
            let (a, r) = rest.split_at_mut(w[1] - w[0]);
            lists.push(a);
            rest = r;
        }
        lists
            .into_par_iter()
            .with_min_len(1024)
            .for_each(|l| l.sort_unstable());
        self.reference = self.cells.wrapped().to_vec();
        self.current.clone_from(&self.reference);
        self.builds += 1;
        Ok(())
    }

    /// Whether some particle moved farther than `skin / 2` (minimum image) since the last
    /// build, or the particle count changed: the list may then miss a pair.
    pub fn needs_rebuild(&self, positions: &[[f64; D]]) -> Result<bool> {
        if positions.len() != self.reference.len() || self.builds == 0 {
            return Ok(true);
        }
        let limit = 0.25 * self.skin * self.skin;
        let g = &self.grid;
        positions
            .par_iter()
            .zip(self.reference.par_iter())
            .enumerate()
            .with_min_len(4096)
            .try_fold(
                || false,
                |acc, (i, (&p, &r))| {
                    let t = g.wrap(i, p)?;
                    Ok::<bool, Error>(acc || g.separation(t, r).1 > limit)
                },
            )
            .try_reduce(|| false, |a, b| Ok(a || b))
    }

    /// Takes new positions: rebuilds the list when [`needs_rebuild`](Self::needs_rebuild)
    /// says so (returns `true`), otherwise only stores the positions (returns `false`).
    pub fn update(&mut self, positions: &[[f64; D]]) -> Result<bool> {
        if self.needs_rebuild(positions)? {
            self.build(positions)?;
            return Ok(true);
        }
        let g = &self.grid;
        self.current
            .par_iter_mut()
            .enumerate()
            .with_min_len(4096)
            .try_for_each(|(i, c)| {
                *c = g.wrap(i, positions[i])?;
                Ok::<(), Error>(())
            })?;
        Ok(false)
    }

    /// The interaction grid (cutoff without skin).
    pub fn grid(&self) -> &CellGrid<D> {
        &self.grid
    }

    /// The skin.
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// Half or full list.
    pub fn kind(&self) -> ListKind {
        self.kind
    }

    /// How many times the list was built.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// CSR offsets (`N + 1`): particle `i`'s list is `indices()[offsets()[i]..offsets()[i + 1]]`.
    pub fn offsets(&self) -> &[usize] {
        &self.offsets
    }

    /// CSR neighbour indices (ascending per particle).
    pub fn indices(&self) -> &[u32] {
        &self.neighbors
    }

    /// The stored list of particle `i` (pairs within `cutoff + skin` at build time), or
    /// `None` if there is no particle `i` in the last build.
    pub fn list_of(&self, i: usize) -> Option<&[u32]> {
        (i < self.current.len()).then(|| self.stored(i))
    }

    /// The stored list of particle `i`, known to exist.
    #[inline]
    fn stored(&self, i: usize) -> &[u32] {
        &self.neighbors[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Number of stored entries.
    pub fn stored_entries(&self) -> usize {
        self.neighbors.len()
    }

    #[inline]
    fn filter<F: FnMut(usize, usize, [f64; D], f64)>(&self, i: usize, rc2: f64, f: &mut F) {
        let ti = self.current[i];
        for &j in self.stored(i) {
            let (sep, r2) = self.grid.separation(ti, self.current[j as usize]);
            if r2 <= rc2 {
                f(i, j as usize, sep, r2);
            }
        }
    }

    /// Calls `f(i, j, sep, r2)` once per unordered pair within the cutoff, using the
    /// positions of the last [`build`](Self::build) or [`update`](Self::update).
    pub fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&self, mut f: F) {
        let rc2 = self.grid.cutoff().powi(2);
        let full = self.kind == ListKind::Full;
        for i in 0..self.current.len() {
            self.filter(i, rc2, &mut |i, j, sep, r2| {
                if !full || j > i {
                    f(i, j, sep, r2);
                }
            });
        }
    }

    /// Parallel version of [`for_each_pair`](Self::for_each_pair): every rayon task folds
    /// its pairs into its own accumulator made by `init`; returns the accumulators.
    pub fn par_fold_pairs<T, I, F>(&self, init: I, f: F) -> Vec<T>
    where
        T: Send,
        I: Fn() -> T + Sync + Send,
        F: Fn(&mut T, usize, usize, [f64; D], f64) + Sync + Send,
    {
        let rc2 = self.grid.cutoff().powi(2);
        let full = self.kind == ListKind::Full;
        (0..self.current.len())
            .into_par_iter()
            .with_min_len(512)
            .fold(&init, |mut acc, i| {
                self.filter(i, rc2, &mut |i, j, sep, r2| {
                    if !full || j > i {
                        f(&mut acc, i, j, sep, r2);
                    }
                });
                acc
            })
            .collect()
    }

    /// Parallel gather over a full list: calls `f(&mut out[i], i, j, sep, r2)` for every
    /// neighbour `j` of every particle `i`, each task writing only its own `out[i]`.
    ///
    /// Errors: a half list (build with [`ListKind::Full`]), or `out` of the wrong length.
    pub fn par_for_each_particle<T, F>(&self, out: &mut [T], f: F) -> Result<()>
    where
        T: Send,
        F: Fn(&mut T, usize, usize, [f64; D], f64) + Sync + Send,
    {
        if self.kind != ListKind::Full {
            return Err(Error::Unsupported(
                "par_for_each_particle needs a full list: create the VerletList with \
                 ListKind::Full"
                    .into(),
            ));
        }
        if out.len() != self.current.len() {
            return Err(Error::invalid(
                "par_for_each_particle: output length",
                out.len(),
                format!("must equal the particle count ({})", self.current.len()),
            ));
        }
        let rc2 = self.grid.cutoff().powi(2);
        out.par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, o)| self.filter(i, rc2, &mut |i, j, sep, r2| f(o, i, j, sep, r2)));
        Ok(())
    }
}

impl<const D: usize> NeighborSearch<D> for VerletList<D> {
    fn name(&self) -> String {
        format!("Verlet list (skin {})", self.skin)
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        VerletList::build(self, positions)
    }

    fn particle_count(&self) -> usize {
        self.current.len()
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, f: F) -> Result<()> {
        VerletList::for_each_pair(self, f);
        Ok(())
    }
}
