//! Neighbour search for particle simulations: every pair of particles closer than a cutoff,
//! in 2D and 3D boxes with any mix of periodic and closed axes, on the CPU (serial and rayon)
//! and on the GPU (wgpu), all proven to find the same pairs.
//!
//! # Dimension
//! One implementation serves both dimensions through a const generic: [`CellGrid<2>`] and
//! [`CellGrid<3>`] over positions `[f64; D]` (`glam::DVec3::to_array()` gives one). Other `D`
//! are refused with an error by [`CellGrid::new`].
//!
//! # Methods
//! - [`BruteForce`]: O(N^2) reference.
//! - [`LinkedCells`]: `head`/`link` arrays, O(N) build, random memory access.
//! - [`SortedCells`]: counting sort by cell (`cell_start`, permutation `order`, reorder
//!   helpers), structure-of-arrays positions in cell order; the fastest traversal, with
//!   half-shell ([`SortedCells::for_each_pair`], [`SortedCells::par_fold_pairs`]) and
//!   full-shell ([`SortedCells::for_each_neighbor`], [`SortedCells::par_for_each_particle`])
//!   loops.
//! - [`VerletList`]: CSR half or full list within `cutoff + skin`, with
//!   [`VerletList::needs_rebuild`] / [`VerletList::update`].
//! - [`BlockedHalfList`]: cell-sorted half list within `cutoff + skin` in fixed blocks of
//!   consecutive particles ([`HalfListBlock`]), cross-image pairs stored apart with their
//!   shift; for block-parallel force loops with Newton's third law that are bit-identical
//!   for any thread count (the `dem` CPU backend's list).
//! - [`GhostedList`]: one rank's particles in a spatial decomposition over MPI ranks, with
//!   ghost copies from the neighbouring regions and full lists sorted by global index (the
//!   distributed runs of `dem` and `md`, whose results do not depend on the rank count).
//! - GPU: [`GpuCellList`] (device-resident sorted cells whose buffers other kernels bind,
//!   plus [`CELLS_WGSL`] helper functions), [`GpuNeighborList`] (CSR count-then-fill) and
//!   [`GpuNeighborSearch`] (the [`NeighborSearch`] trait on the GPU).
//!
//! All of them but [`BlockedHalfList`] and [`GhostedList`] implement [`NeighborSearch`]. [`Neighbors`] picks the
//! recommended one (sorted cells, or the GPU search) from a [`simkit_backend::Backend`]
//! value, built like every simkit simulation:
//! `Neighbors::new(&grid, &Config::default(), backend)`.
//!
//! # Conventions
//! Pairs are reported as `(i, j, sep, r2)` with original particle indices, the minimum image
//! separation `sep = r_i - r_j` and `r2 = |sep|^2 <= cutoff^2`; see [`CellGrid`] for wrapping
//! and cell sizes. Half-shell traversals report each unordered pair once (which particle is
//! `i` is unspecified); full-shell traversals report each pair from both ends.
//!
//! ```
//! use simkit_neighbor::{CellGrid, NeighborSearch, SortedCells};
//! # fn main() -> simkit_backend::Result<()> {
//! let grid = CellGrid::new([0.0; 3], [10.0; 3], [true; 3], 2.5)?;
//! let positions = vec![[0.5, 0.5, 0.5], [9.5, 0.5, 0.5], [5.0, 5.0, 5.0]];
//! let mut cells = SortedCells::new(&grid);
//! cells.build(&positions)?;
//! let mut pairs = Vec::new();
//! cells.for_each_pair(|i, j, sep, r2| pairs.push((i.min(j), i.max(j), sep, r2)));
//! assert_eq!(pairs.len(), 1); // 0 and 1 meet across the periodic x face
//! assert_eq!((pairs[0].0, pairs[0].1), (0, 1));
//! assert!((pairs[0].3 - 1.0).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod blocked;
mod brute;
mod config;
mod ghosted;
#[cfg(feature = "gpu")]
mod gpu;
mod grid;
mod linked;
mod neighbors;
mod rank;
mod run;
mod search;
mod sorted;
mod stencil;
mod traverse;
mod verlet;

pub use blocked::{BlockedHalfList, HalfListBlock};
pub use brute::BruteForce;
pub use config::Config;
pub use ghosted::GhostedList;
#[cfg(feature = "gpu")]
pub use gpu::{
    AnyGpuCellList, CELLS_WGSL, GPU_LOOP_RESERVE, GPU_MAX_CELLS_PER_AXIS, GPU_MAX_PER_CELL,
    GpuCellBuffers, GpuCellList, GpuGridParams, GpuNeighborList, GpuNeighborSearch,
    positions_to_f32,
};
pub use grid::{CELL_MARGIN, CellGrid, MAX_CELLS, OutOfBox, wrap_periodic};
pub use linked::{EMPTY, LinkedCells};
pub use neighbors::Neighbors;
pub use rank::{Finding, Parts, RECORD, RankParticles, Record};
pub use run::{ByDim, DistributedRun, RankRun, RankView};
pub use search::{NeighborLists, NeighborSearch};
pub use sorted::SortedCells;
pub use stencil::{HALF_SHELL_2D, HALF_SHELL_3D};
pub use traverse::TraversalKernel;
pub use verlet::{ListKind, VerletList};
