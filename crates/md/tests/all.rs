//! Every integration test of `simkit-md` in one test binary: each file of `tests/` is a
//! module here, so the crate and its generic code are compiled and linked once for all
//! of them instead of once per file.
//! `tests/mpi.rs` stays its own binary: it launches itself under `mpirun` and needs the
//! `mpi` feature. A new test file is added here as a module (the crate's Cargo.toml
//! sets `autotests = false`).

mod api;
mod conformance;
mod distributed;
mod gpu_kernels;
mod guards;
mod lammps;
mod laws;
mod nist;
mod physics;
mod reorder;
mod restart;
mod robustness;
mod thermostat;
