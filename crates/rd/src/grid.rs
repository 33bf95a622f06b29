//! The grid: species fields on a square 2D lattice with spacing `h` and edge conditions.

use rayon::prelude::*;
use simkit_backend::{Error, Real, Result, require_positive};

use crate::boundary::Boundaries;
use simkit_backend::guard::first_non_finite;
use simkit_backend::max_or_nan;

/// One or more species fields on an `nx x ny` grid of square cells of side `h`.
///
/// Field `s` is stored row-major: cell `(i, j)` is `fields[s][j * nx + i]`, `i` along x.
/// This is also the host-side snapshot ([`simkit_backend::Simulation::State`]) of every rd backend.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid<T: Real> {
    nx: usize,
    ny: usize,
    h: f64,
    boundaries: Boundaries,
    fields: Vec<Vec<T>>,
}

impl<T: Real> Grid<T> {
    /// A grid from its fields; checks sizes, `h > 0`, finite values and the boundaries.
    pub fn new(
        nx: usize,
        ny: usize,
        h: f64,
        boundaries: Boundaries,
        fields: Vec<Vec<T>>,
    ) -> Result<Self> {
        let n = check_size(nx, ny)?;
        require_positive("grid spacing h", h)?;
        check_values(n, fields.len())?;
        for (s, f) in fields.iter().enumerate() {
            if f.len() != nx * ny {
                return Err(Error::invalid(
                    format!("length of field {s}"),
                    f.len(),
                    format!("must be nx * ny = {}", nx * ny),
                ));
            }
            if let Some(k) = f.iter().position(|v| !v.to_f64().is_finite()) {
                return Err(Error::invalid(
                    format!("field {s} at cell ({}, {})", k % nx, k / nx),
                    f[k],
                    "every value must be finite",
                ));
            }
        }
        boundaries.validate(fields.len())?;
        Ok(Self {
            nx,
            ny,
            h,
            boundaries,
            fields,
        })
    }

    /// A grid with `species` fields, all set to `value`. The size (`nx * ny * species`
    /// values, overflow-safe) is checked before anything is allocated.
    pub fn uniform(
        nx: usize,
        ny: usize,
        h: f64,
        boundaries: Boundaries,
        species: usize,
        value: T,
    ) -> Result<Self> {
        let n = check_size(nx, ny)?;
        check_values(n, species)?;
        Self::new(nx, ny, h, boundaries, vec![vec![value; n]; species])
    }

    /// Cells along x.
    pub fn nx(&self) -> usize {
        self.nx
    }
    /// Cells along y.
    pub fn ny(&self) -> usize {
        self.ny
    }
    /// Cell side.
    pub fn h(&self) -> f64 {
        self.h
    }
    /// Edge conditions.
    pub fn boundaries(&self) -> &Boundaries {
        &self.boundaries
    }
    /// Number of species fields.
    pub fn species(&self) -> usize {
        self.fields.len()
    }
    /// All fields.
    pub fn fields(&self) -> &[Vec<T>] {
        &self.fields
    }
    /// Field `s` (row-major, `j * nx + i`); the empty slice if there is no species `s`
    /// (`s >= species()`; [`Grid::try_field`] tells the two apart).
    pub fn field(&self, s: usize) -> &[T] {
        self.try_field(s).unwrap_or(&[])
    }
    /// Field `s` (row-major, `j * nx + i`), or `None` if `s >= species()`.
    pub fn try_field(&self, s: usize) -> Option<&[T]> {
        self.fields.get(s).map(Vec::as_slice)
    }
    /// Mutable field `s`: values written here are checked again when a simulation is built.
    /// The empty slice if there is no species `s` (`s >= species()`).
    pub fn field_mut(&mut self, s: usize) -> &mut [T] {
        match self.fields.get_mut(s) {
            Some(f) => f,
            None => &mut [],
        }
    }
    /// Value of species `s` at cell `(i, j)`, or `None` if there is no such species
    /// (`s >= species()`) or cell (`i >= nx()` or `j >= ny()`).
    pub fn get(&self, s: usize, i: usize, j: usize) -> Option<T> {
        if i >= self.nx || j >= self.ny {
            return None;
        }
        self.fields.get(s)?.get(j * self.nx + i).copied()
    }
    /// Integral of species `s` over the domain, `h^2 * sum`, accumulated in `f64`; NaN if
    /// there is no species `s` or a value is NaN.
    pub fn total(&self, s: usize) -> f64 {
        match self.fields.get(s) {
            Some(f) => f.iter().map(|v| v.to_f64()).sum::<f64>() * self.h * self.h,
            None => f64::NAN,
        }
    }
    /// Largest absolute value of species `s`: NaN if any value is NaN (a blown-up run) or
    /// if there is no species `s`.
    pub fn max_abs(&self, s: usize) -> f64 {
        match self.fields.get(s) {
            Some(f) => f.iter().map(|v| v.to_f64().abs()).fold(0.0, max_or_nan),
            None => f64::NAN,
        }
    }
    /// Converts to another precision.
    pub fn convert<U: Real>(&self) -> Grid<U> {
        Grid {
            nx: self.nx,
            ny: self.ny,
            h: self.h,
            boundaries: self.boundaries.clone(),
            fields: self
                .fields
                .iter()
                .map(|f| f.iter().map(|v| U::from_f64(v.to_f64())).collect())
                .collect(),
        }
    }

    /// The fields padded with one ghost layer, concatenated: `species * (nx + 2) * (ny + 2)`.
    pub(crate) fn padded(&self) -> Vec<T> {
        pad(&self.fields, self.nx, self.ny)
    }

    /// Replaces the fields from padded storage (the inverse of [`Grid::padded`]).
    pub(crate) fn set_from_padded(&mut self, p: &[T]) {
        let (nx, ny) = (self.nx, self.ny);
        let plane = (nx + 2) * (ny + 2);
        for (s, f) in self.fields.iter_mut().enumerate() {
            f.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
                let r = s * plane + (j + 1) * (nx + 2) + 1;
                row.copy_from_slice(&p[r..r + nx]);
            });
        }
    }
}

/// Most values (cells times species) a grid may hold: 32-bit indexing of the padded planes
/// with room to spare, and at most 4 GiB of `f64` per copy of the state.
const MAX_VALUES: usize = u32::MAX as usize / 8;

/// Checks `species` fields of `cells` cells each: at least one field, and at most
/// [`MAX_VALUES`] values in all (overflow-safe).
fn check_values(cells: usize, species: usize) -> Result<()> {
    if species == 0 {
        return Err(Error::invalid(
            "fields",
            0,
            "give at least one species field",
        ));
    }
    match cells.checked_mul(species) {
        Some(n) if n <= MAX_VALUES => Ok(()),
        _ => Err(Error::invalid(
            "number of species fields",
            species,
            format!(
                "{species} fields of {cells} cells exceed {MAX_VALUES} values; use fewer \
                 species or a smaller grid"
            ),
        )),
    }
}

/// Checks `nx x ny` (both >= 1, cell count small enough for 32-bit indexing; overflow-safe)
/// and returns the cell count.
pub(crate) fn check_size(nx: usize, ny: usize) -> Result<usize> {
    if nx == 0 || ny == 0 {
        return Err(Error::invalid(
            "grid size",
            format!("{nx} x {ny}"),
            "both dimensions must be >= 1",
        ));
    }
    match nx.checked_mul(ny) {
        Some(n) if n <= MAX_VALUES => Ok(n),
        _ => Err(Error::invalid(
            "grid size",
            format!("{nx} x {ny}"),
            "too many cells for 32-bit indexing; split the domain",
        )),
    }
}

/// Pads row-major `nx x ny` fields with a zero ghost layer and concatenates them.
pub(crate) fn pad<T: Real>(fields: &[Vec<T>], nx: usize, ny: usize) -> Vec<T> {
    let w = nx + 2;
    let plane = w * (ny + 2);
    let mut out = vec![T::default(); plane * fields.len()];
    for (s, f) in fields.iter().enumerate() {
        for j in 0..ny {
            let r = s * plane + (j + 1) * w + 1;
            out[r..r + nx].copy_from_slice(&f[j * nx..(j + 1) * nx]);
        }
    }
    out
}

/// Where padded storage (species planes of `(nx + 2) x (ny + 2)`, as [`pad`] lays them out)
/// first holds a non-finite value: the first bad interior cell in species, row, column
/// order, as `"species s at cell (x, y) = value"`, or, when every interior value is finite,
/// the first bad ghost cell. `None` when every value is finite.
pub(crate) fn first_bad_cell<T: Real>(padded: &[T], nx: usize, ny: usize) -> Option<String> {
    first_non_finite(padded)?;
    let w = nx + 2;
    let plane = w * (ny + 2);
    let mut ghost = None;
    for (s, p) in padded.chunks(plane).enumerate() {
        let mut from = 0;
        while let Some(k) = first_non_finite(&p[from..]) {
            let k = from + k;
            let (i, j) = (k % w, k / w);
            if (1..=nx).contains(&i) && (1..=ny).contains(&j) {
                return Some(format!(
                    "species {s} at cell ({}, {}) = {}",
                    i - 1,
                    j - 1,
                    p[k]
                ));
            }
            ghost.get_or_insert_with(|| {
                let (x, y) = (i.clamp(1, nx) - 1, j.clamp(1, ny) - 1);
                format!(
                    "species {s} in the ghost cell next to cell ({x}, {y}) = {}",
                    p[k]
                )
            });
            from = k + 1;
        }
    }
    ghost
}
