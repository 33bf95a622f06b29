//! The model trait: what a reaction–diffusion model supplies to both backends.

use std::fmt::Debug;

use serde::Serialize;
use serde::de::DeserializeOwned;
use simkit_backend::{Real, Result};

use crate::grid::Grid;

/// One row segment of the padded input fields, handed to [`Model::update_row`].
///
/// Storage is padded with one ghost layer: every plane is row-major with row width
/// `width = nx + 2`, interior rows and columns start at 1. The species planes may be a band of
/// rows (the CPU backend's temporal blocking keeps intermediate steps in a small buffer), so
/// species and coefficient planes carry their own plane length and row index. The segment
/// covers padded columns `i0..i1`.
#[derive(Clone, Copy, Debug)]
pub struct RowIn<'a, T: Real> {
    /// Species planes (the state being advanced), `species_plane` values each.
    pub species: &'a [T],
    /// Values per species plane.
    pub species_plane: usize,
    /// Row of the segment in the species planes (rows `species_row +- 1` are read too).
    pub species_row: usize,
    /// Coefficient planes (static fields such as the colony model's `d`), possibly empty;
    /// `(nx + 2) * (ny + 2)` values each.
    pub coefficients: &'a [T],
    /// Values per coefficient plane, `(nx + 2) * (ny + 2)`.
    pub coefficient_plane: usize,
    /// Padded grid row of the segment (1..=ny): its row in the coefficient planes.
    pub row: usize,
    /// Row width, `nx + 2`.
    pub width: usize,
    /// First padded column of the segment (>= 1).
    pub i0: usize,
    /// One past the last padded column (<= nx + 1).
    pub i1: usize,
}

/// The five stencil slices (centre and the four neighbours) of one field over a row segment,
/// all of the same length.
#[derive(Clone, Copy, Debug)]
pub struct Stencil<'a, T> {
    /// Centre cells.
    pub c: &'a [T],
    /// West neighbours (`i - 1`).
    pub w: &'a [T],
    /// East neighbours (`i + 1`).
    pub e: &'a [T],
    /// South neighbours (`j - 1`).
    pub s: &'a [T],
    /// North neighbours (`j + 1`).
    pub n: &'a [T],
}

impl<'a, T: Real> RowIn<'a, T> {
    fn slices(&self, buf: &'a [T], start: usize) -> Stencil<'a, T> {
        let (a, b) = (start + self.i0, start + self.i1);
        Stencil {
            c: &buf[a..b],
            w: &buf[a - 1..b - 1],
            e: &buf[a + 1..b + 1],
            s: &buf[a - self.width..b - self.width],
            n: &buf[a + self.width..b + self.width],
        }
    }
    /// Stencil slices of species `s`.
    pub fn species_stencil(&self, s: usize) -> Stencil<'a, T> {
        self.slices(
            self.species,
            s * self.species_plane + self.species_row * self.width,
        )
    }
    /// Stencil slices of coefficient field `k`.
    pub fn coefficient_stencil(&self, k: usize) -> Stencil<'a, T> {
        self.slices(
            self.coefficients,
            k * self.coefficient_plane + self.row * self.width,
        )
    }
}

/// A reaction–diffusion model: reaction terms plus a diffusion operator on the 5-point stencil.
///
/// The CPU backend calls [`Model::update_row`] on cache-blocked row segments; the GPU backend
/// compiles [`Model::wgsl`] into its tiled and global-memory kernels with [`Model::gpu_params`]
/// as run-time parameters. Both evaluate the same formula. A model owns its parameters and
/// coefficient fields (`'static`): the simulation keeps it for the whole run. A model is
/// part of every checkpoint, hence the serde bounds (derive `Serialize` and `Deserialize`);
/// [`Model::validate`] is run again on a model read from a checkpoint.
pub trait Model: Clone + Debug + Send + Sync + Serialize + DeserializeOwned + 'static {
    /// Short name, e.g. `"gray-scott"`.
    fn name(&self) -> &'static str;
    /// Number of species fields the model advances.
    fn species(&self) -> usize;
    /// Checks the parameters (and coefficient field sizes against `nx x ny`).
    fn validate(&self, nx: usize, ny: usize) -> Result<()>;
    /// Static coefficient fields (row-major `nx x ny`), e.g. the colony model's `d(x, y)`.
    fn coefficients(&self) -> &[Vec<f64>] {
        &[]
    }
    /// Largest effective diffusivity for the given fields (sets the stability bound
    /// `dt <= h^2 / (4 D_max)`). Must be NaN if a value it depends on is NaN (`f64::max`
    /// skips NaN): a NaN `D_max` makes `step` an error instead of an infinite bound.
    fn max_diffusivity<T: Real>(&self, grid: &Grid<T>) -> f64;
    /// Whether [`Model::max_diffusivity`] depends on the fields (then backends re-check the
    /// stability bound from the current fields before each `step` call).
    fn field_dependent_diffusivity(&self) -> bool {
        false
    }
    /// Largest effective diffusivity over a run of cells: `species[s]` and `coefficients[k]`
    /// hold the values of species `s` and coefficient field `k` of the same cells (equal
    /// lengths). Over all cells of the grid it must equal [`Model::max_diffusivity`] (up to
    /// the rounding of coefficient fields to the fields' precision). The CPU backend uses it
    /// for its re-check before each `step` call: on rows just written by the last sweep of the
    /// previous call (still in cache), or in place. Models with a constant diffusivity return
    /// the constant.
    fn max_cell_diffusivity<T: Real>(&self, species: &[&[T]], coefficients: &[&[T]]) -> f64;
    /// Writes `u + dt * F(u)` over the segment into `out` (one slice per species, each of
    /// length `i1 - i0`); with `average`, writes `(out + u + dt * F(u)) / 2` instead (the second
    /// stage of Heun's method). `inv_h2 = 1 / h^2`.
    fn update_row<T: Real>(
        &self,
        input: &RowIn<'_, T>,
        dt: f64,
        inv_h2: f64,
        out: &mut [&mut [T]],
        average: bool,
    );
    /// WGSL defining `fn model_update(dt: real, ih2: real)`, which reads the stencil with
    /// `ld(field, dx, dy)` (species first, then coefficient fields), the model parameters with
    /// `mp(k)` and writes species `s` with `put(s, value)`; and `fn model_diffusivity() -> real`,
    /// the effective diffusivity at the current cell (the GPU re-check reduces it over the grid
    /// for models with a field-dependent diffusivity).
    fn wgsl(&self) -> &'static str;
    /// Parameter values read by `mp(k)` in [`Model::wgsl`].
    fn gpu_params(&self) -> Vec<f64>;
}
