//! Placeholder until the pp_coulomb crate issue lands its criterion bench here.
fn main() {}
