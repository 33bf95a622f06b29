//! The backend-neutral engine interface behind [`crate::Dem`].

use simkit_backend::particles::Dynamics;
use simkit_backend::{Precision, Result, checkpoint};

use crate::prepared::Prepared;
use crate::{ContactLaw, Material, State};

/// The checkpoint model string of an engine: backend, precision, dimension and, for a
/// contact law other than the default [`Material`], the law's name
/// ([`checkpoint::model_with_law`]).
pub(crate) fn model_name<L: ContactLaw>(gpu: bool, precision: Precision, axes: usize) -> String {
    let kind = checkpoint::engine_kind(gpu, precision, axes);
    checkpoint::model_with_law("Dem", &kind, L::NAME, Material::NAME)
}

/// One backend instance (CPU at some dimension and precision, or GPU).
pub(crate) trait Engine<L>: Send {
    /// Advances `steps` time steps with the blow-up check (see [`simkit_backend::guard`]);
    /// on a failed check the engine is back at the last state that passed and returns
    /// [`simkit_backend::Error::BlowUp`].
    fn step(&mut self, steps: u32) -> Result<()>;
    /// Time, positions and velocities (scene order, `[x, y, 0]` in 2D).
    fn state(&mut self) -> Result<State>;
    /// The validated scene and run settings the engine was built from.
    fn prepared(&self) -> &Prepared<L>;
    /// Backend description (device, precision, threads).
    fn name(&self) -> String;
    /// Steps done since the start of the run (checkpoints included).
    fn steps_done(&self) -> u64;
    /// The checkpoint model string (backend kind, precision, dimension).
    fn model(&self) -> String;
    /// The complete dynamic state (downloaded on the GPU): CPU: positions (not wrapped
    /// since the last list build), velocities, accelerations, predicted velocities
    /// (velocity Verlet) or last displacements (position Verlet) as `aux`, the slot order
    /// (cell order of the last list build) and the list-build positions, the step count and
    /// the accumulated time; GPU: `(x, y, z, radius)`, `(vx, vy, vz, mass)`, the
    /// accelerations with the deepest overlap ratio as `w`, in scene order.
    fn save(&mut self) -> Result<Dynamics>;
    /// The forces and torques on every particle (scene order) that the next step starts
    /// from: evaluated now if the run has not started (as its first step would, so the
    /// run's results do not change), else those of the last step.
    fn forces(&mut self) -> Result<crate::Forces>;
}
