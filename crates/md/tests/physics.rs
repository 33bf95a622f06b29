//! Physics checks: second-order energy conservation of both integrators (Lennard-Jones and
//! Morse), reflecting walls,
//! the Verlet-list skin (results the same to rounding), the CPU's independence of the
//! thread count, 2D, the energy shift.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use simkit_backend::{Backend, Precision, Result, Simulation};
use simkit_md::{
    Config, Dim, Integrator, LennardJones, Md, Morse, PairLaw, PairTable, System, scenes,
};

/// A 32-atom Lennard-Jones cluster (2^3 FCC cells at density 1, T = 0.5) in the middle of
/// a closed box of 30, with a cutoff (12) longer than the cluster: no pair ever crosses the
/// cutoff, so the energy is smooth and the integrator error is all there is.
fn cluster() -> Result<System> {
    cluster_of(PairTable::uniform(1, LennardJones::new(1.0, 1.0, 12.0))?)
}

/// The atoms of [`cluster`] with pair table `table` (every cutoff beyond the cluster).
fn cluster_of<L: PairLaw>(table: PairTable<L>) -> Result<System<L>> {
    let lattice = scenes::fcc_lattice(
        [2; 3],
        1.0,
        0.5,
        PairTable::uniform(1, LennardJones::new(1.0, 1.0, 1.0))?,
        &[0],
        3,
    )?;
    let mut sys = System::new(
        Dim::Three,
        [0.0; 3],
        [30.0; 3],
        [false; 3],
        vec![1.0],
        table,
    )?;
    let pos: Vec<[f64; 3]> = lattice
        .positions()
        .iter()
        .map(|p| p.map(|x| x + 14.0))
        .collect();
    sys.set_particles(lattice.species(), &pos, lattice.velocities())?;
    Ok(sys)
}

/// Largest |E(t) - E(0)| over `t = 0.04 k`, `t <= 1`, at time step `dt`.
fn energy_error<L: PairLaw>(sys: &System<L>, integrator: Integrator, dt: f64) -> Result<f64> {
    let config = Config {
        integrator,
        ..Config::default().with_dt(dt)
    };
    let mut md = Md::new(sys.clone(), &config, Backend::Cpu)?;
    let e0 = md.diagnostics()?.total;
    let per_sample = (0.04 / dt).round() as u32;
    let mut worst = 0.0f64;
    for _ in 0..25 {
        md.step(per_sample)?;
        let e = md.diagnostics()?.total;
        assert!(e.is_finite());
        worst = worst.max((e - e0).abs());
    }
    Ok(worst)
}

#[test]
fn energy_error_is_second_order_in_dt_for_both_integrators() -> Result<()> {
    let sys = cluster()?;
    for integrator in [Integrator::VelocityVerlet, Integrator::Leapfrog] {
        let coarse = energy_error(&sys, integrator, 0.004)?;
        let fine = energy_error(&sys, integrator, 0.001)?;
        let order = (coarse / fine).ln() / 4f64.ln();
        eprintln!(
            "{integrator:?}: |dE| {coarse:.3e} at dt 0.004, {fine:.3e} at dt 0.001: order {order:.3}"
        );
        assert!(
            (1.8..=2.2).contains(&order),
            "{integrator:?}: order {order}"
        );
    }
    Ok(())
}

/// The same with the Morse law (a well of depth 1 at the lattice's neighbour distance,
/// alpha = 3): the integrator's order does not depend on the law.
#[test]
fn energy_error_is_second_order_in_dt_with_the_morse_law() -> Result<()> {
    let sys = cluster_of(PairTable::uniform(1, Morse::new(1.0, 3.0, 1.12, 12.0))?)?;
    let coarse = energy_error(&sys, Integrator::VelocityVerlet, 0.004)?;
    let fine = energy_error(&sys, Integrator::VelocityVerlet, 0.001)?;
    let order = (coarse / fine).ln() / 4f64.ln();
    eprintln!("Morse: |dE| {coarse:.3e} at dt 0.004, {fine:.3e} at dt 0.001: order {order:.3}");
    assert!((1.8..=2.2).contains(&order), "order {order}");
    Ok(())
}

#[test]
fn the_two_integrators_follow_the_same_trajectory() -> Result<()> {
    // Leapfrog with fused kicks is velocity Verlet up to rounding.
    let sys = cluster()?;
    let run = |integrator| -> Result<simkit_md::State> {
        let config = Config {
            integrator,
            ..Config::default().with_dt(0.002)
        };
        let mut md = Md::new(sys.clone(), &config, Backend::Cpu)?;
        md.step(300)?;
        md.state()
    };
    let (a, b) = (run(Integrator::VelocityVerlet)?, run(Integrator::Leapfrog)?);
    for (x, y) in a.positions.iter().zip(&b.positions) {
        for d in 0..3 {
            assert!(abs_diff_eq!(x[d], y[d], epsilon = 1e-9), "{x:?} {y:?}");
        }
    }
    for (x, y) in a.velocities.iter().zip(&b.velocities) {
        for d in 0..3 {
            assert!(abs_diff_eq!(x[d], y[d], epsilon = 1e-9), "{x:?} {y:?}");
        }
    }
    Ok(())
}

#[test]
fn a_particle_reflects_off_a_closed_wall_with_its_speed() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(
        Dim::Three,
        [0.0; 3],
        [10.0; 3],
        [false, true, true],
        vec![1.0],
        table,
    )?;
    sys.add_particle(0, [9.0, 5.0, 5.0], [2.0, 0.5, 0.0])?;
    let mut md = Md::new(sys, &Config::default().with_dt(0.01), Backend::Cpu)?;
    md.step(100)?; // 2 units of travel along x: 1 to the wall at x = 10, 1 back
    let s = md.state()?;
    assert!(
        (s.positions[0][0] - 9.0).abs() < 1e-12,
        "{:?}",
        s.positions[0]
    );
    assert_eq!(s.velocities[0], [-2.0, 0.5, 0.0]);
    // Periodic y: 5 + 0.5 * 1 = 5.5.
    assert_abs_diff_eq!(s.positions[0][1], 5.5, epsilon = 1e-12);
    Ok(())
}

#[test]
fn periodic_wrap_and_skin_change_the_trajectory_by_rounding_only() -> Result<()> {
    // The list skin decides when the list is rebuilt, and a rebuild sorts the particles by
    // cell, which changes the order of the force sums: every skin gives the same trajectory
    // to rounding (1e-16 per step, grown by the chaotic dynamics over 200 steps).
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let sys = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0], 11)?;
    let run = |skin| -> Result<simkit_md::State> {
        let config = Config {
            skin,
            ..Config::default().with_dt(0.005)
        };
        let mut md = Md::new(sys.clone(), &config, Backend::Cpu)?;
        md.step(200)?;
        md.state()
    };
    let a = run(0.0)?;
    for skin in [0.3, 1.0] {
        let b = run(skin)?;
        let d = a
            .positions
            .iter()
            .chain(&a.velocities)
            .flatten()
            .zip(b.positions.iter().chain(&b.velocities).flatten())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(d < 1e-9, "skin {skin}: {d:e}");
        assert_ne!(a, b, "skin {skin}: the sums ran in the same order");
        assert_eq!(b, run(skin)?, "skin {skin}: not reproducible");
    }
    // Atoms crossed the periodic faces and stayed in the box.
    let len = sys.lengths()[0];
    assert!(
        a.positions
            .iter()
            .flatten()
            .all(|&x| (0.0..len).contains(&x))
    );
    Ok(())
}

#[test]
fn cpu_results_do_not_depend_on_the_thread_count() -> Result<()> {
    // 864 atoms of two species: four blocks of the half list, whose reactions cross block
    // boundaries; the same bits on 1, 2 and 3 threads, in both precisions.
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
    let sys = scenes::fcc_lattice([6; 3], 0.8442, 1.44, table, &[0, 1], 5)?;
    for precision in [Precision::F64, Precision::F32] {
        let config = Config {
            precision,
            ..Config::default().with_dt(0.005)
        };
        let run = |threads| -> Result<(simkit_md::State, Vec<[f64; 3]>, f64)> {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| simkit_backend::Error::Unsupported(e.to_string()))?;
            pool.install(|| {
                let mut md = Md::new(sys.clone(), &config, Backend::Cpu)?;
                md.step(60)?;
                Ok((md.state()?, md.forces()?, md.diagnostics()?.total))
            })
        };
        let one = run(1)?;
        for threads in [2, 3] {
            let other = run(threads)?;
            assert_eq!(one.0, other.0, "{precision:?}, {threads} threads");
            assert_eq!(one.1, other.1, "{precision:?}, {threads} threads");
            assert_eq!(
                one.2.to_bits(),
                other.2.to_bits(),
                "{precision:?}, {threads} threads"
            );
        }
    }
    Ok(())
}

#[test]
fn two_dimensional_runs_conserve_energy_and_momentum() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(
        Dim::Two,
        [0.0; 3],
        [12.0, 12.0, 0.0],
        [true, true, false],
        vec![1.0],
        table,
    )?;
    let mut k = 0u32;
    for i in 0..10 {
        for j in 0..10 {
            k += 1;
            let v = [
                ((k * 37) % 11) as f64 / 11.0 - 0.5,
                ((k * 53) % 7) as f64 / 7.0 - 0.5,
                0.0,
            ];
            sys.add_particle(0, [0.6 + 1.2 * i as f64, 0.6 + 1.2 * j as f64, 0.0], v)?;
        }
    }
    let config = Config {
        shift: true,
        ..Config::default().with_dt(0.002)
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    let d0 = md.diagnostics()?;
    let p0: [f64; 2] =
        std::array::from_fn(|d| md.state().unwrap().velocities.iter().map(|v| v[d]).sum());
    md.step(500)?;
    let d1 = md.diagnostics()?;
    let s = md.state()?;
    let p1: [f64; 2] = std::array::from_fn(|d| s.velocities.iter().map(|v| v[d]).sum());
    assert!(s.positions.iter().all(|p| p[2] == 0.0));
    assert!(
        (d1.total - d0.total).abs() < 2e-3 * d0.kinetic,
        "{d0:?} {d1:?}"
    );
    for d in 0..2 {
        assert!(abs_diff_eq!(p1[d], p0[d], epsilon = 1e-10), "{p0:?} {p1:?}");
    }
    // The 2D virial pressure uses D = 2.
    let want = (2.0 * d1.kinetic + d1.virial) / (2.0 * 144.0);
    assert_abs_diff_eq!(d1.pressure, want, epsilon = 1e-12 * want.abs().max(1.0));
    Ok(())
}

#[test]
fn the_shift_moves_the_energy_by_phi_at_the_cutoff_per_pair() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = System::new(Dim::Three, [0.0; 3], [10.0; 3], [true; 3], vec![1.0], table)?;
    sys.add_particle(0, [1.0, 1.0, 1.0], [0.0; 3])?;
    sys.add_particle(0, [2.2, 1.0, 1.0], [0.0; 3])?;
    let pe = |shift| -> Result<f64> {
        let config = Config {
            shift,
            ..Config::default()
        };
        Md::new(sys.clone(), &config, Backend::Cpu)?
            .diagnostics()
            .map(|d| d.potential)
    };
    let phi = LennardJones::new(1.0, 1.0, 2.5);
    let (plain, shifted) = (pe(false)?, pe(true)?);
    assert_abs_diff_eq!(plain, phi.energy(1.2), epsilon = 1e-14);
    assert!((plain - shifted - phi.energy(2.5)).abs() < 1e-14);
    Ok(())
}

#[test]
fn species_temperatures_and_default_dt() -> Result<()> {
    let sys = scenes::three_phase_mix([6; 3], 0.4, 1.0, 5)?;
    let md = Md::new(sys.clone(), &Config::default(), Backend::Cpu)?;
    // The stiffest pair is gas-gas (sigma 0.5, purely repulsive, reduced mass 1/2).
    let g = simkit_md::time_step_guide(&sys).unwrap();
    assert_eq!(g.pair, (0, 0));
    let k = LennardJones::repulsive(1.0, 0.5, 2.0).curvature(0.5);
    let period = 2.0 * std::f64::consts::PI * (0.5 / k).sqrt();
    assert_abs_diff_eq!(g.period, period, epsilon = 1e-15);
    assert_eq!(md.dt(), period / simkit_md::DEFAULT_STEPS_PER_PERIOD);
    let mut md = md;
    let d = md.diagnostics()?;
    let mean: f64 = d.species_temperature.iter().sum::<f64>() / 3.0;
    // Drawn at T = 1 with 3N - 3 degrees of freedom; each species within sampling noise.
    for t in &d.species_temperature {
        assert!(
            abs_diff_eq!(*t, 1.0, epsilon = 0.15),
            "{:?}",
            d.species_temperature
        );
    }
    assert_abs_diff_eq!(mean, 1.0, epsilon = 0.05);
    Ok(())
}

#[test]
fn the_lj_melt_scene_is_lammps_in_lj() -> Result<()> {
    let sys = scenes::lj_melt()?;
    assert_eq!(sys.particle_count(), 32_000);
    let len = sys.lengths();
    // 20 cells of (4 / 0.8442)^(1/3) = 1.6796: a box of 33.592.
    assert_abs_diff_eq!(len[0], 20.0 * (4.0f64 / 0.8442).cbrt(), epsilon = 1e-12);
    assert_abs_diff_eq!(
        sys.particle_count() as f64 / sys.volume(),
        0.8442,
        epsilon = 1e-12
    );
    let mut md = Md::new(sys, &Config::default().with_dt(0.005), Backend::Cpu)?;
    let d = md.diagnostics()?;
    // T = 2 K / (3N - 3) = 1.44 exactly as drawn. Step 0 of LAMMPS's bench/in.lj (29 Sep
    // 2021, `thermo_modify format float %.10g`, `run 0`): E_pair = -6.773368053,
    // Press = -5.019707259 (the pressure depends on the velocities only through T).
    let t = 2.0 * d.kinetic / (3.0 * 32_000.0 - 3.0);
    assert!(abs_diff_eq!(t, 1.44, epsilon = 1e-12), "{t}");
    eprintln!("U/N = {:.9}, P = {:.9}", d.potential / 32e3, d.pressure);
    assert!((d.potential / 32_000.0 + 6.773368053).abs() < 1e-9);
    assert!((d.pressure + 5.019707259).abs() < 1e-9);
    Ok(())
}
