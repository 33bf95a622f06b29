//! Physics validation: Rutherford scattering, Coulomb explosion of a cold sphere, energy
//! conservation of leapfrog with softening.

#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::{Backend, Simulation};
use simkit_pp_coulomb::analytic::{explosion_omega, explosion_time, rutherford_angle};
use simkit_pp_coulomb::scenes::{Expansion, cold_sphere};
use simkit_pp_coulomb::{
    Config, ForceLaw, Integrator, Particles, PpCoulomb, Precision, Region, Species, Velocities,
};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Two equal repulsive charges in their centre-of-mass frame: the deflection angle of the
/// relative velocity must match Rutherford's formula within 0.1%.
#[test]
fn rutherford_deflection() {
    let (q, m, b, d, v0) = (1.0, 1.0, 2.0, 400.0, 1.0);
    let mut p = Particles::new();
    let s = p.add_species(Species::new("ion", q, m)).unwrap();
    p.push(s, [-d / 2.0, b / 2.0, 0.0], [v0 / 2.0, 0.0, 0.0])
        .unwrap();
    p.push(s, [d / 2.0, -b / 2.0, 0.0], [-v0 / 2.0, 0.0, 0.0])
        .unwrap();
    let mu = m * m / (m + m);
    let r0 = (d * d + b * b).sqrt();
    // Energy and angular momentum of the relative motion fix the asymptotic speed and b.
    let energy = 0.5 * mu * v0 * v0 + q * q / r0;
    let v_inf = (2.0 * energy / mu).sqrt();
    let b_inf = mu * v0 * b / (mu * v_inf);
    let theta = rutherford_angle(q * q, mu, v_inf, b_inf);
    let dt = 0.02;
    let mut sim = PpCoulomb::new(p, &Config::new(dt, ForceLaw::Exact), Backend::Cpu).unwrap();
    let d0 = sim.diagnostics().unwrap();
    sim.step((2.0 * d / v0 / dt) as u32).unwrap();
    let st = sim.state().unwrap();
    let d1 = sim.diagnostics().unwrap();
    let vrel = sub(st.velocity[0], st.velocity[1]);
    let cos = vrel[0] / norm(vrel);
    let measured = cos.clamp(-1.0, 1.0).acos();
    let rel = (measured - theta).abs() / theta;
    let de = ((d1.total - d0.total) / d0.total).abs();
    let dl = norm(sub(d1.angular_momentum, d0.angular_momentum)) / norm(d0.angular_momentum);
    println!(
        "Rutherford: theta {measured:.6} rad vs {theta:.6} (rel {rel:.1e}); energy error \
         {de:.1e}, angular momentum error {dl:.1e}; separation {:.0}",
        norm(sub(st.position[0], st.position[1]))
    );
    assert!(
        norm(sub(st.position[0], st.position[1])) > 0.9 * d,
        "not yet separated"
    );
    assert!(rel < 1e-3, "deflection off by {rel:e}");
    assert!(de < 1e-5, "energy {de:e}");
    assert!(dl < 1e-12, "angular momentum {dl:e}");
}

/// Runs a Coulomb explosion of `n` equal charges (total charge 1, total mass 1, R = 1, so
/// omega = 1) and returns the times at which the expansion reaches xi = 2 and xi = 4.
fn explosion_times(n: usize, precision: Precision, backend: Backend<'_>) -> [f64; 2] {
    let radius = 1.0;
    let p = cold_sphere(n, radius, 2024).unwrap();
    let expansion = Expansion::new(&p.position, radius);
    let omega = explosion_omega(1.0 / n as f64, 1.0, 1.0 / n as f64, radius);
    assert!((omega - 1.0).abs() < 1e-12);
    let config = Config::new(0.05, ForceLaw::Exact).with_precision(precision);
    let mut sim = PpCoulomb::new(p, &config, backend).unwrap();
    let (mut t_prev, mut xi_prev) = (0.0, 1.0_f64);
    let mut found = [f64::NAN; 2];
    while found[1].is_nan() && sim.time() < 10.0 {
        // The dynamical time grows as xi^(3/2): so does the step.
        sim.set_dt(0.05 * xi_prev.powf(1.5) / omega).unwrap();
        sim.step(1).unwrap();
        let xi = expansion.factor(&sim.state().unwrap().position);
        for (k, target) in [2.0, 4.0].into_iter().enumerate() {
            if found[k].is_nan() && xi >= target {
                found[k] = t_prev + (sim.time() - t_prev) * (target - xi_prev) / (xi - xi_prev);
            }
        }
        t_prev = sim.time();
        xi_prev = xi;
    }
    println!(
        "explosion N={n} on {}: {} steps",
        sim.backend_name(),
        sim.steps_done()
    );
    found
}

fn check_explosion(times: [f64; 2]) {
    for (t, xi) in times.iter().zip([2.0, 4.0]) {
        let want = explosion_time(xi, 1.0);
        let rel = (t - want).abs() / want;
        println!("xi = {xi}: t = {t:.4} vs analytic {want:.4} (rel {rel:.2e})");
        assert!(rel < 0.02, "xi = {xi}: {t} vs {want}");
    }
}

#[test]
fn coulomb_explosion_n20000_cpu() {
    check_explosion(explosion_times(20_000, Precision::F32, Backend::Cpu));
    check_explosion(explosion_times(20_000, Precision::F64, Backend::Cpu));
}

#[cfg(feature = "gpu")]
#[test]
fn coulomb_explosion_gpu() {
    let Some(ctx) = gpu_or_skip("coulomb_explosion_gpu") else {
        return;
    };
    // Smaller N: lavapipe (the CI adapter) runs at a few GFLOP/s.
    check_explosion(explosion_times(4096, Precision::F32, Backend::Gpu(&ctx)));
}

/// Leapfrog with softening: the energy error stays bounded and scales as dt^2 (and
/// symplectic Euler's as dt).
#[test]
fn energy_error_scales_as_dt_squared() {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 1.0, 10.0)).unwrap();
    let sphere = Region::Sphere {
        center: [0.0; 3],
        radius: 5.0,
    };
    p.fill(
        e,
        200,
        sphere,
        Velocities::Maxwellian { thermal_speed: 0.3 },
        11,
    )
    .unwrap();
    p.fill(
        ion,
        200,
        sphere,
        Velocities::Maxwellian { thermal_speed: 0.1 },
        12,
    )
    .unwrap();
    let law = ForceLaw::Plummer { epsilon: 0.5 };
    let max_error = |integrator: Integrator, dt: f64| {
        let config = Config::new(dt, law).with_integrator(integrator);
        let mut sim = PpCoulomb::new(p.clone(), &config, Backend::Cpu).unwrap();
        let e0 = sim.diagnostics().unwrap().total;
        let steps = (4.0 / dt).round() as u32;
        // Worst relative energy error over the first and the second half of the run.
        let mut worst = [0.0_f64; 2];
        for k in 0..20 {
            sim.step(steps / 20).unwrap();
            let e = sim.diagnostics().unwrap().total;
            worst[k / 10] = worst[k / 10].max(((e - e0) / e0).abs());
        }
        worst
    };
    let [l1a, l1] = max_error(Integrator::Leapfrog, 0.02);
    let l1 = l1.max(l1a);
    let [l2a, l2b] = max_error(Integrator::Leapfrog, 0.01);
    let l2 = l2a.max(l2b);
    let [s1a, s1b] = max_error(Integrator::SymplecticEuler, 0.02);
    let [s2a, s2b] = max_error(Integrator::SymplecticEuler, 0.01);
    let (s1, s2) = (s1a.max(s1b), s2a.max(s2b));
    println!(
        "energy error: leapfrog {l1:.2e} -> {l2:.2e} (ratio {:.2}); symplectic Euler {s1:.2e} \
         -> {s2:.2e} (ratio {:.2})",
        l1 / l2,
        s1 / s2
    );
    println!("leapfrog dt = 0.01: worst error first half {l2a:.2e}, second half {l2b:.2e}");
    assert!(l1 < 5e-3, "leapfrog error {l1:e}");
    assert!(
        l2b < 2.0 * l2a,
        "leapfrog energy error drifts: {l2a:e} -> {l2b:e}"
    );
    assert!(
        (3.2..5.0).contains(&(l1 / l2)),
        "leapfrog order: {}",
        l1 / l2
    );
    assert!((1.6..2.5).contains(&(s1 / s2)), "Euler order: {}", s1 / s2);
}

/// Angular momentum about the centre is conserved by the central pair forces (f64).
#[test]
fn angular_momentum_conserved_in_a_plasma() {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("e", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 1.0, 50.0)).unwrap();
    let sphere = Region::Sphere {
        center: [0.0; 3],
        radius: 4.0,
    };
    p.fill(e, 150, sphere, Velocities::Uniform { half_width: 0.5 }, 3)
        .unwrap();
    p.fill(ion, 150, sphere, Velocities::Cold, 4).unwrap();
    let config = Config::new(0.02, ForceLaw::Plummer { epsilon: 0.3 });
    let mut sim = PpCoulomb::new(p, &config, Backend::Cpu).unwrap();
    let d0 = sim.diagnostics().unwrap();
    sim.step(100).unwrap();
    let d1 = sim.diagnostics().unwrap();
    let scale: f64 = {
        let s = sim.state().unwrap();
        (0..s.len())
            .map(|i| s.mass[i] * norm(cross(s.position[i], s.velocity[i])))
            .sum()
    };
    let dl = norm(sub(d1.angular_momentum, d0.angular_momentum)) / scale;
    let dp = norm(sub(d1.momentum, d0.momentum));
    println!("angular momentum drift {dl:.1e} of sum |m r x v|; momentum drift {dp:.1e}");
    assert!(dl < 1e-12 && dp < 1e-12, "{dl:e} {dp:e}");
}
