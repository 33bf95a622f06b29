//! `dem`: granular discrete-element dynamics of discs (2D) and spheres (3D) with a linear
//! spring–dashpot contact, Coulomb-capped friction, walls (planes, boxes, a 3D cylinder),
//! a vibrated container and periodic axes, on the CPU (rayon, `f64` or `f32`) and on the
//! GPU (wgpu, `f32`, the whole step on the device).
//!
//! - [`Scene`]: particles, species-pair [`Material`] table, walls, gravity, [`Vibration`].
//! - [`ContactCoefficients`]: spring and dashpot from the requested restitution `e` and
//!   contact time `t_c` with the reduced mass, so `e` holds for any mass pair and for walls.
//! - The laws, one function each for every CPU path (both precisions, diagnostics
//!   included) with a WGSL twin in `shaders/` that the GPU force kernel calls:
//!   [`normal_force`], [`friction_force`], [`reduced_mass`] (contact), [`plane_overlap`],
//!   [`cylinder_overlap`], [`wall_motion`] (walls); [`spring_energy`] for the diagnostics.
//! - [`Config`]: [`Integrator`] (velocity or position Verlet), [`Precision`], time step
//!   (default `t_c / 30`; above [`safe_dt`] an error unless overridden).
//! - [`Dem`]: the simulation ([`simkit_backend::Simulation`]), with [`Diagnostics`].
//! - [`Units`]: the source's normalised units from cm, g, s, Hz and `Gamma`.
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
//! let mut sim = Dem::new(&scene, &Config::default(), Backend::Cpu)?;
//! sim.step(3000)?;
//! let d = sim.diagnostics()?;
//! assert!(d.finite && d.com_height > 0.0 && d.com_height < 8.0);
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod config;
mod contact;
mod cpu;
mod diagnostics;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
mod input;
mod prepared;
pub mod scenes;
mod sim;
mod units;
mod walls;

pub use config::{Config, DEFAULT_STEPS_PER_CONTACT, Integrator, resolve_dt, safe_dt};
pub use contact::{ContactCoefficients, friction_force, normal_force, reduced_mass, spring_energy};
pub use diagnostics::Diagnostics;
pub use diagnostics::MAX_INITIAL_OVERLAP;
pub use input::{Dim, Material, Particle, Scene, Vibration, Wall, WallShape, pair_index};
pub use sim::{Dem, State};
pub use simkit_backend::Precision;
pub use units::Units;
pub use walls::{cylinder_overlap, plane_overlap, wall_motion};
