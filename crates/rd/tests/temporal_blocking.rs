//! Temporal blocking (several Euler steps fused into one sweep on the CPU) gives bit-identical
//! fields to one pass per step, for every fused depth, band layout and edge condition.

use simkit_backend::rng::rng_uniform;
use simkit_backend::{Backend, Simulation};
use simkit_rd::scenes::colony_scene;
use simkit_rd::{
    Boundaries, Boundary, Config, DEFAULT_STEPS_PER_SWEEP, Diffusion, GrayScott, Grid, Model, Rd,
    Real, Stepping,
};

fn run<T: Real, M: Model>(grid: &Grid<T>, model: &M, dt: f64, k: u32, steps: u32) -> Grid<T> {
    let config = Config::new(Stepping::euler(dt)).with_steps_per_sweep(k);
    let mut sim = Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).unwrap();
    // Two calls: the fused depth restarts at every call.
    sim.step(steps / 2).unwrap();
    sim.step(steps - steps / 2).unwrap();
    sim.state().unwrap()
}

fn same_for_every_depth<T: Real, M: Model>(grid: &Grid<T>, model: &M, dt: f64, steps: u32) {
    same_for_depths(grid, model, dt, steps, &[2, 3, 4, 7]);
}

fn same_for_depths<T: Real, M: Model>(
    grid: &Grid<T>,
    model: &M,
    dt: f64,
    steps: u32,
    depths: &[u32],
) {
    let plain = run(grid, model, dt, 1, steps);
    assert_ne!(&plain, grid, "the fields must change");
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for &k in depths {
            let fused = pool.install(|| run(grid, model, dt, k, steps));
            assert!(
                fused == plain,
                "{} {}x{} {:?}: k = {k}, {threads} threads differs from one pass per step",
                model.name(),
                grid.nx(),
                grid.ny(),
                grid.boundaries()
            );
        }
    }
}

/// A grid of `species` fields of uniform noise in [0, 1).
fn noise_grid(nx: usize, ny: usize, bc: Boundaries, species: u32) -> Grid<f64> {
    let fields = (0..species)
        .map(|s| {
            (0..nx * ny)
                .map(|k| f64::from(rng_uniform(7 + s, 0, k as u32)))
                .collect()
        })
        .collect();
    Grid::new(nx, ny, 1.0, bc, fields).unwrap()
}

/// The colony scene (no-flux, coefficient field, f32 and f64) on grids of 1, 2, 3 bands and a
/// partial band, and a grid one row high.
#[test]
fn colony_fused_is_bit_identical() {
    for (nx, ny) in [(40, 37), (33, 96), (20, 1), (18, 2), (70, 65)] {
        let (grid, model) = colony_scene::<f32>(nx, ny, 11).unwrap();
        same_for_every_depth(&grid, &model, 0.005, 23);
        let (grid, model) = colony_scene::<f64>(nx, ny, 12).unwrap();
        same_for_every_depth(&grid, &model, 0.005, 23);
    }
}

/// Mixed edges: Dirichlet south (one value per species), no-flux north, periodic or Dirichlet
/// west/east; diffusion and Gray–Scott, also on grids of 1-3 rows with k up to 16.
#[test]
fn mixed_edges_fused_are_bit_identical() {
    let diffusion = Diffusion::new(&[1.0, 0.4]).unwrap();
    let gs = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
    for (west, east) in [
        (Boundary::Periodic, Boundary::Periodic),
        (Boundary::Dirichlet(vec![0.5, -1.0]), Boundary::NoFlux),
    ] {
        let bc = Boundaries {
            west,
            east,
            south: Boundary::Dirichlet(vec![1.0, -0.5]),
            north: Boundary::NoFlux,
        };
        let grid = noise_grid(29, 71, bc.clone(), 2);
        same_for_every_depth(&grid, &diffusion, 0.2, 31);
        same_for_every_depth(&grid.convert::<f32>(), &gs, 0.2, 31);
        for (nx, ny) in [(9, 1), (7, 2), (6, 3)] {
            let grid = noise_grid(nx, ny, bc.clone(), 2);
            same_for_depths(&grid, &diffusion, 0.2, 37, &[2, 3, 5, 16]);
            same_for_depths(&grid.convert::<f32>(), &gs, 0.2, 37, &[2, 3, 5, 16]);
        }
    }
}

/// Periodic south/north edges: the bands at the bottom and top take their halo rows from
/// the other end of the grid. Grids of 1-3 rows (lower than the halo, so a row wraps more than
/// once) with k up to 16, grids lower than a band and heights that are not a multiple of the
/// band; periodic, Dirichlet and no-flux west/east edges; diffusion, Gray–Scott (f32, f64)
/// and the colony scene made periodic (a coefficient field that wraps too).
#[test]
fn periodic_y_fused_is_bit_identical() {
    let wests = [
        (Boundary::Periodic, Boundary::Periodic),
        (Boundary::Dirichlet(vec![0.5, -1.0]), Boundary::NoFlux),
    ];
    let gs = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
    let diffusion = Diffusion::new(&[1.0, 0.4]).unwrap();
    for (west, east) in wests {
        let bc = Boundaries {
            west,
            east,
            south: Boundary::Periodic,
            north: Boundary::Periodic,
        };
        for (nx, ny) in [(9, 1), (7, 2), (6, 3)] {
            let grid = noise_grid(nx, ny, bc.clone(), 2);
            let depths = [2, 3, 5, 16];
            same_for_depths(&grid, &diffusion, 0.2, 37, &depths);
            same_for_depths(&grid.convert::<f32>(), &gs, 0.2, 37, &depths);
        }
        for (nx, ny) in [(24, 24), (17, 63), (29, 64), (13, 130), (11, 200)] {
            let grid = noise_grid(nx, ny, bc.clone(), 2);
            same_for_every_depth(&grid, &diffusion, 0.2, 31);
            same_for_every_depth(&grid, &gs, 0.2, 31);
            same_for_every_depth(&grid.convert::<f32>(), &gs, 0.2, 31);
        }
    }
    for (nx, ny) in [(40, 37), (20, 1), (18, 3), (70, 65)] {
        let (grid, model) = colony_scene::<f32>(nx, ny, 13).unwrap();
        let periodic = Grid::new(
            nx,
            ny,
            grid.h(),
            Boundaries::periodic(),
            grid.fields().to_vec(),
        )
        .unwrap();
        same_for_every_depth(&periodic, &model, 0.005, 23);
    }
}

/// The default depth and the bounds on it: 0 and 17 are refused.
#[test]
fn default_and_bad_depths() {
    let grid = noise_grid(24, 24, Boundaries::periodic(), 1);
    let model = Diffusion::new(&[1.0]).unwrap();
    let config = Config::new(Stepping::euler(0.2));
    assert_eq!(config.steps_per_sweep, DEFAULT_STEPS_PER_SWEEP);
    for bad in [0, 17] {
        let config = config.with_steps_per_sweep(bad);
        assert!(config.validate().is_err(), "{bad}");
        assert!(Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).is_err());
    }
}
