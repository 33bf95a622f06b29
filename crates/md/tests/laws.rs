//! The WGSL pair law (`shaders/law.wgsl`) that the GPU force kernel calls, evaluated on the
//! GPU, against its Rust twin `simkit_md::pair_force_energy::<f32>`.
//!
//! Tolerance: 8 f32 ulps (`8 * 2^-23`) relative to the larger of the two terms that are
//! subtracted (`12 c12 / r^12` and `6 c6 / r^6` for the force, `c12 / r^12` and
//! `c6 / r^6` for the energy), not to the result, which may cancel. Both sides run the same
//! operation sequence in f32; WGSL allows 2.5 ulps for a division and lets the compiler
//! contract `a * b + c` into an FMA.
#![cfg(feature = "gpu")]

use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_md::{PairParams, PairTable, pair_force_energy};

const LAW_WGSL: &str = simkit_backend::wgsl!("law.wgsl");

/// 8 f32 ulps at 1.
const ULPS8: f64 = 8.0 * f32::EPSILON as f64;

/// `(c12, c6, rc2, shift, r2, 0, 0, 0)` records as the harness reads them.
const CASE_WGSL: &str = "struct Case { c: vec4<f32>, r: vec4<f32> }";

#[test]
fn the_wgsl_pair_law_matches_the_rust_one() {
    let Some(ctx) = gpu_or_skip("the_wgsl_pair_law_matches_the_rust_one") else {
        return;
    };
    let mut params = vec![
        PairParams::lj(1.0, 1.0, 2.5),
        PairParams::repulsive(1.0, 0.5, 2.0),
        PairParams::new(0.7, 1.3, 0.4, 1.9, 3.5),
        PairParams::new(0.0, 1.0, 1.0, 1.0, 2.5),
        PairParams::new(2.0, 0.9, 0.0, 1.0, 2.0),
    ];
    params.push(PairParams::lj(1e-3, 3.0, 9.0));
    let mut inputs: Vec<[[f32; 4]; 2]> = Vec::new();
    let mut twins = Vec::new();
    for p in &params {
        let table = PairTable::uniform(1, *p).unwrap();
        for shift in [false, true] {
            let c = table.coefficients::<f32>(shift)[0];
            // From deep in the core to past the cutoff, and the cutoff itself.
            let rc = p.r_c as f32;
            let mut rs: Vec<f32> = (1..=60).map(|k| p.sigma as f32 * 0.02 * k as f32).collect();
            rs.extend([rc, rc * 0.999_99, rc * 1.000_01]);
            for r in rs {
                let r2 = r * r;
                inputs.push([[c.c12, c.c6, c.rc2, c.shift], [r2, 0.0, 0.0, 0.0]]);
                twins.push((c, r2));
            }
        }
    }
    let gpu: Vec<[f32; 2]> = eval_wgsl(
        &ctx,
        &[CASE_WGSL, LAW_WGSL],
        "Case",
        "vec2<f32>",
        "md_pair_force_energy(x.c, x.r.x)",
        &inputs,
    )
    .unwrap();
    assert_eq!(gpu.len(), twins.len());
    let mut worst = 0.0f64;
    for (g, (c, r2)) in gpu.iter().zip(&twins) {
        let (f, e) = pair_force_energy(c, *r2);
        let ir6 = 1.0 / (f64::from(*r2)).powi(3);
        let rep = f64::from(c.c12) * ir6 * ir6;
        let att = f64::from(c.c6) * ir6;
        let scale_f = (12.0 * rep).max(6.0 * att) / f64::from(*r2);
        let scale_e = rep.max(att).max(f64::from(c.shift).abs());
        for (got, want, scale) in [(g[0], f, scale_f), (g[1], e, scale_e)] {
            let d = (f64::from(got) - f64::from(want)).abs();
            assert!(
                got.is_finite() == want.is_finite(),
                "c = {c:?}, r2 = {r2}: {got} vs {want}"
            );
            if want.is_finite() && scale > 0.0 {
                worst = worst.max(d / scale);
                assert!(d <= ULPS8 * scale, "c = {c:?}, r2 = {r2}: {got} vs {want}");
            } else {
                assert_eq!(got, want);
            }
        }
    }
    eprintln!(
        "{} cases, worst difference {worst:.2e} of the term size",
        twins.len()
    );
}
