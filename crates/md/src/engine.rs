//! The backend-neutral engine interface behind [`crate::Md`], and the engine part of a
//! checkpoint.

use serde::{Deserialize, Serialize};
use simkit_backend::Result;

use crate::{Diagnostics, State};

/// One backend instance (the CPU at some dimension and precision).
pub(crate) trait Engine: Send {
    /// Advances `steps` time steps with the blow-up check (see [`simkit_backend::guard`]);
    /// on a failed check the engine is back at the last state that passed and returns
    /// [`simkit_backend::Error::BlowUp`].
    fn step(&mut self, steps: u32) -> Result<()>;
    /// Time, positions, velocities (at the step) and species, in the system's order.
    fn state(&mut self) -> Result<State>;
    /// Energies, virial pressure and per-species temperatures of the current state.
    fn diagnostics(&mut self) -> Result<Diagnostics>;
    /// The forces on every particle at the current positions (`[fx, fy, 0]` in 2D).
    fn forces(&mut self) -> Result<Vec<[f64; 3]>>;
    /// Backend description (device, precision, threads).
    fn name(&self) -> String;
    /// Steps done since the start of the run (checkpoints included).
    fn steps_done(&self) -> u64;
    /// The checkpoint model string (backend kind, precision, dimension).
    fn model(&self) -> String;
    /// The complete dynamic state.
    fn save(&mut self) -> Result<EngineState>;
    /// The positions the neighbour list was last built from (flat, system order), which a
    /// bit-exact resume needs along with [`save`](Self::save)'s state; empty for an
    /// engine whose list is a function of the current positions.
    fn list_positions(&self) -> Vec<f64> {
        Vec::new()
    }
}

/// The dynamic state of an engine as a checkpoint stores it. Vectors are flat, `D` values
/// per particle, and hold the engine's numbers exactly (`f32` widens to `f64` without
/// rounding). The forces are not stored: they are a deterministic function of the
/// positions and are recomputed, bit for bit, on resume.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct EngineState {
    /// Steps done.
    pub steps: u64,
    /// Positions: on the GPU with periodic axes wrapped into the box; on the CPU as the
    /// engine holds them, periodic coordinates unwrapped since its last list build (by at
    /// most half the skin).
    pub pos: Vec<f64>,
    /// Velocities as the integrator stores them (leapfrog: at the half step `t + dt/2`).
    pub vel: Vec<f64>,
    /// The CPU's slot order (the system index of the particle in each slot, in cell order
    /// as of the last list build; empty: the system order). The force sums run in slot
    /// order, so a bit-exact resume needs it.
    pub order: Vec<u32>,
}
