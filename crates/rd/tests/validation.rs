//! Physics validation: heat kernel convergence orders, conservation, stability guard,
//! Dirichlet profile, colony reaction bookkeeping.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use simkit_backend::Backend;
use simkit_backend::rng::rng_uniform;
use simkit_backend::testing::backends;
#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::{Error, Simulation};
#[cfg(feature = "gpu")]
use simkit_rd::GpuOptions;
use simkit_rd::scenes::colony_scene;
use simkit_rd::{
    Boundaries, Boundary, Colony, Config, Diffusion, Grid, Integrator, Rd, Stepping, stable_dt,
};

const L: f64 = 40.0;

/// Heat kernel of a unit mass at time `t` (D = 1) centred in the periodic box.
fn heat_kernel(n: usize, t: f64) -> Vec<f64> {
    let h = L / n as f64;
    let mut u = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let x = (i as f64 + 0.5) * h - L / 2.0;
            let y = (j as f64 + 0.5) * h - L / 2.0;
            u.push((-(x * x + y * y) / (4.0 * t)).exp() / (4.0 * std::f64::consts::PI * t));
        }
    }
    u
}

fn sci(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.3e}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn l2(a: &[f64], b: &[f64], h: f64) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() * h * h).sqrt()
}

/// Runs the heat kernel from t = 1 to t = 2 on an `n x n` periodic grid.
fn gaussian_run(n: usize, dt: f64, integrator: Integrator) -> Vec<f64> {
    let h = L / n as f64;
    let grid = Grid::new(n, n, h, Boundaries::periodic(), vec![heat_kernel(n, 1.0)]).unwrap();
    let steps = (1.0 / dt).round() as u32;
    assert_abs_diff_eq!(steps as f64 * dt, 1.0, epsilon = 1e-12);
    let stepping = Stepping {
        dt,
        integrator,
        ..Stepping::euler(dt)
    };
    let mut sim = Rd::new(
        grid,
        Diffusion::new(&[1.0]).unwrap(),
        &Config::new(stepping),
        Backend::Cpu,
    )
    .unwrap();
    sim.step(steps).unwrap();
    sim.state().unwrap().field(0).to_vec()
}

/// Space: Heun with dt = 0.05 h^2 (time error ~ dt^2, negligible) against the analytic heat
/// kernel; the error falls ~4x per halving of h.
#[test]
fn gaussian_second_order_in_space() {
    let mut errs = Vec::new();
    for n in [80, 160, 320] {
        let h = L / n as f64;
        let u = gaussian_run(n, 0.05 * h * h, Integrator::Heun);
        errs.push(l2(&u, &heat_kernel(n, 2.0), h));
    }
    let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    println!(
        "space: L2 errors {}, observed orders {orders:.3?}",
        sci(&errs)
    );
    for o in orders {
        assert!(abs_diff_eq!(o, 2.0, epsilon = 0.1), "spatial order {o}");
    }
}

/// Time: on a fixed grid (h = 0.5) the spatial error is the same for every dt, so the error
/// against a same-grid Heun reference with a 64x smaller dt isolates the time error: it falls
/// ~2x (Euler) and ~4x (Heun) per halving of dt.
#[test]
fn gaussian_time_orders() {
    let n = 80;
    let reference = gaussian_run(n, 0.05 / 64.0, Integrator::Heun);
    let h = L / n as f64;
    for (integrator, want) in [(Integrator::Euler, 1.0), (Integrator::Heun, 2.0)] {
        let errs: Vec<f64> = [0.05, 0.025, 0.0125]
            .iter()
            .map(|&dt| l2(&gaussian_run(n, dt, integrator), &reference, h))
            .collect();
        let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        println!(
            "time {integrator:?}: errors {}, observed orders {orders:.3?}",
            sci(&errs)
        );
        for o in orders {
            assert!(
                abs_diff_eq!(o, want, epsilon = 0.1),
                "{integrator:?} time order {o}"
            );
        }
    }
}

fn random_field(nx: usize, ny: usize, seed: u32) -> Vec<f64> {
    (0..nx * ny)
        .map(|k| 1.0 + f64::from(rng_uniform(seed, 0, k as u32)))
        .collect()
}

/// No-flux edges conserve the total of each species over 10^4 steps (f64): measured relative
/// changes 1.9e-15 and 1.6e-16 (this test, `--nocapture`); bound 6e-15 (3x the larger).
#[test]
fn no_flux_conserves_mass() {
    let (nx, ny) = (24, 20);
    let grid = Grid::new(
        nx,
        ny,
        0.5,
        Boundaries::no_flux(),
        vec![random_field(nx, ny, 1), random_field(nx, ny, 2)],
    )
    .unwrap();
    let before = [grid.total(0), grid.total(1)];
    let model = Diffusion::new(&[1.0, 0.3]).unwrap();
    let dt = 0.9 * stable_dt(&model, &grid);
    let mut sim = Rd::new(grid, model, &Config::new(Stepping::heun(dt)), Backend::Cpu).unwrap();
    sim.step(10_000).unwrap();
    let g = sim.state().unwrap();
    for (s, b) in before.iter().enumerate() {
        let rel = (g.total(s) - b).abs() / b;
        println!("species {s}: relative change of total {rel:e}");
        assert!(rel < 6e-15, "species {s}: {rel:e}");
    }
    // ... and the field has actually diffused towards uniform.
    assert!(simkit_rd::scenes::variance(&g, 0) < 1e-6);
}

/// The colony model: total b changes each step by exactly dt * h^2 * sum(reaction) (the flux
/// form moves b between cells without creating any), and b + n is conserved.
#[test]
fn colony_b_changes_only_through_reaction() {
    let (grid, model) = colony_scene::<f64>(48, 40, 5).unwrap();
    let dt = 0.005;
    let h2 = grid.h() * grid.h();
    let start = grid.total(0) + grid.total(1);
    let b0 = grid.total(0);
    let mut sim = Rd::new(
        grid,
        model.clone(),
        &Config::new(Stepping::euler(dt)),
        Backend::Cpu,
    )
    .unwrap();
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let g = sim.state().unwrap();
        let r: f64 = g
            .field(0)
            .iter()
            .zip(g.field(1))
            .map(|(b, n)| model.reaction(*b, *n))
            .sum();
        let before = g.total(0);
        sim.step(1).unwrap();
        let after = sim.state().unwrap().total(0);
        let err = (after - before - dt * h2 * r).abs() / before;
        // Measured at most 6.9e-15 over the 200 steps (printed below); bound 2e-14 (3x).
        assert!(err < 2e-14, "b bookkeeping off by {err:e}");
        worst = worst.max(err);
    }
    println!("b bookkeeping: worst relative error over 200 steps {worst:e}");
    sim.step(2000).unwrap();
    let g = sim.state().unwrap();
    let rel = (g.total(0) + g.total(1) - start).abs() / start;
    println!(
        "b + n relative change after 2200 steps: {rel:e} (b: {:.6} -> {:.6})",
        b0,
        g.total(0)
    );
    // Measured 0. Derived bound: each step moves dt r from n to b in every cell with one
    // rounding on each side (eps / 2 relative to the totals at most), 2200 steps:
    // 2200 eps = 4.9e-13; asserted 1e-12.
    assert!(rel < 1e-12, "{rel:e}");
}

fn checker_noise_grid(n: usize) -> Grid<f64> {
    let f = (0..n * n)
        .map(|k| 1e-3 * f64::from(rng_uniform(9, 0, k as u32)))
        .collect();
    Grid::new(n, n, 1.0, Boundaries::periodic(), vec![f]).unwrap()
}

/// The guard's bound is tight: 0.99 x bound stays bounded, 1.01 x bound is refused, and with
/// the override it blows up.
#[test]
fn stability_guard_is_tight() {
    let model = Diffusion::new(&[0.8]).unwrap();
    let grid = checker_noise_grid(32);
    let bound = stable_dt(&model, &grid);
    assert!(
        abs_diff_eq!(bound, 1.0 / 3.2, epsilon = 1e-15),
        "bound {bound}"
    );
    for integrator in [Integrator::Euler, Integrator::Heun] {
        let s = |dt| Stepping {
            dt,
            integrator,
            ..Stepping::euler(dt)
        };
        let mut ok = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(s(0.99 * bound)),
            Backend::Cpu,
        )
        .unwrap();
        ok.step(3000).unwrap();
        assert!(ok.state().unwrap().max_abs(0) <= grid.max_abs(0));

        let err = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(s(1.01 * bound)),
            Backend::Cpu,
        )
        .unwrap_err();
        assert!(matches!(err, Error::Unstable { .. }), "{err}");
        println!("{integrator:?} refused: {err}");

        let mut wild = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(s(1.01 * bound).unguarded()),
            Backend::Cpu,
        )
        .unwrap();
        wild.step(3000).unwrap();
        let m = wild.state().unwrap().max_abs(0);
        assert!(
            m > 1e3 * grid.max_abs(0),
            "{integrator:?}: overridden run stayed at {m}"
        );
    }
}

/// The colony bound follows the fields: raising b (so d n b > 1) lowers the bound, and a
/// `step` call re-checks it.
#[test]
fn colony_guard_follows_fields() {
    let (mut grid, model) = colony_scene::<f64>(16, 16, 2).unwrap();
    // h = 0.5 and n diffuses with D = 1 > d n b: bound h^2 / 4.
    assert_eq!(stable_dt(&model, &grid), 0.25 / 4.0);
    grid.field_mut(0)[5] = 4.0;
    let kappa = model.d()[5] * 4.0 * grid.field(1)[5];
    assert_abs_diff_eq!(
        stable_dt(&model, &grid),
        0.25 / (4.0 * kappa),
        epsilon = 1e-15
    );
    let err = Rd::new(
        grid,
        model,
        &Config::new(Stepping::euler(0.25 / 4.0)),
        Backend::Cpu,
    )
    .unwrap_err();
    assert!(matches!(err, Error::Unstable { .. }), "{err}");
}

/// The re-check before each `step` call reads the current fields: the in-place bound equals
/// `stable_dt` of the downloaded state exactly (f64), and once the reaction has grown `b`
/// enough that `d n b` passes the bound for the running `dt`, the next `step` is refused with
/// exactly that bound. Calls of 5 steps end with a plain pass (bound found in place), calls of
/// 8 with a fused sweep (bound found from the rows as they are written).
#[test]
fn colony_step_rechecks_current_fields() {
    let (mut grid, model) = colony_scene::<f64>(24, 20, 4).unwrap();
    // Uniform b = 0.5, n = 3: nothing diffuses, the reaction turns n into b, and b n (hence
    // max d n b, from 1.6) grows until b = n. dt just under the initial bound runs at first.
    grid.field_mut(0).fill(0.5);
    grid.field_mut(1).fill(3.0);
    let dt = 0.98 * stable_dt(&model, &grid);
    for per_call in [5, 8] {
        let mut sim = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(Stepping::euler(dt)),
            Backend::Cpu,
        )
        .unwrap();
        let mut refused = None;
        for call in 0..200 {
            let state = sim.state().unwrap();
            assert_eq!(sim.stable_dt().unwrap(), stable_dt(&model, &state));
            match sim.step(per_call) {
                Ok(()) => {}
                Err(Error::Unstable { bound, .. }) => {
                    assert!(bound < dt);
                    assert_eq!(bound, stable_dt(&model, &state));
                    refused = Some(call);
                    break;
                }
                Err(e) => panic!("{e}"),
            }
        }
        let call = refused.expect("b grows through the reaction, so dt must be refused");
        println!(
            "{per_call} steps per call: refused at call {call} (after {} steps)",
            sim.steps_done()
        );
        assert!(call > 0, "the first call must run");
    }
}

/// The GPU re-checks from the fields on the device (reduction in f32): same refusal point as
/// the CPU for the same scene, with a bound within f32 rounding of the CPU's.
#[cfg(feature = "gpu")]
#[test]
fn gpu_colony_step_rechecks_device_fields() {
    let Some(ctx) = gpu_or_skip("gpu_colony_step_rechecks_device_fields") else {
        return;
    };
    let (mut grid, model) = colony_scene::<f32>(24, 20, 4).unwrap();
    grid.field_mut(0).fill(0.5);
    grid.field_mut(1).fill(3.0);
    let dt = 0.98 * stable_dt(&model, &grid);
    let run = |backend| {
        let mut sim = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(Stepping::euler(dt)),
            backend,
        )
        .unwrap();
        for call in 0..200 {
            match sim.step(5) {
                Ok(()) => {}
                Err(Error::Unstable { bound, .. }) => return (call, bound),
                Err(e) => panic!("{e}"),
            }
        }
        panic!("{}: never refused", sim.backend_name());
    };
    let (cpu_call, cpu_bound) = run(Backend::Cpu);
    let (gpu_call, gpu_bound) = run(Backend::Gpu(&ctx));
    println!(
        "refused at call {cpu_call} (CPU, bound {cpu_bound}) / {gpu_call} (GPU, bound {gpu_bound})"
    );
    assert!(cpu_call > 0);
    assert_eq!(cpu_call, gpu_call);
    // The GPU forms d b n in f32 (two roundings) where the CPU forms it in f64 from the same f32
    // values: derived bound 2 eps_f32 relative (measured: equal).
    assert_abs_diff_eq!(
        cpu_bound,
        gpu_bound,
        epsilon = 2.0 * f64::from(f32::EPSILON) * cpu_bound
    );
}

/// Dirichlet 0 (west) and 1 (east) with no-flux north/south relax to the linear profile,
/// which the scheme represents exactly: on both backends. After 3000 steps (t = 720) the
/// slowest mode has decayed by e^-28; what is left is f32 round-off: measured 2.6e-6 at most
/// on the CPU and on llvmpipe (this test, `--nocapture`); bound 8e-6 (3x).
#[test]
fn dirichlet_relaxes_to_linear_profile() {
    let (nx, ny) = (16, 4);
    let bc = Boundaries {
        west: Boundary::Dirichlet(vec![0.0]),
        east: Boundary::Dirichlet(vec![1.0]),
        south: Boundary::NoFlux,
        north: Boundary::NoFlux,
    };
    let grid = Grid::new(nx, ny, 1.0, bc, vec![vec![0.3f32; nx * ny]]).unwrap();
    let model = Diffusion::new(&[1.0]).unwrap();
    for backend in backends("dirichlet_relaxes_to_linear_profile") {
        let mut sim = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(Stepping::euler(0.24)),
            backend,
        )
        .unwrap();
        sim.step(3000).unwrap();
        let g = sim.state().unwrap();
        let mut worst = 0.0f64;
        for j in 0..ny {
            for i in 0..nx {
                let want = (i as f64 + 0.5) / nx as f64;
                let got = f64::from(g.get(0, i, j).unwrap());
                worst = worst.max((got - want).abs());
                assert!(
                    (got - want).abs() < 8e-6,
                    "{} ({i},{j}): {got} vs {want}",
                    sim.backend_name()
                );
            }
        }
        println!("{}: worst |u - linear| = {worst:e}", sim.backend_name());
    }
}

/// Bad input gives clear errors, never a panic.
#[test]
fn bad_input_is_refused() {
    let bc = Boundaries::no_flux;
    let inv = |r: simkit_backend::Result<Grid<f64>>| match r {
        Err(Error::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    };
    println!("{}", inv(Grid::new(0, 4, 1.0, bc(), vec![vec![]])));
    println!("{}", inv(Grid::new(4, 4, 0.0, bc(), vec![vec![0.0; 16]])));
    println!("{}", inv(Grid::new(4, 4, -1.0, bc(), vec![vec![0.0; 16]])));
    println!(
        "{}",
        inv(Grid::new(4, 4, f64::NAN, bc(), vec![vec![0.0; 16]]))
    );
    println!("{}", inv(Grid::new(4, 4, 1.0, bc(), vec![vec![0.0; 15]])));
    println!("{}", inv(Grid::new(4, 4, 1.0, bc(), vec![])));
    let mut nan = vec![0.0; 16];
    nan[6] = f64::NAN;
    let name = inv(Grid::new(4, 4, 1.0, bc(), vec![nan]));
    assert!(name.contains("(2, 1)"), "{name}");
    let half_periodic = Boundaries {
        west: Boundary::Periodic,
        ..Boundaries::no_flux()
    };
    inv(Grid::new(4, 4, 1.0, half_periodic, vec![vec![0.0; 16]]));
    inv(Grid::new(
        4,
        4,
        1.0,
        Boundaries::all(Boundary::Dirichlet(vec![1.0, 2.0])),
        vec![vec![0.0; 16]],
    ));

    assert!(Diffusion::new(&[-1.0]).is_err());
    assert!(Diffusion::new(&[f64::NAN]).is_err());
    assert!(Diffusion::new(&[]).is_err());
    assert!(simkit_rd::GrayScott::new(1.0, -0.5, 0.03, 0.06).is_err());
    assert!(Colony::new(-0.5, 2, 2, vec![1.0; 4]).is_err());
    assert!(Colony::new(0.5, 2, 2, vec![1.0; 3]).is_err());
    assert!(Colony::new(0.5, 2, 2, vec![1.0, -1.0, 1.0, 1.0]).is_err());

    let grid = Grid::new(4, 4, 1.0, bc(), vec![vec![0.0; 16]]).unwrap();
    let one = Diffusion::new(&[1.0]).unwrap();
    let two = Diffusion::new(&[1.0, 1.0]).unwrap();
    assert!(
        Rd::new(
            grid.clone(),
            two,
            &Config::new(Stepping::euler(0.1)),
            Backend::Cpu
        )
        .is_err()
    );
    for dt in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        let e = Rd::new(
            grid.clone(),
            one.clone(),
            &Config::new(Stepping::euler(dt).unguarded()),
            Backend::Cpu,
        );
        assert!(matches!(e, Err(Error::InvalidParameter { .. })), "dt {dt}");
    }
    let (cgrid, _) = colony_scene::<f64>(8, 8, 1).unwrap();
    let small = Colony::new(0.5, 4, 4, vec![1.0; 16]).unwrap();
    assert!(
        Rd::new(
            cgrid,
            small,
            &Config::new(Stepping::euler(0.001)),
            Backend::Cpu
        )
        .is_err()
    );
    let mut edited = grid;
    edited.field_mut(0)[3] = f64::INFINITY;
    assert!(
        Rd::new(
            edited,
            one,
            &Config::new(Stepping::euler(0.1)),
            Backend::Cpu
        )
        .is_err()
    );
}

/// GPU tiles over the device's workgroup limits (or empty) are refused with a clear error.
#[cfg(feature = "gpu")]
#[test]
fn gpu_rejects_bad_tiles() {
    let Some(ctx) = gpu_or_skip("gpu_rejects_bad_tiles") else {
        return;
    };
    let (grid, model) = colony_scene::<f32>(32, 32, 1).unwrap();
    for tile in [(0, 16), (16, 0), (1024, 1024)] {
        let config = Config::new(Stepping::euler(0.005)).with_gpu(GpuOptions {
            tile,
            ..GpuOptions::default()
        });
        let err = Rd::new(grid.clone(), model.clone(), &config, Backend::Gpu(&ctx)).unwrap_err();
        assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
    }
}

/// A colony run blown up with the guard overridden used to return `Ok` holding NaN (and,
/// before that, to step on with an infinite bound). Its `step` now returns `Error::BlowUp`
/// and the run holds the last finite state that passed the check, so the next step starts
/// from finite fields; a NaN `D_max` is still an error, never an infinite bound (unit tests in
/// `stepper.rs`).
#[test]
fn a_blown_up_colony_is_stopped_and_rolled_back() {
    let (grid, model) = colony_scene::<f32>(64, 64, 3).unwrap();
    let bound = stable_dt(&model, &grid);
    assert!(
        abs_diff_eq!(bound, 0.0625, epsilon = 1e-12),
        "bound {bound}"
    );
    for backend in backends("a_blown_up_colony_is_stopped_and_rolled_back") {
        let config = Config::new(Stepping::euler(16.0 * bound).unguarded());
        let mut sim = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
        let e = sim.step(400).unwrap_err();
        let Error::BlowUp {
            step,
            rolled_back_to,
            ..
        } = e
        else {
            panic!("{}: expected BlowUp, got {e}", sim.backend_name());
        };
        assert!(rolled_back_to < step && step <= 400, "{e}");
        assert_eq!(sim.steps_done(), rolled_back_to);
        let state = sim.state().unwrap();
        assert!(state.max_abs(0).is_finite() && state.max_abs(1).is_finite());
        assert!(stable_dt(&model, &state).is_finite());
        assert!(sim.stable_dt().unwrap().is_finite());
    }
}

#[test]
fn max_abs_is_nan_if_any_value_is_nan() {
    let mut grid = Grid::uniform(4, 3, 1.0, Boundaries::no_flux(), 1, 2.0f64).unwrap();
    assert_eq!(grid.max_abs(0), 2.0);
    grid.field_mut(0)[5] = -3.0;
    assert_eq!(grid.max_abs(0), 3.0);
    grid.field_mut(0).fill(f64::NAN);
    assert!(grid.max_abs(0).is_nan(), "all NaN used to give 0");
    grid.field_mut(0).fill(1.0);
    grid.field_mut(0)[7] = f64::NAN;
    assert!(grid.max_abs(0).is_nan());
}

#[test]
fn grid_get_is_checked() {
    let (nx, ny) = (4, 3);
    let a: Vec<f64> = (0..nx * ny).map(|k| k as f64).collect();
    let grid = Grid::new(nx, ny, 1.0, Boundaries::no_flux(), vec![a]).unwrap();
    assert_eq!(grid.get(0, 1, 2), Some(9.0));
    assert_eq!(grid.get(0, nx - 1, ny - 1), Some(11.0));
    // x = nx + 1 used to read the next row's cell (1, 1); a bad species used to panic.
    assert_eq!(grid.get(0, nx + 1, 0), None);
    assert_eq!(grid.get(0, nx, 0), None);
    assert_eq!(grid.get(0, 0, ny), None);
    assert_eq!(grid.get(0, usize::MAX, usize::MAX), None);
    assert_eq!(grid.get(1, 0, 0), None);
}

#[test]
fn uniform_checks_the_size_before_allocating() {
    // 100_000 x 100_000 used to allocate ~80 GB (and abort) before the size check.
    for (nx, ny) in [(100_000, 100_000), (usize::MAX, 2), (1 << 32, 1 << 32)] {
        let e = Grid::uniform(nx, ny, 1.0, Boundaries::no_flux(), 1, 0.0f64)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("grid size: {nx} x {ny}")) && e.contains("too many cells"),
            "{e}"
        );
    }
    let e = Grid::uniform(0, 5, 1.0, Boundaries::no_flux(), 1, 0.0f64)
        .unwrap_err()
        .to_string();
    assert!(e.contains("grid size: 0 x 5"), "{e}");
}

/// The colony model of a `4 x 4` grid under a validation that does not check its
/// coefficient field's size (as a user's own model might).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
struct Lenient(Colony);

impl simkit_rd::Model for Lenient {
    fn name(&self) -> &'static str {
        "lenient"
    }
    fn species(&self) -> usize {
        self.0.species()
    }
    fn validate(&self, _nx: usize, _ny: usize) -> simkit_backend::Result<()> {
        Ok(())
    }
    fn coefficients(&self) -> &[Vec<f64>] {
        self.0.coefficients()
    }
    fn max_diffusivity<T: simkit_rd::Real>(&self, grid: &Grid<T>) -> f64 {
        self.0.max_diffusivity(grid)
    }
    fn field_dependent_diffusivity(&self) -> bool {
        self.0.field_dependent_diffusivity()
    }
    fn max_cell_diffusivity<T: simkit_rd::Real>(&self, s: &[&[T]], c: &[&[T]]) -> f64 {
        self.0.max_cell_diffusivity(s, c)
    }
    fn update_row<T: simkit_rd::Real>(
        &self,
        input: &simkit_rd::RowIn<'_, T>,
        dt: f64,
        inv_h2: f64,
        out: &mut [&mut [T]],
        average: bool,
    ) {
        self.0.update_row(input, dt, inv_h2, out, average);
    }
    fn wgsl(&self) -> &'static str {
        self.0.wgsl()
    }
    fn gpu_params(&self) -> Vec<f64> {
        self.0.gpu_params()
    }
}

#[test]
fn a_model_coefficient_field_of_the_wrong_size_is_refused() {
    // Before: a model whose own validation missed it panicked while padding the field.
    let model = Lenient(Colony::new(0.5, 4, 4, vec![1.0; 16]).unwrap());
    let grid = Grid::uniform(8, 8, 1.0, Boundaries::no_flux(), 2, 0.5).unwrap();
    for backend in backends("a_model_coefficient_field_of_the_wrong_size_is_refused") {
        let config = Config::new(Stepping::euler(0.01));
        match Rd::new(grid.clone(), model.clone(), &config, backend) {
            Err(Error::InvalidParameter { name, .. }) => {
                assert!(name.contains("coefficient field 0 length"), "{name}")
            }
            other => panic!("expected InvalidParameter, got {:?}", other.err()),
        }
    }
}
