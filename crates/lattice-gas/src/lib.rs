//! FHP lattice gas (D2Q6) on a hexagonal lattice: lookup-table, multi-spin and GPU backends
//! that give bit-identical lattices, with boundaries, forcing and observables.
//!
//! - [`Lattice`]: one byte per site (six direction bits, bit 7 = wall), odd rows shifted half
//!   a site; [`Obstacle`] masks (rectangle, disc, bitmap given as
//!   data, row 0 the bottom).
//! - [`RuleSet`]: FHP-I or the full conservation-law table ([`CollisionTable`] generates both).
//! - [`Config`]: rules, seed, periodic axes, inflow/outflow columns, body force, and the
//!   backend choices as plain data ([`CpuMethod`], [`GpuLayout`]).
//! - [`LatticeGas`]: the simulation, `LatticeGas::new(lattice, &config, backend)`,
//!   implementing [`simkit_backend::Simulation`] with `State = Lattice`. Its backends, chosen
//!   by [`Config::cpu`] and [`Config::gpu_layout`], are bit-identical for the same seed and
//!   scene: the lookup table (one byte per site; 64 sites per `vpermi2b` where the CPU has
//!   AVX-512 VBMI, or the portable loop), multi-spin (64-site bit-planes, boolean
//!   collisions, AVX-512/AVX2 dispatch) and, with the `gpu` feature, the GPU in
//!   [`GpuLayout::BitPlanes`] or [`GpuLayout::Bytes`].
//! - Checkpoints: [`LatticeGas`] implements [`simkit_backend::Restart`] (`checkpoint`,
//!   `write_checkpoint`, `resume`, `resume_file`): the settings, the lattice and the step
//!   counter that keys the random bits, so a resumed run continues bit for bit, on any backend.
//! - [`DistributedLatticeGas`]: the lattice block-decomposed over the ranks of a
//!   [`simkit_backend::comm::Comm`] (MPI with the `mpi` feature), bit-identical to one
//!   process on any rank count ([`Distributed`]: state and checkpoints on every rank).
//! - [`PoiseuilleChannel`]: the viscosity from the profile of a body-forced channel;
//!   [`ShearWave`]: the shear-wave viscosity measurement, [`fhp1_viscosity`] the FHP-I
//!   theory.
//! - [`BlockField`]: block sums of density and momentum (filled from site bytes or straight
//!   from the multi-spin bit-planes), [`TimeAverage`]: their time average; returned as data
//!   (files are written by the caller, e.g. with `simkit-output`).
//! - [`laws`]: each rule of the model stated once with its WGSL twin: the lattice vectors
//!   and site observables, the collision of six direction bits, the counter-based random
//!   bits shared by all backends.
//!
//! ```
//! use simkit_backend::{Backend, Simulation};
//! use simkit_lattice_gas::{Config, CpuMethod, Lattice, LatticeGas};
//! # fn main() -> simkit_backend::Result<()> {
//! let mut lattice = Lattice::new(64, 32)?;
//! lattice.fill_random(0.2, 7)?;
//! let n0 = lattice.particle_count();
//! let config = Config { cpu: CpuMethod::MultiSpin, ..Config::default() };
//! let mut sim = LatticeGas::new(lattice, &config, Backend::Cpu)?;
//! sim.step(100)?;
//! assert_eq!(sim.state()?.particle_count(), n0); // periodic box: particles are conserved
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod config;
mod cpu;
mod distributed;
mod engine;
mod field;
#[cfg(feature = "gpu")]
mod gpu;
#[cfg(feature = "gpu")]
mod gpu_block;
mod lattice;
pub mod laws;
mod observables;
mod poiseuille;
mod random;
mod rules;
mod sim;
mod viscosity;

pub use config::{Config, CpuMethod, GpuLayout};
pub use distributed::DistributedLatticeGas;
pub use field::BlockField;
pub use lattice::{Lattice, Obstacle, ROW_SPACING};
pub use observables::TimeAverage;
pub use poiseuille::{PoiseuilleChannel, PoiseuilleResult};
pub use rules::{CollisionTable, RuleSet};
pub use sim::LatticeGas;
pub use simkit_backend::{Backend, Distributed, Error, Restart, Result, Simulation};
pub use viscosity::{ShearResult, ShearWave, fhp1_viscosity};

/// Bit of an east-moving particle (direction 1).
pub const EAST: u8 = 1;
/// Bit of a west-moving particle (direction 4).
pub const WEST: u8 = 8;
/// Reserved rest-particle bit (bit 6); never set in this D2Q6 model.
pub const REST: u8 = 64;
/// Wall/obstacle bit (bit 7).
pub const WALL: u8 = 128;
