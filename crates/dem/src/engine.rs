//! The backend-neutral engine interface behind [`crate::Dem`].

use simkit_backend::particles::Dynamics;
use simkit_backend::{Backend, Precision, Result};

use crate::prepared::Prepared;
use crate::{ContactLaw, State};

/// The engine constructor of law `L` (`crate::sim::build_engine` compiled for it): the
/// prepared scene, the CPU's precision, the backend and, on resume, the saved dynamic
/// state.
pub(crate) type Build<L> =
    fn(Prepared<L>, Precision, Backend<'_>, Option<&Dynamics>) -> Result<Box<dyn Engine<L>>>;

/// The engines of one contact law, compiled where this value is made: see
/// [`ContactLaw::engines`].
#[doc(hidden)]
pub struct Engines<L>(pub(crate) Build<L>);

impl<L: ContactLaw> Engines<L> {
    /// The engines of `L`, compiled in the crate that calls this.
    pub(crate) fn compiled_here() -> Self {
        Self(crate::sim::build_engine::<L>)
    }
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
}
