//! Test support shared by every crate's conformance tests: the backends to compare, a shared
//! GPU context or an explained skip, and comparison metrics with stated tolerances.
//!
//! A conformance test runs the same scene on every backend [`backends`] returns (the CPU,
//! then the GPU when the `gpu` feature is compiled in and an adapter exists) and compares
//! each result with the CPU's: bit for bit where a crate promises it, else with
//! [`max_rel_diff`] against a tolerance the test states and justifies.

#[cfg(feature = "gpu")]
mod wgsl;
#[cfg(feature = "gpu")]
pub use wgsl::{FieldOffset, WgslStruct, assert_mirrors, eval_wgsl, wgsl_struct};

#[cfg(feature = "gpu")]
use std::sync::OnceLock;

use crate::Backend;
#[cfg(feature = "gpu")]
use crate::{Error, GpuContext};

/// Environment variable that turns a missing GPU adapter from a skip into a test failure
/// (set by `.ci/run`).
pub const REQUIRE_GPU_ENV: &str = "SIMKIT_REQUIRE_GPU";

#[cfg(feature = "gpu")]
static CONTEXT: OnceLock<Result<GpuContext, Error>> = OnceLock::new();

/// Whether `SIMKIT_REQUIRE_GPU` is set to something other than `0` or empty.
pub fn gpu_required() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| !v.is_empty() && v != "0")
}

#[cfg(feature = "gpu")]
/// The process-wide GPU context for tests, or `None` with a printed reason.
///
/// # Panics
/// When no adapter is available and `SIMKIT_REQUIRE_GPU=1`: a GPU test must then fail
/// rather than pass silently.
pub fn gpu_or_skip(test: &str) -> Option<GpuContext> {
    shared_gpu(test).cloned()
}

#[cfg(feature = "gpu")]
/// The process-wide GPU context (lives as long as the test process), or `None` with a
/// printed reason; panics like [`gpu_or_skip`] under `SIMKIT_REQUIRE_GPU=1`.
pub fn shared_gpu(test: &str) -> Option<&'static GpuContext> {
    match CONTEXT.get_or_init(GpuContext::new) {
        Ok(ctx) => Some(ctx),
        Err(e) if gpu_required() => {
            panic!("{test}: {REQUIRE_GPU_ENV} is set but no GPU is available: {e}")
        }
        Err(e) => {
            eprintln!("SKIPPED {test}: {e}");
            None
        }
    }
}

/// Every backend a conformance test runs: [`Backend::Cpu`] first, then the GPU on the shared
/// context when the `gpu` feature is compiled in and an adapter exists (a missing adapter is
/// a printed skip, or a panic under `SIMKIT_REQUIRE_GPU=1`).
pub fn backends(test: &str) -> Vec<Backend<'static>> {
    #[allow(unused_mut)] // only the `gpu` feature adds a second backend
    let mut list = vec![Backend::Cpu];
    #[cfg(feature = "gpu")]
    if let Some(ctx) = shared_gpu(test) {
        list.push(Backend::Gpu(ctx));
    }
    #[cfg(not(feature = "gpu"))]
    eprintln!("{test}: the `gpu` feature is off, CPU backend only");
    list
}

/// Largest difference between `a` and `b` relative to the largest magnitude in `reference`
/// (a scale for the whole field, so values near zero do not inflate the figure). `NaN`
/// anywhere gives `f64::INFINITY`, so a blown-up run never passes a tolerance.
///
/// # Panics
/// When the slices differ in length (a test bug, not a physics difference).
pub fn max_rel_diff(a: &[f64], b: &[f64], reference: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "compared fields differ in length");
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut worst = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        let d = (x - y).abs();
        if d.is_nan() {
            return f64::INFINITY;
        }
        worst = worst.max(d);
    }
    if scale > 0.0 { worst / scale } else { worst }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cpu_backend_comes_first() {
        let b = backends("the_cpu_backend_comes_first");
        assert!(matches!(b[0], Backend::Cpu));
        assert!(b.len() <= 2);
    }

    #[test]
    fn relative_difference_scales_by_the_reference_and_flags_nan() {
        assert_eq!(max_rel_diff(&[1.0, 2.0], &[1.0, 2.0], &[1.0, 2.0]), 0.0);
        assert!((max_rel_diff(&[1.0, 2.0], &[1.0, 2.2], &[1.0, 2.0]) - 0.1).abs() < 1e-12);
        assert_eq!(max_rel_diff(&[0.0], &[1e-3], &[0.0]), 1e-3);
        assert_eq!(max_rel_diff(&[0.0], &[f64::NAN], &[1.0]), f64::INFINITY);
    }
}
