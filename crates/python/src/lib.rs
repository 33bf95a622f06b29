//! Python bindings of simkit: the native module `simkit._native`, re-exported by the pure
//! Python package `simkit` (crates/python/python/simkit).
//!
//! One class per simulation crate (`Md`, `Dem`, `Rd`, `LatticeGas`, `PpCoulomb`) and the
//! neighbour search (`NeighborSearch`). Every constructor takes numpy arrays (or anything
//! `numpy.asarray` accepts) and keyword arguments named after the Rust configs' fields, with
//! the same defaults; every check of the Rust library applies, and its errors become Python
//! exceptions (`ValueError` for a bad input, `simkit.BlowUp` for a run that turned
//! non-finite, `OSError` for I/O, `RuntimeError` for the GPU stack). `step(n)` releases the
//! GIL while the simulation runs.

mod arrays;
mod backend;
mod common;
mod dem;
mod errors;
mod lattice_gas;
mod md;
mod neighbor;
mod pp_coulomb;
mod rd;

use pyo3::prelude::*;

/// The native module. Its contents are re-exported by `simkit/__init__.py`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("BlowUp", py.get_type::<errors::BlowUp>())?;
    m.add_function(wrap_pyfunction!(backend::adapters, m)?)?;
    m.add_function(wrap_pyfunction!(backend::has_gpu_support, m)?)?;
    m.add_class::<md::Md>()?;
    m.add_class::<dem::Dem>()?;
    m.add_class::<rd::Rd>()?;
    m.add_class::<lattice_gas::LatticeGas>()?;
    m.add_class::<pp_coulomb::PpCoulomb>()?;
    m.add_class::<neighbor::NeighborSearch>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
