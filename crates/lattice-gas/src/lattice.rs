//! The hexagonal lattice (one byte per site) and obstacles.

use simkit_backend::{Error, Result};

use crate::{REST, WALL};

/// Vertical distance between rows in lattice units (rows of a hexagonal lattice).
pub const ROW_SPACING: f64 = 0.866_025_403_784_438_6;

/// A hexagonal lattice stored as a `width x height` rectangle, odd rows shifted half a site
/// to the right, row `j = 0` at the bottom (south).
///
/// Each site is one byte: bits 0..5 are the directions 1..6 (east, south-east, south-west,
/// west, north-west, north-east), bit 6 is reserved for a rest particle (refused: this is
/// D2Q6), bit 7 marks a wall/obstacle site (no-slip bounce-back).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Lattice {
    width: usize,
    height: usize,
    cells: Vec<u8>,
}

impl Lattice {
    /// An empty lattice. Both sizes must be at least 1 and the site count must fit in u32.
    pub fn new(width: usize, height: usize) -> Result<Self> {
        check_size(width, height)?;
        Ok(Self {
            width,
            height,
            cells: vec![0; width * height],
        })
    }

    /// A lattice from raw site bytes (row-major, `cells[j * width + i]`).
    pub fn from_cells(width: usize, height: usize, cells: Vec<u8>) -> Result<Self> {
        check_size(width, height)?;
        if cells.len() != width * height {
            return Err(Error::invalid(
                "cells.len()",
                cells.len(),
                format!("must equal width * height = {}", width * height),
            ));
        }
        if let Some(pos) = cells.iter().position(|c| c & REST != 0) {
            return Err(Error::invalid(
                format!("cells[{pos}]"),
                cells[pos],
                "bit 6 (rest particle) is not part of the D2Q6 model; clear it",
            ));
        }
        Ok(Self {
            width,
            height,
            cells,
        })
    }

    /// Sites per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// All site bytes, row-major.
    pub fn cells(&self) -> &[u8] {
        &self.cells
    }

    /// The byte of site `(i, j)`, or `None` outside the lattice.
    pub fn get(&self, i: usize, j: usize) -> Option<u8> {
        (i < self.width && j < self.height).then(|| self.cells[j * self.width + i])
    }

    /// Sets site `(i, j)`; errors outside the lattice or with the rest bit set.
    pub fn set(&mut self, i: usize, j: usize, value: u8) -> Result<()> {
        if i >= self.width || j >= self.height {
            return Err(Error::invalid(
                "site",
                format!("({i}, {j})"),
                format!("must lie inside {} x {}", self.width, self.height),
            ));
        }
        if value & REST != 0 {
            return Err(Error::invalid(
                "value",
                value,
                "bit 6 (rest particle) is not allowed",
            ));
        }
        self.cells[j * self.width + i] = value;
        Ok(())
    }

    /// Physical position of site `(i, j)` in lattice units (odd rows shifted by 1/2).
    pub fn position(i: usize, j: usize) -> (f64, f64) {
        (i as f64 + 0.5 * (j & 1) as f64, j as f64 * ROW_SPACING)
    }

    /// Occupies every direction of every non-wall site independently with probability
    /// `density` (the reduced density d), drawing from the counter-based hash with `seed`.
    pub fn fill_random(&mut self, density: f64, seed: u32) -> Result<()> {
        check_probability("density", density)?;
        self.fill_with(seed, |_, _, _| density)
    }

    /// Occupies direction `k` (0..6) of site `(i, j)` with probability `prob(i, j, k)`
    /// (non-wall sites only), drawing from the counter-based hash with `seed`.
    pub fn fill_with(
        &mut self,
        seed: u32,
        prob: impl Fn(usize, usize, usize) -> f64,
    ) -> Result<()> {
        let w = self.width;
        for (s, c) in self.cells.iter_mut().enumerate() {
            if *c & WALL != 0 {
                continue;
            }
            let (i, j) = (s % w, s / w);
            let mut v = 0u8;
            for k in 0..6 {
                let p = prob(i, j, k);
                check_probability("occupation probability", p)?;
                let u = simkit_backend::rng::rng_uniform(seed, k as u32, s as u32);
                if f64::from(u) < p {
                    v |= 1 << k;
                }
            }
            *c = v;
        }
        Ok(())
    }

    /// Marks the bottom and top rows as walls (the channel of the source).
    pub fn add_wall_rows(&mut self) {
        let w = self.width;
        let h = self.height;
        for i in 0..w {
            self.cells[i] |= WALL;
            self.cells[(h - 1) * w + i] |= WALL;
        }
    }

    /// Marks the sites of an obstacle as walls (their particles are kept and bounce back).
    pub fn add_obstacle(&mut self, obstacle: &Obstacle) -> Result<()> {
        let mask = obstacle.mask(self.width, self.height)?;
        for (c, m) in self.cells.iter_mut().zip(mask) {
            if m {
                *c |= WALL;
            }
        }
        Ok(())
    }

    /// Total number of particles.
    pub fn particle_count(&self) -> u64 {
        self.cells
            .iter()
            .map(|c| u64::from((c & 0x3f).count_ones()))
            .sum()
    }

    /// Total momentum in the integer units of [`crate::laws::invariants`]: `(2 p_x, 2 p_y / sqrt(3))`.
    pub fn momentum_units(&self) -> (i64, i64) {
        self.cells.iter().fold((0, 0), |(x, y), &c| {
            let (_, px, py) = crate::rules::invariants(c & 0x3f);
            (x + i64::from(px), y + i64::from(py))
        })
    }
}

/// Checks a lattice size: both sides at least 1, at most 2^32 - 1 sites (overflow-safe).
pub(crate) fn check_size(width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::invalid(
            "lattice size",
            format!("{width} x {height}"),
            "width and height must both be at least 1",
        ));
    }
    // Overflow-safe: `1 << 32` by `1 << 32` must not wrap to a small (or zero) product.
    if width
        .checked_mul(height)
        .is_none_or(|n| n > u32::MAX as usize)
    {
        return Err(Error::invalid(
            "lattice size",
            format!("{width} x {height}"),
            "more than 2^32 - 1 sites; the site index is 32-bit",
        ));
    }
    Ok(())
}

fn check_probability(name: &str, p: f64) -> Result<()> {
    if !(0.0..=1.0).contains(&p) {
        return Err(Error::invalid(name, p, "must be a probability in [0, 1]"));
    }
    Ok(())
}

/// An obstacle shape, rasterised onto the lattice as wall sites.
#[derive(Clone, Debug, PartialEq)]
pub enum Obstacle {
    /// Sites with `x0 <= i < x1` and `y0 <= j < y1` (site indices).
    Rect {
        /// First column.
        x0: usize,
        /// One past the last column.
        x1: usize,
        /// First row.
        y0: usize,
        /// One past the last row.
        y1: usize,
    },
    /// Sites whose physical position ([`Lattice::position`]) lies within `radius` of
    /// `(cx, cy)` (lattice units; rows are sqrt(3)/2 apart).
    Disc {
        /// Centre x.
        cx: f64,
        /// Centre y.
        cy: f64,
        /// Radius.
        radius: f64,
    },
    /// A bitmap of the lattice's size, `true` = wall, row-major in lattice order:
    /// `data[j * width + i]` is site `(i, j)`, so the first `width` flags are the bottom
    /// (south) row `j = 0` and the last `width` flags the top row. (An image, whose row 0 is
    /// usually the top, must be flipped vertically.)
    Mask {
        /// Width of the bitmap (must equal the lattice width).
        width: usize,
        /// Height of the bitmap (must equal the lattice height).
        height: usize,
        /// `width * height` flags.
        data: Vec<bool>,
    },
}

impl Obstacle {
    /// The wall flags of this obstacle on a `width x height` lattice.
    pub fn mask(&self, width: usize, height: usize) -> Result<Vec<bool>> {
        match self {
            Obstacle::Rect { x0, x1, y0, y1 } => {
                if x0 >= x1 || y0 >= y1 || *x1 > width || *y1 > height {
                    return Err(Error::invalid(
                        "Obstacle::Rect",
                        format!("x {x0}..{x1}, y {y0}..{y1}"),
                        format!("must be non-empty and inside the {width} x {height} lattice"),
                    ));
                }
                Ok((0..width * height)
                    .map(|s| {
                        let (i, j) = (s % width, s / width);
                        (*x0..*x1).contains(&i) && (*y0..*y1).contains(&j)
                    })
                    .collect())
            }
            Obstacle::Disc { cx, cy, radius } => {
                if !(cx.is_finite() && cy.is_finite() && radius.is_finite() && *radius > 0.0) {
                    return Err(Error::invalid(
                        "Obstacle::Disc",
                        format!("centre ({cx}, {cy}), radius {radius}"),
                        "centre must be finite and radius positive",
                    ));
                }
                Ok((0..width * height)
                    .map(|s| {
                        let (x, y) = Lattice::position(s % width, s / width);
                        (x - cx).powi(2) + (y - cy).powi(2) <= radius * radius
                    })
                    .collect())
            }
            Obstacle::Mask {
                width: mw,
                height: mh,
                data,
            } => {
                if *mw != width || *mh != height || data.len() != width * height {
                    return Err(Error::invalid(
                        "obstacle mask size",
                        format!("{mw} x {mh} ({} flags)", data.len()),
                        format!("must match the lattice: {width} x {height}"),
                    ));
                }
                Ok(data.clone())
            }
        }
    }
}

impl Lattice {
    /// Internal: wraps cells already known to be valid.
    pub(crate) fn from_raw(width: usize, height: usize, cells: Vec<u8>) -> Self {
        Self {
            width,
            height,
            cells,
        }
    }

    /// Internal: the cell vector.
    pub(crate) fn into_cells(self) -> Vec<u8> {
        self.cells
    }
}
