//! Outputs (filled in).
