//! The lattice vectors and block sums of density and momentum: the data every backend and
//! the observables share (the multi-spin backend fills a [`BlockField`] straight from its
//! bit-planes, [`BlockField::from_lattice`] from the site bytes).

use simkit_backend::{Error, Result};

use crate::{Lattice, ROW_SPACING, WALL};

/// x components of the six unit lattice vectors (directions 1..6).
pub const CX: [f64; 6] = [1.0, 0.5, -0.5, -1.0, -0.5, 0.5];
/// y components of the six unit lattice vectors (directions 1..6).
pub const CY: [f64; 6] = [
    0.0,
    -ROW_SPACING,
    -ROW_SPACING,
    0.0,
    ROW_SPACING,
    ROW_SPACING,
];

/// Number of particles at a site.
pub fn site_density(cell: u8) -> u32 {
    (cell & 0x3f).count_ones()
}

/// Momentum `(p_x, p_y)` of a site (unit particle mass and speed).
pub fn site_momentum(cell: u8) -> (f64, f64) {
    (0..6)
        .filter(|k| cell & (1 << k) != 0)
        .fold((0.0, 0.0), |(x, y), k| (x + CX[k], y + CY[k]))
}

/// Sums over `block x block` groups of fluid (non-wall) sites; the last block of a row or
/// column is smaller when the size is not a multiple of `block`. Block `(bx, by)` is entry
/// `by * nx + bx`; block row 0 holds lattice rows `0..block` (the bottom).
///
/// Built by [`BlockField::zeros`], [`BlockField::from_lattice`] or a simulation's
/// `block_field`, and read through its accessors: the fields are private, so the block
/// counts and the arrays' lengths always agree (a field cannot be edited into a shape its
/// methods would index out of bounds).
///
/// ```compile_fail
/// let mut f = simkit_lattice_gas::BlockField::zeros(64, 32, 8).unwrap();
/// f.nx = 0; // private: a field's shape is fixed when it is built
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BlockField {
    /// Blocks along x.
    pub(crate) nx: usize,
    /// Blocks along y.
    pub(crate) ny: usize,
    /// Block side in sites.
    pub(crate) block: usize,
    /// Fluid site-visits per block (sites times samples).
    pub(crate) sites: Vec<f64>,
    /// Particles per block (summed over samples).
    pub(crate) particles: Vec<f64>,
    /// Momentum x per block (summed).
    pub(crate) px: Vec<f64>,
    /// Momentum y per block (summed).
    pub(crate) py: Vec<f64>,
    /// Samples summed.
    pub(crate) samples: u64,
}

impl BlockField {
    /// An all-zero field of one sample over a `width x height` lattice in `block x block`
    /// blocks; errors unless the size is a valid lattice size (as [`Lattice::new`] checks)
    /// and `1 <= block <= max(width, height)`.
    pub fn zeros(width: usize, height: usize, block: usize) -> Result<Self> {
        crate::lattice::check_size(width, height)?;
        if block == 0 || block > width.max(height) {
            return Err(Error::invalid(
                "block",
                block,
                format!(
                    "must be between 1 and the larger lattice side ({})",
                    width.max(height)
                ),
            ));
        }
        let (nx, ny) = (width.div_ceil(block), height.div_ceil(block));
        Ok(Self {
            nx,
            ny,
            block,
            sites: vec![0.0; nx * ny],
            particles: vec![0.0; nx * ny],
            px: vec![0.0; nx * ny],
            py: vec![0.0; nx * ny],
            samples: 1,
        })
    }

    /// Block sums of one lattice snapshot.
    pub fn from_lattice(lattice: &Lattice, block: usize) -> Result<Self> {
        let w = lattice.width();
        let mut f = Self::zeros(w, lattice.height(), block)?;
        for (s, &c) in lattice.cells().iter().enumerate() {
            if c & WALL != 0 {
                continue;
            }
            let b = (s / w / block) * f.nx + (s % w) / block;
            let (mx, my) = site_momentum(c);
            f.sites[b] += 1.0;
            f.particles[b] += f64::from(site_density(c));
            f.px[b] += mx;
            f.py[b] += my;
        }
        Ok(f)
    }

    /// Blocks along x and along y: `(nx, ny)`.
    pub fn blocks(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Block side in sites.
    pub fn block(&self) -> usize {
        self.block
    }

    /// Fluid site-visits per block (fluid sites times samples), `ny x nx` row-major.
    pub fn sites(&self) -> &[f64] {
        &self.sites
    }

    /// Particles per block, summed over the samples.
    pub fn particles(&self) -> &[f64] {
        &self.particles
    }

    /// Momentum `(p_x, p_y)` per block, summed over the samples.
    pub fn momentum(&self) -> (&[f64], &[f64]) {
        (&self.px, &self.py)
    }

    /// Snapshots summed into this field (1 for one snapshot).
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Mean particles per fluid site of each block (0 where a block has no fluid).
    pub fn density(&self) -> Vec<f64> {
        ratio(&self.particles, &self.sites)
    }

    /// Mean velocity `(u_x, u_y)` of each block: momentum over particles.
    pub fn velocity(&self) -> (Vec<f64>, Vec<f64>) {
        (
            ratio(&self.px, &self.particles),
            ratio(&self.py, &self.particles),
        )
    }

    /// The velocity on a grid of physically square cells, for images: a block is `b` sites
    /// wide but only `b sqrt(3)/2` high, so columns are repeated (nearest neighbour) to
    /// `round(nx / (sqrt(3)/2))` columns. Returns `(u_x, u_y, columns, rows)`, row-major,
    /// row 0 the bottom block row.
    pub fn velocity_square_cells(&self) -> (Vec<f64>, Vec<f64>, usize, usize) {
        let (ux, uy) = self.velocity();
        let cols = ((self.nx as f64 / ROW_SPACING).round() as usize).max(1);
        let src: Vec<usize> = (0..cols)
            .map(|c| (((c as f64 + 0.5) * ROW_SPACING) as usize).min(self.nx - 1))
            .collect();
        let resample = |u: &[f64]| -> Vec<f64> {
            (0..self.ny)
                .flat_map(|r| src.iter().map(move |&c| u[r * self.nx + c]))
                .collect()
        };
        (resample(&ux), resample(&uy), cols, self.ny)
    }

    /// Physical centre of block `(0, 0)` and the block spacing `(dx, dy)` in lattice units
    /// (rows are sqrt(3)/2 apart): `([b/2, b sqrt(3)/4], [b, b sqrt(3)/2])`, e.g. the origin
    /// and spacing of an image-data file of the field.
    pub fn block_geometry(&self) -> ([f64; 2], [f64; 2]) {
        let b = self.block as f64;
        ([0.5 * b, 0.5 * b * ROW_SPACING], [b, b * ROW_SPACING])
    }
}

fn ratio(num: &[f64], den: &[f64]) -> Vec<f64> {
    num.iter()
        .zip(den)
        .map(|(&n, &d)| if d > 0.0 { n / d } else { 0.0 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_square_cells_repeat_columns() {
        let mut l = Lattice::new(128, 64).unwrap();
        l.add_wall_rows();
        l.fill_with(4, |_, _, k| if k == 0 { 0.5 } else { 0.2 })
            .unwrap();
        let f = BlockField::from_lattice(&l, 8).unwrap();
        let (ux, uy) = f.velocity();
        assert!(ux.iter().sum::<f64>() > 0.0, "east-movers dominate");
        // 16 x 8 blocks of 8 x 8 sites: 18 columns of physically square cells.
        let (sx, sy, cols, rows) = f.velocity_square_cells();
        assert_eq!((cols, rows, sx.len(), sy.len()), (18, 8, 144, 144));
        assert_eq!((sx[0], sx[17], sy[17 + 18]), (ux[0], ux[15], uy[15 + 16]));
        let (origin, spacing) = f.block_geometry();
        assert_eq!(origin, [4.0, 4.0 * ROW_SPACING]);
        assert_eq!(spacing, [8.0, 8.0 * ROW_SPACING]);
        assert!(BlockField::zeros(128, 64, 0).is_err());
        assert!(BlockField::zeros(128, 64, 129).is_err());
    }
}
