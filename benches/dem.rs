//! Placeholder until the dem crate issue lands its criterion bench here.
fn main() {}
