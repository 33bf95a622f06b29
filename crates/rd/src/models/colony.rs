//! The bacterial colony model (after Kawasaki et al.) in conservative flux form.

use multiversion::multiversion;
use rayon::prelude::*;
use simkit_backend::{Error, Real, Result, require_non_negative};

use crate::grid::{Grid, check_size};
use crate::model::{Model, RowIn, Stencil};
use crate::models::store;
use simkit_backend::max_or_nan;

/// Bacteria `b` (species 0) feeding on nutrient `n` (species 1):
///
/// `db/dt = div(d n b grad b) + n b / (1 + gamma n)`, `dn/dt = lap n - n b / (1 + gamma n)`,
///
/// with a static, spatially varying coefficient `d(x, y)`.
///
/// The nonlinear term is discretised in conservative flux form: with `kappa = d n b` per cell,
/// the flux through the face between cells P and Q is `(kappa_P + kappa_Q) / 2 * (b_Q - b_P) / h`,
/// and what leaves one cell enters its neighbour, so diffusion alone conserves the total of `b`
/// to round-off. (The expanded form `d (b n lap b + b grad b . grad n + n |grad b|^2)` with
/// central differences is consistent but not conservative, and it drops the `grad d` term.)
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Colony {
    gamma: f64,
    nx: usize,
    ny: usize,
    d: Vec<Vec<f64>>,
}

impl Colony {
    /// A colony model with saturation `gamma >= 0` and coefficient field `d` (row-major
    /// `nx x ny`, every value finite and `>= 0`).
    pub fn new(gamma: f64, nx: usize, ny: usize, d: Vec<f64>) -> Result<Self> {
        let m = Self {
            gamma,
            nx,
            ny,
            d: vec![d],
        };
        m.validate(nx, ny)?;
        Ok(m)
    }

    /// The coefficient `d = mean * (1 + amplitude * U(-1, 1))`, drawn per cell from the shared
    /// counter-based RNG with `seed` (reproducible on any machine). Errors for a grid size the
    /// [`Grid`] would refuse (checked before allocating).
    pub fn random_d(
        nx: usize,
        ny: usize,
        mean: f64,
        amplitude: f64,
        seed: u32,
    ) -> Result<Vec<f64>> {
        let cells = check_size(nx, ny)?;
        Ok((0..cells)
            .map(|k| {
                let u = f64::from(simkit_backend::rng::rng_uniform(seed, 0, k as u32));
                mean * (1.0 + amplitude * (2.0 * u - 1.0))
            })
            .collect())
    }

    /// Saturation constant `gamma`.
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// The coefficient field `d` (row-major).
    pub fn d(&self) -> &[f64] {
        self.d.first().map_or(&[], Vec::as_slice)
    }

    /// The reaction term `n b / (1 + gamma n)` at one cell.
    pub fn reaction(&self, b: f64, n: f64) -> f64 {
        n * b / (1.0 + self.gamma * n)
    }
}

#[derive(Clone, Copy)]
struct Coefs<T> {
    /// dt / (2 h^2)
    half_a: T,
    /// dt / h^2
    a: T,
    dt: T,
    gamma: T,
}

#[inline(always)]
fn rows<T: Real, const AVG: bool>(
    b: Stencil<'_, T>,
    nu: Stencil<'_, T>,
    d: Stencil<'_, T>,
    k: Coefs<T>,
    ob: &mut [T],
    on: &mut [T],
) {
    let len = ob.len().min(on.len());
    let (bc, bw, be, bs, bn) = (
        &b.c[..len],
        &b.w[..len],
        &b.e[..len],
        &b.s[..len],
        &b.n[..len],
    );
    let (nc, nw, ne, ns, nn) = (
        &nu.c[..len],
        &nu.w[..len],
        &nu.e[..len],
        &nu.s[..len],
        &nu.n[..len],
    );
    let (dc, dw, de, ds, dn) = (
        &d.c[..len],
        &d.w[..len],
        &d.e[..len],
        &d.s[..len],
        &d.n[..len],
    );
    let (ob, on) = (&mut ob[..len], &mut on[..len]);
    let one = T::from_f64(1.0);
    let four = T::from_f64(4.0);
    for i in 0..len {
        let kc = dc[i] * nc[i] * bc[i];
        let kw = dw[i] * nw[i] * bw[i];
        let ke = de[i] * ne[i] * be[i];
        let ks = ds[i] * ns[i] * bs[i];
        let kn = dn[i] * nn[i] * bn[i];
        let flux = ((kc + kw) * (bw[i] - bc[i]) + (kc + ke) * (be[i] - bc[i]))
            + ((kc + ks) * (bs[i] - bc[i]) + (kc + kn) * (bn[i] - bc[i]));
        let r = nc[i] * bc[i] / (one + k.gamma * nc[i]);
        let lap_n = (nw[i] + ne[i]) + (ns[i] + nn[i]) - four * nc[i];
        store::<T, AVG>(&mut ob[i], bc[i] + (k.half_a * flux + k.dt * r));
        store::<T, AVG>(&mut on[i], nc[i] + (k.a * lap_n - k.dt * r));
    }
}

/// Largest `d b n` over a row segment (0 if none is positive, NaN if any is NaN), multiplied
/// in the same order as [`Colony::max_diffusivity`] (so in f64 the two agree exactly).
/// Sixteen independent running maxima, so the loop vectorises without reordering anything.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma+avx", "x86_64+avx2+fma+avx"))]
fn max_kappa<T: Real>(b: &[T], n: &[T], d: &[T]) -> f64 {
    const LANES: usize = 16;
    let len = b.len().min(n.len()).min(d.len());
    let mut acc = [T::default(); LANES];
    let mut k = 0;
    while k + LANES <= len {
        let (b, n, d) = (&b[k..k + LANES], &n[k..k + LANES], &d[k..k + LANES]);
        for j in 0..LANES {
            let v = d[j] * b[j] * n[j];
            // A NaN is taken, and then kept (`v > NaN` is false), as in `max_or_nan`; an
            // unordered self-comparison is the NaN test.
            let nan = v.partial_cmp(&v).is_none();
            acc[j] = if v > acc[j] || nan { v } else { acc[j] };
        }
        k += LANES;
    }
    let mut m = acc.iter().fold(0.0, |m, v| max_or_nan(m, v.to_f64()));
    for i in k..len {
        m = max_or_nan(m, (d[i] * b[i] * n[i]).to_f64());
    }
    m
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma+avx", "x86_64+avx2+fma+avx"))]
fn colony_row<T: Real>(
    b: Stencil<'_, T>,
    n: Stencil<'_, T>,
    d: Stencil<'_, T>,
    k: Coefs<T>,
    ob: &mut [T],
    on: &mut [T],
    average: bool,
) {
    if average {
        rows::<T, true>(b, n, d, k, ob, on);
    } else {
        rows::<T, false>(b, n, d, k, ob, on);
    }
}

impl Model for Colony {
    fn name(&self) -> &'static str {
        "bacterial colony"
    }
    fn species(&self) -> usize {
        2
    }
    fn validate(&self, nx: usize, ny: usize) -> Result<()> {
        require_non_negative("gamma", self.gamma)?;
        let d = self.d();
        if self.d.len() != 1
            || (nx, ny) != (self.nx, self.ny)
            || Some(d.len()) != nx.checked_mul(ny)
        {
            return Err(Error::invalid(
                "coefficient field d",
                format!(
                    "{} fields, {} values for a {} x {} model",
                    self.d.len(),
                    d.len(),
                    self.nx,
                    self.ny
                ),
                format!("must be one field of nx * ny = {nx} x {ny} values, matching the grid"),
            ));
        }
        if let Some(k) = d.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::invalid(
                format!("d at cell ({}, {})", k % nx, k / nx),
                d[k],
                "must be finite and >= 0",
            ));
        }
        Ok(())
    }
    fn coefficients(&self) -> &[Vec<f64>] {
        &self.d
    }
    fn max_diffusivity<T: Real>(&self, grid: &Grid<T>) -> f64 {
        let (b, n) = (grid.field(0), grid.field(1));
        if b.len() != self.d().len() || n.len() != self.d().len() {
            // Not this model's grid (the backends check the model against the grid first).
            return f64::NAN;
        }
        // Re-checked before every `step` call: a parallel pass over the fields.
        let kappa = self
            .d()
            .par_iter()
            .zip(b.par_iter().zip(n.par_iter()))
            .map(|(d, (b, n))| d * b.to_f64() * n.to_f64())
            .reduce(|| 0.0, max_or_nan);
        max_or_nan(kappa, 1.0)
    }
    fn field_dependent_diffusivity(&self) -> bool {
        true
    }
    fn max_cell_diffusivity<T: Real>(&self, species: &[&[T]], coefficients: &[&[T]]) -> f64 {
        // The backends always pass b, n and d; anything else is refused by the guard.
        let ([b, n, ..], [d, ..]) = (species, coefficients) else {
            return f64::INFINITY;
        };
        max_or_nan(max_kappa(b, n, d), 1.0)
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
            half_a: T::from_f64(0.5 * dt * inv_h2),
            a: T::from_f64(dt * inv_h2),
            dt: T::from_f64(dt),
            gamma: T::from_f64(self.gamma),
        };
        let [ob, on] = out else { return };
        colony_row(
            input.species_stencil(0),
            input.species_stencil(1),
            input.coefficient_stencil(0),
            k,
            ob,
            on,
            average,
        );
    }
    fn wgsl(&self) -> &'static str {
        simkit_backend::wgsl!("model_colony.wgsl")
    }
    fn gpu_params(&self) -> Vec<f64> {
        vec![self.gamma]
    }
}
