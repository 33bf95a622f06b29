//! Shear viscosity from the decay of a sinusoidal shear wave (and the FHP-I theory).
//!
//! The lattice starts near local equilibrium, `N_k = d (1 + 2 c_k . u)`, with the velocity
//! `u_x(y) = U sin(2 pi j / H)` (row j; rows are sqrt(3)/2 apart, so the wavelength is
//! `H sqrt(3)/2`). The projection `A(t) = sum_j sin(2 pi j / H) P_x(j)` of the row momenta
//! decays as `exp(-nu k^2 t)` with `k = 2 pi / (H sqrt(3)/2)`; a least-squares fit of `ln A`
//! against `t` gives `nu`. Runs on the multi-spin backend.

use simkit_backend::{Error, Result, Simulation};

use crate::cpu::multispin::MultiSpinCpu;
use crate::{Config, Lattice, ROW_SPACING, RuleSet};

/// The FHP-I kinematic shear viscosity `1/(12 d (1-d)^3) - 1/8` (Frisch et al. 1987).
pub fn fhp1_viscosity(d: f64) -> f64 {
    1.0 / (12.0 * d * (1.0 - d).powi(3)) - 0.125
}

/// A shear-wave measurement.
#[derive(Clone, Debug)]
pub struct ShearWave {
    /// Sites per row (a multiple of 64); more rows of sites average the noise away.
    pub width: usize,
    /// Rows (even): one wavelength of the shear wave.
    pub height: usize,
    /// Reduced density d (mean occupation per direction).
    pub density: f64,
    /// Velocity amplitude U (keep it small, e.g. 0.1).
    pub amplitude: f64,
    /// Rule set.
    pub rules: RuleSet,
    /// Random seed (initial state and collisions).
    pub seed: u32,
    /// Steps skipped before fitting (initial kinetic transient).
    pub skip: u32,
    /// The fit ends when the amplitude has fallen to this fraction of its value at `skip`.
    pub stop_fraction: f64,
    /// Steps between samples.
    pub sample_every: u32,
}

impl ShearWave {
    /// A measurement at density `d` on a `width x height` lattice with defaults:
    /// U = 0.1, FHP-I, seed 1, skip 30 steps, fit down to 30 % of the amplitude, sample every 10 steps.
    pub fn new(width: usize, height: usize, density: f64) -> Self {
        Self {
            width,
            height,
            density,
            amplitude: 0.1,
            rules: RuleSet::FhpI,
            seed: 1,
            skip: 30,
            stop_fraction: 0.3,
            sample_every: 10,
        }
    }

    /// Runs the measurement and returns the fitted viscosity.
    pub fn measure(&self) -> Result<ShearResult> {
        let d = self.density;
        if !(d > 0.0 && d < 1.0) {
            return Err(Error::invalid("density", d, "must lie in (0, 1)"));
        }
        if !(self.amplitude > 0.0 && 2.0 * d * (1.0 + self.amplitude) <= 1.0 + d) {
            return Err(Error::invalid(
                "amplitude",
                self.amplitude,
                "must be positive and keep every occupation probability <= 1",
            ));
        }
        if !(self.stop_fraction > 0.0 && self.stop_fraction < 1.0) || self.sample_every == 0 {
            return Err(Error::invalid(
                "stop_fraction / sample_every",
                format!("{} / {}", self.stop_fraction, self.sample_every),
                "need 0 < stop_fraction < 1 and sample_every >= 1",
            ));
        }
        let h = self.height;
        let two_pi = std::f64::consts::TAU;
        let cx = [1.0, 0.5, -0.5, -1.0, -0.5, 0.5];
        let mut lattice = Lattice::new(self.width, h)?;
        let u0 = self.amplitude;
        lattice.fill_with(self.seed, |_, j, k| {
            let u = u0 * (two_pi * j as f64 / h as f64).sin();
            (d * (1.0 + 2.0 * cx[k] * u)).clamp(0.0, 1.0)
        })?;
        let config = Config {
            rules: self.rules,
            seed: self.seed,
            ..Config::default()
        };
        let mut sim = MultiSpinCpu::new(lattice, &config)?;
        let weights: Vec<f64> = (0..h)
            .map(|j| (two_pi * j as f64 / h as f64).sin())
            .collect();
        let project = |sim: &MultiSpinCpu| -> f64 {
            sim.row_counts()
                .iter()
                .zip(&weights)
                .map(|(c, w)| {
                    let px: f64 = c.iter().zip(cx).map(|(&n, x)| n as f64 * x).sum();
                    w * px
                })
                .sum()
        };
        sim.step(self.skip)?;
        let a_start = project(&sim);
        let mut samples = vec![(f64::from(self.skip), a_start)];
        let max_steps = 200_000u64;
        loop {
            sim.step(self.sample_every)?;
            let a = project(&sim);
            if a <= self.stop_fraction * a_start || sim.steps_done() > max_steps {
                break;
            }
            samples.push((sim.steps_done() as f64, a));
        }
        if samples.len() < 5 {
            return Err(Error::invalid(
                "sample_every",
                self.sample_every,
                "too few samples before the wave decayed; sample more often",
            ));
        }
        let n = samples.len() as f64;
        let (st, sl) = samples
            .iter()
            .fold((0.0, 0.0), |(a, b), &(t, amp)| (a + t, b + amp.ln()));
        let (mt, ml) = (st / n, sl / n);
        let (sxy, sxx) = samples.iter().fold((0.0, 0.0), |(a, b), &(t, amp)| {
            (a + (t - mt) * (amp.ln() - ml), b + (t - mt) * (t - mt))
        });
        let rate = -sxy / sxx;
        let k = two_pi / (h as f64 * ROW_SPACING);
        Ok(ShearResult {
            density: d,
            viscosity: rate / (k * k),
            theory: fhp1_viscosity(d),
            samples,
        })
    }
}

/// The outcome of a [`ShearWave`] measurement.
#[derive(Clone, Debug)]
pub struct ShearResult {
    /// Reduced density.
    pub density: f64,
    /// Fitted kinematic viscosity (lattice units).
    pub viscosity: f64,
    /// FHP-I theory at this density (for the FHP-I rule set).
    pub theory: f64,
    /// `(step, amplitude)` samples used in the fit.
    pub samples: Vec<(f64, f64)>,
}
