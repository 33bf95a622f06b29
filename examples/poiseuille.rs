//! Body-force-driven channel (plane Poiseuille flow): walls on the top and bottom rows,
//! periodic in x, a force that turns west-movers into east-movers with probability p. Fits a
//! parabola to the time-averaged velocity profile and prints the viscosity it implies,
//! `nu = -g / (2 a)` with `u(y) = a y^2 + b y + c`, against the FHP-I theory.
//!
//! The acceleration is measured, not assumed: the same density and p in a periodic box
//! without walls gives the momentum gained per particle per step at rest. The force acts only
//! where a west-mover meets no east-mover, so it weakens where the flow is fast; the second
//! fit uses the local acceleration of each row, `g(y) = 2 p <sites with a west-mover and no
//! east-mover> / <particles>` counted on the lattice, and fits `u = G(y)/nu + b y + c` with
//! `G'' = -g`.
//!
//! ```text
//! cargo run --release --example poiseuille [-- DENSITY P HEIGHT]
//! ```
//! Defaults: d = 0.2, p = 0.0005, 64 rows (4096 x 64 sites; other heights keep ~2^18
//! sites); writes out/poiseuille/profile.csv.

use simkit::backend::{Result, Simulation};
use simkit::lattice_gas::observables::CX;
use simkit::lattice_gas::viscosity::fhp1_viscosity;
use simkit::lattice_gas::{Config, EAST, Lattice, MultiSpinCpu, ROW_SPACING, WALL, WEST};
use simkit::output::csv::write_csv;

fn row_px(sim: &MultiSpinCpu) -> Vec<(f64, f64)> {
    sim.row_counts()
        .iter()
        .map(|c| {
            let px = c.iter().zip(CX).map(|(&n, x)| n as f64 * x).sum();
            (px, c.iter().sum::<u64>() as f64)
        })
        .collect()
}

fn main() -> Result<()> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let d = args.first().copied().unwrap_or(0.2);
    let p = args.get(1).copied().unwrap_or(0.0005);
    let h = args.get(2).map_or(64, |&x| x as usize);
    if h < 8 || h % 2 == 1 {
        return Err(simkit::backend::Error::invalid(
            "HEIGHT",
            h,
            "use an even number of rows, at least 8",
        ));
    }
    // About 2^18 sites, the width a multiple of 64.
    let w = ((1usize << 18) / h).div_ceil(64) * 64;
    let seed = 9;

    // 1. The acceleration from the force: periodic box, momentum gain per particle per step.
    let mut free = Lattice::new(w, h)?;
    free.fill_random(d, seed)?;
    let config = Config {
        body_force: p,
        seed,
        ..Config::default()
    };
    let mut boxed = MultiSpinCpu::new(free, &config)?;
    let totals = |sim: &MultiSpinCpu| {
        row_px(sim)
            .iter()
            .fold((0.0, 0.0), |(a, b), &(px, n)| (a + px, b + n))
    };
    let (p0, n) = totals(&boxed);
    let g_steps = 200;
    boxed.step(g_steps)?;
    let g = (totals(&boxed).0 - p0) / n / f64::from(g_steps);

    // 2. The channel.
    let mut lattice = Lattice::new(w, h)?;
    lattice.add_wall_rows();
    lattice.fill_random(d, seed + 1)?;
    let channel = Config {
        periodic_y: false,
        ..config
    };
    let mut sim = MultiSpinCpu::new(lattice, &channel)?;
    // The slowest mode relaxes in ~H^2 / (pi^2 nu) steps: 16000 steps at 64 rows, scaled.
    let relax = (16_000 * h * h / (64 * 64)).max(4000) as u32;
    let average = relax;
    let every = 20;
    let t = std::time::Instant::now();
    sim.step(relax)?;
    let mut sums = vec![(0.0, 0.0); h];
    // Sites per row where the force can act (a west-mover, no east-mover, not a wall),
    // counted on the lattice after each sampled step.
    let mut eligible = vec![0.0f64; h];
    for _ in 0..average / every {
        sim.step(every)?;
        for (s, r) in sums.iter_mut().zip(row_px(&sim)) {
            s.0 += r.0;
            s.1 += r.1;
        }
        let state = sim.state()?;
        for (e, row) in eligible.iter_mut().zip(state.cells().chunks(w)) {
            *e += row
                .iter()
                .filter(|&&c| c & (WALL | EAST | WEST) == WEST)
                .count() as f64;
        }
    }
    // Local acceleration of each row: the force turns an eligible site's west-mover into an
    // east-mover (momentum +2) with probability p; the sampled lattice is after the force, so
    // a fraction p of the eligible sites has already been turned: divide by 1 - p.
    let local_g: Vec<f64> = eligible
        .iter()
        .zip(&sums)
        .map(|(&e, &(_, n))| {
            if n > 0.0 {
                2.0 * p / (1.0 - p) * e / n
            } else {
                0.0
            }
        })
        .collect();
    let elapsed = t.elapsed().as_secs_f64();
    // Fluid rows 1..h-1; y in lattice units.
    let profile: Vec<(f64, f64)> = (1..h - 1)
        .map(|j| (j as f64 * ROW_SPACING, sums[j].0 / sums[j].1))
        .collect();
    let a = fit_three(&profile, |y| y * y);
    let nu = -g / (2.0 * a);
    // G'' = -g(y) by double integration over the fluid rows (trapezoid rule).
    let dy = ROW_SPACING;
    let mut slope = 0.0;
    let mut big_g = vec![0.0; profile.len()];
    for i in 1..profile.len() {
        let (g0, g1) = (local_g[i], local_g[i + 1]);
        let new_slope = slope - 0.5 * (g0 + g1) * dy;
        big_g[i] = big_g[i - 1] + 0.5 * (slope + new_slope) * dy;
        slope = new_slope;
    }
    let inv_nu = fit_three(&profile, |y| big_g[((y / dy).round() as usize) - 1]);
    let nu_local = 1.0 / inv_nu;
    let theory = fhp1_viscosity(d);
    let umax = profile.iter().map(|&(_, u)| u).fold(f64::MIN, f64::max);
    println!(
        "Poiseuille channel {w} x {h}, d = {d}, p = {p}, {} steps ({elapsed:.1} s)",
        relax + average
    );
    println!("acceleration g = {g:.4e} per step (measured in a periodic box)");
    println!("centre-line velocity {umax:.4}, curvature a = {a:.4e}");
    println!(
        "viscosity from the parabola and the at-rest g: {nu:.4}; FHP-I theory {theory:.4} ({:+.1} %)",
        100.0 * (nu / theory - 1.0)
    );
    println!(
        "viscosity with the local, velocity-dependent g(y): {nu_local:.4} ({:+.1} %)",
        100.0 * (nu_local / theory - 1.0)
    );
    let rows: Vec<[f64; 2]> = profile.iter().map(|&(y, u)| [y, u]).collect();
    write_csv("out/poiseuille/profile.csv", &["y", "u_x"], &rows)?;
    Ok(())
}

/// Least-squares fit `u = a f(y) + b y + c`; returns `a`.
fn fit_three(points: &[(f64, f64)], f: impl Fn(f64) -> f64) -> f64 {
    // Normal equations for the basis (f(y), y, 1).
    let mut m = [[0.0f64; 3]; 3];
    let mut v = [0.0f64; 3];
    for &(y, u) in points {
        let basis = [f(y), y, 1.0];
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += basis[r] * basis[c];
            }
            v[r] += basis[r] * u;
        }
    }
    // Cramer's rule for the first unknown.
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let mut ma = m;
    for r in 0..3 {
        ma[r][0] = v[r];
    }
    det(&ma) / det(&m)
}
