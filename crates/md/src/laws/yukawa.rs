//! The screened Coulomb (Yukawa) potential `phi(r) = A e^(-kappa r) / r`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Real, Result};

use super::{bounded, check_cutoff, non_negative};
use crate::PairLaw;

/// The screened Coulomb (Yukawa, Debye–Hückel) potential, as LAMMPS `pair_style yukawa`:
/// `phi(r) = A e^(-kappa r) / r` for `r < r_c`, zero beyond (`A > 0`: like charges,
/// `A < 0`: opposite ones; `kappa` the inverse screening length).
///
/// The law has no well and no intrinsic closest distance, so it gives no time-step
/// guidance ([`PairLaw::stiffness`] is `None`): a system of Yukawa pairs needs an explicit
/// [`Config::dt`](crate::Config::dt).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Yukawa {
    /// Strength `A` (energy times length).
    pub a: f64,
    /// Inverse screening length `kappa >= 0` (`0`: bare Coulomb, cut at `r_c`).
    pub kappa: f64,
    /// Cutoff `r_c > 0`.
    pub r_c: f64,
}

impl Yukawa {
    /// Strength `a`, inverse screening length `kappa`, cutoff `r_c`.
    pub fn new(a: f64, kappa: f64, r_c: f64) -> Self {
        Self { a, kappa, r_c }
    }
}

/// [`Yukawa`] as the force loops read it: `phi = a e^(-kappa r) / r - shift`,
/// `f / r = a e^(-kappa r) (1 + kappa r) / r^3`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YukawaCoeff<T> {
    /// `A`.
    pub a: T,
    /// `kappa`.
    pub kappa: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift.
    pub shift: T,
}

impl PairLaw for Yukawa {
    type Coeff<T: Real> = YukawaCoeff<T>;
    type Gpu = [f32; 4];
    const NAME: &'static str = "yukawa";
    const WGSL: &'static str = simkit_backend::wgsl!("laws/yukawa.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        if self.a.is_nan() {
            return Err(simkit_backend::Error::invalid(
                format!("{pair} a"),
                self.a,
                "must be a finite strength (A > 0: like charges, A < 0: opposite ones)",
            ));
        }
        bounded(pair, "a", "A", self.a)?;
        non_negative(pair, "kappa", self.kappa, "(0: unscreened)")?;
        bounded(pair, "kappa", "kappa", self.kappa)?;
        check_cutoff(pair, self.r_c)
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        self.a * (-self.kappa * r).exp() / r
    }

    fn coefficients<T: Real>(&self, shift: f64) -> YukawaCoeff<T> {
        YukawaCoeff {
            a: T::from_f64(self.a),
            kappa: T::from_f64(self.kappa),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &YukawaCoeff<f32>) -> [f32; 4] {
        [c.a, c.kappa, c.rc2, c.shift]
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &YukawaCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let r = r2.sqrt();
            let e = c.a * (-(c.kappa * r)).exp() / r;
            (e * (T::ONE + c.kappa * r) / r2, e - c.shift)
        } else {
            (T::ZERO, T::ZERO)
        }
    }
}
