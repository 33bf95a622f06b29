//! FHP lattice gas (D2Q6) on a hexagonal lattice: lookup-table, multi-spin and GPU backends
//! that give bit-identical lattices, with boundaries, forcing and observables.
//!
//! - [`Lattice`]: one byte per site (six direction bits, bit 7 = wall), odd rows shifted half
//!   a site; [`Obstacle`] masks (rectangle, disc, bitmap given as
//!   data, row 0 the bottom).
//! - [`RuleSet`]: FHP-I or the full conservation-law table ([`CollisionTable`] generates both).
//! - [`Params`]: seed, periodic axes, inflow/outflow columns, body force.
//! - Backends implementing [`simkit_backend::Simulation`] with `State = Lattice`, bit-identical for
//!   the same seed and scene: [`LutCpu`] (one byte per site, table lookup; 64 sites per
//!   `vpermi2b` where the CPU has AVX-512 VBMI), [`MultiSpinCpu`]
//!   (64-site bit-planes, boolean collisions, AVX-512/AVX2 dispatch) and [`GpuLattice`]
//!   (WGSL, [`GpuLayout::BitPlanes`] or [`GpuLayout::Bytes`]); [`simulation`] picks one from
//!   an [`Engine`].
//! - [`viscosity`]: the shear-wave viscosity measurement and the FHP-I theory.
//! - [`field`]: the lattice vectors and [`field::BlockField`], block sums of density and
//!   momentum (filled from site bytes or straight from the multi-spin bit-planes).
//! - [`observables`]: block-averaged density and velocity and time averages, returned as
//!   data (files are written by the caller, e.g. with `simkit-output`).
//! - [`random`]: the exact use of the counter-based random bits shared by all backends.
//!
//! ```
//! use simkit_backend::Simulation;
//! use simkit_lattice_gas::{Engine, Lattice, Params, simulation};
//! # fn main() -> simkit_backend::Result<()> {
//! let mut lattice = Lattice::new(64, 32)?;
//! lattice.fill_random(0.2, 7)?;
//! let n0 = lattice.particle_count();
//! let mut sim = simulation(lattice, Params::default(), Engine::MultiSpin)?;
//! sim.step(100)?;
//! assert_eq!(sim.state()?.particle_count(), n0); // periodic box: particles are conserved
//! # Ok(())
//! # }
//! ```

pub mod field;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lattice;
pub mod lut;
#[cfg(target_arch = "x86_64")]
mod lut_vbmi;
pub mod multispin;
pub mod observables;
pub mod random;
pub mod rules;
pub mod viscosity;

#[cfg(feature = "gpu")]
pub use gpu::{GpuLattice, GpuLayout};
pub use lattice::{Lattice, Obstacle, Params, ROW_SPACING};
pub use lut::LutCpu;
pub use multispin::MultiSpinCpu;
pub use rules::{CollisionTable, RuleSet};

#[cfg(feature = "gpu")]
use simkit_backend::GpuContext;
use simkit_backend::{Backend, Result, Simulation};

/// Bit of an east-moving particle (direction 1).
pub const EAST: u8 = 1;
/// Bit of a west-moving particle (direction 4).
pub const WEST: u8 = 8;
/// Reserved rest-particle bit (bit 6); never set in this D2Q6 model.
pub const REST: u8 = 64;
/// Wall/obstacle bit (bit 7).
pub const WALL: u8 = 128;

/// Which backend runs a lattice.
#[derive(Clone, Copy, Debug)]
pub enum Engine<'a> {
    /// CPU lookup table, rayon over rows (any width).
    Lut,
    /// CPU multi-spin coding, 64 sites per word (width a multiple of 64).
    MultiSpin,
    /// GPU (WGSL) on the given context.
    #[cfg(feature = "gpu")]
    Gpu(&'a GpuContext),
    /// Never constructed (keeps the lifetime when the `gpu` feature is off).
    #[cfg(not(feature = "gpu"))]
    #[doc(hidden)]
    NoGpu(std::convert::Infallible, std::marker::PhantomData<&'a ()>),
}

impl<'a> Engine<'a> {
    /// The engine for a common [`Backend`]. CPU: the lookup table where the CPU has
    /// AVX-512 VBMI ([`lut::has_vbmi`]: as fast as multi-spin per step, and its
    /// [`Simulation::state`] is a plain copy), else multi-spin when `width` is a multiple of
    /// 64, else the lookup table.
    pub fn for_backend(backend: Backend<'a>, width: usize) -> Self {
        match backend {
            Backend::Cpu if lut::has_vbmi() => Engine::Lut,
            Backend::Cpu if width.is_multiple_of(64) => Engine::MultiSpin,
            Backend::Cpu => Engine::Lut,
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Engine::Gpu(ctx),
        }
    }
}

/// A boxed simulation of `lattice` under `params` on `engine`.
pub fn simulation(
    lattice: Lattice,
    params: Params,
    engine: Engine<'_>,
) -> Result<Box<dyn Simulation<State = Lattice>>> {
    Ok(match engine {
        Engine::Lut => Box::new(LutCpu::new(lattice, params)?),
        Engine::MultiSpin => Box::new(MultiSpinCpu::new(lattice, params)?),
        #[cfg(feature = "gpu")]
        Engine::Gpu(ctx) => Box::new(GpuLattice::new(ctx, lattice, params)?),
    })
}
