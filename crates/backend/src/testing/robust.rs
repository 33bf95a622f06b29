//! The property-test runner and the awkward inputs every crate's robustness tests share
//! (feature `proptest`, for dev-dependencies): every public entry point driven with
//! arbitrary values must return `Ok` with a finite result or a clear `Err`, never panic.
//!
//! Runs are reproducible: [`runner`] draws from a fixed ChaCha seed with no failure
//! persistence, so a failure shows the same case on every run and machine.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed, TestCaseError, TestRng, TestRunner};

use crate::Error;

/// A runner of `cases` cases drawn from the fixed `seed`.
pub fn runner(seed: &[u8; 32], cases: u32) -> TestRunner {
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, seed))
}

/// The settings of a `proptest!` block of `cases` cases from the fixed `seed` (ChaCha, no
/// failure persistence): `#![proptest_config(robust::config(SEED, 200))]`.
pub fn config(seed: u64, cases: u32) -> Config {
    Config {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Runs `test` on `cases` values of `strategy` from the fixed `seed`.
///
/// # Panics
/// With proptest's report (the minimal failing input) when a case fails or panics.
pub fn run<S: Strategy>(
    seed: &[u8; 32],
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<(), TestCaseError>,
) {
    if let Err(e) = runner(seed, cases).run(&strategy, test) {
        panic!("{e}");
    }
}

/// Floats that break code, often, among ordinary ones: NaN, infinities, signed zeros, the
/// extremes, subnormals, values whose square overflows or underflows, and any bit pattern.
pub fn awkward_f64() -> BoxedStrategy<f64> {
    prop_oneof![
        3 => prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            -1.0,
            1.0,
            0.1,
            f64::MAX,
            -f64::MAX,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::EPSILON,
            5e-324,
            -5e-324,
            1e-300,
            -1e-300,
            1e-160,
            1e-154,
            1e154,
            2e154,
            1e16,
            -1e16,
            1e35,
            1e300,
            -1e300,
        ]),
        2 => -10.0..10.0f64,
        1 => 0.0..2.0f64,
        1 => any::<f64>(),
    ]
    .boxed()
}

/// Mostly a value of `valid` (four in five), sometimes an [`awkward_f64`].
pub fn mostly(valid: impl Strategy<Value = f64> + 'static) -> BoxedStrategy<f64> {
    prop_oneof![4 => valid, 1 => awkward_f64()].boxed()
}

/// Sizes from the edges: 0, small, powers of two around the `u32` limits, and near
/// `usize::MAX` (each huge one alone past every size limit).
pub fn awkward_usize() -> BoxedStrategy<usize> {
    prop_oneof![
        0usize..70,
        Just(1 << 16),
        Just(1 << 32),
        Just(usize::MAX / 2),
        Just(usize::MAX),
        any::<usize>(),
    ]
    .boxed()
}

/// `Ok` when `e` is a clear error (a message of more than a few words, and not a dump); a
/// failed case otherwise.
pub fn clear(e: &Error) -> Result<(), TestCaseError> {
    let s = e.to_string();
    prop_assert!(s.len() > 20 && s.len() < 4000, "unclear error: {s:?}");
    Ok(())
}
