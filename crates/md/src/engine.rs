//! The backend-neutral engine interface behind [`crate::Md`].

use simkit_backend::particles::Dynamics;
use simkit_backend::{Backend, Result};

use crate::{Config, Diagnostics, PairLaw, State, System};

/// The engine constructor of law `L` (`crate::sim::build_engine` compiled for it): the
/// system, the settings, the resolved time step, the backend and, on resume, the saved
/// dynamic state.
pub(crate) type Build<L> =
    fn(&System<L>, &Config, f64, Backend<'_>, Option<&Dynamics>) -> Result<Box<dyn Engine>>;

/// The engines of one pair law, compiled where this value is made: see
/// [`PairLaw::engines`].
#[doc(hidden)]
pub struct Engines<L>(pub(crate) Build<L>);

impl<L: PairLaw> Engines<L> {
    /// The engines of `L`, compiled in the crate that calls this.
    pub(crate) fn compiled_here() -> Self {
        Self(crate::sim::build_engine::<L>)
    }
}

/// The override of [`PairLaw::engines`] for the built-in laws: their engines are compiled
/// once, in this crate (`inline(never)` keeps the function, and so the engines, from
/// being copied into the crates that call it).
macro_rules! engines_compiled_in_simkit_md {
    () => {
        #[inline(never)]
        fn engines() -> crate::engine::Engines<Self> {
            crate::engine::Engines::compiled_here()
        }
    };
}
pub(crate) use engines_compiled_in_simkit_md;

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
