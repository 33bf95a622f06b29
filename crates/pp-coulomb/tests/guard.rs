//! The blow-up guard (see `Config::check_every`): unstable runs return `Error::BlowUp` on
//! every backend, rolled back to the last state that passed a check (bit-identical to a run
//! stepped exactly to that step), and the checks never change a stable run's results.

use simkit_backend::testing::backends;
use simkit_backend::{Backend, Error, Simulation};
use simkit_pp_coulomb::{
    Config, DEFAULT_ENERGY_TOLERANCE, ForceLaw, Integrator, Particles, PpCoulomb, Precision,
    Region, Species, Velocities,
};

/// `n / 2` electrons and `n / 2` ions of charge +1 and mass 1 (opposite charges that attract)
/// in a cube of edge 10, with thermal velocities.
fn opposite_charges(n: usize, seed: u64) -> Particles {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 1.0, 1.0)).unwrap();
    let cube = Region::Cube {
        min: [0.0; 3],
        length: 10.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.1 };
    p.fill(e, n / 2, cube, v, seed).unwrap();
    p.fill(ion, n - n / 2, cube, v, seed + 1).unwrap();
    p
}

/// The precisions to run on `backend`: f64 and f32 on the CPU, f32 on a GPU (and f64 where
/// it has SHADER_F64).
fn precisions(backend: Backend<'_>) -> Vec<Precision> {
    match backend {
        Backend::Cpu => vec![Precision::F64, Precision::F32],
        _ if backend.has_f64() => vec![Precision::F32, Precision::F64],
        _ => {
            println!("{backend:?}: no SHADER_F64, f32 only");
            vec![Precision::F32]
        }
    }
}

/// Bits of a state: positions, then velocities.
fn bits(p: &Particles) -> Vec<u64> {
    p.position
        .iter()
        .chain(&p.velocity)
        .flatten()
        .map(|c| c.to_bits())
        .collect()
}

/// Steps `sim` by `steps` and returns the blow-up's (step, rolled_back_to, message).
fn expect_blow_up(sim: &mut PpCoulomb, steps: u32) -> (u64, u64, String) {
    match sim.step(steps) {
        Err(e @ Error::BlowUp { .. }) => {
            let Error::BlowUp {
                step,
                rolled_back_to,
                ..
            } = e
            else {
                unreachable!()
            };
            (step, rolled_back_to, e.to_string())
        }
        other => panic!("expected a blow-up, got {other:?}"),
    }
}

/// The rolled-back run holds the state of an identical run stepped exactly to
/// `rolled_back_to`: finite, bit-identical, same step counter and time.
fn check_rollback(sim: &mut PpCoulomb, make: impl Fn() -> PpCoulomb, rolled_back_to: u64) {
    assert_eq!(sim.steps_done(), rolled_back_to);
    let state = sim.state().unwrap();
    assert!(
        state
            .position
            .iter()
            .chain(&state.velocity)
            .flatten()
            .all(|c| c.is_finite())
    );
    let mut again = make();
    again.step(rolled_back_to as u32).unwrap();
    assert_eq!(again.steps_done(), rolled_back_to);
    assert_eq!(again.time().to_bits(), sim.time().to_bits());
    assert!(
        bits(&again.state().unwrap()) == bits(&state),
        "rolled-back state differs"
    );
}

/// Every check of `sim.step(steps)` passes and the run ends where it should.
fn step_ok(sim: &mut PpCoulomb, steps: u32) {
    let before = sim.steps_done();
    sim.step(steps)
        .unwrap_or_else(|e| panic!("{}: {e}", sim.backend_name()));
    assert_eq!(sim.steps_done(), before + u64::from(steps));
}

/// The reported run: the exact law, dt = 10, 400 opposite charges. It used to return Ok with
/// the energy off by 1e8; now the energy guard stops it, names the particle and the cause,
/// and the run is back at the last good check.
#[test]
fn exact_law_with_a_huge_step_is_a_blow_up() {
    for backend in backends("exact_law_with_a_huge_step_is_a_blow_up") {
        for precision in precisions(backend) {
            for (integrator, dt) in [
                (Integrator::Leapfrog, 10.0),
                (Integrator::SymplecticEuler, 10.0),
                // Smaller steps: the first close approach comes later, after checks that pass.
                (Integrator::Leapfrog, 0.01),
            ] {
                let config = Config::new(dt, ForceLaw::Exact)
                    .with_precision(precision)
                    .with_integrator(integrator)
                    .with_check_every(10);
                let make = || PpCoulomb::new(opposite_charges(400, 3), &config, backend).unwrap();
                let mut sim = make();
                let e0 = sim.diagnostics().unwrap().total;
                let (step, rolled, msg) = expect_blow_up(&mut sim, 1000);
                println!("{} {precision:?} {integrator:?}: {msg}", sim.backend_name());
                assert!(msg.contains("particle"), "{msg}");
                assert!(
                    msg.contains("close approach under the exact law") || msg.contains("NaN"),
                    "{msg}"
                );
                assert!(step > rolled && step.is_multiple_of(10), "{step} {rolled}");
                if dt < 1.0 {
                    assert!(rolled > 0, "the small step should pass its first check");
                }
                let e = sim.diagnostics().unwrap().total;
                println!("  energy {e0:.4e} at step 0, {e:.4e} at step {rolled}");
                check_rollback(&mut sim, make, rolled);
                // With the guard off the same run returns Ok and a wrong energy (the report).
                let off = config.with_energy_tolerance(None);
                let mut blind = PpCoulomb::new(opposite_charges(400, 3), &off, backend).unwrap();
                if blind.step(step as u32).is_ok() {
                    let e = blind.diagnostics().unwrap().total;
                    println!("  unguarded: energy {e:.4e} at step {step}");
                }
            }
        }
    }
}

/// The mixed mode (`Config::mixed`, CPU only) has the same guard: the reported run (exact
/// law, dt = 10 and 0.01, 400 opposite charges) is a blow-up rolled back bit-identically,
/// and a Plummer run whose separations overflow the f32 pair kernel (dt = 4e8, as f32)
/// stops at the next interval check naming the non-finite particle.
#[test]
fn mixed_mode_blow_ups_are_caught_and_rolled_back() {
    let mixed = |dt, law| {
        Config::new(dt, law)
            .with_precision(Precision::F32)
            .with_mixed(true)
            .with_check_every(10)
    };
    for dt in [10.0, 0.01] {
        let config = mixed(dt, ForceLaw::Exact);
        let make = || PpCoulomb::new(opposite_charges(400, 3), &config, Backend::Cpu).unwrap();
        let mut sim = make();
        let (step, rolled, msg) = expect_blow_up(&mut sim, 1000);
        println!("{} dt {dt}: {msg}", sim.backend_name());
        assert!(sim.backend_name().contains("mixed"));
        assert!(
            msg.contains("close approach under the exact law") || msg.contains("NaN"),
            "{msg}"
        );
        assert!(step > rolled && step.is_multiple_of(10), "{step} {rolled}");
        if dt < 1.0 {
            assert!(rolled > 0, "the small step should pass its first check");
        }
        check_rollback(&mut sim, make, rolled);
    }
    // As `non_finite_state_is_a_blow_up_rolled_back_to_the_last_check` in f32: the f32
    // pair kernel's r^2 overflows once separations pass 1.8e19 (NaN on the AVX-512 rsqrt
    // path; elsewhere the positions themselves overflow, at a larger step).
    let dt = overflow_dt(Backend::Cpu, Precision::F32);
    let config = mixed(dt, ForceLaw::Plummer { epsilon: 1.0 });
    let make = || PpCoulomb::new(opposite_charges(64, 9), &config, Backend::Cpu).unwrap();
    let mut sim = make();
    let (step, rolled, msg) = expect_blow_up(&mut sim, 1000);
    println!("{}: {msg}", sim.backend_name());
    assert!(
        msg.contains("particle") && msg.contains("is too large"),
        "{msg}"
    );
    assert!(msg.contains("inf") || msg.contains("NaN"), "{msg}");
    assert!(rolled > 0 && step == rolled + 10, "{step} {rolled}");
    check_rollback(&mut sim, make, rolled);
}

/// A time step at which the opposite-charge runs below turn non-finite after a hundred or
/// two steps. The first step gives speeds `a0 dt`, after which the particles are far apart
/// and coast. With the AVX-512 rsqrt kernel the force turns non-finite once `r^2`
/// overflows (separations of `sqrt(largest float)`: 1.8e19 in f32, 1.3e154 in f64; the
/// rsqrt estimate and its Newton step give NaN for `r^2 = inf`), after about `sqrt(max) /
/// (a0 dt^2)` steps. The portable CPU kernel's `1 / sqrt(inf)` and llvmpipe's
/// `inverseSqrt(inf)` are 0, so there the positions themselves overflow, after about `max /
/// (a0 dt^2)` steps.
fn overflow_dt(backend: Backend<'_>, precision: Precision) -> f64 {
    #[cfg(target_arch = "x86_64")]
    let avx512 = std::is_x86_feature_detected!("avx512f");
    #[cfg(not(target_arch = "x86_64"))]
    let avx512 = false;
    let rsqrt = !backend.is_gpu() && avx512;
    match (rsqrt, precision) {
        (true, Precision::F32) => 4e8,
        (true, Precision::F64) => 1e76,
        (false, Precision::F32) => 1.5e18,
        (false, Precision::F64) => 1.2e153,
    }
}

/// A step so large that positions overflow to infinity after about a hundred steps (Plummer
/// softening: the force stays bounded, the drift does not): the finite check catches it at
/// the next interval check, names the particle, and the run is back at the last interval
/// check that passed (bit-identical to a run stepped exactly there).
#[test]
fn non_finite_state_is_a_blow_up_rolled_back_to_the_last_check() {
    for backend in backends("non_finite_state_is_a_blow_up_rolled_back_to_the_last_check") {
        for precision in precisions(backend) {
            let dt = overflow_dt(backend, precision);
            let config = Config::new(dt, ForceLaw::Plummer { epsilon: 1.0 })
                .with_precision(precision)
                .with_check_every(10);
            let make = || PpCoulomb::new(opposite_charges(64, 9), &config, backend).unwrap();
            let mut sim = make();
            let (step, rolled, msg) = expect_blow_up(&mut sim, 1000);
            println!("{} {precision:?}: {msg}", sim.backend_name());
            assert!(
                msg.contains("particle") && msg.contains("is too large"),
                "{msg}"
            );
            assert!(msg.contains("inf") || msg.contains("NaN"), "{msg}");
            assert!(rolled > 0 && step == rolled + 10, "{step} {rolled}");
            check_rollback(&mut sim, make, rolled);
        }
    }
}

/// A stable run gives the same bits with the checks on (every 7 steps, energy guard on) as
/// with them off: the checks read and copy the state, never change it. Exact law (a cold
/// sphere of like charges: its Coulomb explosion is resolved at this step, so the energy
/// guard must pass) and Plummer (opposite charges), both integrators, every backend.
#[test]
fn checks_do_not_change_a_stable_run() {
    for backend in backends("checks_do_not_change_a_stable_run") {
        for precision in precisions(backend) {
            for integrator in [Integrator::Leapfrog, Integrator::SymplecticEuler] {
                let scenes = [
                    (
                        simkit_pp_coulomb::scenes::cold_sphere(300, 1.0, 4).unwrap(),
                        ForceLaw::Exact,
                    ),
                    (opposite_charges(300, 5), ForceLaw::Plummer { epsilon: 0.5 }),
                ];
                for (p, law) in scenes {
                    let config = Config::new(0.01, law)
                        .with_precision(precision)
                        .with_integrator(integrator);
                    let run = |every: u32| {
                        let mut sim =
                            PpCoulomb::new(p.clone(), &config.with_check_every(every), backend)
                                .unwrap();
                        step_ok(&mut sim, 60);
                        step_ok(&mut sim, 45);
                        (bits(&sim.state().unwrap()), sim.time().to_bits())
                    };
                    assert!(
                        run(7) == run(0),
                        "{backend:?} {precision:?} {integrator:?} {law:?}"
                    );
                }
            }
        }
    }
}

/// The energy guard does not fire on resolved exact-law runs: a Coulomb explosion followed to
/// three times its radius with the default interval and tolerance, and the energy error it
/// sees stays far below the tolerance (printed).
#[test]
fn energy_guard_passes_a_resolved_explosion() {
    let p = simkit_pp_coulomb::scenes::cold_sphere(500, 1.0, 8).unwrap();
    for integrator in [Integrator::Leapfrog, Integrator::SymplecticEuler] {
        let config = Config::new(0.01, ForceLaw::Exact).with_integrator(integrator);
        let mut sim = PpCoulomb::new(p.clone(), &config, Backend::Cpu).unwrap();
        let e0 = sim.diagnostics().unwrap().total;
        let mut worst = 0.0f64;
        for _ in 0..6 {
            step_ok(&mut sim, 100);
            let e = sim.diagnostics().unwrap().total;
            worst = worst.max(((e - e0) / e0).abs());
        }
        println!("{integrator:?}: worst relative energy error over 600 steps {worst:.2e}");
        // Measured: leapfrog 8.3e-6, symplectic Euler 1.9e-3 (first order): the default
        // tolerance leaves a margin of at least 4 over the integrator's own error.
        assert!(worst < DEFAULT_ENERGY_TOLERANCE / 4.0, "{worst:e}");
    }
}
