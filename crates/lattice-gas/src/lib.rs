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
//!   implementing [`simkit_backend::Simulation`] with `State = Lattice`. Its backends, also
//!   usable directly, are bit-identical for the same seed and scene: [`LutCpu`] (one byte per
//!   site, table lookup; 64 sites per `vpermi2b` where the CPU has AVX-512 VBMI),
//!   [`MultiSpinCpu`] (64-site bit-planes, boolean collisions, AVX-512/AVX2 dispatch) and,
//!   with the `gpu` feature, `GpuLattice` (WGSL, [`GpuLayout::BitPlanes`] or
//!   [`GpuLayout::Bytes`]).
//! - Checkpoints: [`LatticeGas`] implements [`simkit_backend::Restart`] (`checkpoint`,
//!   `write_checkpoint`, `resume`, `resume_file`): the settings, the lattice and the step
//!   counter that keys the random bits, so a resumed run continues bit for bit, on any backend.
//! - [`DistributedLatticeGas`]: the lattice block-decomposed over the ranks of a
//!   [`simkit_backend::comm::Comm`] (MPI with the `mpi` feature), bit-identical to one
//!   process on any rank count; gathers the lattice and writes checkpoints on rank 0.
//! - [`poiseuille`]: the viscosity from the profile of a body-forced channel.
//! - [`viscosity`]: the shear-wave viscosity measurement and the FHP-I theory.
//! - [`field`]: the lattice vectors and [`field::BlockField`], block sums of density and
//!   momentum (filled from site bytes or straight from the multi-spin bit-planes).
//! - [`observables`]: block-averaged density and velocity and time averages, returned as
//!   data (files are written by the caller, e.g. with `simkit-output`).
//! - [`random`]: the exact use of the counter-based random bits shared by all backends.
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

pub mod config;
pub mod cpu;
mod distributed;
mod engine;
pub mod field;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
mod gpu_block;
pub mod lattice;
pub mod observables;
pub mod poiseuille;
pub mod random;
pub mod rules;
mod sim;
pub mod viscosity;

pub use config::{Config, CpuMethod, GpuLayout};
pub use cpu::lut::LutCpu;
pub use cpu::multispin::MultiSpinCpu;
pub use distributed::DistributedLatticeGas;
#[cfg(feature = "gpu")]
pub use gpu::GpuLattice;
pub use lattice::{Lattice, Obstacle, ROW_SPACING};
pub use rules::{CollisionTable, RuleSet};
pub use sim::LatticeGas;
pub use simkit_backend::{Backend, Error, Restart, Result, Simulation};

/// Bit of an east-moving particle (direction 1).
pub const EAST: u8 = 1;
/// Bit of a west-moving particle (direction 4).
pub const WEST: u8 = 8;
/// Reserved rest-particle bit (bit 6); never set in this D2Q6 model.
pub const REST: u8 = 64;
/// Wall/obstacle bit (bit 7).
pub const WALL: u8 = 128;
