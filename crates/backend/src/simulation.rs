//! The common trait every simulation backend implements, and the backend selector.

use crate::Error;
#[cfg(feature = "gpu")]
use crate::GpuContext;

/// A time-stepping simulation with a host-side snapshot type.
///
/// CPU and GPU backends of one model implement this trait with the same `State`, so that
/// examples, tests and user code swap backends with one line.
pub trait Simulation {
    /// Host-side snapshot of the simulation state.
    type State;
    /// Advances the simulation by `steps` time steps (GPU backends: without host round trips).
    ///
    /// Time-stepping crates check the state while they step (see [`crate::guard`]): a run
    /// that turns non-finite or leaves its model's limits returns [`Error::BlowUp`] and is
    /// put back to the last state that passed the check.
    fn step(&mut self, steps: u32) -> Result<(), Error>;
    /// Returns a snapshot of the current state (GPU backends download it).
    fn state(&mut self) -> Result<Self::State, Error>;
    /// Number of steps of this run (a run resumed from a checkpoint counts from the
    /// checkpoint's step).
    fn steps_done(&self) -> u64;
    /// Short human-readable backend name, e.g. `"cpu"`, `"cpu-multispin"`, `"gpu (llvmpipe)"`.
    fn backend_name(&self) -> String;
}

/// Which backend to run a model on: a runtime value, never a compile-time fork.
#[derive(Clone, Copy, Debug)]
pub enum Backend<'a> {
    /// Multi-threaded CPU backend (rayon).
    Cpu,
    /// GPU backend on the given context.
    #[cfg(feature = "gpu")]
    Gpu(&'a GpuContext),
    /// Never constructed: keeps the lifetime parameter when the `gpu` feature is off, so that
    /// code naming `Backend<'_>` builds either way (an uninhabited variant: a by-value `match`
    /// need not list it).
    #[cfg(not(feature = "gpu"))]
    #[doc(hidden)]
    NoGpu(std::convert::Infallible, std::marker::PhantomData<&'a ()>),
}

impl Backend<'_> {
    /// Whether this is a GPU backend.
    pub fn is_gpu(&self) -> bool {
        match self {
            Backend::Cpu => false,
            #[cfg(feature = "gpu")]
            Backend::Gpu(_) => true,
            #[cfg(not(feature = "gpu"))]
            Backend::NoGpu(never, _) => match *never {},
        }
    }

    /// `"cpu"` or `"gpu (<adapter name>)"`.
    pub fn name(&self) -> String {
        match self {
            Backend::Cpu => "cpu".to_string(),
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => format!("gpu ({})", ctx.adapter_info().name),
            #[cfg(not(feature = "gpu"))]
            Backend::NoGpu(never, _) => match *never {},
        }
    }
}
