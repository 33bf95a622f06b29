//! Run configuration: time stepping, CPU temporal blocking and the GPU kernel options.

use serde::{Deserialize, Serialize};
use simkit_backend::guard::DEFAULT_CHECK_EVERY;
use simkit_backend::{Error, Result, require_positive};

use crate::stepper::Stepping;

/// Default number of Euler steps the CPU fuses into one sweep over the grid (temporal
/// blocking).
pub const DEFAULT_STEPS_PER_SWEEP: u32 = 4;
/// Most Euler steps one CPU sweep may fuse.
pub(crate) const MAX_STEPS_PER_SWEEP: u32 = 16;

/// Which stencil kernel the GPU backend runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum GpuKernel {
    /// Tile plus one-cell halo staged in workgroup memory.
    Tiled,
    /// Every neighbour read straight from global memory, served by the caches (default: 1.8x
    /// the tiled kernel on an NVIDIA H200 and 1.2-1.9x on lavapipe; docs/gpu.md).
    #[default]
    Global,
}

/// GPU backend options (plain data: the CPU backend ignores them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GpuOptions {
    /// Stencil kernel.
    pub kernel: GpuKernel,
    /// Tile (= workgroup) size `(x, y)` in cells; a WGSL override constant. Both at least 1;
    /// the device's workgroup limits are checked when the GPU backend is built.
    pub tile: (u32, u32),
    /// Steps recorded into one command buffer before it is submitted (at least 1).
    pub steps_per_submit: u32,
}

impl Default for GpuOptions {
    /// The global-memory kernel, 16 x 16 workgroups, 100 steps per submission.
    fn default() -> Self {
        Self {
            kernel: GpuKernel::Global,
            tile: (16, 16),
            steps_per_submit: 100,
        }
    }
}

/// Everything a run needs besides the grid and the model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// Time step, integrator and stability guard.
    pub stepping: Stepping,
    /// GPU kernel options (ignored by the CPU backend).
    pub gpu: GpuOptions,
    /// CPU backend: explicit Euler steps fused into one sweep over the grid (temporal
    /// blocking), 1..=16; 1 = one pass per step. The results are bit-identical for every
    /// value, only the speed changes. Ignored by the GPU backend. Default
    /// [`DEFAULT_STEPS_PER_SWEEP`].
    pub steps_per_sweep: u32,
    /// Interval, in steps counted from step 0, of the blow-up check inside `step(n)`: every
    /// field finite and, for a model whose diffusivity depends on the fields (with the guard
    /// enforced), `dt` still within the stability bound of the current fields. A failed
    /// check returns [`simkit_backend::Error::BlowUp`] (see [`crate::Rd`]). `0` turns the
    /// interval checks off; the check at the end of every `step(n)` call stays. Checks never
    /// change the results. Default [`DEFAULT_CHECK_EVERY`] (100).
    pub check_every: u32,
}

impl Config {
    /// The given stepping with default GPU options, [`DEFAULT_STEPS_PER_SWEEP`] and a
    /// blow-up check every [`DEFAULT_CHECK_EVERY`] steps.
    pub fn new(stepping: Stepping) -> Self {
        Self {
            stepping,
            gpu: GpuOptions::default(),
            steps_per_sweep: DEFAULT_STEPS_PER_SWEEP,
            check_every: DEFAULT_CHECK_EVERY,
        }
    }

    /// Sets the interval of the blow-up check (see [`Config::check_every`]; 0 = only at the
    /// end of each `step(n)` call).
    pub fn with_check_every(mut self, check_every: u32) -> Self {
        self.check_every = check_every;
        self
    }

    /// Sets the GPU options.
    pub fn with_gpu(mut self, gpu: GpuOptions) -> Self {
        self.gpu = gpu;
        self
    }

    /// Sets the number of Euler steps the CPU fuses into one sweep (see
    /// [`Config::steps_per_sweep`]).
    pub fn with_steps_per_sweep(mut self, steps_per_sweep: u32) -> Self {
        self.steps_per_sweep = steps_per_sweep;
        self
    }

    /// Checks the settings that do not depend on the grid, the model or the device: `dt`
    /// finite and positive, `steps_per_sweep` in 1..=16 (every `check_every` is valid), a GPU tile of at least 1 x 1 and at
    /// least one step per submission. The stability bound is checked when the simulation is
    /// built (it needs the fields), the tile against the device limits when the GPU backend
    /// is built.
    pub fn validate(&self) -> Result<()> {
        require_positive("dt", self.stepping.dt)?;
        if !(1..=MAX_STEPS_PER_SWEEP).contains(&self.steps_per_sweep) {
            return Err(Error::invalid(
                "steps per sweep",
                self.steps_per_sweep,
                format!("must be 1..={MAX_STEPS_PER_SWEEP} (1 = no temporal blocking)"),
            ));
        }
        let (tx, ty) = self.gpu.tile;
        if tx == 0 || ty == 0 {
            return Err(Error::invalid(
                "GPU tile",
                format!("{tx} x {ty}"),
                "both sides must be at least 1",
            ));
        }
        if self.gpu.steps_per_submit == 0 {
            return Err(Error::invalid("steps_per_submit", 0, "must be >= 1"));
        }
        Ok(())
    }
}

impl From<Stepping> for Config {
    /// [`Config::new`].
    fn from(stepping: Stepping) -> Self {
        Self::new(stepping)
    }
}
