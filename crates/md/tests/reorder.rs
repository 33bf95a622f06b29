//! Reordering the particles in cell order on the CPU (`Config::reorder_every`): the same
//! physics to rounding, reproducible, independent of the skin, bit-exact through a
//! blow-up rollback (restart: `tests/restart.rs`), and the state in the system's order.

use std::time::Instant;

use simkit_backend::{Backend, Error, Result, Simulation};
use simkit_md::{Config, Langevin, Md, PairParams, PairTable, State, System, scenes};

fn liquid() -> Result<System> {
    let table = PairTable::uniform(2, PairParams::lj(1.0, 1.0, 2.5))?;
    scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0, 1], 3)
}

fn run(sys: &System, config: &Config, steps: u32) -> Result<(State, f64)> {
    let mut md = Md::new(sys, config, Backend::Cpu)?;
    md.step(steps)?;
    Ok((md.state()?, md.diagnostics()?.total))
}

fn max_diff(a: &State, b: &State) -> f64 {
    a.positions
        .iter()
        .chain(&a.velocities)
        .flatten()
        .zip(b.positions.iter().chain(&b.velocities).flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// 200 steps (one time unit) of a 256-atom liquid, NVE and with the thermostat and a
/// frozen species: reordered every 10 steps against never, positions and velocities
/// within 1e-9 (the sums differ by rounding, 1e-16, grown by the chaotic dynamics), the
/// species in the system's order.
#[test]
fn reordering_changes_results_only_by_rounding() -> Result<()> {
    let mut frozen = liquid()?;
    frozen.set_frozen(1, true)?;
    let thermostat = Some(Langevin::new(1.0, 1.0, 8));
    for (sys, thermostat) in [(liquid()?, None), (frozen, thermostat)] {
        let plain = Config {
            thermostat,
            ..Config::with_dt(0.005)
        };
        let sorted = Config {
            reorder_every: 10,
            ..plain
        };
        let (a, ea) = run(&sys, &plain, 200)?;
        let (b, eb) = run(&sys, &sorted, 200)?;
        let d = max_diff(&a, &b);
        eprintln!(
            "reordered vs plain after 200 steps: {d:.2e}, energy {:.2e}",
            ea - eb
        );
        assert!(d < 1e-9, "{d}");
        assert!((ea - eb).abs() < 1e-9 * ea.abs());
        assert_eq!(a.species, b.species);
        assert_eq!(b.species, sys.species());
        // The forces come back in the system's order too.
        let mut md = Md::new(&sys, &sorted, Backend::Cpu)?;
        md.step(10)?;
        let mut reference = Md::new(&sys, &plain, Backend::Cpu)?;
        reference.step(10)?;
        let (f, g) = (md.forces()?, reference.forces()?);
        let df = f
            .iter()
            .flatten()
            .zip(g.iter().flatten())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(df < 1e-9, "{df}");
    }
    Ok(())
}

/// Reordered runs do not depend on the Verlet-list skin (the reordering is keyed by the
/// step count, not by the list rebuilds).
#[test]
fn reordered_runs_do_not_depend_on_the_skin() -> Result<()> {
    let sys = liquid()?;
    let config = |skin| Config {
        reorder_every: 7,
        skin,
        ..Config::with_dt(0.005)
    };
    let (a, _) = run(&sys, &config(0.3), 150)?;
    let (b, _) = run(&sys, &config(1.0), 150)?;
    let (c, _) = run(&sys, &config(0.0), 150)?;
    assert_eq!(a, b);
    assert_eq!(a, c);
    Ok(())
}

/// A blow-up of a reordered run is rolled back to a state bit-identical to the same run
/// stepped exactly there, and names a particle by its system index.
#[test]
fn a_reordered_blow_up_rolls_back_bit_for_bit() -> Result<()> {
    let table = PairTable::uniform(1, PairParams::lj(1.0, 1.0, 2.5))?;
    let sys = scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)?;
    let config = Config {
        allow_unstable_dt: true,
        check_every: 10,
        reorder_every: 3,
        ..Config::with_dt(0.03)
    };
    let mut md = Md::new(&sys, &config, Backend::Cpu)?;
    let Err(Error::BlowUp {
        rolled_back_to,
        what,
        ..
    }) = md.step(3000)
    else {
        panic!("dt = 0.03 must blow up")
    };
    assert!(what.contains("particle"), "{what}");
    let mut again = Md::new(&sys, &config, Backend::Cpu)?;
    again.step(rolled_back_to as u32)?;
    assert_eq!(again.state()?, md.state()?);
    md.step(2)?;
    again.step(2)?;
    assert_eq!(again.state()?, md.state()?);
    Ok(())
}

/// One short timing run (not a benchmark): LAMMPS's 32 000-atom melt with its particles
/// shuffled in memory (as after a long run), 100 steps never reordered against reordered
/// every 20 steps. Run with `cargo test --release -p simkit-md --test reorder -- --ignored
/// --nocapture`.
#[test]
#[ignore = "timing run, not a test"]
fn timing_of_cell_order() -> Result<()> {
    let melt = scenes::lj_melt()?;
    let n = melt.particle_count();
    // A fixed shuffle (multiplicative hash order).
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by_key(|&i| (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20);
    let mut sys = melt.clone();
    let pick = |v: &[[f64; 3]]| -> Vec<[f64; 3]> { idx.iter().map(|&i| v[i]).collect() };
    let species: Vec<u32> = idx.iter().map(|&i| melt.species()[i]).collect();
    sys.set_particles(&species, &pick(melt.positions()), &pick(melt.velocities()))?;
    for every in [0, 20] {
        let config = Config {
            reorder_every: every,
            ..Config::with_dt(0.005)
        };
        let mut md = Md::new(&sys, &config, Backend::Cpu)?;
        md.step(1)?;
        let t = Instant::now();
        md.step(100)?;
        eprintln!(
            "reorder_every = {every}: {:.3} s for 100 steps on {}",
            t.elapsed().as_secs_f64(),
            md.backend_name()
        );
    }
    Ok(())
}
