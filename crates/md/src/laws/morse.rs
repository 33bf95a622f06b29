//! The Morse potential `phi(r) = D0 (e^(-2 alpha (r - r0)) - 2 e^(-alpha (r - r0)))`.

use serde::{Deserialize, Serialize};
use simkit_backend::{Error, Real, Result};

use super::{bounded, check_cutoff, non_negative, positive};
use crate::PairLaw;

/// The Morse potential (Morse 1929), as LAMMPS `pair_style morse`:
/// `phi(r) = D0 (e^(-2 alpha (r - r0)) - 2 e^(-alpha (r - r0)))` for `r < r_c`, zero
/// beyond: a well of depth `D0` at `r0` with curvature `2 alpha^2 D0`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Morse {
    /// Well depth `D0 >= 0`.
    pub d0: f64,
    /// Inverse width `alpha > 0`.
    pub alpha: f64,
    /// Position of the minimum `r0 >= 0`.
    pub r0: f64,
    /// Cutoff `r_c > 0`.
    pub r_c: f64,
}

impl Morse {
    /// The Morse potential with depth `d0`, inverse width `alpha`, minimum at `r0`, cut at
    /// `r_c`.
    pub fn new(d0: f64, alpha: f64, r0: f64, r_c: f64) -> Self {
        Self { d0, alpha, r0, r_c }
    }
}

/// [`Morse`] as the force loops read it: with `x = e^(-alpha (r - r0))`,
/// `phi = d0 (x^2 - 2 x) - shift` and `f / r = two_alpha_d0 x (x - 1) / r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MorseCoeff<T> {
    /// `D0`.
    pub d0: T,
    /// `alpha`.
    pub alpha: T,
    /// `r0`.
    pub r0: T,
    /// `2 alpha D0`.
    pub two_alpha_d0: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift.
    pub shift: T,
}

impl PairLaw for Morse {
    type Coeff<T: Real> = MorseCoeff<T>;
    type Gpu = [f32; 6];
    const NAME: &'static str = "morse";
    const WGSL: &'static str = simkit_backend::wgsl!("laws/morse.wgsl");
    const BUILT_IN: bool = true;

    fn validate(&self, pair: &str) -> Result<()> {
        non_negative(pair, "d0", self.d0, "(0 switches the pair off)")?;
        positive(pair, "alpha", self.alpha)?;
        non_negative(pair, "r0", self.r0, "")?;
        check_cutoff(pair, self.r_c)?;
        // The energy and force at contact, D0 e^(2 alpha r0) and 2 alpha D0 e^(2 alpha r0),
        // must be finite in f32.
        let core = self.d0 * (2.0 * self.alpha * self.r0).exp();
        bounded(pair, "alpha, r0", "D0 e^(2 alpha r0)", core)?;
        bounded(
            pair,
            "alpha, r0",
            "2 alpha D0 e^(2 alpha r0)",
            2.0 * self.alpha * core,
        )?;
        if !(self.alpha * self.r_c).is_finite() {
            return Err(Error::invalid(
                format!("{pair} alpha"),
                self.alpha,
                "alpha r_c must be finite",
            ));
        }
        Ok(())
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        let x = (-self.alpha * (r - self.r0)).exp();
        self.d0 * (x * x - 2.0 * x)
    }

    fn coefficients<T: Real>(&self, shift: f64) -> MorseCoeff<T> {
        MorseCoeff {
            d0: T::from_f64(self.d0),
            alpha: T::from_f64(self.alpha),
            r0: T::from_f64(self.r0),
            two_alpha_d0: T::from_f64(2.0 * self.alpha * self.d0),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &MorseCoeff<f32>) -> [f32; 6] {
        [c.d0, c.alpha, c.r0, c.two_alpha_d0, c.rc2, c.shift]
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &MorseCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let r = r2.sqrt();
            let x = (-(c.alpha * (r - c.r0))).exp();
            let two = T::from_f64(2.0);
            (
                c.two_alpha_d0 * x * (x - T::ONE) / r,
                c.d0 * (x * x - two * x) - c.shift,
            )
        } else {
            (T::ZERO, T::ZERO)
        }
    }

    /// At the minimum `r0`, where `phi'' = 2 alpha^2 D0`; `None` for `D0 = 0`, and for a
    /// minimum at 0 or at or beyond the cutoff.
    fn stiffness(&self) -> Option<(f64, f64)> {
        (self.d0 > 0.0 && self.r0 > 0.0 && self.r0 < self.r_c)
            .then_some((self.r0, 2.0 * self.alpha * self.alpha * self.d0))
    }

    /// `2 alpha D0 x^2 / r` and `2 alpha D0 x / r` for the force, `D0 x^2` and `2 D0 x`
    /// for the energy.
    fn term_sizes(&self, r: f64) -> (f64, f64) {
        let x = (-self.alpha * (r - self.r0)).exp();
        let f = 2.0 * self.alpha * self.d0 * x * x.max(1.0) / r;
        (f, self.d0 * x * x.max(2.0))
    }
}
