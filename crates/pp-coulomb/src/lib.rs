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
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

pub mod analytic;
mod config;
mod cpu;
mod diagnostics;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
pub mod laws;
mod particles;
pub mod scenes;
mod sim;
pub mod units;

pub use config::{Config, ForceLaw, Integrator};
pub use diagnostics::{Diagnostics, diagnostics, potential_energy, reference_accelerations};
#[cfg(feature = "gpu")]
pub use gpu::gpu_max_particles;
pub use particles::{MAX_PARTICLES, Particles, Region, Species, Velocities};
pub use sim::PpCoulomb;
pub use simkit_backend::{Backend, Precision, Simulation};
