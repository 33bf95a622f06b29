//! Direct-sum (particle–particle) Coulomb dynamics in normalised units, on CPU and GPU.
//!
//! - [`units`]: physical inputs (time step, density, box, temperature in eV, species) to
//!   normalised units with k_e = 1 and dt = 1; Debye length, thermal speed, omega_pe dt.
//! - [`Particles`]: per-particle charge and mass, species, seeded uniform box/sphere
//!   positions and zero-mean Maxwellian or uniform velocities.
//! - [`ForceLaw`]: exact 1/r^2 (coincident particles are an error naming the pair), the
//!   source's exclusion radius, or Plummer softening; each law is its own compiled kernel.
//! - [`laws`]: each law's force weight and potential written once (called by every CPU path),
//!   beside its WGSL twin.
//! - [`Integrator`]: the source's symplectic Euler or leapfrog kick–drift–kick; positions are
//!   double-buffered (never written while another thread reads them).
//! - [`PpCoulomb`]: the simulation on [`Backend::Cpu`] (rayon over targets, structure of
//!   arrays, j-blocking, f32 or f64; an AVX-512 `rsqrt` + Newton kernel chosen at run time,
//!   else a portable kernel compiled for AVX-512/AVX2 with runtime dispatch) or
//!   [`Backend::Gpu`] (tiled all-pairs WGSL kernel, all steps on the device, f32, or f64 where
//!   the adapter has `SHADER_F64`).
//! - Mixed precision on the CPU ([`Config::mixed`], with [`Precision::F32`]): the f32 pair
//!   kernel on separations formed from f64 positions, with f64 sums, state and integrator;
//!   a force error about 20x below f32's in about 1.3x f32's time.
//! - [`DistributedCoulomb`]: the CPU run over the ranks of a `simkit_backend::comm::Comm`
//!   (MPI with the `mpi` feature) with replicated data, bit-identical to one process.
//! - Blow-up checks inside `step(n)` ([`Config::check_every`], default every 100 steps, and
//!   at the end of every call): non-finite positions or velocities, a coincident pair and,
//!   under the exact law, a jump of the total energy beyond [`Config::energy_tolerance`]
//!   (default [`DEFAULT_ENERGY_TOLERANCE`] = 1e-2) return `Error::BlowUp` naming the step,
//!   the particle(s) and the likely cause, with the run put back to the last state that passed
//!   a check (CPU: a copy of the state per check; GPU: `GpuGuard` on the device, plus one small
//!   read-back of the energy per interval under the exact law).
//! - Checkpoints ([`simkit_backend::Restart`]): `checkpoint()` / `resume(bytes, backend)` hold
//!   the complete state (particles, configuration, the accelerations leapfrog keeps between
//!   calls, step counter, simulated time, the energy guard's reference); a resumed run
//!   continues bit for bit on the same backend.
//! - [`Diagnostics`]: kinetic and potential energy, momentum, angular momentum, sum of forces.
//! - [`scenes`]: the source's plasma box and the cold sphere of the Coulomb explosion.
//! - [`analytic`]: Coulomb explosion of a cold uniform sphere and Rutherford scattering.
//!
//! ```
//! use simkit_pp_coulomb::{Config, ForceLaw, Particles, PpCoulomb, Region, Species, Velocities};
//! use simkit_backend::{Backend, Simulation};
//! # fn main() -> simkit_backend::Result<()> {
//! let mut p = Particles::new();
//! let e = p.add_species(Species::new("electron", -1.0, 1.0))?;
//! let cube = Region::Cube { min: [0.0; 3], length: 20.0 };
//! p.fill(e, 500, cube, Velocities::Maxwellian { thermal_speed: 0.5 }, 42)?;
//! let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 });
//! let mut sim = PpCoulomb::new(p, &config, Backend::Cpu)?;
//! let before = sim.diagnostics()?;
//! sim.step(20)?;
//! let after = sim.diagnostics()?;
//! assert!(((after.total - before.total) / before.total).abs() < 1e-3);
//!
//! // Save, resume (here in the same process; in practice from a file with
//! // `write_checkpoint` / `resume_file`) and go on: same bits as an uninterrupted run.
//! use simkit_backend::Restart;
//! let bytes = sim.checkpoint()?;
//! let mut resumed = PpCoulomb::resume(&bytes, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.time()), (20, sim.time()));
//! resumed.step(5)?;
//! sim.step(5)?;
//! assert_eq!(resumed.state()?, sim.state()?);
//!
//! // The bare Coulomb law with a step far too large for the closest pairs: the energy
//! // guard stops the run and puts it back to the last good check.
//! let mut p = Particles::new();
//! let e = p.add_species(Species::new("electron", -1.0, 1.0))?;
//! let ion = p.add_species(Species::new("ion", 1.0, 1.0))?;
//! p.fill(e, 200, cube, Velocities::Maxwellian { thermal_speed: 0.1 }, 1)?;
//! p.fill(ion, 200, cube, Velocities::Maxwellian { thermal_speed: 0.1 }, 2)?;
//! let mut bad = PpCoulomb::new(p, &Config::new(10.0, ForceLaw::Exact), Backend::Cpu)?;
//! match bad.step(1000) {
//!     Err(simkit_backend::Error::BlowUp { rolled_back_to, .. }) => {
//!         assert_eq!(bad.steps_done(), rolled_back_to)
//!     }
//!     other => panic!("expected a blow-up, got {other:?}"),
//! }
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

pub mod analytic;
mod config;
mod cpu;
mod diagnostics;
mod distributed;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
mod guard;
pub mod laws;
mod particles;
mod run;
pub mod scenes;
mod sim;
pub mod units;

pub use config::{Config, DEFAULT_ENERGY_TOLERANCE, ForceLaw, GpuTile, Integrator};
pub use diagnostics::{
    Diagnostics, diagnostics, potential_energy, reference_accelerations, reference_accelerations_of,
};
pub use distributed::DistributedCoulomb;
#[cfg(feature = "gpu")]
pub use gpu::gpu_max_particles;
pub use particles::{MAX_PARTICLES, Particles, Region, Species, Velocities};
pub use sim::PpCoulomb;
pub use simkit_backend::{Backend, Distributed, Error, Precision, Restart, Result, Simulation};
