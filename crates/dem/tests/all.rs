//! Every integration test of `simkit-dem` in one test binary: each file of `tests/` is a
//! module here, so the crate and its generic code are compiled and linked once for all
//! of them instead of once per file.
//! `tests/mpi.rs` stays its own binary: it launches itself under `mpirun` and needs the
//! `mpi` feature. A new test file is added here as a module (the crate's Cargo.toml
//! sets `autotests = false`).

mod api;
mod collisions;
mod conformance;
mod contact_law;
mod distributed;
mod friction;
mod guards;
mod lammps_granular;
mod laws;
mod physics;
mod piles;
mod restart;
mod robustness;
mod rotation;
mod segregation;
