//! Linear diffusion with a constant diffusivity per species.

use multiversion::multiversion;
use simkit_backend::{Error, Real, Result};

use crate::grid::Grid;
use crate::model::{Model, RowIn, Stencil};
use crate::models::store;
use simkit_backend::max_or_nan;

/// `du_s/dt = D_s lap u_s` for 1 to 4 independent species: the validation workhorse.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Diffusion {
    diffusivity: Vec<f64>,
}

impl Diffusion {
    /// Most species a diffusion model can hold.
    pub const MAX_SPECIES: usize = 4;

    /// One species per diffusivity (each finite and `>= 0`; 1 to 4 species).
    pub fn new(diffusivity: &[f64]) -> Result<Self> {
        let m = Self {
            diffusivity: diffusivity.to_vec(),
        };
        m.check()?;
        Ok(m)
    }

    /// The diffusivities.
    pub fn diffusivity(&self) -> &[f64] {
        &self.diffusivity
    }

    fn check(&self) -> Result<()> {
        let n = self.diffusivity.len();
        if n == 0 || n > Self::MAX_SPECIES {
            return Err(Error::invalid(
                "number of diffusivities",
                n,
                format!("give 1 to {} (one per species)", Self::MAX_SPECIES),
            ));
        }
        for (s, &d) in self.diffusivity.iter().enumerate() {
            if !(d.is_finite() && d >= 0.0) {
                return Err(Error::invalid(
                    format!("diffusivity of species {s}"),
                    d,
                    "must be finite and >= 0",
                ));
            }
        }
        Ok(())
    }
}

#[inline(always)]
fn rows<T: Real, const AVG: bool>(st: Stencil<'_, T>, a: T, out: &mut [T]) {
    let n = out.len();
    let (c, w, e, s, nn) = (&st.c[..n], &st.w[..n], &st.e[..n], &st.s[..n], &st.n[..n]);
    let four = T::from_f64(4.0);
    for i in 0..n {
        let lap = (w[i] + e[i]) + (s[i] + nn[i]) - four * c[i];
        store::<T, AVG>(&mut out[i], c[i] + a * lap);
    }
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma+avx", "x86_64+avx2+fma+avx"))]
fn diffusion_row<T: Real>(st: Stencil<'_, T>, a: T, out: &mut [T], average: bool) {
    if average {
        rows::<T, true>(st, a, out);
    } else {
        rows::<T, false>(st, a, out);
    }
}

impl Model for Diffusion {
    fn name(&self) -> &'static str {
        "diffusion"
    }
    fn species(&self) -> usize {
        self.diffusivity.len()
    }
    fn validate(&self, _nx: usize, _ny: usize) -> Result<()> {
        self.check()
    }
    fn max_diffusivity<T: Real>(&self, _grid: &Grid<T>) -> f64 {
        self.diffusivity.iter().copied().fold(0.0, max_or_nan)
    }
    fn max_cell_diffusivity<T: Real>(&self, _species: &[&[T]], _coefficients: &[&[T]]) -> f64 {
        self.diffusivity.iter().copied().fold(0.0, max_or_nan)
    }
    fn update_row<T: Real>(
        &self,
        input: &RowIn<'_, T>,
        dt: f64,
        inv_h2: f64,
        out: &mut [&mut [T]],
        average: bool,
    ) {
        for (s, o) in out.iter_mut().enumerate() {
            let a = T::from_f64(self.diffusivity[s] * dt * inv_h2);
            diffusion_row(input.species_stencil(s), a, o, average);
        }
    }
    fn wgsl(&self) -> &'static str {
        simkit_backend::wgsl!("model_diffusion.wgsl")
    }
    fn gpu_params(&self) -> Vec<f64> {
        let mut p = self.diffusivity.clone();
        p.resize(Self::MAX_SPECIES, 0.0);
        p
    }
}
