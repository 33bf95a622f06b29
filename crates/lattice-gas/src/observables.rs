//! Macroscopic fields: per-site density and momentum, block averages over `b x b` sites
//! (the noise falls as 1/b), time averages, and PNG / VTK output.

use std::path::Path;

use simkit_backend::{Error, Result};
use simkit_output::heatmap::HeatmapOptions;
use simkit_output::vector_field::{VectorFieldOptions, write_vector_field};
use simkit_output::vtk::ImageData;

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
/// column is smaller when the size is not a multiple of `block`.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockField {
    /// Blocks along x.
    pub nx: usize,
    /// Blocks along y.
    pub ny: usize,
    /// Block side in sites.
    pub block: usize,
    /// Fluid site-visits per block (sites times samples).
    pub sites: Vec<f64>,
    /// Particles per block (summed over samples).
    pub particles: Vec<f64>,
    /// Momentum x per block (summed).
    pub px: Vec<f64>,
    /// Momentum y per block (summed).
    pub py: Vec<f64>,
    /// Samples summed.
    pub samples: u64,
}

impl BlockField {
    /// Block sums of one lattice snapshot.
    pub fn from_lattice(lattice: &Lattice, block: usize) -> Result<Self> {
        let (w, h) = (lattice.width(), lattice.height());
        if block == 0 || block > w.max(h) {
            return Err(Error::invalid(
                "block",
                block,
                format!(
                    "must be between 1 and the larger lattice side ({})",
                    w.max(h)
                ),
            ));
        }
        let (nx, ny) = (w.div_ceil(block), h.div_ceil(block));
        let mut f = Self {
            nx,
            ny,
            block,
            sites: vec![0.0; nx * ny],
            particles: vec![0.0; nx * ny],
            px: vec![0.0; nx * ny],
            py: vec![0.0; nx * ny],
            samples: 1,
        };
        for (s, &c) in lattice.cells().iter().enumerate() {
            if c & WALL != 0 {
                continue;
            }
            let b = (s / w / block) * nx + (s % w) / block;
            let (mx, my) = site_momentum(c);
            f.sites[b] += 1.0;
            f.particles[b] += f64::from(site_density(c));
            f.px[b] += mx;
            f.py[b] += my;
        }
        Ok(f)
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
    /// `round(nx / (sqrt(3)/2))` columns. Returns `(u_x, u_y, columns, rows)`, row-major.
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

    /// Writes the velocity field as a PNG: magnitude colour map with arrows, on physically
    /// square cells ([`BlockField::velocity_square_cells`]).
    pub fn write_velocity_png(&self, path: impl AsRef<Path>, title: &str) -> Result<()> {
        let (ux, uy, cols, rows) = self.velocity_square_cells();
        let scale = (768 / cols.max(rows)).clamp(1, 32) as u32;
        let opts =
            VectorFieldOptions::new().background(HeatmapOptions::new().upscale(scale).title(title));
        write_vector_field(path, &ux, &uy, cols, rows, &opts)?;
        Ok(())
    }

    /// Writes density and velocity as VTK image data (`.vti`), block centres in lattice units.
    pub fn write_vti(&self, path: impl AsRef<Path>) -> Result<()> {
        let b = self.block as f64;
        let mut img = ImageData::new_2d(
            self.nx,
            self.ny,
            [0.5 * b, 0.5 * b * ROW_SPACING],
            [b, b * ROW_SPACING],
        )?;
        let (ux, uy) = self.velocity();
        let vel: Vec<f64> = ux
            .iter()
            .zip(&uy)
            .flat_map(|(&x, &y)| [x, y, 0.0])
            .collect();
        img.add_scalar("density", &self.density())?;
        img.add_vector("velocity", &vel, 3)?;
        img.write(path)
    }
}

fn ratio(num: &[f64], den: &[f64]) -> Vec<f64> {
    num.iter()
        .zip(den)
        .map(|(&n, &d)| if d > 0.0 { n / d } else { 0.0 })
        .collect()
}

/// Accumulates block fields over time (sums of particles and momenta, so the averaged
/// velocity is total momentum over total particles).
#[derive(Clone, Debug, Default)]
pub struct TimeAverage {
    sum: Option<BlockField>,
}

impl TimeAverage {
    /// An empty average.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one block field; errors when its block grid differs from earlier ones.
    pub fn add(&mut self, field: &BlockField) -> Result<()> {
        match &mut self.sum {
            None => self.sum = Some(field.clone()),
            Some(s) => {
                if (s.nx, s.ny, s.block) != (field.nx, field.ny, field.block) {
                    return Err(Error::invalid(
                        "block field",
                        format!("{} x {} blocks of {}", field.nx, field.ny, field.block),
                        format!(
                            "must match the average's {} x {} blocks of {}",
                            s.nx, s.ny, s.block
                        ),
                    ));
                }
                for (a, b) in [
                    (&mut s.sites, &field.sites),
                    (&mut s.particles, &field.particles),
                    (&mut s.px, &field.px),
                    (&mut s.py, &field.py),
                ] {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                }
                s.samples += field.samples;
            }
        }
        Ok(())
    }

    /// Samples added so far.
    pub fn samples(&self) -> u64 {
        self.sum.as_ref().map_or(0, |s| s.samples)
    }

    /// The accumulated field (`None` before the first sample).
    pub fn field(&self) -> Option<&BlockField> {
        self.sum.as_ref()
    }

    /// Clears the average.
    pub fn reset(&mut self) {
        self.sum = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_noise_falls_with_block_size() {
        let mut l = Lattice::new(256, 256).unwrap();
        l.fill_random(0.3, 2).unwrap();
        let rms = |b: usize| {
            let f = BlockField::from_lattice(&l, b).unwrap();
            let (ux, _) = f.velocity();
            (ux.iter().map(|u| u * u).sum::<f64>() / ux.len() as f64).sqrt()
        };
        let (r4, r16) = (rms(4), rms(16));
        // Noise ~ 1/b: a factor 4 in b gives about 4 in rms.
        assert!((r4 / r16 - 4.0).abs() < 0.6, "{r4} {r16}");
        let f = BlockField::from_lattice(&l, 8).unwrap();
        let d: f64 = f.density().iter().sum::<f64>() / (f.nx * f.ny) as f64;
        assert!((d / 6.0 - 0.3).abs() < 0.01);
        let mut avg = TimeAverage::new();
        avg.add(&f).unwrap();
        avg.add(&f).unwrap();
        assert_eq!(avg.samples(), 2);
        assert_eq!(avg.field().unwrap().velocity(), f.velocity());
        assert!(avg.add(&BlockField::from_lattice(&l, 4).unwrap()).is_err());
        assert!(BlockField::from_lattice(&l, 0).is_err());
    }

    #[test]
    fn velocity_png_and_vti_are_written() {
        let mut l = Lattice::new(128, 64).unwrap();
        l.add_wall_rows();
        l.fill_with(4, |_, _, k| if k == 0 { 0.5 } else { 0.2 })
            .unwrap();
        let f = BlockField::from_lattice(&l, 8).unwrap();
        let (ux, _) = f.velocity();
        assert!(ux.iter().sum::<f64>() > 0.0, "east-movers dominate");
        let dir = std::env::temp_dir().join(format!("lattice_gas_obs_{}", std::process::id()));
        let (png, vti) = (dir.join("u.png"), dir.join("u.vti"));
        f.write_velocity_png(&png, "test").unwrap();
        f.write_vti(&vti).unwrap();
        let img = image::open(&png).unwrap();
        assert!(img.width() >= 16 * 8 && img.height() >= 8 * 8);
        // 16 x 8 blocks of 8 x 8 sites: 18 columns of physically square cells.
        let (sx, sy, cols, rows) = f.velocity_square_cells();
        assert_eq!((cols, rows, sx.len(), sy.len()), (18, 8, 144, 144));
        let (ux, uy) = f.velocity();
        assert_eq!((sx[0], sx[17], sy[17 + 18]), (ux[0], ux[15], uy[15 + 16]));
        let text = std::fs::read_to_string(&vti).unwrap();
        assert!(
            text.contains("ImageData") && text.contains("velocity") && text.contains("density")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
