//! The backend-neutral engine interface behind [`crate::Dem`].

use simkit_backend::Result;

use crate::State;
use crate::prepared::Prepared;

/// One backend instance (CPU at some dimension and precision, or GPU).
pub(crate) trait Engine: Send {
    /// Advances `steps` time steps.
    fn step(&mut self, steps: u32) -> Result<()>;
    /// Time, positions and velocities (scene order, `[x, y, 0]` in 2D).
    fn state(&mut self) -> Result<State>;
    /// The validated scene and run settings the engine was built from.
    fn prepared(&self) -> &Prepared;
    /// Backend description (device, precision, threads).
    fn name(&self) -> String;
}
