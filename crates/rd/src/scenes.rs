//! Ready-made scenes and observables: the source's colony scene, a seeded Gray–Scott square,
//! the colony gap width and a spot counter.

use simkit_backend::{Real, Result, rng::rng_uniform};

use crate::boundary::Boundaries;
use crate::grid::{Grid, check_size};
use crate::models::Colony;

/// The source's bacterial-colony scene scaled to `nx x ny` (the original is 512 x 512):
/// `h = 0.5`, `gamma = 0.5`, `d = 0.75 (1 + 0.4 U(-1, 1))`, `n = 1 + 0.1 U(-1, 1)`, `b = 0`
/// except two 17 x 17 squares with `b = 0.7` centred at cells `(103, 127)` and `(151, 127)`
/// scaled by `n / 512` (on 512 x 512: cells 95..=111 and 143..=159 along x, 119..=135 along
/// y, the source's 1-based ranges 96..112, 144..160 and 120..136); no-flux edges. Random values come from the shared RNG with
/// `seed`.
pub fn colony_scene<T: Real>(nx: usize, ny: usize, seed: u32) -> Result<(Grid<T>, Colony)> {
    let d = Colony::random_d(nx, ny, 0.75, 0.4, seed)?;
    let model = Colony::new(0.5, nx, ny, d)?;
    let n: Vec<T> = (0..nx * ny)
        .map(|k| {
            let u = f64::from(rng_uniform(seed, 1, k as u32));
            T::from_f64(1.0 + 0.1 * (2.0 * u - 1.0))
        })
        .collect();
    let mut b = vec![T::default(); nx * ny];
    let cy = (ny * 127) / 512;
    for cx in [(nx * 103) / 512, (nx * 151) / 512] {
        for j in cy.saturating_sub(8)..(cy + 9).min(ny) {
            for i in cx.saturating_sub(8)..(cx + 9).min(nx) {
                b[j * nx + i] = T::from_f64(0.7);
            }
        }
    }
    let grid = Grid::new(nx, ny, 0.5, Boundaries::no_flux(), vec![b, n])?;
    Ok((grid, model))
}

/// Pearson's initial condition on a periodic `n x n` grid: `u = 1`, `v = 0`, except a centred
/// square of `side` cells (clamped to `n`) with `u = 0.5`, `v = 0.25`; both perturbed by 1 %
/// noise (shared RNG, `seed`).
/// Errors for a size the [`Grid`] refuses (checked before allocating).
pub fn gray_scott_square<T: Real>(n: usize, h: f64, side: usize, seed: u32) -> Result<Grid<T>> {
    check_size(n, n)?;
    let mut u = vec![1.0f64; n * n];
    let mut v = vec![0.0f64; n * n];
    let side = side.min(n);
    let lo = (n - side) / 2;
    let hi = lo + side;
    for j in lo..hi {
        for i in lo..hi {
            u[j * n + i] = 0.5;
            v[j * n + i] = 0.25;
        }
    }
    let noise = |f: &mut [f64], step: u32| {
        for (k, x) in f.iter_mut().enumerate() {
            *x += 0.01 * (2.0 * f64::from(rng_uniform(seed, step, k as u32)) - 1.0);
        }
    };
    noise(&mut u, 0);
    noise(&mut v, 1);
    let conv = |f: Vec<f64>| f.into_iter().map(T::from_f64).collect::<Vec<T>>();
    Grid::new(n, n, h, Boundaries::periodic(), vec![conv(u), conv(v)])
}

/// Number of connected regions (4-neighbour, periodic wrap) where species `s` exceeds
/// `threshold`.
pub fn count_spots<T: Real>(grid: &Grid<T>, s: usize, threshold: f64) -> usize {
    let (nx, ny) = (grid.nx(), grid.ny());
    let f = grid.field(s);
    let mut seen = vec![false; nx * ny];
    let mut count = 0;
    let mut stack = Vec::new();
    for start in 0..nx * ny {
        if seen[start] || f[start].to_f64() <= threshold {
            continue;
        }
        count += 1;
        seen[start] = true;
        stack.push(start);
        while let Some(k) = stack.pop() {
            let (i, j) = (k % nx, k / nx);
            for (a, b) in [
                ((i + 1) % nx, j),
                ((i + nx - 1) % nx, j),
                (i, (j + 1) % ny),
                (i, (j + ny - 1) % ny),
            ] {
                let q = b * nx + a;
                if !seen[q] && f[q].to_f64() > threshold {
                    seen[q] = true;
                    stack.push(q);
                }
            }
        }
    }
    count
}

/// Width (in length units) of the widest run of cells with `b < threshold` along row `j`
/// strictly between columns `i_left` and `i_right`: the gap the two colonies leave (0 if row
/// `j` is outside the grid).
pub fn gap_width<T: Real>(
    grid: &Grid<T>,
    j: usize,
    i_left: usize,
    i_right: usize,
    threshold: f64,
) -> f64 {
    let mut best = 0;
    let mut run = 0;
    for i in i_left + 1..i_right.min(grid.nx()) {
        if grid.get(0, i, j).is_some_and(|b| b.to_f64() < threshold) {
            run += 1;
            best = best.max(run);
        } else {
            run = 0;
        }
    }
    best as f64 * grid.h()
}

/// Population variance of species `s` (NaN if there is no species `s`).
pub fn variance<T: Real>(grid: &Grid<T>, s: usize) -> f64 {
    let f = grid.field(s);
    let n = f.len() as f64;
    let mean = f.iter().map(|v| v.to_f64()).sum::<f64>() / n;
    f.iter().map(|v| (v.to_f64() - mean).powi(2)).sum::<f64>() / n
}
