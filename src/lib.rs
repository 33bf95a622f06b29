//! # simkit
//!
//! Reusable simulation libraries, each with a CPU and a GPU backend behind a common trait:
//!
//! | crate | what |
//! |---|---|
//! | [`neighbor`] | linked-list and sorted cell lists, half-shell search, Verlet lists |
//! | [`dem`] | spring–dashpot granular dynamics with Verlet integration |
//! | [`lattice_gas`] | FHP D2Q6 lattice-gas automaton |
//! | [`rd`] | reaction–diffusion with a tiled stencil |
//! | [`pp_coulomb`] | normalised direct-sum Coulomb particle–particle method |
//! | [`md`] | multi-species molecular dynamics with a species-pair table of Lennard-Jones-type potentials |
//! | [`backend`] | GPU context, buffers, kernels, scan, shared RNG, common trait and error |
//! | [`output`] | PNG heat maps and plots, GIF, VTK, extended XYZ, CSV (atomic writes) |
//!
//! This facade re-exports the crates (each is also a package of its own: `simkit-dem`,
//! `simkit-rd`, ...) and owns the workspace's `examples/` and `benches/`. The GPU backends
//! are the `gpu` feature, on by default; `default-features = false` builds the CPU backends
//! without compiling wgpu.
//!
//! ```
//! use simkit::prelude::*;
//! use simkit::rd::{Boundaries, Config, Diffusion, Grid, Stepping};
//! # fn main() -> Result<()> {
//! let grid = Grid::new(16, 16, 1.0, Boundaries::no_flux(), vec![vec![1.0f64; 256]])?;
//! let model = Diffusion::new(&[1.0])?;
//! let config = Config::new(Stepping::euler(0.2));
//! let mut sim = Rd::new(grid, model, &config, Backend::Cpu)?;
//! sim.step(10)?;
//! assert_eq!(sim.steps_done(), 10);
//! # Ok(())
//! # }
//! ```

pub use simkit_backend as backend;
pub use simkit_dem as dem;
pub use simkit_lattice_gas as lattice_gas;
pub use simkit_md as md;
pub use simkit_neighbor as neighbor;
pub use simkit_output as output;
pub use simkit_pp_coulomb as pp_coulomb;
pub use simkit_rd as rd;

pub mod api;
pub mod cli;
pub mod files;

/// The names almost every program needs: `use simkit::prelude::*;`.
///
/// The common trait and backend selector, the error type, the precision choice, and each
/// crate's simulation type. Everything else is reached through its crate, e.g.
/// `simkit::dem::Scene`.
pub mod prelude {
    #[cfg(feature = "gpu")]
    pub use crate::backend::GpuContext;
    pub use crate::backend::{
        Backend, Distributed, Error, Precision, Real, Restart, Result, Simulation,
    };
    pub use crate::dem::Dem;
    pub use crate::lattice_gas::{Lattice, LatticeGas};
    pub use crate::md::Md;
    pub use crate::neighbor::{CellGrid, NeighborSearch, Neighbors, SortedCells};
    pub use crate::pp_coulomb::PpCoulomb;
    pub use crate::rd::Rd;
}
