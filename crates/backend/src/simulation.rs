//! The common trait every simulation backend implements, and the backend selector.

use std::ops::ControlFlow;

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

    /// Advances `steps` steps in chunks of `every` and calls `observe` after each chunk
    /// (the last one may be shorter), for progress bars, live output or a stop criterion.
    ///
    /// Each chunk is one [`step`](Self::step) call, so a GPU backend still records a chunk's
    /// steps without host round trips: pick `every` as large as the observation allows.
    /// The result is bit-identical to one `step(steps)` (the crates' checks run on absolute
    /// step numbers, so they do not depend on how a run is split into calls).
    /// `observe` gets the simulation (read its state, diagnostics, [`steps_done`]) and
    /// returns [`ControlFlow::Break`] to stop early; an error it returns is passed on.
    ///
    /// Errors: `every == 0`; any error of `step` or of `observe`.
    ///
    /// ```
    /// use std::ops::ControlFlow;
    /// # use simkit_backend::{Error, Simulation};
    /// # struct Counter(u64);
    /// # impl Simulation for Counter {
    /// #     type State = u64;
    /// #     fn step(&mut self, steps: u32) -> Result<(), Error> { self.0 += u64::from(steps); Ok(()) }
    /// #     fn state(&mut self) -> Result<u64, Error> { Ok(self.0) }
    /// #     fn steps_done(&self) -> u64 { self.0 }
    /// #     fn backend_name(&self) -> String { "cpu".into() }
    /// # }
    /// # let mut sim = Counter(0);
    /// let mut seen = Vec::new();
    /// sim.step_observed(250, 100, |s| {
    ///     seen.push(s.steps_done());
    ///     Ok(ControlFlow::Continue(()))
    /// })?;
    /// assert_eq!(seen, [100, 200, 250]);
    /// # Ok::<(), Error>(())
    /// ```
    ///
    /// [`steps_done`]: Self::steps_done
    fn step_observed<F>(&mut self, steps: u64, every: u32, mut observe: F) -> Result<(), Error>
    where
        Self: Sized,
        F: FnMut(&mut Self) -> Result<ControlFlow<()>, Error>,
    {
        if every == 0 {
            return Err(Error::invalid(
                "observation interval `every`",
                every,
                "at least 1 step",
            ));
        }
        let mut left = steps;
        while left > 0 {
            let chunk = left.min(u64::from(every)) as u32;
            self.step(chunk)?;
            left -= u64::from(chunk);
            if observe(self)?.is_break() {
                break;
            }
        }
        Ok(())
    }
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

    /// Whether this backend computes in `f64`: the CPU always, a GPU when its adapter has
    /// `SHADER_F64` ([`GpuContext::has_f64`]).
    pub fn has_f64(&self) -> bool {
        match self {
            Backend::Cpu => true,
            #[cfg(feature = "gpu")]
            Backend::Gpu(ctx) => ctx.has_f64(),
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
