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

/// Checkpoints made from the valid checkpoint `bytes` by changing its payload (bytes
/// overwritten, inserted or removed, a cut, a stretch copied over another, a huge length
/// prefix, or a random payload) and sealing it again with a correct length and checksum:
/// each gets past the container's checks to the crate's payload decoder and validation,
/// where a plain corruption would stop at the checksum.
///
/// # Panics
/// When `bytes` is not a valid checkpoint.
pub fn resealed(bytes: &[u8]) -> BoxedStrategy<Vec<u8>> {
    let (_, payload) = crate::checkpoint::split(bytes, "<fuzz>").expect("a valid checkpoint");
    let at = payload.as_ptr() as usize - bytes.as_ptr() as usize;
    // The header up to the payload length, and the payload.
    let (head, payload) = (bytes[..at - 8].to_vec(), payload.to_vec());
    let n = payload.len().max(1);
    let changed = prop_oneof![
        4 => prop::collection::vec((any::<usize>(), any::<u8>()), 1..8).prop_map({
            let p = payload.clone();
            move |writes| {
                let mut p = p.clone();
                for (i, b) in writes {
                    if let Some(x) = p.get_mut(i % n) {
                        *x = b;
                    }
                }
                p
            }
        }),
        1 => any::<usize>().prop_map({
            let p = payload.clone();
            move |cut| p[..cut % n].to_vec()
        }),
        1 => (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16)).prop_map({
            let p = payload.clone();
            move |(i, extra)| {
                let mut p = p.clone();
                let i = i % n;
                p.splice(i.min(p.len())..i.min(p.len()), extra);
                p
            }
        }),
        1 => (any::<usize>(), 1usize..64).prop_map({
            let p = payload.clone();
            move |(i, len)| {
                let mut p = p.clone();
                let i = (i % n).min(p.len());
                p.drain(i..(i + len).min(p.len()));
                p
            }
        }),
        1 => (any::<usize>(), any::<usize>(), 1usize..64).prop_map({
            let p = payload.clone();
            move |(from, to, len)| {
                let mut p = p.clone();
                let (from, to) = (from % n, to % n);
                let len = len.min(p.len().saturating_sub(from)).min(p.len().saturating_sub(to));
                p.copy_within(from..from + len, to);
                p
            }
        }),
        2 => (any::<usize>(), 1usize..10).prop_map({
            let p = payload.clone();
            move |(i, width)| {
                // A varint of `width` bytes near its largest value: a huge count or length.
                let mut p = p.clone();
                let i = i % n;
                for k in 0..width {
                    if let Some(x) = p.get_mut(i + k) {
                        *x = if k + 1 == width { 0x01 } else { 0xff };
                    }
                }
                p
            }
        }),
        1 => prop::collection::vec(any::<u8>(), 0..256),
    ];
    changed
        .prop_map(move |p| {
            let mut out = head.clone();
            out.extend_from_slice(&(p.len() as u64).to_le_bytes());
            out.extend_from_slice(&p);
            out.extend_from_slice(&[0; 4]);
            super::reseal(&mut out);
            out
        })
        .boxed()
}

/// A global allocator that records the largest single allocation (install it in a test
/// binary with `#[global_allocator] static ALLOC: LargestAllocation =
/// LargestAllocation::new();`), to check that a reader allocates no more than its input
/// justifies.
#[derive(Debug)]
pub struct LargestAllocation {
    largest: std::sync::atomic::AtomicUsize,
}

impl LargestAllocation {
    /// Nothing recorded yet.
    pub const fn new() -> Self {
        Self {
            largest: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// The largest single allocation (bytes) since the last call, and starts again.
    pub fn take(&self) -> usize {
        self.largest.swap(0, std::sync::atomic::Ordering::Relaxed)
    }
}

impl Default for LargestAllocation {
    fn default() -> Self {
        Self::new()
    }
}

// SAFETY: every call is passed on unchanged to the system allocator; the only addition is
// an atomic maximum of the requested sizes.
unsafe impl std::alloc::GlobalAlloc for LargestAllocation {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        self.largest
            .fetch_max(layout.size(), std::sync::atomic::Ordering::Relaxed);
        // SAFETY: the caller's contract for `layout` is passed on.
        unsafe { std::alloc::System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this `layout`.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        self.largest
            .fetch_max(layout.size(), std::sync::atomic::Ordering::Relaxed);
        // SAFETY: as `alloc`.
        unsafe { std::alloc::System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new: usize) -> *mut u8 {
        self.largest
            .fetch_max(new, std::sync::atomic::Ordering::Relaxed);
        // SAFETY: `ptr` came from this allocator (the system's) with `layout`.
        unsafe { std::alloc::System.realloc(ptr, layout, new) }
    }
}

/// Resumes each of `cases` [`resealed`] variants of the checkpoint `bytes` with `resume`
/// (which may also step the run it gets), from the fixed `seed`: every case must return
/// `Ok` or a clear `Err`, never panic, and allocate at most `limit(file length)` bytes at
/// once (read from `alloc`). Returns how many resumed.
///
/// # Panics
/// With proptest's report of the first failing case.
pub fn fuzz_checkpoints(
    seed: &[u8; 32],
    cases: u32,
    bytes: &[u8],
    alloc: &LargestAllocation,
    limit: impl Fn(usize) -> usize,
    resume: impl Fn(&[u8]) -> crate::Result<()>,
) -> usize {
    let resumed = std::sync::atomic::AtomicUsize::new(0);
    run(seed, cases, resealed(bytes), |file| {
        alloc.take();
        let out = resume(&file);
        let largest = alloc.take();
        match out {
            Ok(()) => {
                resumed.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
            Err(e) => clear(&e)?,
        }
        prop_assert!(
            largest <= limit(file.len()),
            "a {}-byte checkpoint made an allocation of {largest} bytes",
            file.len()
        );
        Ok(())
    });
    resumed.into_inner()
}
