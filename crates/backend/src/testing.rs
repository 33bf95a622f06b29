//! Test support: a shared [`GpuContext`] or an explained skip.

use std::sync::OnceLock;

use crate::{Error, GpuContext};

/// Environment variable that turns a missing GPU adapter from a skip into a test failure
/// (set by `.ci/run`).
pub const REQUIRE_GPU_ENV: &str = "SIMKIT_REQUIRE_GPU";

static CONTEXT: OnceLock<Result<GpuContext, Error>> = OnceLock::new();

/// Whether `SIMKIT_REQUIRE_GPU` is set to something other than `0` or empty.
pub fn gpu_required() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| !v.is_empty() && v != "0")
}

/// The process-wide GPU context for tests, or `None` with a printed reason.
///
/// # Panics
/// When no adapter is available and `SIMKIT_REQUIRE_GPU=1`: a GPU test must then fail
/// rather than pass silently.
pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    match CONTEXT.get_or_init(GpuContext::new) {
        Ok(ctx) => Some(ctx.clone()),
        Err(e) if gpu_required() => {
            panic!("{test}: {REQUIRE_GPU_ENV} is set but no GPU is available: {e}")
        }
        Err(e) => {
            eprintln!("SKIPPED {test}: {e}");
            None
        }
    }
}
