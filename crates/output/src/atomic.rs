//! Atomic file writes: every output of this crate goes through here.
//!
//! The implementation lives in [`simkit_backend::atomic`] (checkpoints use it too): data is
//! written to a temporary file in the target's directory, flushed and synced, then renamed
//! over the target, so a reader sees either the old file or the complete new one.

pub use simkit_backend::atomic::{AtomicFile, io_error, write_atomic};
