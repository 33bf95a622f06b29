//! Placeholder until the neighbor crate issue lands its criterion bench here.
fn main() {}
