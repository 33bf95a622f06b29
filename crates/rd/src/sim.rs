//! [`Rd`]: the reaction–diffusion simulation on either backend, chosen by a
//! [`simkit_backend::Backend`] value.

use simkit_backend::{Backend, Result, Simulation};

use crate::cpu::CpuRd;
use crate::engine::Engine;
#[cfg(feature = "gpu")]
use crate::gpu::GpuRd;
use crate::{Config, Grid, Model, Real, Stepping};

/// Reaction–diffusion of the fields of a [`Grid`] under a [`Model`], on the backend chosen at
/// construction.
///
/// The stability bound `dt <= h^2 / (4 D_max)` is checked at construction, at
/// [`Rd::set_stepping`] and, for models whose diffusivity depends on the fields, again before
/// each `step` call from the current fields (on the GPU, a reduction kernel finds `D_max` on
/// the device, in f32, and only that number is read back).
pub struct Rd<T: Real, M: Model> {
    engine: Box<dyn Engine<T, M>>,
}

impl<T: Real, M: Model> std::fmt::Debug for Rd<T, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rd")
            .field("backend", &self.engine.name())
            .field("model", self.engine.model())
            .field("stepping", &self.engine.stepping())
            .field("steps", &self.engine.steps_done())
            .finish()
    }
}

impl<T: Real, M: Model> Rd<T, M> {
    /// Validates `config`, checks the model against the grid and `dt` against the stability
    /// bound (unless overridden), and builds the backend `backend` names (the grid is
    /// uploaded once on the GPU).
    ///
    /// Errors: an invalid [`Config`], a model that does not fit the grid, non-finite field
    /// values, an unstable `dt`; on the GPU also `f64` fields without `SHADER_F64`, a tile
    /// over the device's workgroup limits, a grid over the buffer or dispatch limits.
    pub fn new(grid: Grid<T>, model: M, config: &Config, backend: Backend<'_>) -> Result<Self> {
        config.validate()?;
        let engine: Box<dyn Engine<T, M>> = match backend {
            Backend::Cpu => Box::new(CpuRd::new(grid, model, config)?),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => Box::new(GpuRd::new(ctx, grid, model, config)?),
        };
        Ok(Self { engine })
    }

    /// The model.
    pub fn model(&self) -> &M {
        self.engine.model()
    }

    /// Changes the time-stepping settings (checked against the stability bound from the
    /// current fields).
    pub fn set_stepping(&mut self, stepping: Stepping) -> Result<()> {
        self.engine.set_stepping(stepping)
    }

    /// Current time-stepping settings.
    pub fn stepping(&self) -> Stepping {
        self.engine.stepping()
    }

    /// Simulated time, `steps_done * dt` (for a constant `dt`).
    pub fn time(&self) -> f64 {
        self.engine.steps_done() as f64 * self.engine.stepping().dt
    }

    /// Largest stable `dt`, `h^2 / (4 D_max)`, for the current fields (on the GPU, for
    /// models whose diffusivity depends on the fields, `D_max` is reduced on the device in
    /// f32 and read back: hence the `Result`).
    pub fn stable_dt(&self) -> Result<f64> {
        self.engine.stable_dt()
    }
}

impl<T: Real, M: Model> Simulation for Rd<T, M> {
    type State = Grid<T>;

    /// Advances `steps` steps; the stability bound is re-checked first from the current
    /// fields when the model's diffusivity depends on them.
    fn step(&mut self, steps: u32) -> Result<()> {
        self.engine.step(steps)
    }

    fn state(&mut self) -> Result<Grid<T>> {
        self.engine.state()
    }

    fn steps_done(&self) -> u64 {
        self.engine.steps_done()
    }

    fn backend_name(&self) -> String {
        self.engine.name()
    }
}
