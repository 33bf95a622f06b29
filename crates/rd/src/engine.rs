//! What every backend implements ([`Engine`]); the CPU and GPU backends import this module,
//! and [`crate::Rd`] builds them.

use simkit_backend::{Real, Result};

use crate::grid::Grid;
use crate::model::Model;
use crate::stepper::Stepping;

/// One backend instance (CPU or GPU) advancing a grid of `T` under model `M`.
pub(crate) trait Engine<T: Real, M: Model>: Send {
    /// Advances `steps` steps with the blow-up checks (see [`crate::Rd`]): the bound from
    /// the current fields first (`Error::Unstable`, nothing done), then in stretches ending
    /// on multiples of `check_every` and at the end of the call, each followed by the finite
    /// check (on failure: back to the last state that passed, `Error::BlowUp`) and, inside
    /// the call, the bound re-check (on failure: stop there, `Error::BlowUp`).
    fn step(&mut self, steps: u32) -> Result<()>;
    /// The current fields.
    fn state(&mut self) -> Result<Grid<T>>;
    /// Backend name.
    fn name(&self) -> String;
    /// Steps taken so far.
    fn steps_done(&self) -> u64;
    /// The model.
    fn model(&self) -> &M;
    /// Current time-stepping settings.
    fn stepping(&self) -> Stepping;
    /// Changes the time-stepping settings (checked against the bound from the current
    /// fields).
    fn set_stepping(&mut self, stepping: Stepping) -> Result<()>;
    /// Largest stable `dt` for the current fields.
    fn stable_dt(&self) -> Result<f64>;
}
