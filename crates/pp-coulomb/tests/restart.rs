//! Checkpoint and resume: bit-exact in a new process on every backend and precision
//! (`simkit_backend::testing::check_restart`), the clock and step counter restored, and clear
//! errors for checkpoints of another model, truncated or corrupted ones.

/// The conformance suite every simulation crate runs (`conformance_tests!`).
#[path = "suite/mod.rs"]
mod suite;

use approx::assert_abs_diff_eq;
use simkit_backend::checkpoint;
use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Restart, Simulation};
use simkit_pp_coulomb::{
    Config, ForceLaw, Integrator, Particles, PpCoulomb, Precision, Region, Species, Velocities,
};

/// 150 electrons and 50 ions in a cube of edge 12.
fn plasma() -> Particles {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0)).unwrap();
    let ion = p.add_species(Species::new("ion", 3.0, 50.0)).unwrap();
    let cube = Region::Cube {
        min: [-6.0; 3],
        length: 12.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.2 };
    p.fill(e, 150, cube, v, 21).unwrap();
    p.fill(ion, 50, cube, v, 22).unwrap();
    p
}

/// A run of 2 x 35 steps against 35 steps, checkpoint, resume in a new process and 35 more
/// steps, byte for byte, for: the exact law (energy guard on, a cold sphere) with leapfrog,
/// Plummer with symplectic Euler, and the exclusion law with leapfrog after a `set_dt` (the
/// clock's origin moves), each in f64 and f32 on the CPU, in f32 on the GPU, and in f64 on a
/// GPU with SHADER_F64 (a GPU without it is reported, not skipped silently). The check
/// interval 10 puts checks inside both halves and the resume at a non-multiple of it.
#[test]
fn restart_is_bit_exact() {
    let name = &test_path(module_path!(), "restart_is_bit_exact");
    for backend in backends(name) {
        let mut precisions = vec![Precision::F32];
        if backend.has_f64() {
            precisions.push(Precision::F64);
        } else {
            println!("{backend:?}: no SHADER_F64 on this adapter, f64 restart not tested");
        }
        for precision in precisions {
            let cases = [
                ("exact leapfrog", ForceLaw::Exact, Integrator::Leapfrog),
                (
                    "plummer euler",
                    ForceLaw::Plummer { epsilon: 0.3 },
                    Integrator::SymplecticEuler,
                ),
                (
                    "exclusion leapfrog set_dt",
                    ForceLaw::Exclusion { radius: 0.5 },
                    Integrator::Leapfrog,
                ),
            ];
            for (label, law, integrator) in cases {
                let label = format!("{label} {precision:?}");
                check_restart(name, &label, backend, 35, |b| {
                    let config = Config::new(0.02, law)
                        .with_integrator(integrator)
                        .with_precision(precision)
                        .with_check_every(10);
                    let p = match law {
                        ForceLaw::Exact => simkit_pp_coulomb::scenes::cold_sphere(200, 1.0, 5)?,
                        _ => plasma(),
                    };
                    let mut sim = PpCoulomb::new(p, &config, b)?;
                    if matches!(law, ForceLaw::Exclusion { .. }) {
                        sim.step(3)?;
                        sim.set_dt(0.015)?;
                    }
                    Ok(sim)
                });
            }
        }
    }
}

/// The mixed mode (`Config::mixed`, CPU only) restarts bit for bit in a new process too,
/// in the cases of `restart_is_bit_exact`; its checkpoint is model `PpCoulomb<mixed>`, and
/// the same state relabelled as f32 (or an f32 one as mixed) is refused.
#[test]
fn mixed_restart_is_bit_exact() {
    let name = &test_path(module_path!(), "mixed_restart_is_bit_exact");
    let cases = [
        ("exact leapfrog", ForceLaw::Exact, Integrator::Leapfrog),
        (
            "plummer euler",
            ForceLaw::Plummer { epsilon: 0.3 },
            Integrator::SymplecticEuler,
        ),
        (
            "exclusion leapfrog set_dt",
            ForceLaw::Exclusion { radius: 0.5 },
            Integrator::Leapfrog,
        ),
    ];
    let config = |law, integrator| {
        Config::new(0.02, law)
            .with_integrator(integrator)
            .with_precision(Precision::F32)
            .with_mixed(true)
            .with_check_every(10)
    };
    for (label, law, integrator) in cases {
        check_restart(name, label, Backend::Cpu, 35, |b| {
            let p = match law {
                ForceLaw::Exact => simkit_pp_coulomb::scenes::cold_sphere(200, 1.0, 5)?,
                _ => plasma(),
            };
            let mut sim = PpCoulomb::new(p, &config(law, integrator), b)?;
            if matches!(law, ForceLaw::Exclusion { .. }) {
                sim.step(3)?;
                sim.set_dt(0.015)?;
            }
            Ok(sim)
        });
    }
    let c = config(ForceLaw::Plummer { epsilon: 0.3 }, Integrator::Leapfrog);
    let mut sim = PpCoulomb::new(plasma(), &c, Backend::Cpu).unwrap();
    sim.step(4).unwrap();
    let bytes = sim.checkpoint().unwrap();
    assert_eq!(
        checkpoint::header(&bytes).unwrap().model,
        "PpCoulomb<mixed>"
    );
    let back = PpCoulomb::resume(&bytes, Backend::Cpu).unwrap();
    assert_eq!(back.config(), sim.config());
    let e = checkpoint_error(&simkit_backend::testing::relabel(&bytes, "PpCoulomb<f32>"));
    assert!(
        e.contains("PpCoulomb<f32>") && e.contains("PpCoulomb<mixed>"),
        "{e}"
    );
    let mut f32_run = PpCoulomb::new(plasma(), &c.with_mixed(false), Backend::Cpu).unwrap();
    let e = checkpoint_error(&simkit_backend::testing::relabel(
        &f32_run.checkpoint().unwrap(),
        "PpCoulomb<mixed>",
    ));
    assert!(
        e.contains("PpCoulomb<f32>") && e.contains("PpCoulomb<mixed>"),
        "{e}"
    );
}

/// The resumed run has the step counter, the simulated time (after a `set_dt`), the
/// configuration and the state of the original.
#[test]
fn resume_restores_clock_and_state() {
    for backend in backends("resume_restores_clock_and_state") {
        let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.4 })
            .with_precision(Precision::F32)
            .with_check_every(7);
        let mut sim = PpCoulomb::new(plasma(), &config, backend).unwrap();
        sim.step(11).unwrap();
        sim.set_dt(0.03).unwrap();
        sim.step(5).unwrap();
        let bytes = sim.checkpoint().unwrap();
        let mut back = PpCoulomb::resume(&bytes, backend).unwrap();
        assert_eq!(back.steps_done(), 16);
        assert_eq!(back.time().to_bits(), sim.time().to_bits());
        assert_abs_diff_eq!(back.time(), 11.0 * 0.05 + 5.0 * 0.03, epsilon = 1e-12);
        assert_eq!(back.config(), sim.config());
        assert_eq!(back.state().unwrap(), sim.state().unwrap());
        // The empty system too.
        let mut empty = PpCoulomb::new(Particles::new(), &config, backend).unwrap();
        empty.step(4).unwrap();
        let back = PpCoulomb::resume(&empty.checkpoint().unwrap(), backend).unwrap();
        assert_eq!((back.steps_done(), back.len()), (4, 0));
    }
}

fn checkpoint_error(bytes: &[u8]) -> String {
    match PpCoulomb::resume(bytes, Backend::Cpu) {
        Err(e @ Error::Checkpoint { .. }) => e.to_string(),
        Err(e) => panic!("expected Error::Checkpoint, got {e}"),
        Ok(_) => panic!("expected Error::Checkpoint, got a run"),
    }
}

/// Another crate's or model's checkpoint, a truncated one, one flipped bit, and a file whose
/// header and contents disagree are each a clear `Error::Checkpoint`.
#[test]
fn bad_checkpoints_are_clear_errors() {
    let config = Config::new(0.05, ForceLaw::Exact);
    let mut sim = PpCoulomb::new(plasma(), &config, Backend::Cpu).unwrap();
    sim.step(3).unwrap();
    let good = sim.checkpoint().unwrap();
    let version = env!("CARGO_PKG_VERSION");
    let foreign = checkpoint::encode("simkit-dem", version, "Dem<f64, 3>", &1u8).unwrap();
    let e = checkpoint_error(&foreign);
    assert!(e.contains("simkit-dem"), "{e}");
    let other_model =
        checkpoint::encode("simkit-pp-coulomb", version, "PpCoulomb<f16>", &1u8).unwrap();
    let e = checkpoint_error(&other_model);
    assert!(e.contains("PpCoulomb<f16>"), "{e}");
    let e = checkpoint_error(&good[..good.len() - 9]);
    assert!(e.contains("truncated"), "{e}");
    for at in [20, good.len() / 2, good.len() - 5] {
        let mut bad = good.clone();
        bad[at] ^= 0x10;
        let e = checkpoint_error(&bad);
        assert!(e.contains("checksum") || e.contains("model"), "{e}");
    }
    // The f64 run's state relabelled as f32: the header and the payload disagree.
    let header = checkpoint::header(&good).unwrap();
    assert_eq!(header.model, "PpCoulomb<f64>");
    let relabelled = simkit_backend::testing::relabel(&good, "PpCoulomb<f32>");
    assert_eq!(
        checkpoint::header(&relabelled).unwrap().model,
        "PpCoulomb<f32>"
    );
    let e = checkpoint_error(&relabelled);
    assert!(
        e.contains("PpCoulomb<f32>") && e.contains("PpCoulomb<f64>"),
        "{e}"
    );
}
