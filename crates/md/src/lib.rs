//! Molecular dynamics of several particle species interacting through pair potentials
//! `phi(r)`, cut at `r_c`, of any law that implements [`PairLaw`], with parameters set per
//! unordered species pair in one [`PairTable`], optionally shifted by `phi(r_c)`
//! ([`Config::shift`]), integrated at constant energy (NVE) with velocity
//! Verlet or leapfrog ([`Integrator`]) in a 2D or 3D box with periodic or reflecting axes.
//! Optional: a Langevin thermostat ([`Config::thermostat`], [`Langevin`]; BAOAB splitting
//! of Leimkuhler & Matthews 2013, global or per-species targets, counter-based random
//! numbers shared by the CPU and the GPU) and frozen species ([`System::set_frozen`]: a
//! substrate that exerts forces but does not move).
//!
//! - [`PairLaw`]: what a potential provides (parameters, coefficients, the force and
//!   energy as one Rust function generic over [`simkit_backend::Real`] with its WGSL twin,
//!   cutoff, curvature for the time-step guidance, validation). Built in:
//!   [`LennardJones`] (`4 eps (a (sigma/r)^12 - b (sigma/r)^6)`, the default law),
//!   [`Morse`], [`Yukawa`], [`Mie`], [`Wca`], [`Buckingham`], each validated against
//!   LAMMPS. A law of your own runs at the speed of a built-in one on every backend
//!   (`examples/custom_law/`; test its WGSL with [`check_law_on_gpu`]).
//! - [`System`]: box, species masses, pair table, particles (validated).
//! - [`Md`]: the run, `Md::new(system, &config, backend)`, implementing
//!   [`simkit_backend::Simulation`] and [`simkit_backend::Restart`].
//! - [`DistributedMd`]: the CPU run (`f64`) over the ranks of a
//!   [`simkit_backend::comm::Comm`] (MPI with the `mpi` feature) by spatial decomposition,
//!   the same bits on any rank count, checkpoints in `Md`'s format.
//! - [`Diagnostics`]: kinetic, potential and total energy, virial pressure, per-species
//!   temperature.
//! - [`time_step_guide`]: the default and largest safe time step from the stiffest pair.
//! - [`scenes`]: LAMMPS's `in.lj` melt and a gas/liquid/solid table.
//! - [`reference`](mod@reference): NIST's truncated Lennard-Jones state point, reproduced by a
//!   thermostatted run.
//!
//! The CPU backend keeps a Verlet list within `max r_c + skin` (rebuilt when a particle has
//! moved more than half the skin) and gathers the forces per particle in parallel: results
//! do not depend on the thread count. Forces, energy and pressure agree with LAMMPS to
//! about 1e-14 relative (`tests/lammps.rs`; see the guide `docs/md.md`). The GPU backend
//! (`gpu` feature, on by default; `Backend::Gpu`) runs whole steps on the device in `f32`:
//! the device cell list of `simkit_neighbor` and one invocation per particle gathering its
//! forces over the neighbouring cells; it agrees with the CPU in `f32` to about 5e-7.
//!
//! # Runs that cannot silently go wrong
//!
//! `step(n)` checks the state every [`Config::check_every`] steps (default 100, counted
//! from step 0; `0` leaves only the check at the end of each call): a non-finite position,
//! velocity or force, or a particle that left the box, returns
//! [`simkit_backend::Error::BlowUp`] with the run rolled back to the last state that
//! passed (on the GPU the check and the snapshots stay on the device). [`Md::new`] refuses a
//! time step above `T_min / 20` ([`time_step_guide`]) unless
//! [`Config::allow_unstable_dt`] is set.
//!
//! # Example
//!
//! ```
//! use simkit_backend::{Backend, Restart, Simulation};
//! use simkit_md::{Config, LennardJones, Md, PairTable, scenes};
//! # fn main() -> simkit_backend::Result<()> {
//! // 4 x 4 x 4 FCC cells of Lennard-Jones atoms (256), density 0.8442, T = 1.44.
//! let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
//! let system = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0], 1)?;
//! let mut md = Md::new(system, &Config::default().with_dt(0.005), Backend::Cpu)?;
//! let e0 = md.diagnostics()?.total;
//! md.step(100)?;
//! let d = md.diagnostics()?;
//! assert!((d.total - e0).abs() < 1e-2 * e0.abs());
//! // Checkpoint and resume: the run continues bit for bit.
//! let bytes = md.checkpoint()?;
//! let mut again = Md::<LennardJones>::resume(&bytes, Backend::Cpu)?;
//! md.step(10)?;
//! again.step(10)?;
//! assert_eq!(md.state()?, again.state()?);
//! # Ok(())
//! # }
//! ```
//!
//! Another law is another type in the table; everything else is the same:
//!
//! ```
//! use simkit_backend::{Backend, Simulation};
//! use simkit_md::{Config, Md, Morse, PairTable, scenes};
//! # fn main() -> simkit_backend::Result<()> {
//! // Morse atoms (well depth 1 at r0 = 1.1, alpha = 4) on the same lattice.
//! let table = PairTable::uniform(1, Morse::new(1.0, 4.0, 1.1, 2.5))?;
//! let system = scenes::fcc_lattice([4; 3], 0.8442, 0.5, table, &[0], 1)?;
//! // dt from the curvature of the well, 2 alpha^2 D0.
//! let mut md = Md::new(system, &Config::default(), Backend::Cpu)?;
//! let e0 = md.diagnostics()?.total;
//! md.step(100)?;
//! assert!((md.diagnostics()?.total - e0).abs() < 1e-3 * e0.abs());
//! // A checkpoint names its law: it resumes as Md::<Morse> only.
//! let bytes = simkit_backend::Restart::checkpoint(&mut md)?;
//! assert!(<simkit_md::Md as simkit_backend::Restart>::resume(&bytes, Backend::Cpu).is_err());
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod build;
mod config;
mod cpu;
mod diagnostics;
mod distributed;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
mod input;
mod law;
#[cfg(feature = "gpu")]
mod law_check;
mod laws;
pub mod reference;
pub mod scenes;
mod sim;
mod table;
mod thermostat;

pub use config::{
    Config, DEFAULT_SKIN, DEFAULT_STEPS_PER_PERIOD, GpuKernel, Integrator, MIN_STEPS_PER_PERIOD,
    StepGuide, time_step_guide,
};
pub use diagnostics::Diagnostics;
pub use distributed::DistributedMd;
pub use input::{Dim, MAX_PARTICLES, System};
pub use law::PairLaw;
#[cfg(feature = "gpu")]
pub use law_check::{LawCheck, check_law_on_gpu};
pub use laws::{
    BuckCoeff, Buckingham, LennardJones, LjCoeff, MAX_COEFFICIENT, MIN_CUTOFF, Mie, MieCoeff,
    Morse, MorseCoeff, Wca, Yukawa, YukawaCoeff,
};
pub use sim::Md;
pub use simkit_backend::particles::State;
pub use simkit_backend::{
    Backend, Distributed, Error, Precision, Real, Restart, Result, Simulation,
};
pub use table::{MAX_SPECIES, PairTable};
pub use thermostat::Langevin;
