//! The Mie potential `phi(r) = C eps ((sigma/r)^n - (sigma/r)^m)`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

use super::{bounded, check_cutoff, non_negative, positive};
use crate::PairLaw;

/// The Mie n–m potential (Mie 1903), as LAMMPS `pair_style mie/cut` (there `gamma_R = n`,
/// `gamma_A = m`): `phi(r) = C eps ((sigma/r)^n - (sigma/r)^m)` for `r < r_c`, zero beyond,
/// with `C = n / (n - m) (n / m)^(m / (n - m))` so that the well depth is `eps` (`C = 4`
/// for 12–6, Lennard-Jones). Real exponents `n > m > 0`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mie {
    /// Well depth `eps >= 0`.
    pub eps: f64,
    /// Length scale `sigma > 0` (`phi(sigma) = 0`).
    pub sigma: f64,
    /// Repulsive exponent `n > m`.
    pub n: f64,
    /// Attractive exponent `m > 0`.
    pub m: f64,
    /// Cutoff `r_c > 0`.
    pub r_c: f64,
}

impl Mie {
    /// Depth `eps`, length `sigma`, exponents `n > m > 0`, cutoff `r_c`.
    pub fn new(eps: f64, sigma: f64, n: f64, m: f64, r_c: f64) -> Self {
        Self {
            eps,
            sigma,
            n,
            m,
            r_c,
        }
    }

    /// The prefactor `C = n / (n - m) (n / m)^(m / (n - m))`.
    pub fn prefactor(&self) -> f64 {
        let (n, m) = (self.n, self.m);
        n / (n - m) * (n / m).powf(m / (n - m))
    }

    /// `phi''(r) = C eps (n (n + 1) sigma^n / r^(n + 2) - m (m + 1) sigma^m / r^(m + 2))`.
    pub fn curvature(&self, r: f64) -> f64 {
        let (n, m) = (self.n, self.m);
        let x = self.sigma / r;
        self.prefactor() * self.eps * (n * (n + 1.0) * x.powf(n) - m * (m + 1.0) * x.powf(m))
            / (r * r)
    }
}

/// [`Mie`] as the force loops read it: with `l = ln(1 / r^2)`,
/// `rep = c_n e^(half_n l)`, `att = c_m e^(half_m l)`, `phi = rep - att - shift` and
/// `f / r = (n rep - m att) / r^2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MieCoeff<T> {
    /// `C eps sigma^n`.
    pub c_n: T,
    /// `C eps sigma^m`.
    pub c_m: T,
    /// `n / 2`.
    pub half_n: T,
    /// `m / 2`.
    pub half_m: T,
    /// `n`.
    pub n: T,
    /// `m`.
    pub m: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift.
    pub shift: T,
}

impl PairLaw for Mie {
    type Coeff<T: Real> = MieCoeff<T>;
    type Gpu = [f32; 8];
    const NAME: &'static str = "mie";
    const WGSL: &'static str = simkit_backend::wgsl!("laws/mie.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        non_negative(pair, "eps", self.eps, "(0 switches the pair off)")?;
        positive(pair, "sigma", self.sigma)?;
        positive(pair, "m", self.m)?;
        if !(self.n.is_finite() && self.n > self.m && self.n <= 100.0) {
            return Err(Error::invalid(
                format!("{pair} n"),
                self.n,
                format!(
                    "the repulsive exponent must be finite, above the attractive one (m = {}) \
                     and at most 100",
                    self.m
                ),
            ));
        }
        check_cutoff(pair, self.r_c)?;
        let c = self.prefactor() * self.eps;
        bounded(
            pair,
            "eps, sigma, n",
            "C eps sigma^n",
            c * self.sigma.powf(self.n),
        )?;
        bounded(
            pair,
            "eps, sigma, m",
            "C eps sigma^m",
            c * self.sigma.powf(self.m),
        )
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        let x = self.sigma / r;
        self.prefactor() * self.eps * (x.powf(self.n) - x.powf(self.m))
    }

    fn coefficients<T: Real>(&self, shift: f64) -> MieCoeff<T> {
        let c = self.prefactor() * self.eps;
        MieCoeff {
            c_n: T::from_f64(c * self.sigma.powf(self.n)),
            c_m: T::from_f64(c * self.sigma.powf(self.m)),
            half_n: T::from_f64(0.5 * self.n),
            half_m: T::from_f64(0.5 * self.m),
            n: T::from_f64(self.n),
            m: T::from_f64(self.m),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &MieCoeff<f32>) -> [f32; 8] {
        [c.c_n, c.c_m, c.half_n, c.half_m, c.n, c.m, c.rc2, c.shift]
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &MieCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let ir2 = T::ONE / r2;
            let l = ir2.ln();
            let rep = c.c_n * (c.half_n * l).exp();
            let att = c.c_m * (c.half_m * l).exp();
            ((c.n * rep - c.m * att) * ir2, rep - att - c.shift)
        } else {
            (T::ZERO, T::ZERO)
        }
    }

    /// At the minimum `sigma (n / m)^(1 / (n - m))`; `None` for `eps = 0`.
    fn stiffness(&self) -> Option<(f64, f64)> {
        if self.eps == 0.0 {
            return None;
        }
        let r = self.sigma * (self.n / self.m).powf(1.0 / (self.n - self.m));
        Some((r, self.curvature(r)))
    }

    /// `n rep / r^2` and `m att / r^2` for the force, `rep` and `att` for the energy.
    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let c = self.prefactor() * self.eps;
        let x = self.sigma / r;
        let (rep, att) = (c * x.powf(self.n), c * x.powf(self.m));
        ((self.n * rep).max(self.m * att) / (r * r), rep.max(att))
    }
}
