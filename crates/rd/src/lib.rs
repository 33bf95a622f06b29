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
//! - Backends: [`CpuRd`] (cache-blocked tiles in parallel, vectorised with run-time CPU
//!   feature dispatch, several Euler steps fused per sweep over the grid) and [`GpuRd`] (WGSL; tile + halo in workgroup memory, or a plain
//!   global-memory kernel; many steps per submission), both behind
//!   [`simkit_backend::Simulation`]; [`Rd`] picks one from a [`simkit_backend::Backend`] value.
//!
//! ```
//! use simkit_backend::{Backend, Simulation};
//! use simkit_rd::{Boundaries, Diffusion, Grid, Rd, Stepping};
//! # fn main() -> simkit_backend::Result<()> {
//! let (nx, ny, h) = (32, 32, 1.0);
//! let mut u = vec![0.0f64; nx * ny];
//! u[16 * nx + 16] = 1.0;
//! let grid = Grid::new(nx, ny, h, Boundaries::no_flux(), vec![u])?;
//! let model = Diffusion::new(&[1.0])?;
//! assert!(Rd::new(Backend::Cpu, grid.clone(), model.clone(), Stepping::euler(0.3)).is_err());
//! let mut sim = Rd::new(Backend::Cpu, grid, model, Stepping::euler(0.2))?;
//! sim.step(100)?;
//! let total = sim.state()?.total(0);
//! assert!((total - 1.0).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```

mod boundary;
mod cpu;
#[cfg(feature = "gpu")]
mod gpu;
mod grid;
mod model;
mod models;
pub mod scenes;
mod stepper;
mod sweep;

pub use boundary::{Boundaries, Boundary};
pub use cpu::{CpuRd, DEFAULT_STEPS_PER_SWEEP};
#[cfg(feature = "gpu")]
pub use gpu::{GpuKernel, GpuOptions, GpuRd};
pub use grid::Grid;
pub use model::{Model, RowIn, Stencil};
pub use models::{Colony, Diffusion, GrayScott};
pub use simkit_backend::Real;
pub use stepper::{Guard, Integrator, Stepping, stable_dt};

use simkit_backend::{Backend, Result, Simulation};

/// A simulation on either backend, chosen at run time.
// One simulation object per run: the few hundred bytes of difference do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Rd<T: Real, M: Model> {
    /// CPU backend.
    Cpu(CpuRd<T, M>),
    /// GPU backend.
    #[cfg(feature = "gpu")]
    Gpu(GpuRd<T, M>),
}

impl<T: Real, M: Model> Rd<T, M> {
    /// Builds the simulation on `backend` (GPU with default [`GpuOptions`]).
    pub fn new(backend: Backend<'_>, grid: Grid<T>, model: M, stepping: Stepping) -> Result<Self> {
        match backend {
            Backend::Cpu => Ok(Rd::Cpu(CpuRd::new(grid, model, stepping)?)),
            #[cfg(feature = "gpu")]
            gpu => Self::with_options(gpu, grid, model, stepping, GpuOptions::default()),
        }
    }

    /// Builds the simulation on `backend`; `options` apply to the GPU backend only.
    #[cfg(feature = "gpu")]
    pub fn with_options(
        backend: Backend<'_>,
        grid: Grid<T>,
        model: M,
        stepping: Stepping,
        options: GpuOptions,
    ) -> Result<Self> {
        Ok(match backend {
            Backend::Cpu => Rd::Cpu(CpuRd::new(grid, model, stepping)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Rd::Gpu(GpuRd::new(ctx, grid, model, stepping, options)?),
        })
    }

    /// Changes the time-stepping settings (checked against the stability bound).
    pub fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        match self {
            Rd::Cpu(s) => s.set_stepping(stepping),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.set_stepping(stepping),
        }
    }

    /// Current time-stepping settings.
    pub fn stepping(&self) -> Stepping {
        match self {
            Rd::Cpu(s) => s.stepping(),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.stepping(),
        }
    }

    /// Simulated time, `steps_done * dt`.
    pub fn time(&self) -> f64 {
        match self {
            Rd::Cpu(s) => s.time(),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.time(),
        }
    }
}

impl<T: Real, M: Model> Simulation for Rd<T, M> {
    type State = Grid<T>;
    fn step(&mut self, steps: u32) -> Result<()> {
        match self {
            Rd::Cpu(s) => s.step(steps),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.step(steps),
        }
    }
    fn state(&mut self) -> Result<Grid<T>> {
        match self {
            Rd::Cpu(s) => s.state(),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.state(),
        }
    }
    fn steps_done(&self) -> u64 {
        match self {
            Rd::Cpu(s) => s.steps_done(),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.steps_done(),
        }
    }
    fn backend_name(&self) -> String {
        match self {
            Rd::Cpu(s) => s.backend_name(),
            #[cfg(feature = "gpu")]
            Rd::Gpu(s) => s.backend_name(),
        }
    }
}
