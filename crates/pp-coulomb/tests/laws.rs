//! Law-level checks: each WGSL pair law (`pair_weight` of `shaders/law_*.wgsl`) runs on the
//! GPU for a sample of separations and is compared with its Rust twin in
//! `simkit_pp_coulomb::laws`, in f32 and (where the adapter has `SHADER_F64`) in f64.
//!
//! Each input is a separation `d` (components of both signs), its `r^2` (formed once, with
//! fused multiply-adds as the CPU field kernel does, and given to both sides: the laws are
//! discontinuous at the exclusion radius, where a 1-ulp difference in `r^2` would flip the
//! result) and the law parameter `p`; both sides return the pair field `w d` and the weight
//! `w`.
//!
//! Tolerance: 12 ulp relative (`12 * EPSILON` of the type) per output, and exact zeros where
//! the Rust law gives 0 (self pair, inside or at the exclusion radius). Budget, in ulps of
//! the result: the GPU's reciprocal square root may be off by 2 ulp (WGSL `inverseSqrt`; the
//! f64 prelude's `1.0 / sqrt` is held to the same bound), which cubing triples to 6, plus 2
//! roundings of the cube; the CPU's correctly rounded `sqrt` and division and its 2 roundings
//! add 2; the product `w d` adds 1 on each side. That is 12 ulp.

#![cfg(feature = "gpu")]

use simkit_backend::testing::{eval_wgsl, gpu_or_skip};
use simkit_backend::{GpuContext, Real};
use simkit_pp_coulomb::laws;

/// Unit directions, with negative components.
const DIRECTIONS: [[f64; 3]; 5] = [
    [1.0, 0.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.6, -0.8, 0.0],
    [-2.0 / 3.0, 2.0 / 3.0, -1.0 / 3.0],
    [-0.48, 0.6, -0.64],
];

/// One law under test: its WGSL source, its Rust weight, its parameter `p` and the distances
/// at which it is sampled.
struct Case {
    name: &'static str,
    wgsl: &'static str,
    weight32: fn(f32, f32) -> f32,
    weight64: fn(f64, f64) -> f64,
    p: f64,
    distances: &'static [f64],
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "exact",
            wgsl: laws::EXACT_WGSL,
            weight32: |r2, _| laws::exact_weight(r2),
            weight64: |r2, _| laws::exact_weight(r2),
            p: 0.0,
            // r = 0 is the self pair (weight 0).
            distances: &[0.0, 1e-3, 0.1, 1.0, 1.5, 10.0, 1e3, 1e5],
        },
        Case {
            name: "exclusion (radius 1.5)",
            wgsl: laws::EXCLUSION_WGSL,
            weight32: laws::exclusion_weight,
            weight64: laws::exclusion_weight,
            p: 2.25,
            // Inside, at the radius (r^2 = 2.25 exactly along an axis), just outside, far.
            distances: &[0.0, 0.5, 1.4999, 1.5, 1.5001, 3.0, 1e3, 1e5],
        },
        Case {
            name: "plummer (epsilon 0.5)",
            wgsl: laws::PLUMMER_WGSL,
            weight32: laws::plummer_weight,
            weight64: laws::plummer_weight,
            p: 0.25,
            // r = 0 (weight eps^-3), r << eps, r ~ eps, r >> eps.
            distances: &[0.0, 1e-4, 0.01, 0.5, 2.0, 50.0, 1e3, 1e5],
        },
        Case {
            name: "plummer (epsilon 0.001)",
            wgsl: laws::PLUMMER_WGSL,
            weight32: laws::plummer_weight,
            weight64: laws::plummer_weight,
            p: 1e-6,
            distances: &[0.0, 1e-5, 1e-3, 0.1, 10.0],
        },
    ]
}

/// The inputs `[[dx, dy, dz, r^2], [p, 0, 0, 0]]` of a case in precision `T`, with `r^2`
/// formed as the CPU field kernel forms it (fused multiply-adds).
fn inputs<T: Real>(case: &Case) -> Vec<[[T; 4]; 2]> {
    let mut v = Vec::new();
    for &r in case.distances {
        for u in DIRECTIONS {
            let [dx, dy, dz] = u.map(|c| T::from_f64(c * r));
            let r2 = dx.mul_add(dx, dy.mul_add(dy, dz * dz));
            v.push([
                [dx, dy, dz, r2],
                [T::from_f64(case.p), T::ZERO, T::ZERO, T::ZERO],
            ]);
        }
    }
    v
}

/// The Rust side for one input: `[w dx, w dy, w dz, w]`.
fn rust_side<T: Real>(x: [[T; 4]; 2], weight: fn(T, T) -> T) -> [T; 4] {
    let [[dx, dy, dz, r2], [p, ..]] = x;
    let w = weight(r2, p);
    [w * dx, w * dy, w * dz, w]
}

/// Runs every case on the GPU in precision `T` and prints the largest relative difference
/// in units of `epsilon`; panics past `12 * epsilon` or on a nonzero where Rust has 0.
fn check<T: Real>(ctx: &GpuContext, weight: impl Fn(&Case) -> fn(T, T) -> T, epsilon: f64) {
    let prelude = laws::wgsl_prelude(T::PRECISION);
    let tolerance = 12.0 * epsilon;
    for case in cases() {
        let x = inputs::<T>(&case);
        let gpu: Vec<[T; 4]> = eval_wgsl(
            ctx,
            &[prelude, case.wgsl],
            "array<vec4<REAL>, 2>",
            "vec4<REAL>",
            "vec4<REAL>(pair_weight(x[0].w, x[1].x) * x[0].xyz, pair_weight(x[0].w, x[1].x))",
            &x,
        )
        .unwrap();
        let mut worst = 0.0f64;
        for (input, g) in x.iter().zip(&gpu) {
            let r = rust_side(*input, weight(&case));
            for k in 0..4 {
                let (gk, rk) = (g[k].to_f64(), r[k].to_f64());
                if rk == 0.0 {
                    assert_eq!(
                        gk,
                        0.0,
                        "{} {}: input {input:?}: gpu {g:?}",
                        case.name,
                        T::WGSL
                    );
                    continue;
                }
                let rel = (gk - rk).abs() / rk.abs();
                assert!(
                    rel <= tolerance,
                    "{} {}: input {input:?}: gpu {g:?} rust {r:?} (relative {rel:e})",
                    case.name,
                    T::WGSL,
                );
                worst = worst.max(rel);
            }
        }
        println!(
            "{} {}: {} inputs, max relative difference {worst:.2e} = {:.1} ulp (tolerance 12)",
            case.name,
            T::WGSL,
            x.len(),
            worst / epsilon
        );
    }
}

#[test]
fn wgsl_laws_match_their_rust_twins() {
    let Some(ctx) = gpu_or_skip("wgsl_laws_match_their_rust_twins") else {
        return;
    };
    check::<f32>(&ctx, |c| c.weight32, f64::from(f32::EPSILON));
    if ctx.has_f64() {
        check::<f64>(&ctx, |c| c.weight64, f64::EPSILON);
    } else {
        println!(
            "f64 half skipped: adapter '{}' has no SHADER_F64",
            ctx.adapter_info().name
        );
    }
}

/// The energy guard's potential `pair_potential(r2)` (in `law_exact.wgsl`) against
/// `laws::exact_pair_potential`: 0 for the self pair, else within 4 ulp (the reciprocal square
/// root's 2 ulp, plus the CPU's correctly rounded square root and division).
fn check_potential<T: Real>(ctx: &GpuContext, epsilon: f64) {
    let r2: Vec<T> = [0.0, 1e-6, 1e-2, 0.5, 1.0, 2.25, 7.0, 1e4, 1e10]
        .into_iter()
        .map(T::from_f64)
        .collect();
    let gpu: Vec<T> = eval_wgsl(
        ctx,
        &[laws::wgsl_prelude(T::PRECISION), laws::EXACT_WGSL],
        "REAL",
        "REAL",
        "pair_potential(x)",
        &r2,
    )
    .unwrap();
    for (x, g) in r2.iter().zip(&gpu) {
        let want = laws::exact_pair_potential(*x).to_f64();
        let got = g.to_f64();
        if want == 0.0 {
            assert_eq!(got, 0.0, "{} r2 = {x:?}", T::WGSL);
        } else {
            let rel = (got - want).abs() / want;
            assert!(
                rel <= 4.0 * epsilon,
                "{} r2 = {x:?}: {got} vs {want}",
                T::WGSL
            );
        }
    }
}

#[test]
fn wgsl_pair_potential_matches_its_rust_twin() {
    let Some(ctx) = gpu_or_skip("wgsl_pair_potential_matches_its_rust_twin") else {
        return;
    };
    check_potential::<f32>(&ctx, f64::from(f32::EPSILON));
    if ctx.has_f64() {
        check_potential::<f64>(&ctx, f64::EPSILON);
    } else {
        println!(
            "f64 half skipped: adapter '{}' has no SHADER_F64",
            ctx.adapter_info().name
        );
    }
}
