//! The Langevin thermostat (BAOAB) and frozen species.
//!
//! Statistical checks run with a fixed seed, so they are reproducible; their tolerances are
//! three standard errors from block averaging (10 blocks of the samples), measured values
//! in the comments and in `docs/md.md`.

use approx::abs_diff_eq;
use simkit_backend::testing::backends;
use simkit_backend::{Backend, Result, Simulation};
use simkit_md::{Config, Langevin, LennardJones, Md, PairTable, System, scenes};

/// Mean and standard error of the mean of `x` from `blocks` block averages.
fn block_mean(x: &[f64], blocks: usize) -> (f64, f64) {
    let per = x.len() / blocks;
    let means: Vec<f64> = (0..blocks)
        .map(|b| x[b * per..(b + 1) * per].iter().sum::<f64>() / per as f64)
        .collect();
    let m = means.iter().sum::<f64>() / blocks as f64;
    let var = means.iter().map(|y| (y - m).powi(2)).sum::<f64>() / (blocks - 1) as f64;
    (m, (var / blocks as f64).sqrt())
}

/// Two Lennard-Jones fluids that do not interact with each other (cross `eps = 0`) in one
/// box, 500 atoms at partial densities 0.4: species 0 (mass 1) at the global target `T = 2`,
/// `gamma = 1`; species 1 (mass 2) at its own target `T = 1.5`, `gamma = 2` (both above the
/// critical temperature, about 1.1 for this cutoff, so that no condensation releases heat
/// while the samples are taken). Each species' kinetic temperature, and
/// each axis separately (equipartition per degree of freedom, `<m v_d^2> = T`), must relax
/// to its target within three standard errors.
#[test]
fn kinetic_temperature_relaxes_to_the_target_per_species_and_per_axis() -> Result<()> {
    let mut table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
    table.set(0, 1, LennardJones::new(0.0, 1.0, 2.5))?;
    let mut sys = scenes::fcc_lattice([5; 3], 0.8, 1.44, table, &[0, 1], 4)?;
    let masses = [1.0, 2.0];
    let mut with_mass = System::new(
        sys.dim(),
        sys.lo(),
        sys.lengths(),
        sys.periodic(),
        masses.to_vec(),
        sys.table().clone(),
    )?;
    with_mass.set_particles(sys.species(), sys.positions(), sys.velocities())?;
    sys = with_mass;
    sys.set_species_langevin(1, Some([1.5, 2.0]))?;
    let target = [2.0, 1.5];
    let config = Config {
        thermostat: Some(Langevin::new(2.0, 1.0, 2024)),
        ..Config::default().with_dt(0.005)
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    md.step(1000)?;
    // samples[species][axis]
    let mut samples = vec![vec![Vec::new(); 3]; 2];
    for _ in 0..400 {
        md.step(10)?;
        let s = md.state()?;
        let mut sum = [[0.0f64; 3]; 2];
        let mut count = [0usize; 2];
        for (v, &k) in s.velocities.iter().zip(&s.species) {
            let k = k as usize;
            count[k] += 1;
            for d in 0..3 {
                sum[k][d] += masses[k] * v[d] * v[d];
            }
        }
        for k in 0..2 {
            for d in 0..3 {
                samples[k][d].push(sum[k][d] / count[k] as f64);
            }
        }
    }
    for k in 0..2 {
        let all: Vec<f64> = (0..samples[k][0].len())
            .map(|i| (samples[k][0][i] + samples[k][1][i] + samples[k][2][i]) / 3.0)
            .collect();
        let (m, se) = block_mean(&all, 10);
        eprintln!(
            "species {k}: T = {m:.4} +- {se:.4} (target {}), z = {:.2}",
            target[k],
            (m - target[k]) / se
        );
        assert!(
            abs_diff_eq!(m, target[k], epsilon = 3.0 * se),
            "species {k}: {m} +- {se}"
        );
        for (d, axis) in samples[k].iter().enumerate() {
            let (m, se) = block_mean(axis, 10);
            eprintln!("  axis {d}: <m v^2> = {m:.4} +- {se:.4}");
            assert!(
                (m - target[k]).abs() < 3.0 * se,
                "species {k} axis {d}: {m} +- {se}"
            );
        }
    }
    Ok(())
}

/// Configurational temperature `k T_conf = <sum |F_i|^2> / <sum lap_i U>` (Rugh 1997;
/// Butler, Ayton, Jepps & Evans 1998) of a soft-sphere fluid (`4 (1/r)^12`, cut at 2.5,
/// 256 atoms at density 0.8) under the thermostat at `T = 1`: the positions must be
/// distributed at the target temperature, not only the velocities. The force at the cutoff
/// (`3.8e-4`) biases the estimator by below 1e-3, far under the tolerance.
#[test]
fn configurational_temperature_matches_the_target() -> Result<()> {
    let rc = 2.5;
    let table = PairTable::uniform(1, LennardJones::repulsive(1.0, 1.0, rc))?;
    let sys = scenes::fcc_lattice([4; 3], 0.8, 1.0, table, &[0], 8)?;
    let l = sys.lengths();
    let config = Config {
        thermostat: Some(Langevin::new(1.0, 1.0, 77)),
        ..Config::default().with_dt(0.004)
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    md.step(1000)?;
    let (mut num, mut den) = (Vec::new(), Vec::new());
    for _ in 0..300 {
        md.step(10)?;
        let f2: f64 = md
            .forces()?
            .iter()
            .map(|f| f.iter().map(|x| x * x).sum::<f64>())
            .sum();
        let x = md.state()?.positions;
        let mut lap = 0.0;
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                let mut r2 = 0.0;
                for d in 0..3 {
                    let mut s = x[i][d] - x[j][d];
                    s -= l[d] * (s / l[d]).round();
                    r2 += s * s;
                }
                if r2 < rc * rc {
                    // phi = 4 r^-12: 2 (phi'' + 2 phi' / r) = 2 (156 - 24) 4 r^-14.
                    lap += 2.0 * 132.0 * 4.0 / r2.powi(7);
                }
            }
        }
        num.push(f2);
        den.push(lap);
    }
    // Block ratios of sums.
    let blocks = 10;
    let per = num.len() / blocks;
    let ratios: Vec<f64> = (0..blocks)
        .map(|b| {
            let r = b * per..(b + 1) * per;
            num[r.clone()].iter().sum::<f64>() / den[r].iter().sum::<f64>()
        })
        .collect();
    let (m, se) = block_mean(&ratios, blocks);
    eprintln!("T_conf = {m:.4} +- {se:.4}, z = {:.2}", (m - 1.0) / se);
    assert!(abs_diff_eq!(m, 1.0, epsilon = 3.0 * se), "{m} +- {se}");
    Ok(())
}

/// A mixture with species 1 frozen, with and without the thermostat, on every backend:
/// the frozen particles keep their positions bit for bit and zero velocities.
#[test]
fn frozen_particles_do_not_move_bit_for_bit() -> Result<()> {
    let name = "frozen_particles_do_not_move_bit_for_bit";
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = scenes::fcc_lattice([4; 3], 0.8442, 1.44, table, &[0, 1], 5)?;
    sys.set_frozen(1, true)?;
    for backend in backends(name) {
        for thermostat in [None, Some(Langevin::new(1.0, 1.0, 3))] {
            let config = Config {
                thermostat,
                ..Config::default().with_dt(0.005)
            };
            let mut md = Md::new(sys.clone(), &config, backend)?;
            let x0 = md.state()?.positions;
            md.step(150)?;
            let s = md.state()?;
            let mut moved = 0;
            for (i, &k) in s.species.iter().enumerate() {
                if k == 1 {
                    assert_eq!(s.positions[i], x0[i], "{} particle {i}", md.backend_name());
                    assert_eq!(s.velocities[i], [0.0; 3]);
                } else if s.positions[i] != x0[i] {
                    moved += 1;
                }
            }
            assert!(moved > 100, "{moved}");
        }
    }
    Ok(())
}

/// Total momentum of the mobile particles.
fn mobile_momentum(md: &mut Md, frozen: u32) -> Result<[f64; 3]> {
    let s = md.state()?;
    let mut p = [0.0; 3];
    for (v, &k) in s.velocities.iter().zip(&s.species) {
        if k != frozen {
            for d in 0..3 {
                p[d] += v[d];
            }
        }
    }
    Ok(p)
}

/// Sum of the forces on the mobile particles.
fn mobile_force(md: &mut Md, species: &[u32], frozen: u32) -> Result<[f64; 3]> {
    let mut f = [0.0; 3];
    for (g, &k) in md.forces()?.iter().zip(species) {
        if k != frozen {
            for d in 0..3 {
                f[d] += g[d];
            }
        }
    }
    Ok(f)
}

/// NVE (velocity Verlet, masses 1) with species 1 frozen: over every step the mobile
/// momentum changes by `dt/2 (F_m(t) + F_m(t + dt))`, where `F_m`, the sum of the forces
/// on the mobile particles, equals minus the force the mobile particles exert on the frozen
/// ones (computed by the same system unfrozen at the same positions): only the frozen
/// particles change the mobile momentum. With the mobile–frozen pair switched off the
/// mobile momentum is conserved to rounding.
#[test]
fn mobile_momentum_changes_only_through_forces_from_frozen_particles() -> Result<()> {
    for coupled in [true, false] {
        let mut table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
        if !coupled {
            table.set(0, 1, LennardJones::new(0.0, 1.0, 2.5))?;
        }
        let free = scenes::fcc_lattice([4; 3], 0.8442, 1.0, table, &[0, 1], 6)?;
        let mut sys = free.clone();
        sys.set_frozen(1, true)?;
        let dt = 0.005;
        let mut md = Md::new(sys.clone(), &Config::default().with_dt(dt), Backend::Cpu)?;
        let species = sys.species().to_vec();
        let mut p = mobile_momentum(&mut md, 1)?;
        let mut f = mobile_force(&mut md, &species, 1)?;
        let p_scale = sys.velocities().iter().map(|v| v[0].abs()).sum::<f64>();
        let mut total_f = 0.0f64;
        for step in 0..50 {
            md.step(1)?;
            let p1 = mobile_momentum(&mut md, 1)?;
            let f1 = mobile_force(&mut md, &species, 1)?;
            // Newton's third law through the unfrozen twin at the same state.
            let s = md.state()?;
            let mut twin = free.clone();
            twin.set_particles(&s.species, &s.positions, &s.velocities)?;
            let mut twin_md = Md::new(twin, &Config::default().with_dt(dt), Backend::Cpu)?;
            let on_frozen: [f64; 3] = {
                let mut g = [0.0; 3];
                for (h, &k) in twin_md.forces()?.iter().zip(&species) {
                    if k == 1 {
                        for d in 0..3 {
                            g[d] += h[d];
                        }
                    }
                }
                g
            };
            let f_scale = twin_md.forces()?.iter().map(|h| h[0].abs()).sum::<f64>();
            for d in 0..3 {
                let dp = p1[d] - p[d];
                let want = 0.5 * dt * (f[d] + f1[d]);
                assert!(
                    (dp - want).abs() < 1e-12 * p_scale.max(1.0),
                    "step {step} axis {d}: dp {dp}, forces give {want}"
                );
                assert!(
                    (f1[d] + on_frozen[d]).abs() < 1e-12 * f_scale,
                    "step {step} axis {d}: {} vs {}",
                    f1[d],
                    on_frozen[d]
                );
                total_f = total_f.max(f1[d].abs());
            }
            p = p1;
            f = f1;
        }
        if coupled {
            assert!(
                total_f > 1e-3,
                "the frozen particles exert a force: {total_f}"
            );
        } else {
            assert!(total_f < 1e-10, "{total_f}");
        }
    }
    Ok(())
}

/// Bad thermostat settings and species indices are refused with a clear error, on every
/// backend alike (the settings are checked before any backend is built).
#[test]
fn bad_thermostat_settings_and_species_are_refused() -> Result<()> {
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5))?;
    let mut sys = scenes::fcc_lattice([3; 3], 0.5, 1.0, table, &[0, 1], 1)?;
    for bad in [f64::NAN, -1.0, f64::INFINITY, 1e31] {
        for l in [Langevin::new(bad, 1.0, 0), Langevin::new(1.0, bad, 0)] {
            let config = Config {
                thermostat: Some(l),
                ..Config::default()
            };
            let e = Md::new(sys.clone(), &config, Backend::Cpu).err().unwrap();
            assert!(e.to_string().contains("thermostat"), "{e}");
        }
        assert!(sys.set_species_langevin(0, Some([bad, 1.0])).is_err());
        assert!(sys.set_species_langevin(1, Some([1.0, bad])).is_err());
    }
    assert!(sys.set_frozen(2, true).is_err());
    assert!(sys.set_species_langevin(2, None).is_err());
    assert_eq!(sys.frozen(), &[false, false]);
    assert_eq!(sys.species_langevin(), &[None, None]);
    // Everything frozen and a zero-temperature target are fine.
    sys.set_frozen(0, true)?;
    sys.set_frozen(1, true)?;
    let config = Config {
        thermostat: Some(Langevin::new(0.0, 1.0, 0)),
        ..Config::default()
    };
    let mut md = Md::new(sys, &config, Backend::Cpu)?;
    let x0 = md.state()?.positions;
    md.step(10)?;
    assert_eq!(md.state()?.positions, x0);
    Ok(())
}
