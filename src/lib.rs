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
//! | [`backend`] | GPU context, buffers, kernels, scan, shared RNG, common trait and error |
//! | [`output`] | PNG heat maps and plots, GIF, VTK, extended XYZ, CSV (atomic writes) |
//!
//! This facade re-exports the crates and owns the workspace's `examples/` and `benches/`.

pub use simkit_backend as backend;
pub use simkit_dem as dem;
pub use simkit_lattice_gas as lattice_gas;
pub use simkit_neighbor as neighbor;
pub use simkit_output as output;
pub use simkit_pp_coulomb as pp_coulomb;
pub use simkit_rd as rd;

pub mod cli;
