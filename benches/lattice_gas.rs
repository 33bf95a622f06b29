//! Placeholder until the lattice_gas crate issue lands its criterion bench here.
fn main() {}
