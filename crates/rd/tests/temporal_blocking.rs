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
    let plain = run(grid, model, dt, 1, steps);
    assert_ne!(&plain, grid, "the fields must change");
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for k in [2, 3, 4, 7] {
            let fused = pool.install(|| run(grid, model, dt, k, steps));
            assert!(
                fused == plain,
                "{} {}x{}: k = {k}, {threads} threads differs from one pass per step",
                model.name(),
                grid.nx(),
                grid.ny()
            );
        }
    }
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
/// west/east; Gray–Scott with no-flux north and Dirichlet south.
#[test]
fn mixed_edges_fused_are_bit_identical() {
    let (nx, ny) = (29, 71);
    let noise = |seed| {
        (0..nx * ny)
            .map(|k| f64::from(rng_uniform(seed, 0, k as u32)))
            .collect::<Vec<f64>>()
    };
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
        let grid = Grid::new(nx, ny, 1.0, bc.clone(), vec![noise(1), noise(2)]).unwrap();
        same_for_every_depth(&grid, &Diffusion::new(&[1.0, 0.4]).unwrap(), 0.2, 31);
        let gs = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
        same_for_every_depth(&grid.convert::<f32>(), &gs, 0.2, 31);
    }
}

/// Periodic south/north edges fall back to one pass per step (still identical), and bad
/// depths are refused.
#[test]
fn periodic_y_and_bad_depths() {
    let f = (0..24 * 24)
        .map(|k| f64::from(rng_uniform(3, 0, k as u32)))
        .collect();
    let grid = Grid::new(24, 24, 1.0, Boundaries::periodic(), vec![f]).unwrap();
    let model = Diffusion::new(&[1.0]).unwrap();
    same_for_every_depth(&grid, &model, 0.2, 9);
    let config = Config::new(Stepping::euler(0.2));
    assert_eq!(config.steps_per_sweep, DEFAULT_STEPS_PER_SWEEP);
    for bad in [0, 17] {
        let config = config.with_steps_per_sweep(bad);
        assert!(config.validate().is_err(), "{bad}");
        assert!(Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).is_err());
    }
}
