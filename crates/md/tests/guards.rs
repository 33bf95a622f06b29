//! The blow-up guard, the time-step bound and the checks on the initial state.

use approx::abs_diff_eq;
use simkit_backend::testing::backends;
use simkit_backend::{Backend, Error, Result, Simulation};
use simkit_md::{Config, Dim, LennardJones, Md, PairTable, System, scenes};

fn liquid() -> Result<System> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)
}

/// Just above the bound (0.0294): the liquid blows up after a few hundred steps.
fn unstable() -> Config {
    Config {
        allow_unstable_dt: true,
        check_every: 10,
        ..Config::default().with_dt(0.03)
    }
}

#[test]
fn a_step_over_the_bound_is_refused_unless_allowed() -> Result<()> {
    let sys = liquid()?;
    let e = Md::new(sys.clone(), &Config::default().with_dt(0.08), Backend::Cpu)
        .err()
        .unwrap();
    match e {
        Error::Unstable { dt, bound, .. } => {
            assert_eq!(dt, 0.08);
            // T / 20 of Lennard-Jones at m = 1 (reduced mass 1/2): 0.0294.
            assert!(abs_diff_eq!(bound, 0.0294, epsilon = 1e-3), "{bound}");
        }
        other => panic!("{other}"),
    }
    Md::new(sys, &unstable(), Backend::Cpu)?;
    Ok(())
}

#[test]
fn a_blow_up_is_reported_and_rolled_back_to_the_last_good_check() -> Result<()> {
    let sys = liquid()?;
    for backend in backends("a_blow_up_is_reported_and_rolled_back_to_the_last_good_check") {
        let mut md = Md::new(sys.clone(), &unstable(), backend)?;
        let e = md.step(2000).expect_err("dt = 0.03 must blow up");
        let Error::BlowUp {
            step,
            rolled_back_to,
            what,
            cause,
        } = e
        else {
            panic!("{e}")
        };
        eprintln!(
            "{}: blow-up at {step}: {what}; {cause}; back to {rolled_back_to}",
            md.backend_name()
        );
        assert!(step > rolled_back_to && step <= rolled_back_to + 10);
        assert!(rolled_back_to > 0 && rolled_back_to % 10 == 0);
        assert!(what.contains("particle"), "{what}");
        assert!(cause.contains("dt"), "{cause}");
        assert_eq!(md.steps_done(), rolled_back_to);
        let s = md.state()?;
        assert!(
            s.positions
                .iter()
                .chain(&s.velocities)
                .flatten()
                .all(|x| x.is_finite())
        );
        // The same run stepped exactly to that step has the same bits.
        let mut again = Md::new(sys.clone(), &unstable(), backend)?;
        again.step(rolled_back_to as u32)?;
        assert_eq!(again.state()?, s);
        let d = md.diagnostics()?;
        assert!(d.total.is_finite());
        // The run goes on from there (and blows up again).
        assert!(matches!(md.step(2000), Err(Error::BlowUp { .. })));
    }
    Ok(())
}

#[test]
fn the_check_does_not_perturb_a_stable_run() -> Result<()> {
    let sys = liquid()?;
    for backend in backends("the_check_does_not_perturb_a_stable_run") {
        let run = |check_every| -> Result<simkit_md::State> {
            let config = Config {
                check_every,
                ..Config::default().with_dt(0.005)
            };
            let mut md = Md::new(sys.clone(), &config, backend)?;
            md.step(137)?;
            md.step(63)?;
            md.state()
        };
        let a = run(0)?;
        assert_eq!(a, run(100)?);
        assert_eq!(a, run(1)?);
    }
    Ok(())
}

#[test]
fn particles_on_top_of_each_other_are_refused() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(Dim::Three, [0.0; 3], [10.0; 3], [true; 3], vec![1.0], table)?;
    sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
    sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
    let e = Md::new(sys, &Config::default(), Backend::Cpu)
        .err()
        .unwrap();
    assert!(e.to_string().contains("initial state"), "{e}");
    Ok(())
}

#[test]
fn a_particle_thrown_through_a_closed_box_is_a_blow_up() -> Result<()> {
    // Faster than a box length per step: the reflection cannot bring it back.
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(
        Dim::Three,
        [0.0; 3],
        [10.0; 3],
        [false; 3],
        vec![1.0],
        table,
    )?;
    sys.add_particle(0, [5.0, 5.0, 5.0], [3000.0, 0.0, 0.0])?;
    let config = Config {
        check_every: 5,
        ..Config::default().with_dt(0.01)
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    let e = md.step(20).err().unwrap();
    assert!(
        matches!(
            e,
            Error::BlowUp {
                rolled_back_to: 0,
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(md.steps_done(), 0);
    assert_eq!(md.state()?.positions[0], [5.0, 5.0, 5.0]);
    Ok(())
}

#[test]
fn both_backends_refuse_the_same_initial_states() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(Dim::Three, [0.0; 3], [10.0; 3], [true; 3], vec![1.0], table)?;
    sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
    sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
    for backend in backends("both_backends_refuse_the_same_initial_states") {
        let e = Md::new(sys.clone(), &Config::default(), backend)
            .err()
            .unwrap();
        assert!(e.to_string().contains("initial state"), "{e}");
    }
    Ok(())
}

/// With the Langevin thermostat the random stream is keyed by the step, so a rollback must
/// also rewind the step that keys it (on the GPU a device counter): after a blow-up, the
/// run continued from the rolled-back state matches a fresh run stepped to the same step.
#[test]
fn a_thermostatted_blow_up_rolls_back_the_random_stream_too() -> Result<()> {
    let sys = liquid()?;
    let config = Config {
        thermostat: Some(simkit_md::Langevin::new(1.44, 0.5, 17)),
        ..unstable()
    };
    for backend in backends("a_thermostatted_blow_up_rolls_back_the_random_stream_too") {
        let mut md = Md::new(sys.clone(), &config, backend)?;
        let Err(Error::BlowUp { rolled_back_to, .. }) = md.step(3000) else {
            panic!("dt = 0.03 must blow up with the thermostat too")
        };
        assert!(rolled_back_to > 10);
        // Continue 2 steps from the rolled-back state (the blow-up itself comes later).
        let mut fresh = Md::new(sys.clone(), &config, backend)?;
        fresh.step(rolled_back_to as u32 - 10)?;
        let mut again = Md::new(sys.clone(), &config, backend)?;
        again.step(rolled_back_to as u32)?;
        assert_eq!(again.state()?, md.state()?, "{}", md.backend_name());
        md.step(2)?;
        again.step(2)?;
        assert_eq!(again.state()?, md.state()?, "{}", md.backend_name());
        fresh.step(12)?;
        assert_eq!(fresh.state()?, md.state()?, "{}", md.backend_name());
    }
    Ok(())
}

/// Regression (found by the property tests): a finite velocity whose kinetic energy
/// overflows f64 (a pair with no stiffness guidance, so no time-step bound, at dt = 1e300)
/// is a blow-up, not a state with infinite diagnostics.
#[test]
fn an_overflowing_kinetic_energy_is_a_blow_up() -> Result<()> {
    let p = LennardJones::weighted(0.1, 0.3, 0.0, 1.289, 1.85);
    let table = PairTable::uniform(2, p)?;
    let mut sys = System::new(
        Dim::Two,
        [0.0; 3],
        [8.0; 3],
        [false; 3],
        vec![1.0, 2.0],
        table,
    )?;
    sys.add_particle(0, [0.0, 5.97, 0.0], [1e-300, 0.0, 0.0])?;
    sys.add_particle(1, [5.99, 4.92, 0.0], [0.0; 3])?;
    let config = Config {
        dt: Some(1e300),
        check_every: 1,
        ..Config::default()
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    let e = md
        .step(10)
        .expect_err("the kinetic energy overflows at step 5");
    assert!(
        matches!(&e, Error::BlowUp { rolled_back_to: 4, what, .. } if what.contains("kinetic energy")),
        "{e}"
    );
    assert!(md.diagnostics()?.kinetic.is_finite());
    Ok(())
}
