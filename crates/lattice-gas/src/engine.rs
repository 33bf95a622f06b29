//! The backend-neutral engine interface behind [`crate::LatticeGas`].

use simkit_backend::Result;

use crate::Lattice;
use crate::field::BlockField;

/// One backend instance ([`crate::LutCpu`], [`crate::MultiSpinCpu`] or the GPU backend).
pub(crate) trait Engine: Send {
    /// Advances the lattice by `steps` steps.
    fn step(&mut self, steps: u32) -> Result<()>;
    /// The current lattice (the GPU downloads it).
    fn state(&mut self) -> Result<Lattice>;
    /// Short backend name with the instruction set or layout that runs.
    fn name(&self) -> String;
    /// Sets the step counter that keys the random bits (a resumed run continues the
    /// random streams where the checkpointed run stopped).
    fn set_steps(&mut self, steps: u64) -> Result<()>;
    /// Block sums of density and momentum over `block x block` sites of the current lattice
    /// (by default from [`Engine::state`]; multi-spin counts its bit-planes directly).
    fn block_field(&mut self, block: usize) -> Result<BlockField> {
        BlockField::from_lattice(&self.state()?, block)
    }
}

/// Implements [`simkit_backend::Simulation`] for a public backend type by forwarding to its
/// [`Engine`] implementation (the type keeps its step count in a `steps` field).
macro_rules! simulation_via_engine {
    ($backend:ty) => {
        impl simkit_backend::Simulation for $backend {
            type State = $crate::Lattice;

            fn step(&mut self, steps: u32) -> simkit_backend::Result<()> {
                $crate::engine::Engine::step(self, steps)
            }

            fn state(&mut self) -> simkit_backend::Result<$crate::Lattice> {
                $crate::engine::Engine::state(self)
            }

            fn steps_done(&self) -> u64 {
                self.steps
            }

            fn backend_name(&self) -> String {
                $crate::engine::Engine::name(self)
            }
        }
    };
}
pub(crate) use simulation_via_engine;
