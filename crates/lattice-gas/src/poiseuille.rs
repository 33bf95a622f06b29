//! Plane Poiseuille flow: the viscosity from the velocity profile of a body-forced channel.
//!
//! Walls on the top and bottom rows, periodic in x, a body force that turns a west-mover at a
//! site without an east-mover into an east-mover with probability `p`. In the steady state
//! the time-averaged row velocities follow `nu u''(y) = -g(y)`. Two estimates:
//!
//! - **at-rest acceleration**: `g` measured as the momentum gained per particle per step in a
//!   periodic box at rest with the same density and `p`; fitting `u = a y^2 + b y + c` gives
//!   `nu = -g / (2 a)`. This overstates the force, which can only act where a west-mover
//!   meets no east-mover, fewer such sites in a flowing channel;
//! - **local acceleration**: `g(y) = 2 p / (1 - p) * <eligible sites> / <particles>` counted on
//!   each row of the sampled lattice (sampled after the force acted, hence the `1 - p`);
//!   `G'' = -g` integrated twice (trapezoid rule) and `u = G(y) / nu + b y + c` fitted.
//!
//! Both compared with the FHP-I Boltzmann viscosity `1/(12 d (1-d)^3) - 1/8` (Frisch et al.
//! 1987). Runs on the multi-spin backend (the width must be a multiple of 64).

use simkit_backend::{Error, Result, Simulation};

use crate::cpu::multispin::MultiSpinCpu;
use crate::field::CX;
use crate::viscosity::fhp1_viscosity;
use crate::{Config, EAST, Lattice, ROW_SPACING, WALL, WEST};

/// A body-forced channel measurement.
#[derive(Clone, Debug)]
pub struct PoiseuilleChannel {
    /// Sites per row (a multiple of 64).
    pub width: usize,
    /// Rows, the two wall rows included (even, at least 8).
    pub height: usize,
    /// Reduced density d.
    pub density: f64,
    /// Body-force probability p.
    pub force: f64,
    /// Random seed.
    pub seed: u32,
    /// Steps before averaging (the slowest mode relaxes in about `H^2 / (pi^2 nu)` steps).
    pub relax: u32,
    /// Steps averaged over.
    pub average: u32,
    /// Steps between samples.
    pub every: u32,
}

impl PoiseuilleChannel {
    /// A channel of `width x height` sites at density `d` and force `p`, seed 9, relaxed
    /// and averaged over `16000 (H / 64)^2` steps each (at least 4000), sampled every 20
    /// steps.
    pub fn new(width: usize, height: usize, density: f64, force: f64) -> Self {
        let relax =
            (height.saturating_mul(height).saturating_mul(16_000) / (64 * 64)).clamp(4000, 1 << 30);
        Self {
            width,
            height,
            density,
            force,
            seed: 9,
            relax: relax as u32,
            average: relax as u32,
            every: 20,
        }
    }

    /// Runs the box and the channel and fits both viscosities.
    pub fn measure(&self) -> Result<PoiseuilleResult> {
        let (w, h, d, p) = (self.width, self.height, self.density, self.force);
        if h < 8 || !h.is_multiple_of(2) {
            return Err(Error::invalid(
                "height",
                h,
                "use an even number of rows, at least 8",
            ));
        }
        let open_unit = |x: f64| x > 0.0 && x < 1.0;
        if !(open_unit(d) && open_unit(p)) {
            return Err(Error::invalid(
                "density / force",
                format!("{d} / {p}"),
                "both must lie in (0, 1)",
            ));
        }
        if self.every == 0 || self.average < self.every {
            return Err(Error::invalid(
                "every / average",
                format!("{} / {}", self.every, self.average),
                "need 1 <= every <= average",
            ));
        }
        // 1. The acceleration at rest: periodic box, momentum gain per particle per step.
        let mut free = Lattice::new(w, h)?;
        free.fill_random(d, self.seed)?;
        let config = Config {
            body_force: p,
            seed: self.seed,
            ..Config::default()
        };
        let mut boxed = MultiSpinCpu::new(free, &config)?;
        let totals = |sim: &MultiSpinCpu| {
            row_momenta(sim)
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
        lattice.fill_random(d, self.seed.wrapping_add(1))?;
        let channel = Config {
            periodic_y: false,
            ..config
        };
        let mut sim = MultiSpinCpu::new(lattice, &channel)?;
        sim.step(self.relax)?;
        let mut sums = vec![(0.0, 0.0); h];
        let mut eligible = vec![0.0f64; h];
        for _ in 0..self.average / self.every {
            sim.step(self.every)?;
            for (s, r) in sums.iter_mut().zip(row_momenta(&sim)) {
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
        // Fluid rows 1..h-1; y in lattice units.
        let profile: Vec<(f64, f64)> = (1..h - 1)
            .map(|j| (j as f64 * ROW_SPACING, sums[j].0 / sums[j].1))
            .collect();
        let a = fit_three(&profile, |y| y * y);
        // G'' = -g(y), integrated twice over the fluid rows (trapezoid rule).
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
        Ok(PoiseuilleResult {
            acceleration: g,
            nu_at_rest: -g / (2.0 * a),
            nu_local: 1.0 / inv_nu,
            theory: fhp1_viscosity(d),
            centre_velocity: profile
                .iter()
                .map(|&(_, u)| u)
                .fold(f64::NEG_INFINITY, simkit_backend::max_or_nan),
            profile,
        })
    }
}

/// The outcome of a [`PoiseuilleChannel`] measurement.
#[derive(Clone, Debug)]
pub struct PoiseuilleResult {
    /// Acceleration per step measured in the periodic box at rest.
    pub acceleration: f64,
    /// Viscosity from the parabola and the at-rest acceleration.
    pub nu_at_rest: f64,
    /// Viscosity from the fit with the local acceleration of each row.
    pub nu_local: f64,
    /// FHP-I Boltzmann viscosity at this density.
    pub theory: f64,
    /// Largest row velocity.
    pub centre_velocity: f64,
    /// `(y, u_x)` of the fluid rows (y in lattice units).
    pub profile: Vec<(f64, f64)>,
}

/// `(x momentum, particles)` of each row.
fn row_momenta(sim: &MultiSpinCpu) -> Vec<(f64, f64)> {
    sim.row_counts()
        .iter()
        .map(|c| {
            let px = c.iter().zip(CX).map(|(&n, x)| n as f64 * x).sum();
            (px, c.iter().sum::<u64>() as f64)
        })
        .collect()
}

/// Least-squares fit `u = a f(y) + b y + c`; returns `a` (Cramer's rule on the normal
/// equations of the basis `(f(y), y, 1)`).
fn fit_three(points: &[(f64, f64)], f: impl Fn(f64) -> f64) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::fit_three;

    #[test]
    fn the_fit_recovers_a_parabola() {
        let pts: Vec<(f64, f64)> = (0..10)
            .map(|i| {
                let y = f64::from(i) * 0.5;
                (y, -0.3 * y * y + 2.0 * y - 1.0)
            })
            .collect();
        assert!((fit_three(&pts, |y| y * y) + 0.3).abs() < 1e-12);
    }
}
