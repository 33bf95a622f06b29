//! The two GPU force kernels (`GpuKernel`): the cell-block kernel against the per-particle
//! one along a trajectory, reproducibility, its capacity and jump errors, bit-exact restart
//! and the blow-up guard. (Both against the CPU: tests/conformance.rs.) GPU only: without
//! an adapter these tests do nothing (with `SIMKIT_REQUIRE_GPU=1` they fail instead).

use simkit_backend::testing::{backends, check_restart, test_path};
use simkit_backend::{Backend, Error, Result, Simulation};
use simkit_md::{
    Config, Dim, GpuKernel, Integrator, Langevin, LennardJones, Md, PairTable, State, System,
    scenes,
};

fn gpus(test: &str) -> Vec<Backend<'static>> {
    backends(test).into_iter().filter(|b| b.is_gpu()).collect()
}

fn with(kernel: GpuKernel, config: Config) -> Config {
    Config {
        gpu_kernel: kernel,
        ..config
    }
}

/// The Lennard-Jones liquid of in.lj, 4 x 6^3 = 864 atoms (4 cells per axis).
fn liquid() -> System {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    scenes::fcc_lattice([6; 3], 0.8442, 1.44, table, &[0], 7).unwrap()
}

/// 256 atoms of the liquid in a box closed on every face (reflecting walls).
fn closed_box() -> System {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let open = scenes::fcc_lattice([4; 3], 0.7, 1.0, table.clone(), &[0], 3).unwrap();
    let (lo, len) = (open.lo(), open.lengths());
    let mut sys = System::new(
        Dim::Three,
        [0.0; 3],
        [len[0] + 1.0, len[1] + 1.0, len[2] + 1.0],
        [false; 3],
        vec![1.0],
        table,
    )
    .unwrap();
    for (x, v) in open.positions().iter().zip(open.velocities()) {
        let at: [f64; 3] = std::array::from_fn(|d| x[d] - lo[d] + 0.5);
        sys.add_particle(0, at, *v).unwrap();
    }
    sys
}

/// Two species in a 2D box with reflecting walls along x and a periodic y.
fn walls_2d() -> System {
    let table = PairTable::uniform(2, LennardJones::new(1.0, 1.0, 2.5)).unwrap();
    let mut sys = System::new(
        Dim::Two,
        [0.0; 3],
        [14.0, 11.0, 0.0],
        [false, true, false],
        vec![1.0, 2.0],
        table,
    )
    .unwrap();
    for i in 0..11 {
        for j in 0..9 {
            let v = [
                0.6 * (i as f64 - 5.0) / 5.0,
                0.4 * ((i + j) % 3) as f64 - 0.4,
                0.0,
            ];
            sys.add_particle(
                (i + j) % 2,
                [0.6 + 1.2 * i as f64, 0.6 + 1.2 * j as f64, 0.0],
                v,
            )
            .unwrap();
        }
    }
    sys
}

/// Largest coordinate difference of two states.
fn max_dx(a: &State, b: &State) -> f64 {
    a.positions
        .iter()
        .flatten()
        .zip(b.positions.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Both kernels sum the same pairs in the same cell and slot order; they can differ only in
/// how a shader compiler fuses the f32 arithmetic, which would part the trajectories by
/// rounding, growing along the chaotic trajectory. Measured on lavapipe: bit-identical
/// (differences 0 after 100 steps in all four cases); the tolerances leave room for other
/// compilers.
#[test]
fn cell_block_follows_the_per_particle_kernel() -> Result<()> {
    let name = "cell_block_follows_the_per_particle_kernel";
    let cases = [
        (
            "3D liquid, velocity Verlet",
            liquid(),
            Config::default().with_dt(0.005),
        ),
        (
            "3D closed box, velocity Verlet",
            closed_box(),
            Config::default().with_dt(0.005),
        ),
        (
            "3D three-phase mix, three species",
            scenes::three_phase_mix([6; 3], 0.4, 1.0, 21)?,
            Config::default(),
        ),
        (
            "2D walls, leapfrog, shifted",
            walls_2d(),
            Config {
                integrator: Integrator::Leapfrog,
                shift: true,
                ..Config::default().with_dt(0.004)
            },
        ),
    ];
    for backend in gpus(name) {
        for (label, sys, config) in &cases {
            let mut a = Md::new(sys.clone(), &with(GpuKernel::PerParticle, *config), backend)?;
            let mut b = Md::new(
                sys.clone(),
                &with(GpuKernel::cell_block(), *config),
                backend,
            )?;
            let fa: Vec<f64> = a.forces()?.into_iter().flatten().collect();
            let fb: Vec<f64> = b.forces()?.into_iter().flatten().collect();
            let ef = simkit_backend::testing::max_rel_diff(&fb, &fa, &fa);
            let mut dx = Vec::new();
            for chunk in [1, 4, 15, 30, 50] {
                a.step(chunk)?;
                b.step(chunk)?;
                dx.push((a.steps_done(), max_dx(&a.state()?, &b.state()?)));
            }
            let (da, db) = (a.diagnostics()?, b.diagnostics()?);
            let de = (da.total - db.total).abs() / da.total.abs();
            eprintln!(
                "{label} on {}: forces {ef:.2e}, positions {dx:?}, energy after 100 steps {de:.2e}",
                b.backend_name()
            );
            assert!(ef < 1e-6, "{label}: forces {ef}");
            // After 10 steps the difference is still rounding of the separations.
            assert!(dx[1].1 < 1e-5, "{label}: {dx:?}");
            assert!(dx[4].1 < 1e-2, "{label}: {dx:?}");
            assert!(de < 1e-4, "{label}: energy {de}");
        }
    }
    Ok(())
}

/// Same inputs, same bits: the slot lists and the summation order are deterministic.
#[test]
fn cell_block_runs_are_reproducible() -> Result<()> {
    let config = with(GpuKernel::cell_block(), Config::default().with_dt(0.005));
    for backend in gpus("cell_block_runs_are_reproducible") {
        let run = || -> Result<State> {
            let mut md = Md::new(liquid(), &config, backend)?;
            md.step(70)?;
            md.step(30)?;
            md.state()
        };
        assert_eq!(run()?, run()?);
    }
    Ok(())
}

/// Non-interacting particles (eps = 0, cutoff 2.5) in a periodic cube of side `side`.
fn free_particles(side: f64, at: &[([f64; 3], [f64; 3])]) -> System {
    let table = PairTable::uniform(1, LennardJones::new(0.0, 1.0, 2.5)).unwrap();
    let mut sys =
        System::new(Dim::Three, [0.0; 3], [side; 3], [true; 3], vec![1.0], table).unwrap();
    for (x, v) in at {
        sys.add_particle(0, *x, *v).unwrap();
    }
    sys
}

/// Eight particles, one per cell of a 2 x 2 x 2 block, flying towards (3.75, 3.75, 3.75):
/// in the side-10 box the grid has 3 cells per axis (10/3 wide: it keeps a margin over the
/// cutoff), so all eight gather in cell (1, 1, 1) at t = 1.08 (step 54), which has 2 slots:
/// an error naming the capacity, rolled back to the check at step 50.
#[test]
fn a_full_cell_is_an_error_not_a_lost_particle() -> Result<()> {
    let mut at = Vec::new();
    for k in 0..8 {
        let o = |b: usize| if k >> b & 1 == 1 { 1.0 } else { -1.0 };
        let x = [3.75 + 1.5 * o(0), 3.75 + 1.5 * o(1), 3.75 + 1.5 * o(2)];
        at.push((x, [-o(0), -o(1), -o(2)]));
    }
    let sys = free_particles(10.0, &at);
    let config = Config {
        check_every: 10,
        ..with(
            GpuKernel::CellBlock { slots: Some(2) },
            Config::default().with_dt(0.02),
        )
    };
    for backend in gpus("a_full_cell_is_an_error_not_a_lost_particle") {
        let mut md = Md::new(sys.clone(), &config, backend)?;
        let e = md.step(60).expect_err("8 particles in a cell of 2 slots");
        eprintln!("{e}");
        let text = e.to_string();
        assert!(matches!(e, Error::InvalidParameter { .. }), "{e}");
        assert!(text.contains("slots") && text.contains('2'), "{e}");
        assert!(text.contains("PerParticle"), "{e}");
        let back = md.steps_done();
        assert_eq!(back, 50);
        // The state is the one of a run stepped exactly there.
        let mut again = Md::new(sys.clone(), &config, backend)?;
        again.step(back as u32)?;
        assert_eq!(again.state()?, md.state()?);
        // Fewer slots than the fullest initial cell are refused at once.
        let two_in_one = free_particles(10.0, &[([1.0; 3], [0.0; 3]), ([2.0; 3], [0.0; 3])]);
        let cfg = with(
            GpuKernel::CellBlock { slots: Some(1) },
            Config::default().with_dt(0.02),
        );
        let e = Md::new(two_in_one.clone(), &cfg, backend)
            .err()
            .expect("1 slot, 2 particles");
        assert!(e.to_string().contains("fullest cell"), "{e}");
        let cfg = with(
            GpuKernel::CellBlock { slots: Some(0) },
            Config::default().with_dt(0.02),
        );
        assert!(Md::new(two_in_one, &cfg, backend).is_err());
        // The per-particle kernel has no capacity.
        let mut pp = Md::new(sys.clone(), &with(GpuKernel::PerParticle, config), backend)?;
        pp.step(60)?;
    }
    Ok(())
}

/// A particle crossing more than one cell per step (but less than a box length; 11 cells
/// 2.73 wide per axis) would escape the local update: a blow-up, rolled back.
#[test]
fn a_particle_jumping_over_a_cell_is_a_blow_up() -> Result<()> {
    let sys = free_particles(
        30.0,
        &[
            ([1.0, 5.0, 5.0], [300.0, 0.0, 0.0]),
            ([5.0, 20.0, 5.0], [0.0; 3]),
        ],
    );
    let config = Config {
        check_every: 5,
        ..with(GpuKernel::cell_block(), Config::default().with_dt(0.02))
    };
    for backend in gpus("a_particle_jumping_over_a_cell_is_a_blow_up") {
        let mut md = Md::new(sys.clone(), &config, backend)?;
        let e = md
            .step(20)
            .expect_err("6 length units per step, cells 2.5 wide");
        eprintln!("{e}");
        assert!(
            matches!(e, Error::BlowUp { rolled_back_to: 0, ref what, .. } if what.contains("cell")),
            "{e}"
        );
        assert_eq!(md.steps_done(), 0);
    }
    Ok(())
}

/// A labelled scene and its settings.
type Case = (&'static str, fn() -> System, Config);

fn mix() -> System {
    let mut sys = scenes::three_phase_mix([6; 3], 0.4, 1.0, 9).unwrap();
    sys.set_frozen(scenes::SOLID, true).unwrap();
    sys
}

#[test]
fn cell_block_restart_is_bit_exact() {
    let name = &test_path(module_path!(), "cell_block_restart_is_bit_exact");
    let cb = GpuKernel::cell_block();
    let cases: [Case; 3] = [
        (
            "3D liquid, cell block, velocity Verlet",
            liquid,
            Config {
                check_every: 7,
                ..with(cb, Config::default().with_dt(0.005))
            },
        ),
        (
            "3D mix with a frozen solid, cell block, Langevin",
            mix,
            Config {
                thermostat: Some(Langevin::new(0.9, 1.0, 99)),
                ..with(cb, Config::default())
            },
        ),
        (
            "2D walls, cell block, leapfrog (odd step count)",
            walls_2d,
            Config {
                integrator: Integrator::Leapfrog,
                ..with(cb, Config::default().with_dt(0.004))
            },
        ),
    ];
    for backend in gpus(name) {
        for (label, system, config) in cases {
            let steps = if label.contains("odd") { 37 } else { 60 };
            check_restart(name, label, backend, steps, |b| {
                Md::new(system(), &config, b)
            });
        }
    }
}

/// Above the time-step bound the liquid blows up; the run is rolled back to the last good
/// check, the slot lists are rebuilt there, and the run continued from it matches a fresh
/// run stepped to the same point.
#[test]
fn a_cell_block_blow_up_is_rolled_back() -> Result<()> {
    let table = PairTable::uniform(1, LennardJones::new(1.0, 1.0, 2.5))?;
    let sys = scenes::fcc_lattice([3; 3], 0.8442, 1.44, table, &[0], 7)?;
    let config = Config {
        allow_unstable_dt: true,
        check_every: 10,
        ..with(GpuKernel::cell_block(), Config::default().with_dt(0.03))
    };
    for backend in gpus("a_cell_block_blow_up_is_rolled_back") {
        let mut md = Md::new(sys.clone(), &config, backend)?;
        let Err(Error::BlowUp {
            step,
            rolled_back_to,
            what,
            ..
        }) = md.step(2000)
        else {
            panic!("dt = 0.03 must blow up")
        };
        eprintln!("blow-up at {step}: {what}; back to {rolled_back_to}");
        assert!(rolled_back_to > 10 && rolled_back_to % 10 == 0);
        assert!(step > rolled_back_to && step <= rolled_back_to + 10);
        assert_eq!(md.steps_done(), rolled_back_to);
        let mut again = Md::new(sys.clone(), &config, backend)?;
        again.step(rolled_back_to as u32 - 7)?;
        again.step(7)?;
        assert_eq!(again.state()?, md.state()?);
        md.step(3)?;
        again.step(3)?;
        assert_eq!(again.state()?, md.state()?);
    }
    Ok(())
}
