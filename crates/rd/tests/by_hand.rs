//! The models' update against formulas written out by hand in this file, independent of the
//! crate's functions (no `Model::reaction`, no row kernel): one Euler step and one Heun step
//! of Gray–Scott on a periodic grid, one Euler step of the colony model on a no-flux grid
//! (every cell, the edge cells included), and a manufactured solution for the colony's
//! nonlinear flux term `div(d n b grad b)`, whose discrete value must converge to the
//! analytic one at second order in `h`.
//!
//! Tolerances of the hand-computed steps are derived, not measured: both sides evaluate the
//! same real-number formula in f64, in possibly different orders, so they may differ by a few
//! roundings of the largest intermediate: `|crate - hand| <= 8 eps S` per cell, `S` the sum of
//! the magnitudes of the terms (centre value, diffusive terms, reaction terms; for Heun, of both
//! stages; at most ~16 roundings of eps / 2 S each). Measured (f64, `--nocapture`): 0.20 eps S
//! (Gray–Scott Euler), 0.08 (Heun), 0.00 (colony); multiplying the `u v^2` term by 1.01 gave
//! 1.7e12 eps S.

use std::f64::consts::PI;

use simkit_backend::{Backend, Simulation};
use simkit_rd::{Boundaries, Colony, Config, GrayScott, Grid, Rd, Stepping};

/// Cell values chosen to vary (no two neighbours equal, none at a special value).
fn chosen(nx: usize, ny: usize, base: f64, step: f64, a: usize, b: usize, m: usize) -> Vec<f64> {
    (0..nx * ny)
        .map(|k| {
            let (i, j) = (k % nx, k / nx);
            base + step * ((a * i + b * j + i * j) % m) as f64
        })
        .collect()
}

/// The four neighbours (west, east, south, north) of cell `(i, j)` on a periodic grid.
fn periodic(nx: usize, ny: usize, i: usize, j: usize) -> [usize; 4] {
    [
        j * nx + (i + nx - 1) % nx,
        j * nx + (i + 1) % nx,
        ((j + ny - 1) % ny) * nx + i,
        ((j + 1) % ny) * nx + i,
    ]
}

/// The four neighbours on a no-flux grid: a neighbour outside is the cell itself (ghost =
/// adjacent interior cell, so the face gradient is zero).
fn no_flux(nx: usize, ny: usize, i: usize, j: usize) -> [usize; 4] {
    [
        j * nx + i.saturating_sub(1),
        j * nx + (i + 1).min(nx - 1),
        j.saturating_sub(1) * nx + i,
        (j + 1).min(ny - 1) * nx + i,
    ]
}

/// Gray–Scott parameters of the hand-computed tests (not Pearson's, so that diffusion and
/// reaction are of similar size at h = 1, dt = 1).
const DU: f64 = 0.16;
const DV: f64 = 0.08;
const FEED: f64 = 0.035;
const KILL: f64 = 0.065;

/// One forward-Euler step of Gray–Scott written out:
/// `u' = u + dt (Du lap u - u v^2 + F (1 - u))`, `v' = v + dt (Dv lap v + u v^2 - (F + k) v)`,
/// `lap f = (f_W + f_E + f_S + f_N - 4 f_P) / h^2`, periodic edges. Returns the new fields and
/// per cell the sum of the magnitudes of the terms.
fn gray_scott_euler(
    nx: usize,
    ny: usize,
    h: f64,
    dt: f64,
    u: &[f64],
    v: &[f64],
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut u1, mut v1, mut size) = (vec![0.0; nx * ny], vec![0.0; nx * ny], vec![0.0; nx * ny]);
    for j in 0..ny {
        for i in 0..nx {
            let p = j * nx + i;
            let [w, e, s, n] = periodic(nx, ny, i, j);
            let lap_u = (u[w] + u[e] + u[s] + u[n] - 4.0 * u[p]) / (h * h);
            let lap_v = (v[w] + v[e] + v[s] + v[n] - 4.0 * v[p]) / (h * h);
            let uvv = u[p] * v[p] * v[p];
            u1[p] = u[p] + dt * (DU * lap_u - uvv + FEED * (1.0 - u[p]));
            v1[p] = v[p] + dt * (DV * lap_v + uvv - (FEED + KILL) * v[p]);
            let spread = |f: &[f64]| (f[w].abs() + f[e].abs() + f[s].abs() + f[n].abs()) / (h * h);
            size[p] = u[p].abs()
                + v[p].abs()
                + dt * DU * (spread(u) + 4.0 * u[p].abs() / (h * h))
                + dt * DV * (spread(v) + 4.0 * v[p].abs() / (h * h))
                + 2.0 * dt * uvv.abs()
                + dt * FEED * (1.0 + u[p].abs())
                + dt * (FEED + KILL) * v[p].abs();
        }
    }
    (u1, v1, size)
}

/// Largest `|got - want| / (eps S)` over the cells.
fn worst_in_eps(got: &[f64], want: &[f64], size: &[f64]) -> f64 {
    got.iter()
        .zip(want)
        .zip(size)
        .map(|((g, w), s)| (g - w).abs() / (f64::EPSILON * s))
        .fold(0.0, f64::max)
}

fn gray_scott_grid(nx: usize, ny: usize) -> (Vec<f64>, Vec<f64>) {
    (
        chosen(nx, ny, 0.35, 0.09, 3, 5, 7),
        chosen(nx, ny, 0.05, 0.07, 2, 1, 5),
    )
}

/// One Euler step and one Heun step of the crate's Gray–Scott (CPU, f64, 7 x 5 periodic grid,
/// h = 1, dt = 1) against [`gray_scott_euler`]; Heun by hand is
/// `u* = u + dt F(u)`, `u' = (u + u* + dt F(u*)) / 2`.
#[test]
fn gray_scott_step_matches_the_formula_by_hand() {
    let (nx, ny, h, dt) = (7, 5, 1.0, 1.0);
    let (u, v) = gray_scott_grid(nx, ny);
    let grid = Grid::new(
        nx,
        ny,
        h,
        Boundaries::periodic(),
        vec![u.clone(), v.clone()],
    )
    .unwrap();
    let model = GrayScott::new(DU, DV, FEED, KILL).unwrap();
    // The values really exercise every term: u v^2 and the Laplacians are not small.
    let (u1, v1, size) = gray_scott_euler(nx, ny, h, dt, &u, &v);
    for stepping in [Stepping::euler(dt), Stepping::heun(dt)] {
        let mut sim = Rd::new(
            grid.clone(),
            model.clone(),
            &Config::new(stepping),
            Backend::Cpu,
        )
        .unwrap();
        sim.step(1).unwrap();
        let g = sim.state().unwrap();
        let (want_u, want_v, size) = match stepping.integrator {
            simkit_rd::Integrator::Euler => (u1.clone(), v1.clone(), size.clone()),
            simkit_rd::Integrator::Heun => {
                let (u2, v2, size2) = gray_scott_euler(nx, ny, h, dt, &u1, &v1);
                let avg = |a: &[f64], b: &[f64]| {
                    a.iter()
                        .zip(b)
                        .map(|(x, y)| 0.5 * (x + y))
                        .collect::<Vec<f64>>()
                };
                let total = size.iter().zip(&size2).map(|(a, b)| a + b).collect();
                (avg(&u, &u2), avg(&v, &v2), total)
            }
        };
        let worst =
            worst_in_eps(g.field(0), &want_u, &size).max(worst_in_eps(g.field(1), &want_v, &size));
        let moved = u
            .iter()
            .zip(g.field(0))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "Gray-Scott {:?}: worst |crate - hand| = {worst:.2} eps S (bound 8), largest change of u {moved:.3e}",
            stepping.integrator
        );
        assert!(moved > 1e-2, "the step must change the fields ({moved:e})");
        assert!(worst <= 8.0, "{:?}: {worst} eps S", stepping.integrator);
    }
}

/// A few cells of the Gray–Scott step with their numbers written out in full: u = 0.5,
/// v = 0.25 in the centre of a 3 x 3 periodic grid whose other cells hold u = 1, v = 0, with
/// h = 1, dt = 1 and the parameters above. Centre: lap u = 4 * 1 - 4 * 0.5 = 2,
/// lap v = -4 * 0.25 = -1, u v^2 = 0.03125, so
/// u' = 0.5 + 0.16 * 2 - 0.03125 + 0.035 * 0.5 = 0.80625 and
/// v' = 0.25 + 0.08 * (-1) + 0.03125 - 0.1 * 0.25 = 0.17625. Each of the four neighbours of the centre: lap u = 0.5 - 1 = -0.5,
/// lap v = 0.25, u v^2 = 0, so u' = 1 - 0.08 = 0.92, v' = 0.02; each corner cell: lap u = 0,
/// lap v = 0, u' = 1, v' = 0.
#[test]
fn gray_scott_cells_worked_out() {
    let mut u = vec![1.0; 9];
    let mut v = vec![0.0; 9];
    u[4] = 0.5;
    v[4] = 0.25;
    let grid = Grid::new(3, 3, 1.0, Boundaries::periodic(), vec![u, v]).unwrap();
    let model = GrayScott::new(DU, DV, FEED, KILL).unwrap();
    let mut sim = Rd::new(
        grid,
        model,
        &Config::new(Stepping::euler(1.0)),
        Backend::Cpu,
    )
    .unwrap();
    sim.step(1).unwrap();
    let g = sim.state().unwrap();
    for (k, want_u, want_v) in [
        (4usize, 0.80625f64, 0.17625f64),
        (1, 0.92, 0.02),
        (3, 0.92, 0.02),
        (5, 0.92, 0.02),
        (7, 0.92, 0.02),
        (0, 1.0, 0.0),
        (8, 1.0, 0.0),
    ] {
        let (got_u, got_v) = (g.field(0)[k], g.field(1)[k]);
        println!("cell {k}: u' = {got_u} (by hand {want_u}), v' = {got_v} (by hand {want_v})");
        // Terms of size <= 1: a few roundings, 8 eps.
        assert!(
            (got_u - want_u).abs() <= 8.0 * f64::EPSILON,
            "cell {k}: u' = {got_u}"
        );
        assert!(
            (got_v - want_v).abs() <= 8.0 * f64::EPSILON,
            "cell {k}: v' = {got_v}"
        );
    }
}

/// One forward-Euler step of the colony model written out, no-flux edges (fields `d, b, n`):
/// `kappa = d n b` per cell; `b' = b + dt (sum_Q (kappa_P + kappa_Q) / 2 (b_Q - b_P) / h^2
/// + n b / (1 + gamma n))`, `n' = n + dt (lap n - n b / (1 + gamma n))`.
fn colony_euler(
    nx: usize,
    ny: usize,
    h: f64,
    dt: f64,
    gamma: f64,
    [d, b, n]: [&[f64]; 3],
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut b1, mut n1, mut size) = (vec![0.0; nx * ny], vec![0.0; nx * ny], vec![0.0; nx * ny]);
    let kappa: Vec<f64> = (0..nx * ny).map(|p| d[p] * n[p] * b[p]).collect();
    for j in 0..ny {
        for i in 0..nx {
            let p = j * nx + i;
            let faces = no_flux(nx, ny, i, j);
            let mut flux = 0.0;
            let mut flux_size = 0.0;
            let mut lap_n = 0.0;
            for q in faces {
                let face_kappa = 0.5 * (kappa[p] + kappa[q]);
                flux += face_kappa * (b[q] - b[p]) / (h * h);
                flux_size += face_kappa * (b[q].abs() + b[p].abs()) / (h * h);
                lap_n += (n[q] - n[p]) / (h * h);
            }
            let eat = n[p] * b[p] / (1.0 + gamma * n[p]);
            b1[p] = b[p] + dt * (flux + eat);
            n1[p] = n[p] + dt * (lap_n - eat);
            size[p] =
                b[p].abs() + n[p].abs() + dt * (flux_size + 8.0 * n[p].abs() / (h * h) + 2.0 * eat);
        }
    }
    (b1, n1, size)
}

/// One Euler step of the crate's colony model (CPU, f64, 6 x 5 no-flux grid, h = 0.5,
/// dt = 0.01, gamma = 0.5, a chosen non-uniform `d`) against [`colony_euler`], every cell.
#[test]
fn colony_step_matches_the_formula_by_hand() {
    let (nx, ny, h, dt, gamma) = (6, 5, 0.5, 0.01, 0.5);
    let d = chosen(nx, ny, 0.45, 0.15, 1, 2, 5);
    let b = chosen(nx, ny, 0.1, 0.2, 3, 1, 6);
    let n = chosen(nx, ny, 0.8, 0.1, 2, 3, 4);
    let model = Colony::new(gamma, nx, ny, d.clone()).unwrap();
    let grid = Grid::new(nx, ny, h, Boundaries::no_flux(), vec![b.clone(), n.clone()]).unwrap();
    let mut sim = Rd::new(grid, model, &Config::new(Stepping::euler(dt)), Backend::Cpu).unwrap();
    sim.step(1).unwrap();
    let g = sim.state().unwrap();
    let (b1, n1, size) = colony_euler(nx, ny, h, dt, gamma, [&d, &b, &n]);
    let worst = worst_in_eps(g.field(0), &b1, &size).max(worst_in_eps(g.field(1), &n1, &size));
    let moved = b
        .iter()
        .zip(g.field(0))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    println!(
        "colony Euler: worst |crate - hand| = {worst:.2} eps S (bound 8), largest change of b {moved:.3e}"
    );
    assert!(moved > 1e-2, "the step must change b ({moved:e})");
    assert!(worst <= 8.0, "{worst} eps S");
}

/// The manufactured fields on the periodic unit square and the analytic flux divergence:
/// `b = 1 + 0.3 sin(2 pi x) cos(2 pi y)`, `n = 1 + 0.25 cos(2 pi (x - y))`,
/// `d = 0.75 (1 + 0.4 sin(2 pi x) sin(2 pi y))`; with `K = d n b`,
/// `div(K grad b) = K lap b + K_x b_x + K_y b_y`, `K_x = d_x n b + d n_x b + d n b_x` (same
/// for y). Returns `(b, n, d, div(K grad b))` at `(x, y)`.
fn manufactured(x: f64, y: f64) -> (f64, f64, f64, f64) {
    let t = 2.0 * PI;
    let (sx, cx, sy, cy) = ((t * x).sin(), (t * x).cos(), (t * y).sin(), (t * y).cos());
    let b = 1.0 + 0.3 * sx * cy;
    let b_x = 0.3 * t * cx * cy;
    let b_y = -0.3 * t * sx * sy;
    let lap_b = -2.0 * t * t * 0.3 * sx * cy;
    let n = 1.0 + 0.25 * (t * (x - y)).cos();
    let n_x = -0.25 * t * (t * (x - y)).sin();
    let n_y = -n_x;
    let d = 0.75 * (1.0 + 0.4 * sx * sy);
    let d_x = 0.75 * 0.4 * t * cx * sy;
    let d_y = 0.75 * 0.4 * t * sx * cy;
    let k = d * n * b;
    let k_x = d_x * n * b + d * n_x * b + d * n * b_x;
    let k_y = d_y * n * b + d * n_y * b + d * n * b_y;
    (b, n, d, k * lap_b + k_x * b_x + k_y * b_y)
}

/// The discrete flux divergence on an `m x m` periodic grid of the unit square, taken from one
/// Euler step of the crate: `(b' - b) / dt - n b / (1 + gamma n)` (the reaction written out
/// here), against the analytic [`manufactured`] value; returns the max-norm error.
fn flux_error(m: usize) -> f64 {
    let h = 1.0 / m as f64;
    let gamma = 0.5;
    let cells: Vec<(f64, f64, f64, f64)> = (0..m * m)
        .map(|k| manufactured((((k % m) as f64) + 0.5) * h, (((k / m) as f64) + 0.5) * h))
        .collect();
    let b: Vec<f64> = cells.iter().map(|c| c.0).collect();
    let n: Vec<f64> = cells.iter().map(|c| c.1).collect();
    let d: Vec<f64> = cells.iter().map(|c| c.2).collect();
    let model = Colony::new(gamma, m, m, d).unwrap();
    let grid = Grid::new(m, m, h, Boundaries::periodic(), vec![b.clone(), n.clone()]).unwrap();
    // 0.1 h^2 is under the bound h^2 / (4 max(1, d n b)) (max d n b < 1.8). The step's
    // round-off in the recovered divergence is ~eps |b| / dt: 5e-11 at m = 128, far below the
    // discretisation error.
    let dt = 0.1 * h * h;
    let mut sim = Rd::new(grid, model, &Config::new(Stepping::euler(dt)), Backend::Cpu).unwrap();
    sim.step(1).unwrap();
    let g = sim.state().unwrap();
    (0..m * m)
        .map(|p| {
            let eat = n[p] * b[p] / (1.0 + gamma * n[p]);
            let discrete = (g.field(0)[p] - b[p]) / dt - eat;
            (discrete - cells[p].3).abs()
        })
        .fold(0.0, f64::max)
}

/// Manufactured solution for the colony flux term: the discrete `div(d n b grad b)` converges
/// to the analytic value at second order in `h` (max norm, every cell of the periodic grid,
/// h = 1/32, 1/64, 1/128). Measured (f64): max errors 2.680e-1, 6.884e-2, 1.727e-2, orders
/// 1.961, 1.995 (this test, `--nocapture`); asserted 1.8..2.2. Taking `d` or `kappa` of the
/// centre cell on every face instead of averaging the two cells' `kappa` makes the scheme
/// inconsistent (measured orders 0.04 and 0.0002).
#[test]
fn colony_flux_converges_at_second_order() {
    let errs: Vec<f64> = [32, 64, 128].into_iter().map(flux_error).collect();
    let orders: Vec<f64> = errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    let sci: Vec<String> = errs.iter().map(|e| format!("{e:.3e}")).collect();
    println!("colony flux, manufactured: max errors {sci:?}, orders {orders:.3?}");
    for o in orders {
        assert!((1.8..=2.2).contains(&o), "order {o}");
    }
}
