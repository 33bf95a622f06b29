//! Command-line options for the examples: `--name value` pairs and bare `--flag`s, with
//! errors (not panics) that name the option and the value that did not parse.
//!
//! ```
//! // With no `--steps` on the command line the default comes back.
//! let steps: u32 = simkit::cli::arg("--steps", 100).unwrap();
//! assert_eq!(steps, 100);
//! assert!(!simkit::cli::flag("--gpu"));
//! ```

use std::path::{Path, PathBuf};

use crate::backend::{Backend, Error, Restart, Result, guard};

/// The value after `name` on the command line parsed as `T`, or `default` when `name` is
/// absent. A missing or unparsable value is an [`Error::InvalidParameter`] naming both.
pub fn arg<T: std::str::FromStr>(name: &str, default: T) -> Result<T> {
    arg_in(&std::env::args().collect::<Vec<_>>(), name, default)
}

/// Whether the bare option `name` (e.g. `--gpu`) is on the command line.
pub fn flag(name: &str) -> bool {
    std::env::args().any(|a| a == name)
}

/// [`arg`] over an explicit argument list.
fn arg_in<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => {
            let v = args.get(i + 1).map(String::as_str).unwrap_or("");
            v.parse().map_err(|_| {
                Error::invalid(
                    name,
                    v,
                    format!("could not parse it as {}", std::any::type_name::<T>()),
                )
            })
        }
    }
}

/// The checkpoint options of the time-stepping examples:
///
/// - `--checkpoint-every N`: write `<out>/checkpoint.ckpt` whenever the step count reaches a
///   multiple of `N` (atomically, replacing the previous one; 0 = never, the default);
/// - `--resume FILE`: continue the run saved in `FILE` instead of starting a new one (the
///   example then runs on up to its total `--steps`, bit for bit as the uninterrupted run).
///
/// ```no_run
/// use simkit::prelude::*;
/// use simkit::lattice_gas::Config;
/// # fn main() -> Result<()> {
/// let out = std::path::Path::new("out/my_run");
/// let checkpoints = simkit::cli::Checkpoints::from_args(out)?;
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
    /// Reads `--checkpoint-every` and `--resume` from the command line; checkpoints go to
    /// `out/checkpoint.ckpt`.
    pub fn from_args(out: &Path) -> Result<Self> {
        let resume: String = arg("--resume", String::new())?;
        Ok(Self {
            every: arg("--checkpoint-every", 0)?,
            resume: (!resume.is_empty()).then(|| PathBuf::from(resume)),
            path: out.join("checkpoint.ckpt"),
        })
    }

    /// The run to continue: resumed from `--resume FILE` (saying so), else `fresh(backend)`.
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

    /// Advances `sim` by `steps`, writing a checkpoint at every multiple of
    /// `--checkpoint-every` on the way (the stepping is split there; results are the same
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

#[cfg(test)]
mod tests {
    use super::arg_in;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn values_defaults_and_errors() {
        let a = args("prog --n 42 --dt 0.5 --bad x");
        assert_eq!(arg_in::<u32>(&a, "--n", 7).unwrap(), 42);
        assert_eq!(arg_in::<f64>(&a, "--dt", 1.0).unwrap(), 0.5);
        assert_eq!(arg_in::<u32>(&a, "--m", 7).unwrap(), 7);
        let e = arg_in::<u32>(&a, "--bad", 7).unwrap_err().to_string();
        assert!(
            e.contains("--bad") && e.contains('x') && e.contains("u32"),
            "{e}"
        );
        assert!(arg_in::<u32>(&args("prog --n"), "--n", 7).is_err());
    }
}
