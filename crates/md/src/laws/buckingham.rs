//! The Buckingham (exp-6) potential `phi(r) = A e^(-r / rho) - C / r^6`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Real, Result};

use super::{bounded, check_cutoff, non_negative, positive, well_inside};
use crate::PairLaw;

/// The Buckingham exp-6 potential (Buckingham 1938), as LAMMPS `pair_style buck`:
/// `phi(r) = A e^(-r / rho) - C / r^6` for `r < r_c`, zero beyond.
///
/// With `C > 0` the potential turns over at short range (the `-C / r^6` term wins below
/// a maximum of `phi`), where pairs collapse: keep pairs outside it (the blow-up guard
/// stops a run whose energies leave the finite range). The time-step guidance measures
/// the curvature at the well when `phi` has one inside the cutoff; otherwise the law gives
/// none and a run needs an explicit [`Config::dt`](crate::Config::dt).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Buckingham {
    /// Repulsion strength `A >= 0`.
    pub a: f64,
    /// Repulsion range `rho > 0`.
    pub rho: f64,
    /// Dispersion coefficient `C >= 0`.
    pub c: f64,
    /// Cutoff `r_c > 0`.
    pub r_c: f64,
}

impl Buckingham {
    /// Strength `a`, range `rho`, dispersion `c`, cutoff `r_c`.
    pub fn new(a: f64, rho: f64, c: f64, r_c: f64) -> Self {
        Self { a, rho, c, r_c }
    }

    /// `phi'(r) = -A / rho e^(-r / rho) + 6 C / r^7`.
    pub fn derivative(&self, r: f64) -> f64 {
        -self.a / self.rho * (-r / self.rho).exp() + 6.0 * self.c / r.powi(7)
    }
}

/// [`Buckingham`] as the force loops read it: `phi = a e^(-r inv_rho) - c / r^6 - shift`,
/// `f / r = a inv_rho e^(-r inv_rho) / r - 6 c / r^8`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuckCoeff<T> {
    /// `A`.
    pub a: T,
    /// `1 / rho`.
    pub inv_rho: T,
    /// `C`.
    pub c: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift.
    pub shift: T,
}

impl PairLaw for Buckingham {
    type Coeff<T: Real> = BuckCoeff<T>;
    type Gpu = [f32; 5];
    const NAME: &'static str = "buck";
    const WGSL: &'static str = simkit_backend::wgsl!("laws/buckingham.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        non_negative(pair, "a", self.a, "")?;
        bounded(pair, "a", "A", self.a)?;
        positive(pair, "rho", self.rho)?;
        bounded(pair, "1 / rho", "1 / rho", 1.0 / self.rho)?;
        non_negative(pair, "c", self.c, "")?;
        bounded(pair, "c", "C", self.c)?;
        check_cutoff(pair, self.r_c)
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        self.a * (-r / self.rho).exp() - self.c / r.powi(6)
    }

    fn coefficients<T: Real>(&self, shift: f64) -> BuckCoeff<T> {
        BuckCoeff {
            a: T::from_f64(self.a),
            inv_rho: T::from_f64(1.0 / self.rho),
            c: T::from_f64(self.c),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &BuckCoeff<f32>) -> [f32; 5] {
        [c.a, c.inv_rho, c.c, c.rc2, c.shift]
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &BuckCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let r = r2.sqrt();
            let ex = c.a * (-(r * c.inv_rho)).exp();
            let ir2 = T::ONE / r2;
            let att = c.c * ir2 * ir2 * ir2;
            let six = T::from_f64(6.0);
            (ex * c.inv_rho / r - six * att * ir2, ex - att - c.shift)
        } else {
            (T::ZERO, T::ZERO)
        }
    }

    /// At the well of `phi` when it lies inside the cutoff.
    fn stiffness(&self) -> Option<(f64, f64)> {
        if self.a == 0.0 {
            return None;
        }
        let r = well_inside(self.r_c, |r| self.derivative(r))?;
        let k = self.a / (self.rho * self.rho) * (-r / self.rho).exp() - 42.0 * self.c / r.powi(8);
        (k > 0.0).then_some((r, k))
    }

    /// `A e^(-r / rho) / (rho r)` and `6 C / r^8` for the force, `A e^(-r / rho)` and
    /// `C / r^6` for the energy.
    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let ex = self.a * (-r / self.rho).exp();
        let att = self.c / r.powi(6);
        ((ex / (self.rho * r)).max(6.0 * att / (r * r)), ex.max(att))
    }
}
