//! The Gray–Scott model (Pearson 1993).

use multiversion::multiversion;
use simkit_backend::{Error, Real, Result, require_finite};

use crate::grid::Grid;
use crate::model::{Model, RowIn, Stencil};
use crate::models::store;
use simkit_backend::max_or_nan;

/// Gray–Scott: `du/dt = Du lap u - u v^2 + F (1 - u)`, `dv/dt = Dv lap v + u v^2 - (F + k) v`.
///
/// Species 0 is `u` (the substrate), species 1 is `v` (the autocatalyst). The named
/// constructors use Pearson's (1993) set-up: `Du = 2e-5`, `Dv = 1e-5` on a domain of side 2.5
/// (so `h = 2.5 / 256` on his 256 x 256 grid, see [`GrayScott::PEARSON_H`]) with `dt = 1`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GrayScott {
    /// Diffusivity of `u`.
    pub du: f64,
    /// Diffusivity of `v`.
    pub dv: f64,
    /// Feed rate `F`.
    pub feed: f64,
    /// Kill rate `k`.
    pub kill: f64,
}

impl GrayScott {
    /// Pearson's grid spacing: a domain of side 2.5 on 256 cells.
    pub const PEARSON_H: f64 = 2.5 / 256.0;

    /// A Gray–Scott model; all parameters finite, diffusivities and rates `>= 0`.
    pub fn new(du: f64, dv: f64, feed: f64, kill: f64) -> Result<Self> {
        let m = Self { du, dv, feed, kill };
        m.check()?;
        Ok(m)
    }

    fn pearson(feed: f64, kill: f64) -> Self {
        Self {
            du: 2e-5,
            dv: 1e-5,
            feed,
            kill,
        }
    }

    /// Self-replicating spots (`F = 0.035`, `k = 0.065`).
    pub fn spots() -> Self {
        Self::pearson(0.035, 0.065)
    }

    /// Stripes / labyrinth (`F = 0.055`, `k = 0.062`).
    pub fn stripes() -> Self {
        Self::pearson(0.055, 0.062)
    }

    /// Worms: isolated, elongating stripe segments (`F = 0.058`, `k = 0.065`).
    pub fn worms() -> Self {
        Self::pearson(0.058, 0.065)
    }

    fn check(&self) -> Result<()> {
        for (name, v) in [
            ("Du", self.du),
            ("Dv", self.dv),
            ("feed F", self.feed),
            ("kill k", self.kill),
        ] {
            require_finite(name, v)?;
            if v < 0.0 {
                return Err(Error::invalid(name, v, "must be >= 0"));
            }
        }
        Ok(())
    }
}

#[derive(Clone, Copy)]
struct Coefs<T> {
    au: T,
    av: T,
    dt: T,
    feed: T,
    fk: T,
}

#[inline(always)]
fn rows<T: Real, const AVG: bool>(
    u: Stencil<'_, T>,
    v: Stencil<'_, T>,
    k: Coefs<T>,
    ou: &mut [T],
    ov: &mut [T],
) {
    let n = ou.len().min(ov.len());
    let (uc, uw, ue, us, un) = (&u.c[..n], &u.w[..n], &u.e[..n], &u.s[..n], &u.n[..n]);
    let (vc, vw, ve, vs, vn) = (&v.c[..n], &v.w[..n], &v.e[..n], &v.s[..n], &v.n[..n]);
    let (ou, ov) = (&mut ou[..n], &mut ov[..n]);
    let one = T::from_f64(1.0);
    let four = T::from_f64(4.0);
    for i in 0..n {
        let lu = (uw[i] + ue[i]) + (us[i] + un[i]) - four * uc[i];
        let lv = (vw[i] + ve[i]) + (vs[i] + vn[i]) - four * vc[i];
        let uvv = uc[i] * vc[i] * vc[i];
        let nu = uc[i] + (k.au * lu + k.dt * (k.feed * (one - uc[i]) - uvv));
        let nv = vc[i] + (k.av * lv + k.dt * (uvv - k.fk * vc[i]));
        store::<T, AVG>(&mut ou[i], nu);
        store::<T, AVG>(&mut ov[i], nv);
    }
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma+avx", "x86_64+avx2+fma+avx"))]
fn gray_scott_row<T: Real>(
    u: Stencil<'_, T>,
    v: Stencil<'_, T>,
    k: Coefs<T>,
    ou: &mut [T],
    ov: &mut [T],
    average: bool,
) {
    if average {
        rows::<T, true>(u, v, k, ou, ov);
    } else {
        rows::<T, false>(u, v, k, ou, ov);
    }
}

impl Model for GrayScott {
    fn name(&self) -> &'static str {
        "gray-scott"
    }
    fn species(&self) -> usize {
        2
    }
    fn validate(&self, _nx: usize, _ny: usize) -> Result<()> {
        self.check()
    }
    fn max_diffusivity<T: Real>(&self, _grid: &Grid<T>) -> f64 {
        max_or_nan(self.du, self.dv)
    }
    fn max_cell_diffusivity<T: Real>(&self, _species: &[&[T]], _coefficients: &[&[T]]) -> f64 {
        max_or_nan(self.du, self.dv)
    }
    fn update_row<T: Real>(
        &self,
        input: &RowIn<'_, T>,
        dt: f64,
        inv_h2: f64,
        out: &mut [&mut [T]],
        average: bool,
    ) {
        let k = Coefs {
            au: T::from_f64(self.du * dt * inv_h2),
            av: T::from_f64(self.dv * dt * inv_h2),
            dt: T::from_f64(dt),
            feed: T::from_f64(self.feed),
            fk: T::from_f64(self.feed + self.kill),
        };
        let [ou, ov] = out else { return };
        gray_scott_row(
            input.species_stencil(0),
            input.species_stencil(1),
            k,
            ou,
            ov,
            average,
        );
    }
    fn wgsl(&self) -> &'static str {
        simkit_backend::wgsl!("model_gray_scott.wgsl")
    }
    fn gpu_params(&self) -> Vec<f64> {
        vec![self.du, self.dv, self.feed, self.feed + self.kill]
    }
}
