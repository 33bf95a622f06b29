//! Checkpoint and restart, bit for bit (in a new process), and refused checkpoints.

/// The conformance suite every simulation crate runs (`conformance_tests!`).
#[path = "suite/mod.rs"]
mod suite;

use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Precision, Restart, Result, Simulation, checkpoint};
use simkit_md::{Config, Dim, Integrator, Langevin, LennardJones, Md, PairTable, System, scenes};

fn mix() -> System {
    scenes::three_phase_mix([6; 3], 0.4, 1.0, 9).unwrap()
}

/// The mixture with the solid species frozen and the gas on its own thermostat target.
fn mix_frozen() -> System {
    let mut sys = mix();
    sys.set_frozen(scenes::SOLID, true).unwrap();
    sys.set_species_langevin(scenes::GAS, Some([2.0, 4.0]))
        .unwrap();
    sys
}

fn box_2d() -> System {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let mut sys = System::new(
        Dim::Two,
        [0.0; 3],
        [9.0, 6.0, 0.0],
        [true, false, false],
        vec![2.0],
        table,
    )
    .unwrap();
    for i in 0..7 {
        for j in 0..5 {
            let v = [0.3 * (i as f64 - 3.0), 0.5 * (j as f64 - 2.0), 0.0];
            sys.add_particle(0, [0.6 + 1.2 * i as f64, 0.6 + 1.2 * j as f64, 0.0], v)
                .unwrap();
        }
    }
    sys
}

/// A labelled scene and its settings.
type Case = (&'static str, fn() -> System, Config);

#[test]
fn restart_is_bit_exact() {
    let name = &test_path(module_path!(), "restart_is_bit_exact");
    let cases: [Case; 6] = [
        (
            "3D mix, f64, velocity Verlet",
            mix,
            Config {
                check_every: 7,
                ..Config::default()
            },
        ),
        (
            "3D mix, f32, leapfrog, shifted",
            mix,
            Config {
                precision: Precision::F32,
                integrator: Integrator::Leapfrog,
                shift: true,
                ..Config::default()
            },
        ),
        (
            "2D closed walls, f64, leapfrog",
            box_2d,
            Config {
                integrator: Integrator::Leapfrog,
                ..Config::default().with_dt(0.004)
            },
        ),
        (
            "3D mix, f64, Langevin, frozen solid",
            mix_frozen,
            Config {
                check_every: 7,
                thermostat: Some(Langevin::new(0.9, 1.0, 99)),
                ..Config::default()
            },
        ),
        (
            "2D closed walls, f32, leapfrog, Langevin",
            box_2d,
            Config {
                precision: Precision::F32,
                integrator: Integrator::Leapfrog,
                thermostat: Some(Langevin::new(0.5, 3.0, 5)),
                ..Config::default().with_dt(0.004)
            },
        ),
        (
            "3D mix, f64, Langevin (second seed)",
            mix,
            Config {
                thermostat: Some(Langevin::new(0.9, 1.0, 4)),
                ..Config::default()
            },
        ),
    ];
    for backend in backends(name) {
        for (label, system, config) in cases {
            check_restart(name, label, backend, 60, |b| Md::new(system(), &config, b));
        }
    }
}

#[test]
fn the_clock_and_the_step_count_are_restored() -> Result<()> {
    let mut md = Md::new(box_2d(), &Config::default().with_dt(0.004), Backend::Cpu)?;
    md.step(25)?;
    let again = Md::<LennardJones>::resume(&md.checkpoint()?, Backend::Cpu)?;
    assert_eq!(again.steps_done(), 25);
    let mut again = again;
    assert_eq!(again.state()?.time, md.state()?.time);
    assert_eq!(again.state()?.time, 25.0 * 0.004);
    Ok(())
}

#[test]
fn bad_checkpoints_are_refused_with_a_checkpoint_error() -> Result<()> {
    let mut md = Md::new(box_2d(), &Config::default().with_dt(0.004), Backend::Cpu)?;
    md.step(3)?;
    let bytes = md.checkpoint()?;
    let is_ckpt = |r: Result<Md>| matches!(r, Err(Error::Checkpoint { .. }));
    // Truncated, corrupted.
    assert!(is_ckpt(Md::<LennardJones>::resume(
        &bytes[..bytes.len() / 2],
        Backend::Cpu
    )));
    let mut bad = bytes.clone();
    let k = bad.len() - 40;
    bad[k] ^= 0x10;
    assert!(is_ckpt(Md::<LennardJones>::resume(&bad, Backend::Cpu)));
    // Another package, another model with this package's name, garbage payload.
    let other = checkpoint::encode(
        "simkit-dem",
        env!("CARGO_PKG_VERSION"),
        "Dem<cpu f64, 2>",
        &1u8,
    )?;
    assert!(is_ckpt(Md::<LennardJones>::resume(&other, Backend::Cpu)));
    let garbage = checkpoint::encode(
        "simkit-md",
        env!("CARGO_PKG_VERSION"),
        "Md<cpu f64, 2>",
        &[7u8; 5],
    )?;
    assert!(is_ckpt(Md::<LennardJones>::resume(&garbage, Backend::Cpu)));
    // A checkpoint whose model does not match its settings (f32 label on an f64 run).
    let header = checkpoint::header(&bytes)?;
    assert_eq!(header.model, "Md<cpu f64, 2>");
    let start = bytes
        .windows(14)
        .position(|w| w == b"Md<cpu f64, 2>")
        .unwrap();
    let mut relabelled = bytes.clone();
    relabelled[start..start + 14].copy_from_slice(b"Md<cpu f32, 2>");
    simkit_backend::testing::reseal(&mut relabelled);
    let e = Md::<LennardJones>::resume(&relabelled, Backend::Cpu)
        .err()
        .unwrap();
    assert!(matches!(e, Error::Checkpoint { .. }), "{e}");
    assert!(e.to_string().contains("f32"), "{e}");
    Ok(())
}
