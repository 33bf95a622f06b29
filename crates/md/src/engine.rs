//! The backend-neutral engine interface behind [`crate::Md`].

use simkit_backend::particles::Dynamics;
use simkit_backend::{Precision, Result, checkpoint};

use crate::{Diagnostics, LennardJones, PairLaw, State};

/// The checkpoint model string of an engine: backend, precision, dimension and, for a
/// law other than the default [`LennardJones`], the law's name (`Md<cpu f64, 3>`,
/// `Md<gpu f32, 2, morse>`; [`checkpoint::model_with_law`]).
pub(crate) fn model_name<L: PairLaw>(gpu: bool, precision: Precision, axes: usize) -> String {
    let kind = checkpoint::engine_kind(gpu, precision, axes);
    checkpoint::model_with_law("Md", &kind, L::NAME, LennardJones::NAME)
}

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
    /// The complete dynamic state: steps, positions and velocities as the integrator
    /// stores them (leapfrog: the half-step velocities), the slot order and the positions of
    /// the last list build where the engine keeps a list. The forces are not stored: they
    /// are a deterministic function of the positions and are recomputed, bit for bit, on
    /// resume.
    fn save(&mut self) -> Result<Dynamics>;
}
