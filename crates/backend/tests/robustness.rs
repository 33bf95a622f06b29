//! No input through the backend's public CPU API panics: checkpoint decoding of any bytes,
//! the guard's stretches and finite search, the checks of parameters, the prefix sums and
//! the random numbers. Property tests with a fixed seed (`RngSeed::Fixed`: every run draws
//! the same cases, a failure reproduces; no regression files), 18,000 cases in all, sized to
//! run in about a second.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use simkit_backend::guard::{chunks, first_non_finite};
use simkit_backend::prefix::{exclusive_scan, par_exclusive_scan};
use simkit_backend::rng::{rng_bit, rng_u32, rng_uniform};
use simkit_backend::{
    Error, checkpoint, max_or_nan, require_finite, require_non_negative, require_positive,
};

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(0xbac0_e4d5),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn real() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(-0.0),
        Just(f64::MIN_POSITIVE / 2.0),
        Just(f64::MAX),
        any::<f64>(),
        -10.0..10.0,
    ]
}

type Payload = (u64, Vec<f64>, String);

fn sample(step: u64, values: Vec<f64>, name: String) -> Vec<u8> {
    checkpoint::encode("simkit-test", "1.0.0", "Model<f64>", &(step, values, name)).unwrap()
}

proptest! {
    #![proptest_config(config(4000))]

    /// Any bytes, any truncation, any overwritten byte of a valid checkpoint: a clear
    /// `Error::Checkpoint`, never a panic, and never a wrong payload accepted.
    #[test]
    fn checkpoints_decode_or_refuse(
        step in any::<u64>(),
        values in prop::collection::vec(real(), 0..20),
        name in ".{0,20}",
        cut in any::<prop::sample::Index>(),
        at in any::<prop::sample::Index>(),
        byte in any::<u8>(),
        junk in prop::collection::vec(any::<u8>(), 0..100),
    ) {
        let bytes = sample(step, values.clone(), name.clone());
        let back: Payload = checkpoint::decode(&bytes, "simkit-test", "1.0.0", "Model<f64>").unwrap();
        prop_assert_eq!(back.0, step);
        prop_assert_eq!(back.2, name);
        prop_assert!(back.1.iter().zip(&values).all(|(a, b)| a.to_bits() == b.to_bits()));
        let decode = |b: &[u8]| checkpoint::decode::<Payload>(b, "simkit-test", "1.0.0", "Model<f64>");
        let n = cut.index(bytes.len());
        let refused = matches!(decode(&bytes[..n]), Err(Error::Checkpoint { .. }));
        prop_assert!(refused, "a truncated checkpoint was not refused");
        let k = at.index(bytes.len());
        if bytes[k] != byte {
            let mut changed = bytes.clone();
            changed[k] = byte;
            let refused = matches!(decode(&changed), Err(Error::Checkpoint { .. }));
            prop_assert!(refused, "a changed checkpoint was not refused");
        }
        prop_assert!(decode(&junk).is_err());
        prop_assert!(checkpoint::header(&junk).is_err() || junk.starts_with(&checkpoint::MAGIC));
    }

    /// Stretches cover exactly the requested steps, end on multiples of `every` (or the
    /// end), and never overflow, for any counters.
    #[test]
    fn stretches_cover_the_call(done in prop_oneof![0..1000u64, any::<u64>()], steps in 0..3000u32, every in prop_oneof![0..50u32, any::<u32>()]) {
        prop_assume!(done.checked_add(u64::from(steps)).is_some());
        let mut at = done;
        for n in chunks(done, steps, every) {
            prop_assert!(n > 0);
            at += u64::from(n);
            prop_assert!(every == 0 || at % u64::from(every) == 0 || at == done + u64::from(steps));
        }
        prop_assert_eq!(at, done + u64::from(steps));
    }

    /// The first non-finite value is found wherever it is, in f32 and f64.
    #[test]
    fn first_bad_value_is_found(values in prop::collection::vec(real(), 0..300)) {
        let want = values.iter().position(|v| !v.is_finite());
        prop_assert_eq!(first_non_finite(&values), want);
        let single: Vec<f32> = values.iter().map(|&v| v as f32).collect();
        prop_assert_eq!(first_non_finite(&single), single.iter().position(|v| !v.is_finite()));
        let folded = values.iter().copied().fold(f64::NEG_INFINITY, max_or_nan);
        prop_assert_eq!(folded.is_nan(), values.iter().any(|v| v.is_nan()));
    }

    /// The parameter checks accept exactly what they promise and name the parameter.
    #[test]
    fn parameter_checks(v in real()) {
        prop_assert_eq!(require_finite("x", v).is_ok(), v.is_finite());
        prop_assert_eq!(require_positive("x", v).is_ok(), v.is_finite() && v > 0.0);
        prop_assert_eq!(require_non_negative("x", v).is_ok(), v.is_finite() && v >= 0.0);
        if let Err(e) = require_positive("the cutoff", v) {
            prop_assert!(e.to_string().contains("the cutoff"));
        }
    }
}

proptest! {
    #![proptest_config(config(2000))]

    /// Prefix sums wrap like the GPU scan, serial and parallel alike; random numbers are
    /// defined for every key.
    #[test]
    fn scans_and_random_numbers(data in prop::collection::vec(any::<u32>(), 0..200), seed in any::<u32>(), step in any::<u32>(), index in any::<u32>()) {
        let mut a = data.clone();
        let mut b = data.clone();
        let ta = exclusive_scan(&mut a);
        let tb = par_exclusive_scan(&mut b);
        prop_assert_eq!(ta, tb);
        prop_assert_eq!(&a, &b);
        prop_assert_eq!(ta, data.iter().fold(0u32, |s, &x| s.wrapping_add(x)));
        let u = rng_uniform(seed, step, index);
        prop_assert!((0.0..1.0).contains(&u));
        prop_assert!(rng_bit(seed, step, index) <= 1);
        prop_assert_eq!(rng_u32(seed, step, index), rng_u32(seed, step, index));
    }
}
