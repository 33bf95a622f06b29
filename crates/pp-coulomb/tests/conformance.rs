//! The same scenes on every backend (CPU, then the GPU when compiled in and present) and in
//! both precisions, compared with the CPU f64 result.
//!
//! Forces are compared with vector metrics per particle (`max_i |a_i - b_i| / rms |b|` and the
//! L2 relative error, see `common`), trajectories with the same per-particle metric, and the
//! CPU f32 trajectory against f64 with [`max_rel_diff`] over all coordinates.

use crate::common;

use common::{LAWS, l2_relative, max_error_over_rms, plasma};
use simkit_backend::testing::{backends, max_rel_diff};
use simkit_backend::{Backend, Simulation};
use simkit_pp_coulomb::{Config, ForceLaw, Integrator, Particles, PpCoulomb, Precision};

/// Accelerations of `p` at the initial positions under `law` on backend `b`.
fn accelerations(p: &Particles, law: ForceLaw, prec: Precision, b: Backend<'_>) -> Vec<[f64; 3]> {
    let config = Config::new(0.01, law).with_precision(prec);
    PpCoulomb::new(p.clone(), &config, b)
        .unwrap()
        .accelerations()
        .unwrap()
}

/// Forces on every backend against the CPU: f32 at N = 4096 (L2 relative) against the CPU
/// f32 forces; per law, f64 and f32 (worst particle over rms) against the CPU f64 forces. The
/// backends sum the same pairs in a different order, so results differ by rounding only.
/// Bounds: 3x the values measured by this test (llvmpipe and an AVX-512 CPU), or the old
/// 1e-5 where that is tighter, beside each assertion.
#[test]
fn accelerations_match_cpu_on_every_backend() {
    let test = "accelerations_match_cpu_on_every_backend";
    let p = plasma(4096, 2);
    let law = ForceLaw::Plummer { epsilon: 0.1 };
    let cpu32 = accelerations(&p, law, Precision::F32, Backend::Cpu);
    let cpu64 = accelerations(&p, law, Precision::F64, Backend::Cpu);
    let e32_64 = l2_relative(&cpu32, &cpu64);
    println!("N=4096 f32 vs f64 (L2 relative): cpu {e32_64:.2e}");
    // Per law (order of `LAWS`): f32 vs CPU f64, worst particle over rms. Measured: CPU
    // 6.86e-6, 1.53e-6, 4.68e-6; llvmpipe 6.36e-6, 2.23e-6, 5.07e-6. Bounds: 1e-5 (exact,
    // Plummer: 1.5x and 2x the larger), 6.7e-6 (exclusion: 3x).
    const F32_BOUNDS: [f64; 3] = [1e-5, 6.7e-6, 1e-5];
    for backend in backends(test) {
        let acc32 = accelerations(&p, law, Precision::F32, backend);
        let e = l2_relative(&acc32, &cpu32);
        let emax = max_error_over_rms(&acc32, &cpu32);
        let e64 = l2_relative(&acc32, &cpu64);
        println!(
            "{backend:?} N=4096 f32: L2 relative vs cpu f32 {e:.2e} (max_i / rms: {emax:.2e}); \
             vs cpu f64 {e64:.2e}"
        );
        // Measured 1.73e-6 on llvmpipe (0 on the CPU itself); bound 3x.
        assert!(e < 5.2e-6, "{backend:?} vs cpu f32: {e:e}");
        for (law, b32) in LAWS.into_iter().zip(F32_BOUNDS) {
            let p = plasma(300, 3);
            let c = accelerations(&p, law, Precision::F64, Backend::Cpu);
            if backend.has_f64() {
                let g = accelerations(&p, law, Precision::F64, backend);
                let e = max_error_over_rms(&g, &c);
                println!("{backend:?} {law:?} f64 vs cpu f64 {e:.2e}");
                // Measured on llvmpipe: 4.18e-15, 3.50e-15, 5.61e-15; bound 3x the largest.
                assert!(e < 1.7e-14, "{backend:?} {law:?}: {e:e}");
            } else {
                eprintln!(
                    "SKIPPED {test} {law:?} f64 on {backend:?}: the adapter has no SHADER_F64 \
                     (only the f32 comparison ran)"
                );
            }
            let g = accelerations(&p, law, Precision::F32, backend);
            let e = max_error_over_rms(&g, &c);
            println!("{backend:?} {law:?} f32 vs cpu f64 {e:.2e}");
            assert!(e < b32, "{backend:?} {law:?}: f32 vs cpu f64 {e:e}");
        }
    }
}

/// Ten steps of 500 particles, both integrators, on every backend (split into calls of 7 and
/// 3 steps) against the CPU in one call of 10, in f32 (against the CPU in f32) and in f64
/// where the backend has it (a GPU without `SHADER_F64` says so): positions and velocities,
/// worst particle over rms. The CPU in two calls must be bit-identical to one call.
#[test]
fn gpu_and_cpu_trajectories_agree() {
    let test = "gpu_and_cpu_trajectories_agree";
    for backend in backends(test) {
        let mut precisions = vec![Precision::F32];
        if backend.has_f64() {
            precisions.push(Precision::F64);
        } else {
            eprintln!(
                "SKIPPED {test} f64 on {backend:?}: the adapter has no SHADER_F64 (f32 only)"
            );
        }
        for prec in precisions {
            for integrator in [Integrator::SymplecticEuler, Integrator::Leapfrog] {
                let p = plasma(500, 4);
                let p64 = p.clone();
                let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 })
                    .with_integrator(integrator)
                    .with_precision(prec);
                let mut cpu = PpCoulomb::new(p.clone(), &config, Backend::Cpu).unwrap();
                let mut sim = PpCoulomb::new(p, &config, backend).unwrap();
                cpu.step(10).unwrap();
                sim.step(7).unwrap();
                sim.step(3).unwrap();
                let (a, b) = (cpu.state().unwrap(), sim.state().unwrap());
                let dx = max_error_over_rms(&b.position, &a.position);
                let dv = max_error_over_rms(&b.velocity, &a.velocity);
                println!(
                    "{} {integrator:?}: positions {dx:.2e}, velocities {dv:.2e}",
                    sim.backend_name()
                );
                if matches!(backend, Backend::Cpu) {
                    assert!(dx == 0.0 && dv == 0.0, "{integrator:?}: {dx:e} {dv:e}");
                }
                match prec {
                    // Two f32 trajectories differ by rounding that ten steps carry along:
                    // their distance is set by how far f32 is from f64, not by a fixed
                    // number. So the CPU f32 run's distance from the CPU f64 run is the
                    // yardstick: the backend must be no farther from f64 than 1.5x that,
                    // and no farther from the CPU f32 run than that distance itself.
                    // Measured (llvmpipe, AVX-512 CPU): CPU f32 vs f64 velocities 4.6e-6
                    // (symplectic Euler) and 1.5e-5 (leapfrog), the GPU 4.5e-6 and 1.5e-5;
                    // GPU vs CPU f32 1.1e-6 and 6.5e-6; positions 2.8e-7, 2.8e-7, 1.1e-7.
                    Precision::F32 => {
                        let mut exact = PpCoulomb::new(
                            p64.clone(),
                            &config.with_precision(Precision::F64),
                            Backend::Cpu,
                        )
                        .unwrap();
                        exact.step(10).unwrap();
                        let c = exact.state().unwrap();
                        let yard = [
                            max_error_over_rms(&a.position, &c.position),
                            max_error_over_rms(&a.velocity, &c.velocity),
                        ];
                        let far = [
                            max_error_over_rms(&b.position, &c.position),
                            max_error_over_rms(&b.velocity, &c.velocity),
                        ];
                        for (k, what) in ["positions", "velocities"].into_iter().enumerate() {
                            assert!(yard[k] > 0.0, "{integrator:?}: f32 equals f64 ({what})");
                            assert!(
                                far[k] <= 1.5 * yard[k] && [dx, dv][k] <= yard[k],
                                "{integrator:?} {what}: {:e} from f64 and {:e} from the CPU \
                                 f32 run, against the CPU f32 run's {:e} from f64",
                                far[k],
                                [dx, dv][k],
                                yard[k]
                            );
                        }
                    }
                    // Measured on llvmpipe: positions 2.2e-16, velocities 1.9e-15. Derived
                    // bound: ten steps of forces that differ by at most 1.7e-14 of the rms
                    // (the f64 bound of `accelerations_match_cpu_on_every_backend`), with
                    // no time for the difference to grow: 10 x 1.7e-14.
                    Precision::F64 => {
                        let tol = 1.7e-13;
                        assert!(
                            dx < tol && dv < tol,
                            "{prec:?} {integrator:?}: {dx:e} {dv:e} (bound {tol:e})"
                        );
                    }
                }
                assert_eq!(sim.steps_done(), 10);
            }
        }
    }
}

/// All coordinates of a state, flattened (positions, then velocities).
fn flat(p: &Particles) -> (Vec<f64>, Vec<f64>) {
    let f = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    (f(&p.position), f(&p.velocity))
}

/// The CPU in f32 follows the f64 trajectory: 20 leapfrog steps of 500 particles (Plummer
/// softening 0.5): positions and velocities against the f64 run, relative to the largest
/// f64 coordinate (bounds beside the assertions).
#[test]
fn cpu_f32_trajectory_tracks_f64() {
    let p = plasma(500, 7);
    let run = |prec| {
        let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 }).with_precision(prec);
        let mut sim = PpCoulomb::new(p.clone(), &config, Backend::Cpu).unwrap();
        sim.step(20).unwrap();
        flat(&sim.state().unwrap())
    };
    let (x64, v64) = run(Precision::F64);
    let (x32, v32) = run(Precision::F32);
    let (_, v0) = flat(&p);
    // The scene must move: the comparison is empty otherwise.
    assert!(max_rel_diff(&v64, &v0, &v64) > 1e-2);
    let dx = max_rel_diff(&x32, &x64, &x64);
    let dv = max_rel_diff(&v32, &v64, &v64);
    println!("CPU f32 vs f64 after 20 steps: positions {dx:.2e}, velocities {dv:.2e}");
    // Measured 4.09e-7 and 2.54e-6 (this test; the CPU's f32 sums have a fixed order, the
    // same for any thread count or SIMD width); bounds 3x.
    assert!(dx < 1.2e-6, "positions: {dx:e}");
    assert!(dv < 7.6e-6, "velocities: {dv:e}");
}

/// Every GPU force tile gives the same bits (each target sums its sources in index order
/// whatever the tile), and the same as the default tile, under each law, in f32 and (where
/// the adapter has it) f64; N = 1000 is a multiple of no tile. A tile outside the allowed
/// sizes is an error naming the field.
#[cfg(feature = "gpu")]
#[test]
fn every_gpu_tile_gives_the_same_accelerations() {
    use simkit_pp_coulomb::GpuTile;
    let Some(ctx) =
        simkit_backend::testing::shared_gpu("every_gpu_tile_gives_the_same_accelerations")
    else {
        return;
    };
    let p = plasma(1000, 17);
    let tiles = [
        (64, 8),
        (256, 8),
        (128, 1),
        (32, 4),
        (64, 2),
        (256, 4),
        (256, 1),
        (32, 1),
        (128, 2),
    ];
    for law in LAWS {
        for prec in [Precision::F32, Precision::F64] {
            if prec == Precision::F64 && !ctx.has_f64() {
                continue;
            }
            let reference = accelerations(&p, law, prec, Backend::Gpu(ctx));
            for (workgroup, targets) in tiles {
                let config = Config::new(0.01, law)
                    .with_precision(prec)
                    .with_gpu_tile(GpuTile { workgroup, targets });
                let a = PpCoulomb::new(p.clone(), &config, Backend::Gpu(ctx))
                    .unwrap()
                    .accelerations()
                    .unwrap();
                assert_eq!(
                    a, reference,
                    "{law:?} {prec:?} tile {workgroup} x {targets}"
                );
            }
        }
    }
    for (workgroup, targets) in [(100, 1), (128, 3), (512, 1), (128, 0), (128, 16)] {
        let config = Config::new(0.01, LAWS[0]).with_gpu_tile(GpuTile { workgroup, targets });
        let Err(e) = PpCoulomb::new(p.clone(), &config, Backend::Gpu(ctx)) else {
            panic!("tile {workgroup} x {targets} accepted");
        };
        let e = e.to_string();
        assert!(e.contains("gpu_tile"), "{e}");
    }
}
