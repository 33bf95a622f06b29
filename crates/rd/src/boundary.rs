//! Boundary conditions per grid edge, applied through one layer of ghost cells.
//!
//! Fields are cell-centred: cell `(i, j)` has its centre at `((i + 1/2) h, (j + 1/2) h)` and the
//! domain edges lie on cell faces. Each boundary condition sets the ghost cell outside an edge
//! so that the 5-point stencil needs no branches:
//!
//! - [`Boundary::NoFlux`]: ghost = adjacent interior cell (zero gradient on the face, so the
//!   diffusive flux through the face is exactly zero and totals are conserved to round-off);
//! - [`Boundary::Periodic`]: ghost = the interior cell on the opposite edge;
//! - [`Boundary::Dirichlet`]: ghost = `2 g - interior`, so the face value is `g`.

use simkit_backend::{Error, Real, Result};

/// The condition on one edge of the grid.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Boundary {
    /// Zero normal gradient (mirror): nothing flows through the edge.
    NoFlux,
    /// Wrap-around to the opposite edge (must be set on both opposite edges).
    Periodic,
    /// Fixed value on the edge face, one value per species.
    Dirichlet(Vec<f64>),
}

impl Boundary {
    /// The boundary kind as the WGSL kernels encode it.
    #[cfg(feature = "gpu")]
    pub(crate) fn code(&self) -> u32 {
        match self {
            Boundary::NoFlux => 0,
            Boundary::Periodic => 1,
            Boundary::Dirichlet(_) => 2,
        }
    }
}

/// Boundary conditions on the four edges (west = `i = 0`, east = `i = nx - 1`,
/// south = `j = 0`, north = `j = ny - 1`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Boundaries {
    /// Edge at `i = 0`.
    pub west: Boundary,
    /// Edge at `i = nx - 1`.
    pub east: Boundary,
    /// Edge at `j = 0`.
    pub south: Boundary,
    /// Edge at `j = ny - 1`.
    pub north: Boundary,
}

impl Boundaries {
    /// The same condition on all four edges.
    pub fn all(b: Boundary) -> Self {
        Self {
            west: b.clone(),
            east: b.clone(),
            south: b.clone(),
            north: b,
        }
    }

    /// No-flux (mirror) on all edges.
    pub fn no_flux() -> Self {
        Self::all(Boundary::NoFlux)
    }

    /// Periodic in both directions.
    pub fn periodic() -> Self {
        Self::all(Boundary::Periodic)
    }

    /// The edges in the order west, east, south, north.
    pub fn edges(&self) -> [&Boundary; 4] {
        [&self.west, &self.east, &self.south, &self.north]
    }

    /// Checks pairing of periodic edges and the Dirichlet values against `species`.
    pub fn validate(&self, species: usize) -> Result<()> {
        let pair = |a: &Boundary, b: &Boundary, axis: &str| {
            if (*a == Boundary::Periodic) != (*b == Boundary::Periodic) {
                Err(Error::invalid(
                    format!("boundaries ({axis})"),
                    format!("{a:?} / {b:?}"),
                    "periodic must be set on both opposite edges or on neither",
                ))
            } else {
                Ok(())
            }
        };
        pair(&self.west, &self.east, "west/east")?;
        pair(&self.south, &self.north, "south/north")?;
        for (name, b) in ["west", "east", "south", "north"].iter().zip(self.edges()) {
            if let Boundary::Dirichlet(v) = b {
                if v.len() != species {
                    return Err(Error::invalid(
                        format!("Dirichlet values on the {name} edge"),
                        format!("{} values", v.len()),
                        format!("give one value per species ({species})"),
                    ));
                }
                if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                    return Err(Error::invalid(
                        format!("Dirichlet value on the {name} edge"),
                        x,
                        "must be finite",
                    ));
                }
            }
        }
        Ok(())
    }

    /// The same edges with every Dirichlet edge replaced by no-flux (used for coefficient
    /// fields, which have no boundary value of their own).
    pub(crate) fn for_coefficients(&self) -> Self {
        let f = |b: &Boundary| match b {
            Boundary::Dirichlet(_) => Boundary::NoFlux,
            other => other.clone(),
        };
        Self {
            west: f(&self.west),
            east: f(&self.east),
            south: f(&self.south),
            north: f(&self.north),
        }
    }
}

/// The boundary rule: the ghost value of species `s` outside an edge with condition `b`, from
/// the adjacent interior cell and the interior cell on the opposite edge. Used by every CPU
/// path through [`fill_ghosts`]; its WGSL twin is `ghost_value` in `shaders/boundary.wgsl`.
#[inline]
pub(crate) fn ghost_value<T: Real>(b: &Boundary, s: usize, inner: T, opposite: T) -> T {
    match b {
        Boundary::NoFlux => inner,
        Boundary::Periodic => opposite,
        Boundary::Dirichlet(v) => T::from_f64(2.0) * T::from_f64(v[s]) - inner,
    }
}

/// Fills the ghost layer of species field `s` stored padded (`(nx + 2) x (ny + 2)`, row-major).
pub(crate) fn fill_ghosts<T: Real>(f: &mut [T], nx: usize, ny: usize, s: usize, bc: &Boundaries) {
    let w = nx + 2;
    let ghost = |b: &Boundary, inner: T, opposite: T| ghost_value(b, s, inner, opposite);
    for j in 1..=ny {
        let r = j * w;
        f[r] = ghost(&bc.west, f[r + 1], f[r + nx]);
        f[r + nx + 1] = ghost(&bc.east, f[r + nx], f[r + 1]);
    }
    for i in 1..=nx {
        f[i] = ghost(&bc.south, f[w + i], f[ny * w + i]);
        f[(ny + 1) * w + i] = ghost(&bc.north, f[ny * w + i], f[w + i]);
    }
}
