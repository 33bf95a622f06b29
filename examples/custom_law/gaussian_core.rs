//! A pair law defined outside `simkit-md`: the Gaussian core model (Stillinger 1976),
//! `phi(r) = eps exp(-(r / sigma)^2)` cut at `r_c`, a bounded repulsion that lets particles
//! pass through each other (a model of polymer coils in solution).
//!
//! Everything a law provides is here: its parameters (this type), the coefficients the
//! force loops read (`GaussCoeff`, derived once), the force and energy as one Rust function
//! generic over `Real` (used by every CPU path, both precisions, SIMD included), its WGSL
//! twin (the GPU kernels are built from it), the cutoff, the curvature for the time-step
//! guidance and the validation. `examples/custom_law/main.rs` runs it; `tests/custom_law.rs`
//! tests the WGSL against the Rust function with `simkit::md::check_law_on_gpu`.

use serde::{Deserialize, Serialize};
use simkit::backend::{Error, Real, Result};
use simkit::md::PairLaw;

/// `phi(r) = eps exp(-(r / sigma)^2)` for `r < r_c`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaussianCore {
    /// Height of the core `eps >= 0` (the energy of two particles on top of each other).
    pub eps: f64,
    /// Width `sigma > 0`.
    pub sigma: f64,
    /// Cutoff `r_c > 0` (`3.5 sigma`: `phi(r_c) = 5e-6 eps`).
    pub r_c: f64,
}

/// [`GaussianCore`] as the force loops read it: with `g = eps exp(-r^2 / sigma^2)`,
/// `phi = g - shift` and `f / r = 2 g / sigma^2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussCoeff<T> {
    /// `eps`.
    pub eps: T,
    /// `1 / sigma^2`.
    pub inv_s2: T,
    /// `r_c^2`.
    pub rc2: T,
    /// The energy shift.
    pub shift: T,
}

impl PairLaw for GaussianCore {
    type Coeff<T: Real> = GaussCoeff<T>;
    type Gpu = [f32; 4];
    const NAME: &'static str = "gaussian-core";
    // The WGSL twin: `struct MdCoeff` mirrors `Gpu` (four f32), `md_pair_force_energy` is
    // `force_energy` line by line.
    const WGSL: &'static str = "
struct MdCoeff {
    eps: f32,
    inv_s2: f32,
    rc2: f32,
    shift: f32,
}

fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 < c.rc2) {
        let g = c.eps * exp(-(r2 * c.inv_s2));
        return vec2<f32>(2.0 * g * c.inv_s2, g - c.shift);
    }
    return vec2<f32>(0.0, 0.0);
}
";

    fn validate(&self, pair: &str) -> Result<()> {
        for (name, v, positive) in [
            ("eps", self.eps, false),
            ("sigma", self.sigma, true),
            ("r_c", self.r_c, true),
        ] {
            let ok = v.is_finite() && (v > 0.0 || (!positive && v == 0.0));
            if !ok {
                return Err(Error::invalid(
                    format!("{pair} {name}"),
                    v,
                    if positive {
                        "must be finite and > 0"
                    } else {
                        "must be finite and >= 0"
                    },
                ));
            }
        }
        if !(self.eps <= 1e30 && (1.0 / (self.sigma * self.sigma)) <= 1e30) {
            return Err(Error::invalid(
                format!("{pair} eps, sigma"),
                format!("{self:?}"),
                "eps and 1 / sigma^2 must stay below 1e30 (finite in f32)",
            ));
        }
        Ok(())
    }

    fn cutoff(&self) -> f64 {
        self.r_c
    }

    fn energy(&self, r: f64) -> f64 {
        self.eps * (-(r / self.sigma).powi(2)).exp()
    }

    fn coefficients<T: Real>(&self, shift: f64) -> GaussCoeff<T> {
        GaussCoeff {
            eps: T::from_f64(self.eps),
            inv_s2: T::from_f64(1.0 / (self.sigma * self.sigma)),
            rc2: T::from_f64(self.r_c * self.r_c),
            shift: T::from_f64(shift),
        }
    }

    fn gpu(c: &GaussCoeff<f32>) -> [f32; 4] {
        [c.eps, c.inv_s2, c.rc2, c.shift]
    }

    #[inline(always)]
    fn force_energy<T: Real>(c: &GaussCoeff<T>, r2: T) -> (T, T) {
        if r2 < c.rc2 {
            let g = c.eps * (-(r2 * c.inv_s2)).exp();
            (T::from_f64(2.0) * g * c.inv_s2, g - c.shift)
        } else {
            (T::ZERO, T::ZERO)
        }
    }

    /// The core has no well; its stiffest point is the inflection of the force,
    /// `r* = sigma sqrt(3/2)`, where `phi'' = 4 e^(-3/2) eps / sigma^2`.
    fn stiffness(&self) -> Option<(f64, f64)> {
        (self.eps > 0.0).then(|| {
            let r = self.sigma * 1.5f64.sqrt();
            (
                r,
                4.0 * (-1.5f64).exp() * self.eps / (self.sigma * self.sigma),
            )
        })
    }
}
