//! Every backend against the CPU in f32 (the GPU computes in f32): forces, energies and a
//! short trajectory, in 3D periodic (velocity Verlet, three species) and 2D with reflecting
//! walls (leapfrog), and every built-in pair law in 3D. The GPU runs each case with both
//! force kernels (`GpuKernel`).
//!
//! Tolerances: forces within 1e-5 of the largest force (the sums run in another order,
//! each pair term carries a few f32 ulps, and the steep core amplifies the rounding of the
//! separations, which the GPU computes in f32 and the CPU in f64 before rounding); energies
//! and virial 1e-5 relative; positions after 40 steps within 1e-5 (rounding differences
//! grow along the chaotic trajectory, but only by a few times in 0.2 time units). Measured
//! on lavapipe: forces 4.7e-7, positions 4.8e-7 (3D); 1.2e-7 and 6e-8 (2D); the other
//! built-in laws forces 8.6e-8 to 1.1e-6, positions 5.4e-7 to 1.4e-6.

use simkit_backend::testing::{backends, max_rel_diff};
use simkit_backend::{Backend, Precision, Result, Simulation};
use simkit_md::{
    Buckingham, Config, Dim, GpuKernel, Integrator, Langevin, LennardJones, Md, Mie, Morse,
    PairLaw, PairTable, System, Wca, Yukawa, scenes,
};

fn cpu_f32(config: &Config) -> Config {
    Config {
        precision: Precision::F32,
        ..*config
    }
}

fn walls_2d() -> System {
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let mut sys = System::new(
        Dim::Two,
        [0.0; 3],
        [12.0, 9.0, 0.0],
        [false, true, false],
        vec![1.0, 3.0],
        table,
    )
    .unwrap();
    for i in 0..9 {
        for j in 0..7 {
            let v = [
                0.7 * (i as f64 - 4.0) / 4.0,
                0.5 * ((i + j) % 3) as f64 - 0.5,
                0.0,
            ];
            sys.add_particle(
                (i + j) % 2,
                [0.6 + 1.25 * i as f64, 0.6 + 1.2 * j as f64, 0.0],
                v,
            )
            .unwrap();
        }
    }
    sys
}

fn compare<L: PairLaw>(name: &str, sys: &System<L>, config: &Config) -> Result<()> {
    let mut reference = Md::new(sys.clone(), &cpu_f32(config), Backend::Cpu)?;
    let f_ref: Vec<f64> = reference.forces()?.into_iter().flatten().collect();
    let d_ref = reference.diagnostics()?;
    reference.step(40)?;
    let s_ref = reference.state()?;
    let d_ref_end = reference.diagnostics()?;
    let runs = backends(name).into_iter().flat_map(|backend| {
        let kernels = if backend.is_gpu() {
            vec![GpuKernel::PerParticle, GpuKernel::cell_block()]
        } else {
            vec![config.gpu_kernel]
        };
        kernels.into_iter().map(move |k| (backend, k))
    });
    for (backend, gpu_kernel) in runs {
        // The GPU computes in f32 whatever the precision; the CPU is asked for f32 too.
        let config = Config {
            gpu_kernel,
            ..*config
        };
        let mut md = Md::new(sys.clone(), &cpu_f32(&config), backend)?;
        let f: Vec<f64> = md.forces()?.into_iter().flatten().collect();
        let d = md.diagnostics()?;
        let ef = max_rel_diff(&f, &f_ref, &f_ref);
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-30);
        md.step(40)?;
        let s = md.state()?;
        let d_end = md.diagnostics()?;
        let x: Vec<f64> = s.positions.iter().flatten().copied().collect();
        let x_ref: Vec<f64> = s_ref.positions.iter().flatten().copied().collect();
        let dx = x
            .iter()
            .zip(&x_ref)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        eprintln!(
            "{name} on {}: forces {ef:.2e}, pe {:.2e}, virial {:.2e}, positions after 40 \
             steps {dx:.2e}, total energy after 40 steps {:.2e}",
            md.backend_name(),
            rel(d.potential, d_ref.potential),
            rel(d.virial, d_ref.virial),
            rel(d_end.total, d_ref_end.total)
        );
        assert!(ef < 1e-5, "{ef}");
        assert!(rel(d.potential, d_ref.potential) < 1e-5);
        assert!(rel(d.virial, d_ref.virial) < 1e-5);
        assert!(dx < 1e-5, "{dx}");
        assert!(rel(d_end.total, d_ref_end.total) < 1e-4);
        assert_eq!(md.steps_done(), 40);
        assert_eq!(s.time, s_ref.time);
    }
    Ok(())
}

#[test]
fn three_species_periodic_agrees_with_the_cpu() -> Result<()> {
    let sys = scenes::three_phase_mix([6; 3], 0.4, 1.0, 21)?;
    compare(
        "three_species_periodic_agrees_with_the_cpu",
        &sys,
        &Config::default(),
    )
}

#[test]
fn two_dimensional_walls_and_leapfrog_agree_with_the_cpu() -> Result<()> {
    let config = Config {
        integrator: Integrator::Leapfrog,
        shift: true,
        ..Config::default().with_dt(0.004)
    };
    compare(
        "two_dimensional_walls_and_leapfrog_agree_with_the_cpu",
        &walls_2d(),
        &config,
    )
}

/// The Langevin thermostat draws the same random numbers on every backend (counter-based,
/// keyed by seed, step and particle), so a thermostatted run with a frozen species agrees
/// with the CPU to f32 rounding (Box–Muller in f64 on the CPU, in f32 on the GPU).
#[test]
fn thermostat_and_frozen_species_agree_with_the_cpu() -> Result<()> {
    let mut sys = scenes::three_phase_mix([6; 3], 0.4, 1.0, 21)?;
    sys.set_frozen(scenes::SOLID, true)?;
    sys.set_species_langevin(scenes::GAS, Some([2.0, 5.0]))?;
    let config = Config {
        thermostat: Some(Langevin::new(0.8, 1.0, 12345)),
        ..Config::default()
    };
    compare(
        "thermostat_and_frozen_species_agree_with_the_cpu",
        &sys,
        &config,
    )
}

#[test]
fn thermostat_in_two_dimensions_with_leapfrog_agrees_with_the_cpu() -> Result<()> {
    let config = Config {
        integrator: Integrator::Leapfrog,
        shift: true,
        thermostat: Some(Langevin::new(0.5, 2.0, 7)),
        ..Config::default().with_dt(0.004)
    };
    compare(
        "thermostat_in_two_dimensions_with_leapfrog_agrees_with_the_cpu",
        &walls_2d(),
        &config,
    )
}

/// A 256-atom liquid of `table` (FCC 4^3 at density 0.8442, T = 1, each atom displaced
/// by up to 0.1 per axis so that the forces do not cancel) with species drawn from
/// `species`.
fn liquid<L: PairLaw>(table: PairTable<L>, species: &[u32]) -> Result<System<L>> {
    let mut sys = scenes::fcc_lattice([4; 3], 0.8442, 1.0, table, species, 3)?;
    let u = |k: usize, a: u32| f64::from(simkit_backend::rng::rng_uniform(9, a, k as u32));
    let len = sys.lengths();
    let pos: Vec<[f64; 3]> = sys
        .positions()
        .iter()
        .enumerate()
        .map(|(k, x)| {
            std::array::from_fn(|d| (x[d] + 0.2 * (u(k, d as u32) - 0.5)).rem_euclid(len[d]))
        })
        .collect();
    let (kinds, vel) = (sys.species().to_vec(), sys.velocities().to_vec());
    sys.set_particles(&kinds, &pos, &vel)?;
    Ok(sys)
}

/// [`liquid`] of one species with law `law` against the CPU in f32 on every backend.
fn law_liquid<L: PairLaw>(name: &str, law: L, config: &Config) -> Result<()> {
    compare(name, &liquid(PairTable::uniform(1, law)?, &[0])?, config)
}

#[test]
fn every_built_in_law_agrees_with_the_cpu() -> Result<()> {
    let name = "every_built_in_law_agrees_with_the_cpu";
    let dt = Config::default().with_dt(0.002);
    // Morse with two species (the table holds any law).
    let mut t = PairTable::uniform(2, Morse::new(1.0, 4.0, 1.1, 2.5))?;
    t.set(0, 1, Morse::new(0.8, 3.5, 1.15, 2.4))?;
    compare(name, &liquid(t, &[0, 1])?, &Config::default())?;
    law_liquid(name, Mie::new(1.0, 1.0, 14.0, 7.0, 2.5), &Config::default())?;
    let shifted = Config { shift: true, ..dt };
    law_liquid(name, Yukawa::new(12.0, 2.0, 2.5), &shifted)?;
    law_liquid(name, Buckingham::new(2000.0, 0.2, 1.5, 2.5), &dt)?;
    law_liquid(name, Wca::new(1.0, 1.0), &Config::default())
}
