//! Checkpoint and resume: bit for bit on every backend (`check_restart` resumes in a new
//! process), and clear `Error::Checkpoint`s for files of another package or model, and for
//! truncated or corrupted files.

/// The conformance suite every simulation crate runs (`conformance_tests!`).
#[path = "suite/mod.rs"]
mod suite;

use approx::assert_abs_diff_eq;
use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Restart, Simulation, checkpoint};
use simkit_dem::{Config, Dem, Dim, Integrator, Material, Particle, Precision, Scene};

/// A vibrated 2D bed of 40 discs with friction: the wall phase, list rebuilds and contacts
/// all matter over a few hundred steps.
fn bed() -> Scene {
    discs(40, 8, [9.0, 12.0], true)
}

/// `n` discs with friction in rows of `per_row` in a closed box `[0, hi)` under gravity,
/// its floor vibrating when `vibrating`.
fn discs(n: usize, per_row: usize, hi: [f64; 2], vibrating: bool) -> Scene {
    let m = Material::new(0.8, 0.05).with_friction(0.4, 30.0);
    let mut s = Scene::new(Dim::Two, [0.0; 3], [hi[0], hi[1], 0.0], m).unwrap();
    s.set_gravity(1.0).unwrap();
    if vibrating {
        s.set_vibration(0.3, 6.0).unwrap();
    }
    s.add_box_walls(m, vibrating).unwrap();
    for k in 0..n {
        let (x, y) = ((k % per_row) as f64, (k / per_row) as f64);
        let v = [0.3 * ((k % 5) as f64 - 2.0), 0.2 * ((k % 3) as f64), 0.0];
        s.add_particle(
            Particle::new([0.9 + 1.05 * x, 0.9 + 1.05 * y, 0.0], 0.5, 1.0).with_velocity(v),
        )
        .unwrap();
    }
    s
}

/// 27 spheres in a 3D box periodic along x and y, thrown sideways under gravity.
fn box3d() -> Scene {
    let m = Material::new(0.7, 0.05).with_friction(0.3, 20.0);
    let mut s = Scene::new(Dim::Three, [0.0; 3], [6.0, 6.0, 8.0], m).unwrap();
    s.set_periodic([true, true, false]);
    s.set_gravity(1.0).unwrap();
    s.add_box_walls(m, false).unwrap();
    for k in 0..27 {
        let (x, y, z) = ((k % 3) as f64, ((k / 3) % 3) as f64, (k / 9) as f64);
        s.add_particle(
            Particle::new([1.0 + 2.0 * x, 1.0 + 2.0 * y, 1.0 + 1.5 * z], 0.5, 1.0).with_velocity([
                2.0,
                1.0 - 0.2 * k as f64,
                0.0,
            ]),
        )
        .unwrap();
    }
    s
}

#[test]
fn restart_is_bit_exact() {
    let test = &test_path(module_path!(), "restart_is_bit_exact");
    for backend in backends(test) {
        check_restart(test, "bed vv", backend, 250, |b| {
            Dem::new(bed(), &Config::default(), b)
        });
        check_restart(test, "3d vv", backend, 150, |b| {
            Dem::new(box3d(), &Config::default().with_check_every(7), b)
        });
        if matches!(backend, Backend::Cpu) {
            for precision in [Precision::F64, Precision::F32] {
                for integrator in [Integrator::VelocityVerlet, Integrator::PositionVerlet] {
                    let cfg = Config::default()
                        .with_precision(precision)
                        .with_integrator(integrator);
                    let label = format!("bed {integrator:?} {precision:?}");
                    check_restart(test, &label, backend, 250, |b| Dem::new(bed(), &cfg, b));
                    let label = format!("3d {integrator:?} {precision:?}");
                    check_restart(test, &label, backend, 150, |b| Dem::new(box3d(), &cfg, b));
                }
            }
        }
    }
}

#[test]
fn resume_restores_the_clock_and_the_wall_phase() {
    // Rebuilding from state() restarts the clock (and the wall phase) at 0; resume does not.
    let mut sim = Dem::new(bed(), &Config::default(), Backend::Cpu).unwrap();
    sim.step(333).unwrap();
    let bytes = sim.checkpoint().unwrap();
    let mut back = Dem::<Material>::resume(&bytes, Backend::Cpu).unwrap();
    assert_eq!(back.steps_done(), 333);
    assert_eq!(back.state().unwrap(), sim.state().unwrap());
    // The clock accumulates t += dt, so it is 333 dt up to round-off.
    assert_abs_diff_eq!(
        back.state().unwrap().time,
        333.0 * sim.dt(),
        epsilon = 1e-12
    );
    sim.step(100).unwrap();
    back.step(100).unwrap();
    assert_eq!(back.state().unwrap(), sim.state().unwrap());
}

fn is_checkpoint_error(r: Result<Dem, Error>, needle: &str) {
    match r {
        Err(Error::Checkpoint { reason, .. }) => {
            assert!(reason.contains(needle), "{reason} (expected '{needle}')")
        }
        Err(e) => panic!("expected Error::Checkpoint, got {e}"),
        Ok(_) => panic!("a bad checkpoint was accepted"),
    }
}

#[test]
fn bad_checkpoints_are_refused_clearly() {
    let mut sim = Dem::new(bed(), &Config::default(), Backend::Cpu).unwrap();
    sim.step(10).unwrap();
    let bytes = sim.checkpoint().unwrap();
    assert_eq!(checkpoint::header(&bytes).unwrap().model, "Dem<cpu f64, 2>");
    // Truncated anywhere.
    for cut in [0, 5, 20, bytes.len() / 2, bytes.len() - 1] {
        assert!(matches!(
            Dem::<Material>::resume(&bytes[..cut], Backend::Cpu),
            Err(Error::Checkpoint { .. })
        ));
    }
    is_checkpoint_error(
        Dem::<Material>::resume(&bytes[..bytes.len() - 3], Backend::Cpu),
        "truncated",
    );
    // One flipped bit in the payload.
    let mut bad = bytes.clone();
    let at = bytes.len() - 40;
    bad[at] ^= 0x10;
    is_checkpoint_error(Dem::<Material>::resume(&bad, Backend::Cpu), "checksum");
    // Another package.
    let other = checkpoint::encode("simkit-rd", env!("CARGO_PKG_VERSION"), "Rd", &1u8).unwrap();
    is_checkpoint_error(Dem::<Material>::resume(&other, Backend::Cpu), "simkit-rd");
    // Another precision: the same file claiming to hold an f32 run (same-length model
    // string, checksum recomputed) is refused, not misread.
    let mut forged = bytes.clone();
    let pos = forged
        .windows(15)
        .position(|w| w == b"Dem<cpu f64, 2>")
        .unwrap();
    forged[pos..pos + 15].copy_from_slice(b"Dem<cpu f32, 2>");
    simkit_backend::testing::reseal(&mut forged);
    is_checkpoint_error(
        Dem::<Material>::resume(&forged, Backend::Cpu),
        "Dem<cpu f32, 2>",
    );
    // A CPU run resumed on the GPU (and back) is refused with the way out.
    #[cfg(feature = "gpu")]
    if let Some(ctx) = simkit_backend::testing::gpu_or_skip("bad_checkpoints_are_refused_clearly") {
        is_checkpoint_error(
            Dem::<Material>::resume(&bytes, Backend::Gpu(&ctx)),
            "backend that wrote it",
        );
        let mut g = Dem::new(bed(), &Config::default(), Backend::Gpu(&ctx)).unwrap();
        g.step(10).unwrap();
        let gb = g.checkpoint().unwrap();
        assert_eq!(checkpoint::header(&gb).unwrap().model, "Dem<gpu f32, 2>");
        is_checkpoint_error(
            Dem::<Material>::resume(&gb, Backend::Cpu),
            "backend that wrote it",
        );
    }
}

/// 400 discs in a closed box: a checkpoint of about 60 kB, so that a writer spends much of
/// its time writing.
fn big_bed() -> Scene {
    discs(400, 20, [22.0, 30.0], false)
}

#[test]
fn a_writer_killed_at_random_moments_leaves_a_whole_checkpoint() {
    let make = || Dem::new(big_bed(), &Config::default(), Backend::Cpu);
    let seen = simkit_backend::testing::faults::check_killed_writers(
        &test_path(
            module_path!(),
            "a_writer_killed_at_random_moments_leaves_a_whole_checkpoint",
        ),
        60,
        1,
        make,
    );
    if std::env::var("SIMKIT_FAULT_CHILD").is_ok() {
        return;
    }
    println!("{seen:?}");
    assert_eq!(seen.kills, 60);
    // The kills must land inside writes for the test to mean anything.
    assert!(
        seen.mid_write >= 1 && seen.with_checkpoint >= 30,
        "{seen:?}"
    );
}

#[test]
fn a_full_disk_is_an_error_and_the_old_checkpoint_stays() {
    let make = || Dem::new(big_bed(), &Config::default(), Backend::Cpu);
    let message = simkit_backend::testing::faults::check_full_disk(
        &test_path(
            module_path!(),
            "a_full_disk_is_an_error_and_the_old_checkpoint_stays",
        ),
        make,
    );
    if std::env::var("SIMKIT_FAULT_CHILD").is_ok() {
        return;
    }
    println!("{message}");
    assert!(
        message.contains("run.ckpt") && message.contains("file-size limit"),
        "{message}"
    );
}
