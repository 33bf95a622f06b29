//! `rd`: reaction–diffusion on 2D grids with a tiled 5-point stencil, on the CPU and the GPU.
//!
//! - [`Grid`]: one or more species fields (`f32` or `f64`) on square cells of side `h`, with
//!   [`Boundaries`] per edge (no-flux mirror, periodic, Dirichlet).
//! - [`Model`]: reaction terms plus diffusion operator. Provided: [`Diffusion`] (linear, per
//!   species), [`GrayScott`] (Pearson's parameter sets) and [`Colony`] (the bacterial colony
//!   model with a random coefficient `d(x, y)`, in conservative flux form).
//! - [`Stepping`]: `dt`, [`Integrator`] (Euler or Heun) and the stability [`Guard`]: a `dt`
//!   above [`stable_dt`] (`h^2 / (4 D_max)` from the current fields) is refused with
//!   [`simkit_backend::Error::Unstable`] unless overridden.
//! - [`Config`]: the [`Stepping`], the CPU's temporal blocking depth
//!   ([`Config::steps_per_sweep`]), the interval of the blow-up check
//!   ([`Config::check_every`]) and the [`GpuOptions`] (plain data, ignored by the CPU).
//! - [`Rd`]: the simulation behind [`simkit_backend::Simulation`], built as
//!   `Rd::new(grid, model, &config, backend)` on the backend the [`simkit_backend::Backend`]
//!   value names: the CPU (cache-blocked tiles in parallel, vectorised with run-time CPU
//!   feature dispatch, several Euler steps fused per sweep over the grid) or the GPU (WGSL;
//!   tile + halo in workgroup memory, or a plain global-memory kernel; many steps per
//!   submission).
//! - [`DistributedRd`]: the same run block-decomposed over the ranks of a
//!   [`simkit_backend::comm::Comm`] (serial, or MPI with the `mpi` feature), CPU only,
//!   bit-identical to the single-process CPU run for any rank count.
//!
//! # Blow-up checks
//!
//! Inside `step(n)` the run is checked every [`Config::check_every`] steps (default
//! [`simkit_backend::guard::DEFAULT_CHECK_EVERY`] = 100, counted from step 0; 0 = interval
//! checks off) and at the end of the call: every field value must be finite, and for the
//! colony (with the guard enforced) `dt` must still be within `h^2 / (4 D_max)` of the
//! current fields. A failed check returns [`simkit_backend::Error::BlowUp`] naming the step,
//! the first bad cell `(x, y)` with its species and value (or `D_max` and the bound) and the
//! fix, with the run back at the last state that passed (`steps_done()` = `rolled_back_to`);
//! see [`Rd`]. The checks never change the results.
//!
//! # Checkpoints
//!
//! [`Rd`] implements [`simkit_backend::Restart`]: the checkpoint holds the grid, the model,
//! the [`Config`], the step counter and the simulated time, and a resumed run continues bit
//! for bit on the same backend.
//!
//! ```
//! use simkit_backend::{Backend, Restart, Simulation};
//! use simkit_rd::{Config, GrayScott, Rd, Stepping, scenes::gray_scott_square};
//! # fn main() -> simkit_backend::Result<()> {
//! let grid = gray_scott_square::<f64>(32, 1.0, 8, 1)?;
//! let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
//! let mut sim = Rd::new(grid, model, &Config::new(Stepping::euler(0.2)), Backend::Cpu)?;
//! sim.step(50)?;
//! let bytes = sim.checkpoint()?;
//! let mut resumed = Rd::<f64, GrayScott>::resume(&bytes, Backend::Cpu)?;
//! assert_eq!((resumed.steps_done(), resumed.time()), (50, sim.time()));
//! sim.step(50)?;
//! resumed.step(50)?;
//! assert_eq!(resumed.state()?, sim.state()?);
//! # Ok(())
//! # }
//! ```
//!
//! ```
//! use simkit_backend::{Backend, Simulation};
//! use simkit_rd::{Boundaries, Config, Diffusion, Grid, Rd, Stepping};
//! # fn main() -> simkit_backend::Result<()> {
//! let (nx, ny, h) = (32, 32, 1.0);
//! let mut u = vec![0.0f64; nx * ny];
//! u[16 * nx + 16] = 1.0;
//! let grid = Grid::new(nx, ny, h, Boundaries::no_flux(), vec![u])?;
//! let model = Diffusion::new(&[1.0])?;
//! let unstable = Config::new(Stepping::euler(0.3));
//! assert!(Rd::new(grid.clone(), model.clone(), &unstable, Backend::Cpu).is_err());
//! let mut sim = Rd::new(grid, model, &Config::new(Stepping::euler(0.2)), Backend::Cpu)?;
//! sim.step(100)?;
//! let total = sim.state()?.total(0);
//! assert!((total - 1.0).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```

// Links to the GPU items resolve when they are compiled (the `gpu` feature, on by default).
#![cfg_attr(not(feature = "gpu"), allow(rustdoc::broken_intra_doc_links))]

mod boundary;
mod config;
mod cpu;
mod distributed;
mod engine;
#[cfg(feature = "gpu")]
mod gpu;
mod grid;
mod model;
mod models;
pub mod scenes;
mod sim;
mod stepper;
mod sweep;

pub use boundary::{Boundaries, Boundary};
pub use config::{Config, DEFAULT_STEPS_PER_SWEEP, GpuKernel, GpuOptions};
pub use distributed::DistributedRd;
pub use grid::Grid;
pub use model::{Model, RowIn, Stencil};
pub use models::{Colony, Diffusion, GrayScott};
pub use sim::Rd;
pub use simkit_backend::{Backend, Distributed, Error, Real, Restart, Result, Simulation};
pub use stepper::{Guard, Integrator, Stepping, stable_dt};
