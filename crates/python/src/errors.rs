//! simkit's errors as Python exceptions.

use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use simkit::backend::Error;

pyo3::create_exception!(
    simkit,
    BlowUp,
    pyo3::exceptions::PyRuntimeError,
    "A run turned non-finite or left its physical limits during `step(n)`.\n\n\
     Attributes: `step` (the step at which the check found the bad state), \
     `rolled_back_to` (the step of the state the simulation now holds: the last one that \
     passed the check), `what` (the first bad particle, cell or quantity and its value) and \
     `cause` (the likely cause and the usual fix)."
);

/// Converts a simkit error into the Python exception a caller expects: `ValueError` for a
/// bad input (including a time step over the stability bound and an unreadable checkpoint),
/// `BlowUp` (a `RuntimeError`) for a blow-up, `OSError` for I/O, `RuntimeError` for the GPU
/// stack and unsupported requests. The message is the Rust error's, which names the bad
/// value and the fix.
pub(crate) fn to_py(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::InvalidParameter { .. } | Error::Unstable { .. } | Error::Checkpoint { .. } => {
            PyValueError::new_err(message)
        }
        Error::BlowUp {
            step,
            what,
            cause,
            rolled_back_to,
        } => Python::attach(|py| {
            let err = BlowUp::new_err(message);
            let value = err.value(py);
            let set = value
                .setattr("step", step)
                .and_then(|()| value.setattr("rolled_back_to", rolled_back_to))
                .and_then(|()| value.setattr("what", what))
                .and_then(|()| value.setattr("cause", cause));
            match set {
                Ok(()) => err,
                Err(failed) => failed,
            }
        }),
        Error::Io { .. } => PyOSError::new_err(message),
        Error::NoAdapter(_)
        | Error::BufferTooLarge { .. }
        | Error::Gpu(_)
        | Error::Unsupported(_) => PyRuntimeError::new_err(message),
    }
}

/// `Result<T, simkit::Error>` → `PyResult<T>`.
pub(crate) trait IntoPy<T> {
    /// The value, or the error as a Python exception ([`to_py`]).
    fn py(self) -> PyResult<T>;
}

impl<T> IntoPy<T> for simkit::backend::Result<T> {
    fn py(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}
