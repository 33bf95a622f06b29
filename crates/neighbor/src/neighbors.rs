//! [`Neighbors`]: the neighbour search on either backend, chosen by a [`Backend`] value.

use simkit_backend::{Backend, Result};

#[cfg(feature = "gpu")]
use crate::GpuNeighborSearch;
use crate::{CellGrid, Config, NeighborSearch, SortedCells};

/// The recommended neighbour search on the backend a [`Backend`] value names: sorted cells
/// with the half-shell traversal on the CPU ([`SortedCells`]), the device-resident sorted
/// cell list and CSR half list on the GPU ([`GpuNeighborSearch`](crate::GpuNeighborSearch)).
///
/// Both find the same pairs (up to pairs within `f32` rounding of the cutoff on the GPU).
///
/// ```
/// use simkit_backend::Backend;
/// use simkit_neighbor::{CellGrid, Config, NeighborSearch, Neighbors};
/// # fn main() -> simkit_backend::Result<()> {
/// let grid = CellGrid::new([0.0; 2], [10.0; 2], [true; 2], 1.5)?;
/// let mut search = Neighbors::new(&grid, &Config::default(), Backend::Cpu)?;
/// search.build(&[[0.2, 5.0], [9.9, 5.0], [5.0, 5.0]])?;
/// assert_eq!(search.pair_count()?, 1); // across the periodic x face
/// # Ok(())
/// # }
/// ```
pub struct Neighbors<const D: usize> {
    engine: Engine<D>,
}

impl<const D: usize> std::fmt::Debug for Neighbors<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Neighbors")
            .field("method", &self.name())
            .finish()
    }
}

/// The backend behind a [`Neighbors`] (an enum, not a trait object: pair enumeration is
/// generic over the callback).
enum Engine<const D: usize> {
    Cpu(Box<SortedCells<D>>),
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuNeighborSearch<D>>),
}

impl<const D: usize> Neighbors<D> {
    /// A search over `grid` with `config` on `backend`. Errors: a kernel this CPU lacks
    /// (naming the one [`TraversalKernel::Auto`](crate::TraversalKernel::Auto) picks), a grid
    /// over the GPU's limits.
    pub fn new(grid: &CellGrid<D>, config: &Config, backend: Backend<'_>) -> Result<Self> {
        let engine = match backend {
            Backend::Cpu => {
                Engine::Cpu(Box::new(SortedCells::new(grid).with_kernel(config.kernel)?))
            }
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Engine::Gpu(Box::new(GpuNeighborSearch::new(ctx, grid)?)),
        };
        Ok(Self { engine })
    }
}

impl<const D: usize> NeighborSearch<D> for Neighbors<D> {
    fn name(&self) -> String {
        match &self.engine {
            Engine::Cpu(s) => s.name(),
            #[cfg(feature = "gpu")]
            Engine::Gpu(s) => s.name(),
        }
    }

    fn build(&mut self, positions: &[[f64; D]]) -> Result<()> {
        match &mut self.engine {
            Engine::Cpu(s) => NeighborSearch::build(s.as_mut(), positions),
            #[cfg(feature = "gpu")]
            Engine::Gpu(s) => s.build(positions),
        }
    }

    fn particle_count(&self) -> usize {
        match &self.engine {
            Engine::Cpu(s) => s.particle_count(),
            #[cfg(feature = "gpu")]
            Engine::Gpu(s) => s.particle_count(),
        }
    }

    fn for_each_pair<F: FnMut(usize, usize, [f64; D], f64)>(&mut self, f: F) -> Result<()> {
        match &mut self.engine {
            Engine::Cpu(s) => NeighborSearch::for_each_pair(s.as_mut(), f),
            #[cfg(feature = "gpu")]
            Engine::Gpu(s) => s.for_each_pair(f),
        }
    }
}
