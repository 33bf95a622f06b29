//! Linked-list cells: `head[cell]` and `link[particle]`.

use simkit_backend::{Error, Result};

use crate::stencil::Shell;
use crate::{CellGrid, NeighborSearch};

/// Marks the end of a cell's chain in [`LinkedCells::head`] and [`LinkedCells::link`].
pub const EMPTY: u32 = u32::MAX;

/// Linked-list cells: `head[c]` is the last particle inserted into cell `c`, `link[i]` the
/// particle inserted into the same cell before `i` (or [`EMPTY`]).
///
/// O(N) build with two small arrays and no sorting, but traversal jumps through memory in
/// particle order: prefer [`SortedCells`](crate::SortedCells) for large systems.
#[derive(Clone, Debug)]
pub struct LinkedCells<const D: usize> {
    grid: CellGrid<D>,
    head: Vec<u32>,
    link: Vec<u32>,
    wrapped: Vec<[f64; D]>,
}

impl<const D: usize> LinkedCells<D> {
    /// An empty linked-cell list over `grid`.
    pub fn new(grid: &CellGrid<D>) -> Self {
        Self {
            grid: grid.clone(),
            head: vec![EMPTY; grid.n_cells()],
            link: Vec::new(),
            wrapped: Vec::new(),
        }
    }

    /// `head[c]`: the first particle of cell `c`'s chain.
    pub fn head(&self) -> &[u32] {
        &self.head
    }

    /// `link[i]`: the next particle in `i`'s chain.
    pub fn link(&self) -> &[u32] {
        &self.link
    }

    /// The grid.
    pub fn grid(&self) -> &CellGrid<D> {
        &self.grid
    }
}

impl<const D: usize> NeighborSearch<D> for LinkedCells<D> {
    fn name(&self) -> String {
        "linked cells".into()
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        if positions.len() >= EMPTY as usize {
            return Err(Error::invalid(
                "particle count",
                positions.len(),
                "must be below 2^32 - 1 (indices are stored as u32)",
            ));
        }
        self.wrapped = self.grid.wrap_all(positions)?;
        self.head.fill(EMPTY);
        self.link.clear();
        self.link.resize(positions.len(), EMPTY);
        for (i, &t) in self.wrapped.iter().enumerate() {
            let c = self.grid.cell_of(t);
            self.link[i] = self.head[c];
            self.head[c] = i as u32;
        }
        Ok(())
    }

    fn particle_count(&self) -> usize {
        self.wrapped.len()
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, mut f: F) -> Result<()> {
        let g = &self.grid;
        let rc2 = g.cutoff() * g.cutoff();
        let per_pair = g.needs_min_image_per_pair();
        let mut shell = Shell::new();
        for c in 0..g.n_cells() {
            if self.head[c] == EMPTY {
                continue;
            }
            g.half_shell(c, &mut shell);
            let mut i = self.head[c];
            while i != EMPTY {
                let ti = self.wrapped[i as usize];
                for (k, run) in shell.as_slice().iter().enumerate() {
                    for cc in run.first..run.end {
                        // Inside the own cell, partners are the particles after i in its chain.
                        let mut j = if k == 0 && cc == c {
                            self.link[i as usize]
                        } else {
                            self.head[cc]
                        };
                        while j != EMPTY {
                            let tj = self.wrapped[j as usize];
                            let (sep, r2) = if per_pair {
                                g.separation(ti, tj)
                            } else {
                                let mut sep = [0.0; D];
                                let mut r2 = 0.0;
                                for d in 0..D {
                                    let v = (ti[d] - tj[d]) - run.shift[d];
                                    sep[d] = v;
                                    r2 += v * v;
                                }
                                (sep, r2)
                            };
                            if r2 <= rc2 {
                                f(i as usize, j as usize, sep, r2);
                            }
                            j = self.link[j as usize];
                        }
                    }
                }
                i = self.link[i as usize];
            }
        }
        Ok(())
    }
}
