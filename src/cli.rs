//! Support for the examples' command lines (which the examples parse themselves, with
//! clap): checkpoint and resume of a run ([`Checkpoints`]) and the exit status of a run
//! ([`exit_code`]).
//!
//! ```
//! use std::process::ExitCode;
//! use simkit::backend::{Error, Result};
//!
//! fn run(steps: u32) -> Result<()> {
//!     if steps == 0 {
//!         return Err(Error::invalid("--steps", steps, "give at least one step"));
//!     }
//!     Ok(())
//! }
//! // Prints nothing and succeeds; an error would print `error: <its Display text>`.
//! assert_eq!(simkit::cli::exit_code(run(10)), ExitCode::SUCCESS);
//! assert_eq!(simkit::cli::exit_code(run(0)), ExitCode::FAILURE);
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::backend::{Backend, Restart, Result, guard};

/// The exit status of a program whose work returned `result`: success, or failure after
/// printing `error: {e}` (the error's Display text) on stderr.
pub fn exit_code(result: Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Checkpoints of a time-stepping run (the examples' `--checkpoint-every N` and
/// `--resume FILE`):
///
/// - `every`: write `<out>/checkpoint.ckpt` whenever the step count reaches a multiple of
///   `every` (atomically, replacing the previous one; 0 = never);
/// - `resume`: continue the run saved in that file instead of starting a new one (bit for
///   bit as the uninterrupted run).
///
/// ```no_run
/// use simkit::prelude::*;
/// use simkit::lattice_gas::Config;
/// # fn main() -> Result<()> {
/// let out = std::path::Path::new("out/my_run");
/// // A checkpoint every 100 steps, not resuming.
/// let checkpoints = simkit::cli::Checkpoints::new(100, None, out);
/// let mut sim = checkpoints.start(Backend::Cpu, |backend| {
///     let mut lattice = Lattice::new(64, 64)?;
///     lattice.fill_random(0.2, 1)?;
///     LatticeGas::new(lattice, &Config::default(), backend)
/// })?;
/// while sim.steps_done() < 1000 {
///     checkpoints.step(&mut sim, 100)?; // writes out/my_run/checkpoint.ckpt on schedule
/// }
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Checkpoints {
    every: u32,
    resume: Option<PathBuf>,
    path: PathBuf,
}

impl Checkpoints {
    /// A checkpoint every `every` steps (0 = never) to `out/checkpoint.ckpt`, resuming the
    /// run saved in `resume` if given.
    pub fn new(every: u32, resume: Option<PathBuf>, out: &Path) -> Self {
        Self {
            every,
            resume,
            path: out.join("checkpoint.ckpt"),
        }
    }

    /// The run to continue: resumed from the `resume` file (saying so), else
    /// `fresh(backend)`.
    pub fn start<S: Restart>(
        &self,
        backend: Backend<'_>,
        fresh: impl FnOnce(Backend<'_>) -> Result<S>,
    ) -> Result<S> {
        match &self.resume {
            Some(file) => {
                let sim = S::resume_file(file, backend)?;
                println!(
                    "resumed from {} at step {}",
                    file.display(),
                    sim.steps_done()
                );
                Ok(sim)
            }
            None => fresh(backend),
        }
    }

    /// Advances `sim` by `steps`, writing a checkpoint at every multiple of `every` on the
    /// way (the stepping is split there; results are the same
    /// bit for bit).
    pub fn step<S: Restart>(&self, sim: &mut S, steps: u32) -> Result<()> {
        for n in guard::chunks(sim.steps_done(), steps, self.every) {
            sim.step(n)?;
            if self.every > 0 && sim.steps_done().is_multiple_of(u64::from(self.every)) {
                sim.write_checkpoint(&self.path)?;
            }
        }
        Ok(())
    }

    /// Where checkpoints are written.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
