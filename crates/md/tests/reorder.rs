//! The CPU works on its particles in cell order (it sorts them at every list rebuild):
//! the physics does not depend on the order the system lists them in, states and forces
//! come back in the system's order, and a blow-up rollback is bit-exact (restart:
//! `tests/restart.rs`).

use approx::assert_abs_diff_eq;
use simkit_backend::{Backend, Error, Result, Simulation};
use simkit_md::{Config, LennardJones, Md, PairTable, State, System, scenes};

fn liquid() -> Result<System> {
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
    scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0, 1], 3)
}

fn run(sys: &System, config: &Config, steps: u32) -> Result<(State, f64)> {
    let mut md = Md::new(sys.clone(), config, Backend::Cpu)?;
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

/// A fixed shuffle of the system's particles (multiplicative hash order): `(shuffled
/// system, idx)` with shuffled particle `k` = original particle `idx[k]`.
fn shuffled(sys: &System) -> Result<(System, Vec<usize>)> {
    let n = sys.particle_count();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by_key(|&i| (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20);
    let pick = |v: &[[f64; 3]]| -> Vec<[f64; 3]> { idx.iter().map(|&i| v[i]).collect() };
    let species: Vec<u32> = idx.iter().map(|&i| sys.species()[i]).collect();
    let mut out = sys.clone();
    out.set_particles(&species, &pick(sys.positions()), &pick(sys.velocities()))?;
    Ok((out, idx))
}

/// 200 steps (one time unit) of a 256-atom liquid at constant energy, also with a frozen
/// species: the system listed in a shuffled order against the original, positions and
/// velocities within 1e-9 (the sums differ by rounding, 1e-16, grown by the chaotic
/// dynamics), species and forces in the system's order. (A thermostat's noise belongs to
/// the system index, so a shuffled listing is another noise history.)
#[test]
fn the_listing_order_changes_results_only_by_rounding() -> Result<()> {
    let mut frozen = liquid()?;
    frozen.set_frozen(1, true)?;
    for sys in [liquid()?, frozen] {
        let config = Config::default().with_dt(0.005);
        let (mixed, idx) = shuffled(&sys)?;
        let (a, ea) = run(&sys, &config, 200)?;
        let (b, eb) = run(&mixed, &config, 200)?;
        let back = State {
            time: b.time,
            positions: unshuffle(&idx, &b.positions),
            velocities: unshuffle(&idx, &b.velocities),
            angular_velocities: Vec::new(),
            species: unshuffle(&idx, &b.species),
        };
        let d = max_diff(&a, &back);
        eprintln!(
            "shuffled vs plain after 200 steps: {d:.2e}, energy {:.2e}",
            ea - eb
        );
        assert!(d < 1e-9, "{d}");
        assert_abs_diff_eq!(ea, eb, epsilon = 1e-9 * ea.abs());
        assert_eq!(b.species, mixed.species());
        assert_eq!(back.species, sys.species());
        // The forces come back in the system's order too.
        let f = unshuffle(&idx, &Md::new(mixed, &config, Backend::Cpu)?.forces()?);
        let g = Md::new(sys, &config, Backend::Cpu)?.forces()?;
        let df = f
            .iter()
            .flatten()
            .zip(g.iter().flatten())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(df < 1e-12, "{df}");
    }
    Ok(())
}

/// `v` of the shuffled system in the original order.
fn unshuffle<T: Copy + Default>(idx: &[usize], v: &[T]) -> Vec<T> {
    let mut out = vec![T::default(); v.len()];
    for (k, &i) in idx.iter().enumerate() {
        out[i] = v[k];
    }
    out
}

/// A blow-up is rolled back to a state bit-identical to the same run
/// stepped exactly there, and names a particle by its system index.
#[test]
fn a_blow_up_rolls_back_bit_for_bit() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let sys = scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)?;
    let config = Config {
        allow_unstable_dt: true,
        check_every: 10,
        ..Config::default().with_dt(0.03)
    };
    let mut md = Md::new(sys.clone(), &config, Backend::Cpu)?;
    let Err(Error::BlowUp {
        rolled_back_to,
        what,
        ..
    }) = md.step(3000)
    else {
        panic!("dt = 0.03 must blow up")
    };
    assert!(what.contains("particle"), "{what}");
    let mut again = Md::new(sys, &config, Backend::Cpu)?;
    again.step(rolled_back_to as u32)?;
    assert_eq!(again.state()?, md.state()?);
    // The rolled-back run goes on as the fresh one, to the same blow-up if there is one
    // within the next steps.
    let (a, b) = (md.step(2), again.step(2));
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    assert_eq!(again.state()?, md.state()?);
    Ok(())
}
