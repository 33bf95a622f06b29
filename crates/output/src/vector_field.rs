//! PNG of a 2D vector field: the magnitude as a heat map background with arrows on a coarser
//! subgrid.
//!
//! Components are row-major like [`crate::heatmap`]: `vx[row * width + col]`. `vx` points
//! along increasing column (right) and `vy` along increasing row, which is up in the image
//! with the default row 0 at the bottom (and down with
//! [`HeatmapOptions::row0_at_top`](crate::heatmap::HeatmapOptions::row0_at_top)). Arrows are
//! averages over `arrow_spacing` x `arrow_spacing` blocks, scaled so that the longest spans
//! about one block.

use std::path::Path;

use image::RgbImage;

use crate::colormap::luminance;
use crate::heatmap::{HeatmapOptions, check_grid, render_field};
use crate::{png, raster};
use simkit_backend::{Error, Result};

/// How to draw a vector field.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VectorFieldOptions {
    /// Background (magnitude) heat map options: colour map, range, orientation, upscale,
    /// colour bar, title.
    pub background: HeatmapOptions,
    /// Grid cells per arrow along each axis; `0` (default) picks about 24 arrows across the
    /// longer side.
    pub arrow_spacing: usize,
    /// Arrow colour; `None` (default) draws black on light and white on dark background.
    pub arrow_color: Option<[u8; 3]>,
}

impl VectorFieldOptions {
    /// Defaults: viridis magnitude, automatic arrow spacing and colour.
    pub fn new() -> Self {
        Self::default()
    }
    /// Sets the background heat map options.
    pub fn background(mut self, background: HeatmapOptions) -> Self {
        self.background = background;
        self
    }
    /// Sets the number of grid cells per arrow.
    pub fn arrow_spacing(mut self, cells: usize) -> Self {
        self.arrow_spacing = cells;
        self
    }
    /// Sets a fixed arrow colour.
    pub fn arrow_color(mut self, color: [u8; 3]) -> Self {
        self.arrow_color = Some(color);
        self
    }
}

/// Renders the field; returns the image and the magnitude range used for the background.
///
/// Errors like [`crate::heatmap::render_heatmap`], and when `vx` and `vy` differ in length.
pub fn render_vector_field<T: Copy + Into<f64>>(
    vx: &[T],
    vy: &[T],
    width: usize,
    height: usize,
    opts: &VectorFieldOptions,
) -> Result<(RgbImage, (f64, f64))> {
    check_grid("vx", vx.len(), width, height)?;
    check_grid("vy", vy.len(), width, height)?;
    let vx: Vec<f64> = vx.iter().map(|&v| v.into()).collect();
    let vy: Vec<f64> = vy.iter().map(|&v| v.into()).collect();
    let mag: Vec<f64> = vx.iter().zip(&vy).map(|(x, y)| x.hypot(*y)).collect();
    let (mut img, range, place) = render_field(&mag, width, height, &opts.background)?;

    let spacing = if opts.arrow_spacing == 0 {
        (width.max(height) / 24).max(1)
    } else {
        opts.arrow_spacing
    };
    if spacing > width.max(height) {
        return Err(Error::invalid(
            "arrow_spacing",
            spacing,
            format!(
                "larger than the grid ({width} x {height}); use at most {}",
                width.max(height)
            ),
        ));
    }
    // Block averages.
    let (bw, bh) = (width.div_ceil(spacing), height.div_ceil(spacing));
    let mut arrows = Vec::with_capacity(bw * bh);
    let mut longest: f64 = 0.0;
    for bj in 0..bh {
        for bi in 0..bw {
            let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
            let (r0, c0) = (bj * spacing, bi * spacing);
            let (r1, c1) = ((r0 + spacing).min(height), (c0 + spacing).min(width));
            for r in r0..r1 {
                for c in c0..c1 {
                    let (x, y) = (vx[r * width + c], vy[r * width + c]);
                    if x.is_finite() && y.is_finite() {
                        sx += x;
                        sy += y;
                        n += 1;
                    }
                }
            }
            if n > 0 {
                let (ax, ay) = (sx / n as f64, sy / n as f64);
                longest = longest.max(ax.hypot(ay));
                // Block centre in grid coordinates (cells).
                let cx = (c0 + c1) as f64 / 2.0;
                let cy = (r0 + r1) as f64 / 2.0;
                arrows.push((cx, cy, ax, ay));
            }
        }
    }
    if longest <= 0.0 || !longest.is_finite() {
        return Ok((img, range));
    }
    let s = place.scale as f64;
    let cell_px = spacing as f64 * s;
    let scale = 0.9 * cell_px / longest;
    let pen = if cell_px >= 24.0 { 2 } else { 1 };
    let (fw, fh) = (width as f64 * s, height as f64 * s);
    let clip = [
        place.x0 as i64,
        place.y0 as i64,
        (place.x0 as f64 + fw) as i64 - 1,
        (place.y0 as f64 + fh) as i64 - 1,
    ];
    for (cx, cy, ax, ay) in arrows {
        let len = ax.hypot(ay) * scale;
        if len < 1.5 {
            continue;
        }
        let px = place.x0 as f64 + cx * s - 0.5;
        let (py, dy) = if opts.background.row0_at_top {
            (place.y0 as f64 + cy * s - 0.5, ay * scale)
        } else {
            (place.y0 as f64 + fh - cy * s - 0.5, -ay * scale)
        };
        let dx = ax * scale;
        let color = opts.arrow_color.unwrap_or_else(|| {
            let bg = img
                .get_pixel(px.round().max(0.0) as u32, py.round().max(0.0) as u32)
                .0;
            if luminance(bg) > 140.0 {
                [0, 0, 0]
            } else {
                [255, 255, 255]
            }
        });
        // Shaft centred on the block centre.
        let (x0, y0) = (px - dx / 2.0, py - dy / 2.0);
        let (x1, y1) = (px + dx / 2.0, py + dy / 2.0);
        raster::line_clipped(&mut img, x0, y0, x1, y1, pen, color, clip);
        // Head: two strokes at +-25 degrees back from the tip.
        let head = (0.35 * len).max(2.0);
        let (ux, uy) = (dx / len, dy / len);
        let (c, sn) = (25f64.to_radians().cos(), 25f64.to_radians().sin());
        for sign in [-1.0, 1.0] {
            let hx = -(ux * c - sign * uy * sn);
            let hy = -(sign * ux * sn + uy * c);
            raster::line_clipped(
                &mut img,
                x1,
                y1,
                x1 + head * hx,
                y1 + head * hy,
                pen,
                color,
                clip,
            );
        }
    }
    Ok((img, range))
}

/// Renders like [`render_vector_field`] and writes the PNG atomically; returns the magnitude
/// range used.
pub fn write_vector_field<T: Copy + Into<f64>>(
    path: impl AsRef<Path>,
    vx: &[T],
    vy: &[T],
    width: usize,
    height: usize,
    opts: &VectorFieldOptions,
) -> Result<(f64, f64)> {
    let (img, range) = render_vector_field(vx, vy, width, height, opts)?;
    png::write_png(path, &img)?;
    Ok(range)
}
