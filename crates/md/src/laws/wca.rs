//! The Weeks–Chandler–Andersen potential: Lennard-Jones cut at its minimum and lifted by
//! `eps`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Real, Result};

use super::{LennardJones, LjCoeff, positive};
use crate::PairLaw;

/// The Weeks–Chandler–Andersen (WCA) soft sphere (Weeks, Chandler & Andersen 1971):
/// `phi(r) = 4 eps ((sigma/r)^12 - (sigma/r)^6) + eps` for `r < 2^(1/6) sigma`, zero
/// beyond, a purely repulsive potential continuous with its force at the cutoff (LAMMPS:
/// `lj/cut` with cutoff `2^(1/6) sigma` and `pair_modify shift yes`). It runs the
/// Lennard-Jones kernels ([`LennardJones`]'s coefficients and WGSL, the energy shift
/// `-eps` folded into them).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wca {
    /// Energy scale `eps >= 0`.
    pub eps: f64,
    /// Length scale `sigma > 0`; the cutoff is `2^(1/6) sigma`.
    pub sigma: f64,
}

impl Wca {
    /// WCA with energy `eps` and length `sigma`.
    pub fn new(eps: f64, sigma: f64) -> Self {
        Self { eps, sigma }
    }

    /// The Lennard-Jones potential cut at `2^(1/6) sigma`.
    pub fn lennard_jones(&self) -> LennardJones {
        LennardJones::new(self.eps, self.sigma, self.cutoff())
    }
}

impl PairLaw for Wca {
    type Coeff<T: Real> = LjCoeff<T>;
    type Gpu = [f32; 4];
    const NAME: &'static str = "wca";
    const WGSL: &'static str = LennardJones::WGSL;
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        positive(pair, "sigma", self.sigma)?;
        self.lennard_jones().validate(pair)
    }

    /// `2^(1/6) sigma`.
    fn cutoff(&self) -> f64 {
        2f64.powf(1.0 / 6.0) * self.sigma
    }

    fn energy(&self, r: f64) -> f64 {
        self.lennard_jones().energy(r) + self.eps
    }

    fn coefficients<T: Real>(&self, shift: f64) -> LjCoeff<T> {
        self.lennard_jones().coefficients(shift - self.eps)
    }

    fn gpu(c: &LjCoeff<f32>) -> [f32; 4] {
        LennardJones::gpu(c)
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &LjCoeff<T>, r2: T) -> (T, T) {
        LennardJones::force_energy(c, r2)
    }

    /// At the cutoff `2^(1/6) sigma` (the Lennard-Jones minimum, where a WCA pair is
    /// as stiff as a Lennard-Jones one: `phi'' = 57.15 eps / sigma^2`); `None` for
    /// `eps = 0`.
    fn stiffness(&self) -> Option<(f64, f64)> {
        let lj = self.lennard_jones();
        (self.eps > 0.0).then(|| {
            let r = lj.stiffness_distance();
            (r, lj.curvature(r))
        })
    }

    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let (f, e) = self.lennard_jones().term_sizes(r);
        (f, e.max(self.eps))
    }
}
