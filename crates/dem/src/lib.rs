//! `dem`: granular discrete-element dynamics of discs (2D) and spheres (3D) with a contact
//! law of the user's choice (built in: the linear spring–dashpot with Coulomb-capped
//! friction), walls (planes, boxes, a cylinder that may spin), a vibrated container and
//! periodic axes, on the CPU (rayon, `f64` or `f32`) and on the GPU (wgpu, `f32`, the whole
//! step on the device).
//!
//! - [`ContactLaw`]: what a contact model provides (its parameters per material pair, the
//!   coefficients the force loops read, the force of a [`Contact`] as one Rust function
//!   generic over [`simkit_backend::Real`] with its WGSL twin, the elastic energy, the
//!   contact time and the safe time step). Every backend is compiled for the scene's law,
//!   so a law of your own runs at the speed of the built-in one. [`Material`] is the
//!   built-in law and the default.
//! - [`HertzMindlin`] (from [`Solid`]s) and [`LinearHistory`]: laws with a tangential
//!   spring per contact (Cundall–Strack, [`coulomb_spring`]) and optional rolling
//!   resistance; with [`Scene::set_rotation`] the particles spin (solid discs and
//!   spheres, [`moment_of_inertia`]). CPU backend; their forces and torques equal LAMMPS
//!   `pair granular`'s (see `docs/dem.md`).
//! - [`Scene`]: particles, species-pair material table, walls, gravity, [`Vibration`],
//!   rotation.
//! - [`ContactCoefficients`]: spring and dashpot from the requested restitution `e` and
//!   contact time `t_c` with the reduced mass, so `e` holds for any mass pair and for walls.
//! - The laws, one function each for every CPU path (both precisions, diagnostics
//!   included) with a WGSL twin in `shaders/` that the GPU force kernel calls:
//!   [`normal_force`], [`friction_force`], [`reduced_mass`] (contact), [`plane_overlap`],
//!   [`cylinder_overlap`], [`cylinder_surface_velocity`], [`wall_motion`] (walls);
//!   [`spring_energy`] for the diagnostics.
//! - [`Config`]: [`Integrator`] (velocity or position Verlet), [`Precision`], time step
//!   (default `t_c / 30`; above [`safe_dt`] an error unless overridden).
//! - [`Dem`]: the simulation ([`simkit_backend::Simulation`]), with [`Diagnostics`] and
//!   [`Dem::forces`].
//! - [`Units`]: the source's normalised units from cm, g, s, Hz and `Gamma`.
//!
//! # Runs that cannot silently go wrong
//!
//! [`Dem::new`] refuses, on both backends alike (the checks are shared): particles outside
//! the box (periodic axes: more than one box length), initial overlaps deeper than
//! [`MAX_INITIAL_OVERLAP`] of a radius with another particle or a wall, periodic axes
//! shorter than twice the largest diameter times `1 + skin`, magnitudes the precision cannot
//! hold (the GPU and [`Precision::F32`] computations need `f32`), and a time step over
//! [`safe_dt`] unless overridden. Any box size works: the overlap checks need no grid over
//! the box.
//!
//! Inside `step(n)` the state is checked every [`Config::check_every`] steps (default 100,
//! counted from step 0; 0 = only at the end of each call, which always happens): non-finite
//! positions or velocities, a particle more than its radius outside the box along a
//! non-periodic axis (it escaped through a wall, or the box has none), and a contact deeper
//! than [`Config::max_overlap`] of the smaller radius (default [`DEFAULT_MAX_OVERLAP`] =
//! 0.5). A failed check returns [`simkit_backend::Error::BlowUp`] (the step, the particle and
//! its value, the likely cause, e.g. "time step too large for the contact stiffness: use
//! dt <= ..."), and the run is rolled back to the last state that passed:
//! [`simkit_backend::Simulation::steps_done`] and `state()` give it. The CPU keeps a copy of
//! the state per check; the GPU checks on the device (`dem_check` and
//! [`simkit_backend::gpu::GpuGuard`]) with one small download per call. The check does not
//! change the results (tested bit for bit against `check_every = 0`).
//!
//! # Checkpoints
//!
//! [`Dem`] implements [`simkit_backend::Restart`]: the checkpoint holds the scene, the
//! settings and the complete dynamic state (step count, simulated time and so the wall
//! phase, accelerations, half-step quantities, the particle order and the neighbour-list
//! build positions), and a run resumed from it on the backend kind that wrote it continues
//! bit for bit.
//!
//! ```
//! use simkit_backend::{Backend, Restart, Simulation};
//! use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene};
//! # fn main() -> simkit_backend::Result<()> {
//! let mut scene = Scene::new(Dim::Two, [0.0; 3], [4.0, 4.0, 0.0], Material::new(0.9, 0.05))?;
//! scene.set_gravity(1.0)?.add_box_walls(Material::new(0.8, 0.05), false)?;
//! scene.add_particle(Particle::new([2.0, 2.0, 0.0], 0.5, 1.0))?;
//! let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
//! sim.step(150)?;
//! let bytes = sim.checkpoint()?; // or sim.write_checkpoint("run.ckpt")?
//! let mut resumed = Dem::<Material>::resume(&bytes, Backend::Cpu)?;
//! sim.step(100)?;
//! resumed.step(100)?;
//! assert_eq!(resumed.steps_done(), 250);
//! assert_eq!(resumed.state()?, sim.state()?);
//! # Ok(())
//! # }
//! ```
//!
//! ```
//! use simkit_backend::{Backend, Simulation};
//! use simkit_dem::{Config, Dem, Dim, Material, Particle, Scene};
//! # fn main() -> simkit_backend::Result<()> {
//! // A disc dropped on a vibrating floor.
//! let mut scene = Scene::new(Dim::Two, [0.0; 3], [4.0, 8.0, 0.0], Material::new(0.9, 0.02))?;
//! scene.set_gravity(1.0)?.set_vibration(0.05, 2.0)?;
//! scene.add_box_walls(Material::new(0.8, 0.02).with_friction(0.5, 50.0), true)?;
//! scene.add_particle(Particle::new([2.0, 1.0, 0.0], 0.5, 1.0))?;
//! let mut sim = Dem::new(scene, &Config::default(), Backend::Cpu)?;
//! sim.step(3000)?;
//! let d = sim.diagnostics()?;
//! assert!(d.finite && d.com_height > 0.0 && d.com_height < 8.0);
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod build;
mod config;
mod contact;
mod cpu;
mod diagnostics;
mod distributed;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
mod hertz;
mod input;
mod law;
mod prepared;
pub mod scenes;
mod sim;
mod spin;
mod units;
mod walls;

pub use config::{Config, DEFAULT_MAX_OVERLAP, DEFAULT_STEPS_PER_CONTACT, Integrator, safe_dt};
pub use contact::{
    ContactCoefficients, LinearHistory, LinearHistoryCoefficients, friction_force, normal_force,
    reduced_mass, spring_energy,
};
pub use diagnostics::Diagnostics;
pub use diagnostics::MAX_INITIAL_OVERLAP;
pub use distributed::DistributedDem;
pub use hertz::{HertzCoefficients, HertzMindlin, Solid, hertz_contact_time};
pub use input::{Dim, Material, Particle, Scene, Vibration, Wall, WallShape, pair_index};
pub use law::{Contact, ContactForce, ContactLaw, LAW_PRELUDE_WGSL};
pub use sim::{Dem, Forces};
pub use simkit_backend::particles::State;
pub use simkit_backend::{
    Backend, Distributed, Error, Precision, Real, Restart, Result, Simulation,
};
pub use spin::{contact_point_velocity, coulomb_spring, moment_of_inertia};
pub use units::Units;
pub use walls::{cylinder_overlap, cylinder_surface_velocity, plane_overlap, wall_motion};
