//! The same scenes on every backend (CPU, then the GPU when compiled in and present) and in
//! both precisions, compared with the CPU f64 result.
//!
//! Forces are compared with vector metrics per particle (`max_i |a_i - b_i| / rms |b|` and the
//! L2 relative error, see `common`), trajectories with the same per-particle metric, and the
//! CPU f32 trajectory against f64 with [`max_rel_diff`] over all coordinates.

mod common;

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

/// Whether `backend` runs f64 (a GPU needs `SHADER_F64`).
fn has_f64(backend: Backend<'_>) -> bool {
    match backend {
        #[cfg(feature = "gpu")]
        Backend::Gpu(ctx) => ctx.has_f64(),
        _ => true,
    }
}

/// Forces on every backend against the CPU: f32 at N = 4096 within 1e-5 (L2 relative) of the
/// CPU f32 forces; per law, f64 within 1e-12 and f32 within 1e-5 (worst particle over rms) of
/// the CPU f64 forces. The backends sum the same pairs in a different order, so f32 results
/// differ by rounding only. Measured: llvmpipe 1.7e-6 (L2, N = 4096 vs CPU f32) and at most
/// 6.4e-6 (f32 vs CPU f64, exact law); the CPU in f32 (AVX-512 rsqrt path) at most 6.9e-6
/// against f64 (exact law); f64 on llvmpipe at most 5.6e-15 from the CPU.
#[test]
fn accelerations_match_cpu_on_every_backend() {
    let p = plasma(4096, 2);
    let law = ForceLaw::Plummer { epsilon: 0.1 };
    let cpu32 = accelerations(&p, law, Precision::F32, Backend::Cpu);
    let cpu64 = accelerations(&p, law, Precision::F64, Backend::Cpu);
    let e32_64 = l2_relative(&cpu32, &cpu64);
    println!("N=4096 f32 vs f64 (L2 relative): cpu {e32_64:.2e}");
    for backend in backends("accelerations_match_cpu_on_every_backend") {
        let acc32 = accelerations(&p, law, Precision::F32, backend);
        let e = l2_relative(&acc32, &cpu32);
        let emax = max_error_over_rms(&acc32, &cpu32);
        let e64 = l2_relative(&acc32, &cpu64);
        println!(
            "{backend:?} N=4096 f32: L2 relative vs cpu f32 {e:.2e} (max_i / rms: {emax:.2e}); \
             vs cpu f64 {e64:.2e}"
        );
        assert!(e < 1e-5, "{backend:?} vs cpu f32: {e:e}");
        for law in LAWS {
            let p = plasma(300, 3);
            let c = accelerations(&p, law, Precision::F64, Backend::Cpu);
            if has_f64(backend) {
                let g = accelerations(&p, law, Precision::F64, backend);
                let e = max_error_over_rms(&g, &c);
                println!("{backend:?} {law:?} f64 vs cpu f64 {e:.2e}");
                assert!(e < 1e-12, "{backend:?} {law:?}: {e:e}");
            }
            let g = accelerations(&p, law, Precision::F32, backend);
            let e = max_error_over_rms(&g, &c);
            println!("{backend:?} {law:?} f32 vs cpu f64 {e:.2e}");
            assert!(e < 1e-5, "{backend:?} {law:?}: f32 vs cpu f64 {e:e}");
        }
    }
}

/// Ten steps of 500 particles, both integrators, on every backend (split into calls of 7 and
/// 3 steps) against the CPU in one call of 10: positions and velocities within 1e-10 (worst
/// particle over rms) in f64; a GPU without `SHADER_F64` runs f32 against the CPU in f32,
/// within 1e-4. Measured: the CPU in two calls is bit-identical to one call; llvmpipe (f64)
/// within 2e-15.
#[test]
fn gpu_and_cpu_trajectories_agree() {
    for backend in backends("gpu_and_cpu_trajectories_agree") {
        let (prec, tol) = if has_f64(backend) {
            (Precision::F64, 1e-10)
        } else {
            (Precision::F32, 1e-4)
        };
        for integrator in [Integrator::SymplecticEuler, Integrator::Leapfrog] {
            let p = plasma(500, 4);
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
            assert!(dx < tol && dv < tol, "{integrator:?}: {dx:e} {dv:e}");
            assert_eq!(sim.steps_done(), 10);
        }
    }
}

/// All coordinates of a state, flattened (positions, then velocities).
fn flat(p: &Particles) -> (Vec<f64>, Vec<f64>) {
    let f = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    (f(&p.position), f(&p.velocity))
}

/// The CPU in f32 follows the f64 trajectory: 20 leapfrog steps of 500 particles (Plummer
/// softening 0.5), positions within 1e-5 and velocities within 1e-4 of the f64 run, relative
/// to the largest f64 coordinate. Measured: 4.1e-7 and 2.5e-6; the bounds leave room for
/// other f32 summation orders (thread count, SIMD width) while still failing for a
/// precision-dependent law or integrator bug, which moves particles by O(1) relative.
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
    assert!(dx < 1e-5, "positions: {dx:e}");
    assert!(dv < 1e-4, "velocities: {dv:e}");
}
