//! The Langevin thermostat: settings, the Ornstein–Uhlenbeck coefficients of every species
//! and the Gaussian numbers it draws (counter-based, the same on the CPU and the GPU).
//!
//! The step is the BAOAB splitting of Leimkuhler & Matthews (2013): half kick `B`, half
//! drift `A`, the exact Ornstein–Uhlenbeck update `O` of the velocities
//! `v <- c1 v + sqrt((1 - c1^2) k_B T / m) R` with `c1 = exp(-gamma dt)` and `R` standard
//! normal, half drift `A`, forces, half kick `B`. The two half drifts around `O` are fused
//! into one drift `x += (v + v') dt / 2` followed by the boundary rule, so a thermostatted
//! step costs one pass more than NVE only in the random numbers and the `O` update.

use serde::{Deserialize, Serialize};
use simkit_backend::rng::rng_uniform;

use crate::{PairLaw, System};

/// A Langevin thermostat (BAOAB splitting; see the crate guide `docs/md.md`).
///
/// The random numbers are keyed by `(seed, step, particle index)`
/// ([`simkit_backend::rng`]), so a run is reproducible, the CPU and GPU backends draw the
/// same numbers and a resumed run continues the same stream. Per-species targets override
/// these with [`System::set_species_langevin`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Langevin {
    /// Target temperature `k_B T >= 0` (reduced units, `k_B = 1`).
    pub temperature: f64,
    /// Friction `gamma >= 0` (inverse time); `0` leaves the dynamics Newtonian.
    pub gamma: f64,
    /// Seed of the random stream.
    pub seed: u32,
}

impl Langevin {
    /// A thermostat at `temperature` with friction `gamma` and seed `seed`.
    pub fn new(temperature: f64, gamma: f64, seed: u32) -> Self {
        Self {
            temperature,
            gamma,
            seed,
        }
    }
}

/// The Ornstein–Uhlenbeck coefficients `(c1, amplitude)` of every species for time step
/// `dt`: `c1 = exp(-gamma dt)`, `amplitude = sqrt((1 - c1^2) T / m)`; `(1, 0)` for a frozen
/// species (its velocities stay zero).
pub(crate) fn ou_coefficients<L: PairLaw>(
    system: &System<L>,
    global: &Langevin,
    dt: f64,
) -> Vec<(f64, f64)> {
    system
        .masses()
        .iter()
        .enumerate()
        .map(|(s, &m)| {
            if system.frozen()[s] {
                return (1.0, 0.0);
            }
            let (t, gamma) = system.species_langevin()[s]
                .map_or((global.temperature, global.gamma), |[t, g]| (t, g));
            let c1 = (-gamma * dt).exp();
            (c1, ((1.0 - c1 * c1) * t / m).sqrt())
        })
        .collect()
}

/// Two standard normal numbers from two uniforms in `[0, 1)` (Box–Muller), computed in
/// `f64` from the `f32` uniforms; twin of `md_normal_pair` in `shaders/noise.wgsl`.
#[inline(always)]
pub(crate) fn normal_pair(u1: f32, u2: f32) -> [f64; 2] {
    let r = (-2.0 * (1.0 - f64::from(u1)).ln()).sqrt();
    let a = 2.0 * std::f64::consts::PI * f64::from(u2);
    [r * a.cos(), r * a.sin()]
}

/// The `D` standard normal numbers of particle `i` at step `step`: Box–Muller pairs from
/// the uniforms of keys `(seed, step, 4 i + k)`, `k = 0..4`.
#[inline(always)]
pub(crate) fn gaussians<const D: usize>(seed: u32, step: u32, i: u32) -> [f64; D] {
    let base = i.wrapping_mul(4);
    let u = |k: u32| rng_uniform(seed, step, base.wrapping_add(k));
    let a = normal_pair(u(0), u(1));
    if D > 2 {
        let b = normal_pair(u(2), u(3));
        std::array::from_fn(|d| if d < 2 { a[d] } else { b[d - 2] })
    } else {
        std::array::from_fn(|d| a[d])
    }
}
