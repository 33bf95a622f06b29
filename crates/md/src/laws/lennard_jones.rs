//! The Lennard-Jones family `phi(r) = 4 eps (a (sigma/r)^12 - b (sigma/r)^6)`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

use super::{MAX_COEFFICIENT, check_cutoff, non_negative, positive};
use crate::PairLaw;

/// `phi(r) = 4 eps (a (sigma/r)^12 - b (sigma/r)^6)` for `r < r_c`, zero beyond.
///
/// `a = b = 1` is the Lennard-Jones potential (LAMMPS `lj/cut`); `b = 0` a purely
/// repulsive `r^-12` wall.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LennardJones {
    /// Energy scale `eps >= 0`.
    pub eps: f64,
    /// Length scale `sigma > 0`.
    pub sigma: f64,
    /// Weight of the repulsive `r^-12` term (`a >= 0`).
    pub a: f64,
    /// Weight of the attractive `r^-6` term (`b >= 0`).
    pub b: f64,
    /// Cutoff `r_c > 0`: the pair does not interact at `r >= r_c`.
    pub r_c: f64,
}

impl LennardJones {
    /// Lennard-Jones (`a = b = 1`).
    pub fn new(eps: f64, sigma: f64, r_c: f64) -> Self {
        Self::weighted(eps, sigma, 1.0, 1.0, r_c)
    }

    /// Purely repulsive `4 eps (sigma/r)^12` (`a = 1`, `b = 0`).
    pub fn repulsive(eps: f64, sigma: f64, r_c: f64) -> Self {
        Self::weighted(eps, sigma, 1.0, 0.0, r_c)
    }

    /// Any weights of the two terms (checked when the law enters a
    /// [`PairTable`](crate::PairTable)).
    pub fn weighted(eps: f64, sigma: f64, a: f64, b: f64, r_c: f64) -> Self {
        Self {
            eps,
            sigma,
            a,
            b,
            r_c,
        }
    }

    /// `phi''(r) = 4 eps (156 a sigma^12 / r^14 - 42 b sigma^6 / r^8)`.
    pub fn curvature(&self, r: f64) -> f64 {
        let x6 = (self.sigma / r).powi(6);
        4.0 * self.eps * (156.0 * self.a * x6 * x6 - 42.0 * self.b * x6) / (r * r)
    }

    /// The distance at which the time-step guidance measures the pair's stiffness: the
    /// minimum of `phi`, `sigma (2 a / b)^(1/6)`, when `a, b > 0`, else the distance where
    /// the repulsive term alone equals `4 eps`, `sigma a^(1/12)`.
    pub fn stiffness_distance(&self) -> f64 {
        if self.a > 0.0 && self.b > 0.0 {
            self.sigma * (2.0 * self.a / self.b).powf(1.0 / 6.0)
        } else {
            self.sigma * self.a.powf(1.0 / 12.0)
        }
    }
}

/// [`LennardJones`] as the force loops read it: `phi(r) = c12 / r^12 - c6 / r^6 - shift`
/// for `r^2 < rc2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LjCoeff<T> {
    /// `4 eps a sigma^12`.
    pub c12: T,
    /// `4 eps b sigma^6`.
    pub c6: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift (`phi(r_c)` when energies are shifted, else 0).
    pub shift: T,
}

impl PairLaw for LennardJones {
    type Coeff<T: Real> = LjCoeff<T>;
    type Gpu = [f32; 4];
    const NAME: &'static str = "lj";
    const WGSL: &'static str = simkit_backend::wgsl!("laws/lennard_jones.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        let p = *self;
        non_negative(pair, "eps", p.eps, "(0 switches the pair off)")?;
        positive(pair, "sigma", p.sigma)?;
        non_negative(pair, "a", p.a, "")?;
        non_negative(pair, "b", p.b, "")?;
        check_cutoff(pair, p.r_c)?;
        // The coefficients 4 eps a sigma^12 and 4 eps b sigma^6 must be finite in f32 too.
        let c12 = 4.0 * p.eps * p.a * p.sigma.powi(12);
        let c6 = 4.0 * p.eps * p.b * p.sigma.powi(6);
        if !(c12 <= MAX_COEFFICIENT && c6 <= MAX_COEFFICIENT) {
            return Err(Error::invalid(
                format!("{pair} eps, sigma, a, b"),
                format!("{p:?}"),
                format!(
                    "4 eps a sigma^12 = {c12:e} and 4 eps b sigma^6 = {c6:e} must stay below \
                     {MAX_COEFFICIENT:e}; rescale the energy or length unit"
                ),
            ));
        }
        Ok(())
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        let x6 = (self.sigma / r).powi(6);
        4.0 * self.eps * (self.a * x6 * x6 - self.b * x6)
    }

    fn coefficients<T: Real>(&self, shift: f64) -> LjCoeff<T> {
        let s6 = self.sigma.powi(6);
        LjCoeff {
            c12: T::from_f64(4.0 * self.eps * self.a * s6 * s6),
            c6: T::from_f64(4.0 * self.eps * self.b * s6),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &LjCoeff<f32>) -> [f32; 4] {
        [c.c12, c.c6, c.rc2, c.shift]
    }

    /// `f / r = (12 c12 / r^12 - 6 c6 / r^6) / r^2`, `phi = c12 / r^12 - c6 / r^6 - shift`.
    #[inline(always)]
    fn force_energy<T: Real>(c: &LjCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let ir2 = T::ONE / r2;
            let ir6 = ir2 * ir2 * ir2;
            let rep = c.c12 * ir6 * ir6;
            let att = c.c6 * ir6;
            let twelve = T::from_f64(12.0);
            let six = T::from_f64(6.0);
            ((twelve * rep - six * att) * ir2, rep - att - c.shift)
        } else {
            (T::ZERO, T::ZERO)
        }
    }

    /// At [`LennardJones::stiffness_distance`]; `None` when `eps = 0` or `a = 0`.
    fn stiffness(&self) -> Option<(f64, f64)> {
        if self.eps == 0.0 || self.a == 0.0 {
            return None;
        }
        let r = self.stiffness_distance();
        Some((r, self.curvature(r)))
    }

    /// The repulsive and attractive terms: `12 c12 / r^14` and `6 c6 / r^8` for the force,
    /// `c12 / r^12` and `c6 / r^6` for the energy.
    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let c = self.coefficients::<f64>(0.0);
        let ir6 = (r * r).powi(-3);
        let (rep, att) = (c.c12 * ir6 * ir6, c.c6 * ir6);
        ((12.0 * rep).max(6.0 * att) / (r * r), rep.max(att))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PairTable;

    #[test]
    fn law_matches_the_closed_form_and_its_derivative() {
        let p = LennardJones::weighted(1.3, 0.9, 0.7, 1.1, 2.7);
        let c = PairTable::uniform(1, p).unwrap().coefficients::<f64>(false)[0];
        for &r in &[0.8, 1.0, 1.2, 2.0, 2.69] {
            let (fr, e) = LennardJones::force_energy(&c, r * r);
            assert!((e - p.energy(r)).abs() < 1e-12 * p.energy(r).abs().max(1.0));
            let h = 1e-6;
            let deriv = (p.energy(r + h) - p.energy(r - h)) / (2.0 * h);
            assert!(
                (fr * r + deriv).abs() < 1e-6 * deriv.abs().max(1.0),
                "r = {r}"
            );
        }
        assert_eq!(LennardJones::force_energy(&c, 2.7 * 2.7), (0.0, 0.0));
        let cs = PairTable::uniform(1, p).unwrap().coefficients::<f64>(true)[0];
        let r = 2.7 - 1e-9;
        assert!(LennardJones::force_energy(&cs, r * r).1.abs() < 1e-8);
    }

    #[test]
    fn minimum_and_curvature_of_lennard_jones() {
        let p = LennardJones::new(1.0, 1.0, 2.5);
        let rm = p.stiffness_distance();
        assert!((rm - 2f64.powf(1.0 / 6.0)).abs() < 1e-15);
        assert!((p.energy(rm) + 1.0).abs() < 1e-14);
        // 72 eps / (2^(1/3) sigma^2).
        assert!((p.curvature(rm) - 72.0 / 2f64.powf(1.0 / 3.0)).abs() < 1e-11);
    }
}
