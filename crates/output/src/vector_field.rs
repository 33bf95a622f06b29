//! 2D vector fields, PNG or SVG (from the file extension): the magnitude as a heat map
//! (axes, colour bar, titles as in [`crate::heatmap`]) with arrows on a coarser subgrid.
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
use crate::figure::{render_rgb, write_figure};
use crate::heatmap::{FieldFigure, HeatmapOptions, Stroke, check_grid};
use simkit_backend::{Error, Result};

/// How to draw a vector field.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VectorFieldOptions {
    /// Background (magnitude) heat map options: colour map, range, orientation, upscale,
    /// colour bar and its quantity, extent, axis titles, title and subtitle.
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
/// Errors like [`crate::heatmap::render_heatmap`], and when `vx` and `vy` differ in length
/// or the arrow spacing exceeds the grid.
pub fn render_vector_field<T: Copy + Into<f64>>(
    vx: &[T],
    vy: &[T],
    width: usize,
    height: usize,
    opts: &VectorFieldOptions,
) -> Result<(RgbImage, (f64, f64))> {
    let (vx, vy, mag) = components(vx, vy, width, height)?;
    let fig = figure(&vx, &vy, &mag, width, height, opts)?;
    Ok((render_rgb("vector field", &fig)?, fig.range))
}

/// Renders like [`render_vector_field`] and writes the file atomically: PNG for a `.png`
/// path, SVG for `.svg`. Returns the magnitude range used.
pub fn write_vector_field<T: Copy + Into<f64>>(
    path: impl AsRef<Path>,
    vx: &[T],
    vy: &[T],
    width: usize,
    height: usize,
    opts: &VectorFieldOptions,
) -> Result<(f64, f64)> {
    let (vx, vy, mag) = components(vx, vy, width, height)?;
    let fig = figure(&vx, &vy, &mag, width, height, opts)?;
    write_figure("vector field", path.as_ref(), &fig)?;
    Ok(fig.range)
}

type Components = (Vec<f64>, Vec<f64>, Vec<f64>);

/// Checks the grids; returns the components as `f64` and the magnitude.
fn components<T: Copy + Into<f64>>(
    vx: &[T],
    vy: &[T],
    width: usize,
    height: usize,
) -> Result<Components> {
    check_grid("vx", vx.len(), width, height)?;
    check_grid("vy", vy.len(), width, height)?;
    let vx: Vec<f64> = vx.iter().map(|&v| v.into()).collect();
    let vy: Vec<f64> = vy.iter().map(|&v| v.into()).collect();
    let mag = vx.iter().zip(&vy).map(|(x, y)| x.hypot(*y)).collect();
    Ok((vx, vy, mag))
}

/// The magnitude heat map with the arrows as strokes.
fn figure<'a>(
    vx: &[f64],
    vy: &[f64],
    mag: &'a [f64],
    width: usize,
    height: usize,
    opts: &'a VectorFieldOptions,
) -> Result<FieldFigure<'a>> {
    let mut fig = FieldFigure::new(mag, width, height, &opts.background)?;
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
        return Ok(fig);
    }
    // Lengths in pixels: the longest arrow spans 90 % of a block.
    let (dx, _) = fig.cell_size();
    let px_per_cell = dx.abs() * fig.px_per_unit();
    let cell_px = spacing as f64 * px_per_cell;
    let scale = 0.9 * spacing as f64 / longest; // cells per unit of the field
    let pen = if cell_px >= 24.0 { 2 } else { 1 };
    for (cx, cy, ax, ay) in arrows {
        let len_cells = ax.hypot(ay) * scale;
        if len_cells * px_per_cell < 1.5 {
            continue;
        }
        let color = opts.arrow_color.unwrap_or_else(|| {
            let (r, c) = ((cy as usize).min(height - 1), (cx as usize).min(width - 1));
            if luminance(fig.color_at(r, c)) > 140.0 {
                [0, 0, 0]
            } else {
                [255, 255, 255]
            }
        });
        // Shaft centred on the block centre, in cells; then to axis coordinates.
        let (hx, hy) = (ax * scale / 2.0, ay * scale / 2.0);
        let tail = (cx - hx, cy - hy);
        let tip = (cx + hx, cy + hy);
        let at = |(c, r): (f64, f64)| fig.grid_point(r, c);
        // Head: two strokes at +-25 degrees back from the tip, 35 % of the length.
        let head = (0.35 * len_cells).max(2.0 / px_per_cell);
        let (ux, uy) = (ax / ax.hypot(ay), ay / ax.hypot(ay));
        let (c, sn) = (25f64.to_radians().cos(), 25f64.to_radians().sin());
        let barb = |sign: f64| {
            let bx = -(ux * c - sign * uy * sn);
            let by = -(sign * ux * sn + uy * c);
            at((tip.0 + head * bx, tip.1 + head * by))
        };
        let shaft = Stroke {
            points: vec![at(tail), at(tip)],
            color,
            width: pen,
        };
        let head = Stroke {
            points: vec![barb(-1.0), at(tip), barb(1.0)],
            color,
            width: pen,
        };
        fig.strokes.extend([shaft, head]);
    }
    Ok(fig)
}
