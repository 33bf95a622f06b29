//! Test support shared by every crate's conformance tests: the backends to compare, a shared
//! GPU context or an explained skip, and comparison metrics with stated tolerances.
//!
//! A conformance test runs the same scene on every backend [`backends`] returns (the CPU,
//! then the GPU when the `gpu` feature is compiled in and an adapter exists) and compares
//! each result with the CPU's: bit for bit where a crate promises it, else with
//! [`max_rel_diff`] against a tolerance the test states and justifies.

mod mpirun;
#[cfg(feature = "gpu")]
mod wgsl;
#[cfg(feature = "mpi")]
pub use mpirun::check_on_ranks;
pub use mpirun::{MPI_CHILD_ENV, REQUIRE_MPI_ENV, is_mpi_child, mpirun_self};
#[cfg(feature = "gpu")]
pub use wgsl::{
    FieldOffset, WgslStruct, assert_mirrors, check_struct_size, eval_wgsl, eval_wgsl2, wgsl_struct,
};

#[cfg(feature = "gpu")]
use std::sync::OnceLock;

use crate::{Backend, Restart};
#[cfg(feature = "gpu")]
use crate::{Error, GpuContext};

/// Environment variable that turns a missing GPU adapter from a skip into a test failure
/// (set by `.ci/run`).
pub const REQUIRE_GPU_ENV: &str = "SIMKIT_REQUIRE_GPU";

#[cfg(feature = "gpu")]
static CONTEXT: OnceLock<Result<GpuContext, Error>> = OnceLock::new();

/// Environment variable listing the SIMD paths a test run must exercise, comma-separated
/// (`avx2`, `avx512f`, `avx512vbmi`, or `all`); `.ci/run` sets it to what the CPU has.
pub const REQUIRE_SIMD_ENV: &str = "SIMKIT_REQUIRE_SIMD";

/// Reports whether a test exercised the SIMD path `feature` (e.g. `"avx512vbmi"`): when
/// `ran` is false it prints that the test compared the portable code with itself, and
/// panics when `SIMKIT_REQUIRE_SIMD` names `feature` (or `all`), so a CI runner with the
/// feature cannot pass without running it. Returns `ran`.
///
/// # Panics
/// When `ran` is false and the feature is required.
pub fn simd_exercised(test: &str, feature: &str, ran: bool) -> bool {
    if ran {
        println!("{test}: the {feature} path ran");
        return true;
    }
    let required = std::env::var(REQUIRE_SIMD_ENV).unwrap_or_default();
    let listed = required
        .split(',')
        .map(str::trim)
        .any(|f| f == feature || f == "all");
    assert!(
        !listed,
        "{test}: {REQUIRE_SIMD_ENV}={required} requires the {feature} path, which did not run"
    );
    eprintln!(
        "NOT EXERCISED {test}: this CPU (or build) lacks {feature}; the test compared the \
         portable path with itself"
    );
    false
}

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

/// Environment variable through which [`check_restart`] tells its child process what to do.
const RESTART_CHILD_ENV: &str = "SIMKIT_RESTART_CHILD";

/// Checks that a checkpoint resumes bit for bit, in a new process: a run of `2 * steps`
/// steps and a run of `steps` steps, checkpoint file, resume in a child process, and
/// `steps` more steps must give byte-identical checkpoints (the complete state, counters
/// included). The in-process resume is checked the same way first.
///
/// Call it from the `#[test]` function whose full name in the test binary is `test` (e.g.
/// `"restart_is_bit_exact"`): the child is that test binary, run with `--exact test` and an
/// environment variable that makes this call resume, step and write instead. `make` builds
/// the run on `backend` (several calls in one test are told apart by the backend's name and
/// `label`).
///
/// # Panics
/// When a step fails, the states differ (the message gives the first differing byte) or the
/// child process fails.
pub fn check_restart<S: Restart>(
    test: &str,
    label: &str,
    backend: Backend<'_>,
    steps: u32,
    make: impl Fn(Backend<'_>) -> crate::Result<S>,
) {
    let tag = format!("{label} on {}", backend.name());
    if let Ok(job) = std::env::var(RESTART_CHILD_ENV) {
        let Some((want, dir)) = job.split_once('|') else {
            panic!("{RESTART_CHILD_ENV}={job}: expected <tag>|<directory>");
        };
        if want == tag {
            let dir = std::path::Path::new(dir);
            let mut run = S::resume_file(dir.join("half.ckpt"), backend)
                .unwrap_or_else(|e| panic!("{tag}: resume failed: {e}"));
            run.step(steps)
                .unwrap_or_else(|e| panic!("{tag}: stepping the resumed run failed: {e}"));
            run.write_checkpoint(dir.join("resumed.ckpt"))
                .unwrap_or_else(|e| panic!("{tag}: writing the checkpoint failed: {e}"));
        }
        return;
    }
    let ok = |r: crate::Result<()>, what: &str| {
        r.unwrap_or_else(|e| panic!("{tag}: {what} failed: {e}"));
    };
    let mut whole = make(backend).unwrap_or_else(|e| panic!("{tag}: building failed: {e}"));
    ok(whole.step(steps.saturating_mul(2)), "the uninterrupted run");
    let expected = whole
        .checkpoint()
        .expect("checkpoint of the uninterrupted run");
    let mut half = make(backend).unwrap_or_else(|e| panic!("{tag}: building failed: {e}"));
    ok(half.step(steps), "the first half");
    let dir = std::env::temp_dir().join(format!(
        "simkit-restart-{}-{}",
        std::process::id(),
        tag.replace(|c: char| !c.is_ascii_alphanumeric(), "_")
    ));
    ok(
        half.write_checkpoint(dir.join("half.ckpt")),
        "writing the checkpoint",
    );
    // In this process first (clearer failures), then in a new one.
    let bytes = std::fs::read(dir.join("half.ckpt")).expect("reading the checkpoint back");
    let mut resumed = S::resume(&bytes, backend).unwrap_or_else(|e| panic!("{tag}: {e}"));
    ok(resumed.step(steps), "the resumed run");
    let here = resumed.checkpoint().expect("checkpoint of the resumed run");
    assert_same_state(&tag, "resumed in this process", &expected, &here);
    let exe = std::env::current_exe().expect("the test binary's path");
    let out = std::process::Command::new(exe)
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .env(RESTART_CHILD_ENV, format!("{tag}|{}", dir.display()))
        .output()
        .expect("starting the child test process");
    assert!(
        out.status.success(),
        "{tag}: the child process failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let there = std::fs::read(dir.join("resumed.ckpt")).unwrap_or_else(|e| {
        panic!(
            "{tag}: the child wrote no checkpoint ({e}); is `{test}` the exact test name? \
             child output: {}",
            String::from_utf8_lossy(&out.stdout)
        )
    });
    assert_same_state(&tag, "resumed in a new process", &expected, &there);
    let _ = std::fs::remove_dir_all(&dir);
}

fn assert_same_state(tag: &str, how: &str, expected: &[u8], got: &[u8]) {
    if expected != got {
        let at = expected
            .iter()
            .zip(got)
            .position(|(a, b)| a != b)
            .unwrap_or(expected.len().min(got.len()));
        panic!(
            "{tag}: the run {how} differs from the uninterrupted one: checkpoints of {} and {} \
             bytes first differ at byte {at}",
            expected.len(),
            got.len()
        );
    }
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
