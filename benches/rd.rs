//! Placeholder until the rd crate issue lands its criterion bench here.
fn main() {}
