//! Every built-in pair law's WGSL twin (`shaders/laws/*.wgsl`), evaluated on the GPU, against
//! its Rust function `PairLaw::force_energy::<f32>`, through the law-level test that users
//! run on their own laws (`simkit_md::check_law_on_gpu`).
//!
//! Tolerances, in f32 machine epsilons of the size of the largest term each result sums
//! (`PairLaw::term_sizes`, not the result, which may cancel): 8 for the Lennard-Jones
//! family (WGSL allows 2.5 ulps for a division and may fuse a multiply and an add); 64 for
//! the laws with `exp` and `log`, whose WGSL accuracy is `3 + 2 |x|` ulps for `exp(x)` (the
//! arguments here reach about 14, Mie's `half_n ln(1 / r^2)`).
#![cfg(feature = "gpu")]

use simkit_backend::testing::gpu_or_skip;
use simkit_md::{Buckingham, LennardJones, Mie, Morse, PairLaw, Wca, Yukawa, check_law_on_gpu};

/// Rational laws.
const ULPS_RATIONAL: f64 = 8.0;
/// Laws with exponentials and logarithms.
const ULPS_EXP: f64 = 64.0;

fn check<L: PairLaw>(ctx: &simkit_backend::GpuContext, laws: &[L], ulps: f64) {
    let report = check_law_on_gpu(ctx, laws, ulps).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "{}: {} cases, worst {:.2} f32 ulps of the term size",
        L::NAME,
        report.cases,
        report.worst_ulps
    );
    assert!(report.cases >= 160 * laws.len());
}

#[test]
fn every_wgsl_pair_law_matches_its_rust_twin() {
    let Some(ctx) = gpu_or_skip("every_wgsl_pair_law_matches_its_rust_twin") else {
        return;
    };
    check(
        &ctx,
        &[
            LennardJones::new(1.0, 1.0, 2.5),
            LennardJones::repulsive(1.0, 0.5, 2.0),
            LennardJones::weighted(0.7, 1.3, 0.4, 1.9, 3.5),
            LennardJones::weighted(0.0, 1.0, 1.0, 1.0, 2.5),
            LennardJones::weighted(2.0, 0.9, 0.0, 1.0, 2.0),
            LennardJones::new(1e-3, 3.0, 9.0),
        ],
        ULPS_RATIONAL,
    );
    check(
        &ctx,
        &[Wca::new(1.0, 1.0), Wca::new(2.5, 0.7)],
        ULPS_RATIONAL,
    );
    check(
        &ctx,
        &[
            Morse::new(1.0, 4.0, 1.1, 2.5),
            Morse::new(0.8, 3.5, 1.15, 2.4),
            Morse::new(0.3, 1.0, 2.0, 5.0),
        ],
        ULPS_EXP,
    );
    check(
        &ctx,
        &[
            Yukawa::new(12.0, 2.0, 2.5),
            Yukawa::new(-3.0, 0.5, 4.0),
            Yukawa::new(1.0, 0.0, 3.0),
        ],
        ULPS_EXP,
    );
    check(
        &ctx,
        &[
            Mie::new(1.0, 1.0, 14.0, 7.0, 2.5),
            Mie::new(0.8, 1.1, 12.5, 5.5, 3.0),
            Mie::new(1.0, 1.0, 12.0, 6.0, 2.5),
        ],
        ULPS_EXP,
    );
    check(
        &ctx,
        &[
            Buckingham::new(2000.0, 0.2, 1.5, 2.5),
            Buckingham::new(1.0e5, 0.1, 2.0, 2.5),
        ],
        ULPS_EXP,
    );
}

/// A law whose WGSL struct does not match its Rust mirror is refused with a clear error.
#[test]
fn a_wrong_wgsl_layout_is_refused() {
    let Some(ctx) = gpu_or_skip("a_wrong_wgsl_layout_is_refused") else {
        return;
    };
    /// Lennard-Jones with a WGSL struct one member short.
    #[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct Broken(LennardJones);
    impl PairLaw for Broken {
        type Coeff<T: simkit_backend::Real> = <LennardJones as PairLaw>::Coeff<T>;
        type Gpu = [f32; 4];
        const NAME: &'static str = "broken";
        const WGSL: &'static str = "struct MdCoeff { c12: f32, c6: f32, rc2: f32 }\n\
             fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> { return vec2<f32>(0.0); }";
        fn validate(&self, pair: &str) -> simkit_backend::Result<()> {
            self.0.validate(pair)
        }
        fn cutoff(&self) -> f64 {
            self.0.cutoff()
        }
        fn energy(&self, r: f64) -> f64 {
            self.0.energy(r)
        }
        fn coefficients<T: simkit_backend::Real>(&self, shift: f64) -> Self::Coeff<T> {
            self.0.coefficients(shift)
        }
        fn gpu(c: &Self::Coeff<f32>) -> [f32; 4] {
            LennardJones::gpu(c)
        }
        fn force_energy<T: simkit_backend::Real>(c: &Self::Coeff<T>, r2: T) -> (T, T) {
            LennardJones::force_energy(c, r2)
        }
    }
    let e = check_law_on_gpu(&ctx, &[Broken(LennardJones::new(1.0, 1.0, 2.5))], 8.0)
        .expect_err("12-byte struct against a 16-byte mirror");
    assert!(e.to_string().contains("MdCoeff"), "{e}");
}
