//! What every simulation class does the same way: stepping with the GIL released,
//! checkpoints, and diagnostics as dicts.

use std::path::PathBuf;

use pyo3::prelude::*;
use simkit::backend::{Restart, Simulation};

use crate::backend::backend;
use crate::errors::IntoPy;

/// Runs `sim.step(n)` with the GIL released (other Python threads run meanwhile).
pub(crate) fn step<S: Simulation + Send>(py: Python<'_>, sim: &mut S, n: u32) -> PyResult<()> {
    py.detach(|| sim.step(n)).py()
}

/// Writes a checkpoint of `sim` to `path` (atomically: a crash leaves the old file or the
/// new one), with the GIL released.
pub(crate) fn write_checkpoint<S: Restart + Send>(
    py: Python<'_>,
    sim: &mut S,
    path: PathBuf,
) -> PyResult<()> {
    py.detach(|| sim.write_checkpoint(&path)).py()
}

/// Reads a checkpoint written by `write_checkpoint` and continues on `backend_name`.
pub(crate) fn resume<S: Restart + Send>(
    py: Python<'_>,
    path: PathBuf,
    backend_name: &str,
) -> PyResult<S> {
    let b = backend(backend_name)?;
    py.detach(|| S::resume_file(&path, b)).py()
}

/// A dict from `key => value` pairs (values of any type PyO3 converts).
macro_rules! pydict {
    ($py:expr, $($k:literal => $v:expr),+ $(,)?) => {{
        let d = pyo3::types::PyDict::new($py);
        $( pyo3::types::PyDictMethods::set_item(&d, $k, $v)?; )+
        d
    }};
}
pub(crate) use pydict;

/// A simulation owned by a Python object.
///
/// PyO3 shares objects between threads, so a class must be `Sync`; the simulations are
/// `Send` but not `Sync` (their engines keep per-run scratch state). Every method that
/// touches the simulation takes `&mut self`, so PyO3's borrow flag already gives it
/// exclusive access (a second thread calling in while `step` runs gets a `RuntimeError`,
/// "Already borrowed", instead of waiting); the mutex only makes the type `Sync` and is
/// never locked ([`Mutex::get_mut`] needs no lock).
pub(crate) struct Owned<T>(std::sync::Mutex<T>);

impl<T> Owned<T> {
    /// Takes ownership of `sim`.
    pub(crate) fn new(sim: T) -> Self {
        Self(std::sync::Mutex::new(sim))
    }

    /// The simulation, exclusively.
    pub(crate) fn get(&mut self) -> &mut T {
        self.0
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}
