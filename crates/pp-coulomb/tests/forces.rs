//! Force kernels against the plain f64 reference, Newton's third law, bad input (the CPU vs
//! GPU comparisons are in `conformance.rs`).

use crate::common;
use approx::abs_diff_eq;

use common::{LAWS, l2_relative, max_error_over_rms, norm, plasma};
#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::testing::{backends, simd_exercised};
use simkit_backend::{Backend, Simulation};
use simkit_pp_coulomb::{
    Config, ForceLaw, MAX_PARTICLES, Particles, PpCoulomb, Precision, Region, Species, Velocities,
    diagnostics, potential_energy, reference_accelerations, reference_accelerations_of,
};

/// Both CPU kernels (the AVX-512 rsqrt path, where the CPU has it, and the portable sqrt +
/// divide kernel) in f64 and f32 against the scalar f64 reference, per law, and Newton's
/// third law. Bounds: 3x the values measured by this test (f64, 2 cores, AVX-512 CPU; the
/// larger of the two kernels), listed per law in `BOUNDS` below.
#[test]
fn cpu_kernels_match_reference_and_third_law() {
    let p = plasma(1003, 1); // not a multiple of the SIMD width
    // Whether the rsqrt path runs here (a CPU without AVX-512 compares portable with itself).
    let fast = Config::new(0.01, ForceLaw::Exact);
    let name = PpCoulomb::new(p.clone(), &fast, Backend::Cpu)
        .unwrap()
        .backend_name();
    simd_exercised(
        "cpu_kernels_match_reference_and_third_law",
        "avx512f",
        name.contains("avx512-rsqrt"),
    );
    // Per law (order of `LAWS`): f64 max_i / rms, f32 max_i / rms, f32 L2. Measured:
    // exact 1.17e-14, 2.36e-5, 1.46e-6; exclusion 1.01e-14, 1.03e-6, 2.76e-7;
    // Plummer 7.45e-15, 3.28e-6, 4.73e-7. Bounds 3x.
    const BOUNDS: [[f64; 3]; 3] = [
        [3.5e-14, 7.1e-5, 4.4e-6],
        [3.0e-14, 3.1e-6, 8.3e-7],
        [2.2e-14, 9.8e-6, 1.4e-6],
    ];
    for (law, [b64, b32, bl32]) in LAWS.into_iter().zip(BOUNDS) {
        let reference = reference_accelerations(&p, law).unwrap();
        // Both CPU paths: AVX-512 rsqrt + Newton (where the CPU has it) and sqrt + divide.
        for rsqrt in [true, false] {
            let cpu = |prec| {
                let config = Config::new(0.01, law)
                    .with_precision(prec)
                    .with_rsqrt(rsqrt);
                let mut sim = PpCoulomb::new(p.clone(), &config, Backend::Cpu).unwrap();
                (sim.accelerations().unwrap(), sim.backend_name())
            };
            let (f64_acc, name64) = cpu(Precision::F64);
            let (f32_acc, name32) = cpu(Precision::F32);
            let e64 = max_error_over_rms(&f64_acc, &reference);
            let e32 = max_error_over_rms(&f32_acc, &reference);
            let l32 = l2_relative(&f32_acc, &reference);
            println!(
                "{law:?}: {name64} vs reference {e64:.2e}; {name32} vs reference {e32:.2e} \
                 (max_i / rms), {l32:.2e} (L2)"
            );
            assert!(e64 < b64, "{law:?} {name64}: {e64:e} (bound {b64:e})");
            assert!(
                e32 < b32 && l32 < bl32,
                "{law:?} {name32}: {e32:e} {l32:e} (bounds {b32:e}, {bl32:e})"
            );
        }
        let mut sim = PpCoulomb::new(p.clone(), &Config::new(0.01, law), Backend::Cpu).unwrap();
        let d = sim.diagnostics().unwrap();
        let third = norm(d.force_sum) / d.force_magnitude_sum;
        println!("{law:?}: |sum F| / sum |F| = {third:.2e}");
        // Measured 7.41e-17 (exact), 9.31e-17 (exclusion), 7.11e-17 (Plummer); bound 3x.
        assert!(third < 2.8e-16, "{law:?}: third law {third:e}");
    }
}

#[test]
fn zero_and_one_particle_are_fine() {
    for b in backends("zero_and_one_particle_are_fine") {
        let empty = PpCoulomb::new(Particles::new(), &Config::new(0.1, ForceLaw::Exact), b);
        let mut empty = empty.unwrap();
        empty.step(3).unwrap();
        assert!(empty.accelerations().unwrap().is_empty());
        assert_eq!(empty.diagnostics().unwrap().total, 0.0);
        let mut p = Particles::new();
        let s = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
        p.push(s, [1.0, 2.0, 3.0], [0.5, 0.0, 0.0]).unwrap();
        let mut one = PpCoulomb::new(p, &Config::new(0.1, ForceLaw::Exact), b).unwrap();
        assert_eq!(one.accelerations().unwrap(), vec![[0.0; 3]]);
        one.step(10).unwrap();
        let x = one.state().unwrap().position[0];
        assert!(abs_diff_eq!(x[0], 1.5, epsilon = 1e-6), "{x:?}");
    }
}

#[test]
fn bad_input_is_a_clear_error() {
    let mut p = plasma(10, 5);
    p.position[3][1] = f64::NAN;
    let e = PpCoulomb::new(p, &Config::new(0.1, ForceLaw::Exact), Backend::Cpu).unwrap_err();
    assert!(e.to_string().contains("position[3][1]"), "{e}");
    let mut p = plasma(10, 5);
    p.mass[4] = 0.0;
    let e = PpCoulomb::new(p, &Config::new(0.1, ForceLaw::Exact), Backend::Cpu).unwrap_err();
    assert!(e.to_string().contains("mass[4]"), "{e}");
    let p = plasma(10, 5);
    for bad in [
        Config::new(f64::NAN, ForceLaw::Exact),
        Config::new(0.1, ForceLaw::Plummer { epsilon: 0.0 }),
        Config::new(0.1, ForceLaw::Exclusion { radius: -1.0 }),
    ] {
        assert!(PpCoulomb::new(p.clone(), &bad, Backend::Cpu).is_err());
    }
}

/// The reference sums take `Particles`, whose columns are public: columns of different
/// lengths are an error naming the column (before, an index out of bounds panicked).
#[test]
fn the_reference_sums_refuse_inconsistent_particles() {
    let mut p = plasma(10, 1);
    let acc = reference_accelerations(&p, ForceLaw::Exact).unwrap();
    assert_eq!(acc.len(), 10);
    let law = ForceLaw::Exact;
    let short =
        |e: simkit_backend::Error| assert!(e.to_string().contains("length of charge"), "{e}");
    p.charge.pop();
    short(reference_accelerations(&p, law).unwrap_err());
    short(reference_accelerations_of(&p, law, &[0]).unwrap_err());
    short(potential_energy(&p, law).unwrap_err());
    short(diagnostics(&p, &acc, law).unwrap_err());
    p.charge.push(-1.0);
    assert!(diagnostics(&p, &acc, law).is_ok());
    let err = diagnostics(&p, &acc[..9], law).unwrap_err();
    assert!(err.to_string().contains("number of accelerations"), "{err}");
}

#[test]
fn a_softening_whose_square_is_not_a_normal_f64_is_refused() {
    // Before: epsilon = 1e-170 passed (it is > 0) and squared to 0, running the singular
    // law; 1e200 squared to infinity and zeroed every force.
    let p = plasma(10, 5);
    for (law, value) in [
        (ForceLaw::Plummer { epsilon: 1e-170 }, "1e-170"),
        (ForceLaw::Plummer { epsilon: 1e200 }, "1e200"),
        (ForceLaw::Exclusion { radius: 1e-160 }, "1e-160"),
    ] {
        let e = PpCoulomb::new(p.clone(), &Config::new(0.1, law), Backend::Cpu).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(value) && text.contains("is not a normal f64"),
            "{text}"
        );
    }
    // The smallest softening allowed runs.
    let law = ForceLaw::Plummer { epsilon: 1.5e-154 };
    assert!(PpCoulomb::new(p, &Config::new(0.1, law), Backend::Cpu).is_ok());
}

#[test]
fn fill_refuses_a_huge_count_before_allocating() {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    let cube = Region::Cube {
        min: [0.0; 3],
        length: 1.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 1.0 };
    // 1e10 particles used to abort on the allocation.
    let err = p.fill(e, 10_000_000_000, cube, v, 1).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("particle count: 10000000000") && msg.contains("MAX_PARTICLES"),
        "{msg}"
    );
    let err = p.fill(e, MAX_PARTICLES + 1, cube, v, 1).unwrap_err();
    assert!(
        err.to_string().contains(&(MAX_PARTICLES + 1).to_string()),
        "{err}"
    );
    assert_eq!(p.position.capacity(), 0, "nothing may be allocated");
    // With particles already present the total overflows usize: still a clear error.
    p.fill(e, 2, cube, v, 1).unwrap();
    let err = p.fill(e, usize::MAX, cube, v, 1).unwrap_err();
    assert!(err.to_string().contains(&usize::MAX.to_string()), "{err}");
    assert_eq!(p.len(), 2);
}

#[test]
fn coincident_particles_in_exact_mode_name_the_pair() {
    let mut p = plasma(200, 6);
    p.position[150] = p.position[17];
    for b in backends("coincident_particles_in_exact_mode_name_the_pair") {
        let mut sim = PpCoulomb::new(p.clone(), &Config::new(0.1, ForceLaw::Exact), b).unwrap();
        let e = sim.step(1).unwrap_err().to_string();
        assert!(
            e.contains("17") && e.contains("150") && e.contains("coincident"),
            "{e}"
        );
        // Softened or excluded laws handle the same configuration.
        let soft = Config::new(0.1, ForceLaw::Plummer { epsilon: 0.1 });
        let mut sim = PpCoulomb::new(p.clone(), &soft, b).unwrap();
        sim.step(1).unwrap();
        let acc = sim.accelerations().unwrap();
        assert!(acc.iter().flatten().all(|c| c.is_finite()));
    }
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_refuses_more_particles_than_the_adapter_loops_allow() {
    let Some(ctx) = gpu_or_skip("gpu_refuses_more_particles_than_the_adapter_loops_allow") else {
        return;
    };
    let max = simkit_pp_coulomb::gpu_max_particles(&ctx);
    let Some(limit) = ctx.shader_loop_limit() else {
        assert_eq!(max, usize::MAX);
        eprintln!(
            "NOT EXERCISED gpu_refuses_more_particles_than_the_adapter_loops_allow: {} has no \
             shader loop limit, so there is no particle limit to refuse; only checked that \
             gpu_max_particles is unlimited",
            ctx.summary()
        );
        return;
    };
    // llvmpipe: 504 tiles of 128 particles, 130 loop iterations each, fit in 65,535.
    assert_eq!(limit, simkit_backend::gpu::LLVMPIPE_LOOP_LIMIT);
    assert_eq!(max, 64_512);
    let config = Config::new(0.01, ForceLaw::Plummer { epsilon: 0.1 });
    // Construction only: one force evaluation at this size takes seconds on llvmpipe.
    PpCoulomb::new(plasma(max, 5), &config, Backend::Gpu(&ctx)).unwrap();
    let e = PpCoulomb::new(plasma(max + 1, 5), &config, Backend::Gpu(&ctx))
        .expect_err("one particle over the limit")
        .to_string();
    assert!(
        e.contains("64513 particles") && e.contains("at most 64512"),
        "{e}"
    );
    // Other tiles: the limit counts the force kernel's loop per tile of its workgroup, the
    // energy kernel's (tiles of 128) and the padding to a whole number of targets per
    // workgroup (32 x 4: 1927 tiles of 32 fit, 61,664, padded down to 128s: 61,568; 256 x 1:
    // 254 tiles of 256 would fit, the energy kernel's 64,512 binds).
    for (workgroup, targets, expected) in [(32, 4, 61_568), (256, 1, 64_512), (64, 2, 63_488)] {
        let tile = simkit_pp_coulomb::GpuTile { workgroup, targets };
        let most = tile.max_particles(&ctx);
        assert_eq!(most, expected, "tile {workgroup} x {targets}");
        assert!(most / workgroup as usize * (workgroup as usize + 2) < limit as usize);
        let config = config.with_gpu_tile(tile);
        PpCoulomb::new(plasma(most, 5), &config, Backend::Gpu(&ctx)).unwrap();
        let e = PpCoulomb::new(plasma(most + 1, 5), &config, Backend::Gpu(&ctx))
            .expect_err("one particle over the limit")
            .to_string();
        assert!(e.contains(&format!("at most {most}")), "{e}");
    }
}
