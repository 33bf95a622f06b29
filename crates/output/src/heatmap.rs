//! Heat maps of 2D scalar fields, PNG or SVG (from the file extension): the field on
//! spatial axes with units, a colour bar labelled with the quantity, a title and a subtitle
//! (for example the time).
//!
//! Data is row-major: `data[row * width + col]`. By default row 0 is drawn at the bottom
//! (physics convention, y up); [`HeatmapOptions::row0_at_top`] flips that for image-style
//! data. NaN cells are drawn in [`NAN_COLOR`](crate::colormap::NAN_COLOR).
//!
//! ```
//! use simkit_output::heatmap::{write_heatmap, HeatmapOptions};
//! # fn main() -> simkit_backend::Result<()> {
//! let (w, h) = (64, 32);
//! let field: Vec<f64> = (0..w * h).map(|i| ((i % w) as f64 * 0.2).sin()).collect();
//! let opts = HeatmapOptions::new()
//!     .upscale(6)
//!     .extent(0.0, 2.0, 0.0, 1.0)
//!     .x_label("x (mm)")
//!     .y_label("y (mm)")
//!     .quantity("ρ (g/cm³)")
//!     .title("density")
//!     .subtitle("t = 0.5 s");
//! let dir = std::env::temp_dir().join("simkit-doc-heatmap-mod");
//! write_heatmap(dir.join("rho.png"), &field, w, h, &opts)?;
//! write_heatmap(dir.join("rho.svg"), &field, w, h, &opts)?;
//! # Ok(())
//! # }
//! ```

use std::path::Path;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colormap::Colormap;
use crate::figure::{
    Axis, COLORBAR_W, Figure, LABEL_PX, TICK_PX, draw_colorbar, draw_err, draw_header,
    draw_y_title, font, header_height, render_rgb, rgb, spatial_axis, write_figure,
};
pub use crate::figure::{MAX_PIXELS, MAX_SIDE};
use simkit_backend::{Error, Result};

/// The field is enlarged (by a whole factor) until its longer side has at least this many
/// pixels, so that axes and colour bar stay readable next to small grids.
const MIN_FIELD_PX: usize = 320;

/// How to draw a heat map. Build with [`HeatmapOptions::new`] and the chained setters.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatmapOptions {
    /// Colour map (default viridis).
    pub colormap: Colormap,
    /// Fixed `(min, max)` value range; `None` (default) uses the data's finite min and max.
    pub range: Option<(f64, f64)>,
    /// With an automatic range, make it symmetric about zero (`[-m, m]`, `m = max |v|`);
    /// useful with [`Colormap::Diverging`]. Default false.
    pub symmetric: bool,
    /// Draw row 0 at the top instead of the bottom (default false: row 0 at the bottom).
    pub row0_at_top: bool,
    /// Each grid cell becomes at least an `upscale` x `upscale` pixel block (default 1;
    /// small grids are enlarged further so that the field is at least 320 pixels across).
    pub upscale: u32,
    /// Draw a colour bar with ticks and the [`quantity`](Self::quantity) (default true).
    pub colorbar: bool,
    /// Title above the field.
    pub title: Option<String>,
    /// Second, smaller line under the title, for example `"t = 12.5 ps"`.
    pub subtitle: Option<String>,
    /// What the colours mean, with its unit, written along the colour bar
    /// (e.g. `"u (concentration)"`).
    pub quantity: Option<String>,
    /// Spatial extent `(x0, x1, y0, y1)` covered by the grid; `None` (default) numbers the
    /// cells: `(0, width, 0, height)`.
    pub extent: Option<(f64, f64, f64, f64)>,
    /// x-axis title with its unit, e.g. `"x (lattice units)"`.
    pub x_label: Option<String>,
    /// y-axis title with its unit.
    pub y_label: Option<String>,
}

impl Default for HeatmapOptions {
    fn default() -> Self {
        Self {
            colormap: Colormap::Viridis,
            range: None,
            symmetric: false,
            row0_at_top: false,
            upscale: 1,
            colorbar: true,
            title: None,
            subtitle: None,
            quantity: None,
            extent: None,
            x_label: None,
            y_label: None,
        }
    }
}

impl HeatmapOptions {
    /// The defaults: viridis, automatic range, row 0 at the bottom, no upscaling, colour bar,
    /// cell-numbered axes, no titles.
    pub fn new() -> Self {
        Self::default()
    }
    /// Sets the colour map.
    pub fn colormap(mut self, colormap: Colormap) -> Self {
        self.colormap = colormap;
        self
    }
    /// Fixes the value range (checked when rendering: finite, `min < max`).
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.range = Some((min, max));
        self
    }
    /// Makes an automatic range symmetric about zero.
    pub fn symmetric(mut self, yes: bool) -> Self {
        self.symmetric = yes;
        self
    }
    /// Draws row 0 at the top (`true`) or the bottom (`false`, default).
    pub fn row0_at_top(mut self, yes: bool) -> Self {
        self.row0_at_top = yes;
        self
    }
    /// Sets the integer upscale factor (>= 1).
    pub fn upscale(mut self, factor: u32) -> Self {
        self.upscale = factor;
        self
    }
    /// Turns the colour bar on or off.
    pub fn colorbar(mut self, yes: bool) -> Self {
        self.colorbar = yes;
        self
    }
    /// Sets the title.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }
    /// Sets the subtitle (a second line, e.g. the time).
    pub fn subtitle(mut self, subtitle: impl Into<String>) -> Self {
        self.subtitle = Some(subtitle.into());
        self
    }
    /// Sets the quantity written along the colour bar, with its unit.
    pub fn quantity(mut self, quantity: impl Into<String>) -> Self {
        self.quantity = Some(quantity.into());
        self
    }
    /// Sets the spatial extent of the grid (checked when rendering: finite, `x0 < x1`,
    /// `y0 < y1`).
    pub fn extent(mut self, x0: f64, x1: f64, y0: f64, y1: f64) -> Self {
        self.extent = Some((x0, x1, y0, y1));
        self
    }
    /// Sets the x-axis title (write the unit in it).
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = Some(label.into());
        self
    }
    /// Sets the y-axis title (write the unit in it).
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = Some(label.into());
        self
    }
}

/// Renders `data` (`width` x `height`, row-major) to an RGB image; returns it and the value
/// range used. Use this to collect frames for [`crate::gif`]: frames rendered with the same
/// options and grid size have the same size.
///
/// Errors on zero sizes, `data.len() != width * height`, a zero upscale, an image over
/// [`MAX_SIDE`] per side or [`MAX_PIXELS`] in all (checked before it is allocated), a fixed
/// range or extent that is non-finite or empty, or (automatic range) data with no finite
/// value.
pub fn render_heatmap<T: Copy + Into<f64>>(
    data: &[T],
    width: usize,
    height: usize,
    opts: &HeatmapOptions,
) -> Result<(RgbImage, (f64, f64))> {
    let values: Vec<f64> = data.iter().map(|&v| v.into()).collect();
    let fig = FieldFigure::new(&values, width, height, opts)?;
    Ok((render_rgb("heat map", &fig)?, fig.range))
}

/// Renders like [`render_heatmap`] and writes the file atomically to `path`: PNG for a
/// `.png` path, SVG for `.svg`. Returns the value range used.
pub fn write_heatmap<T: Copy + Into<f64>>(
    path: impl AsRef<Path>,
    data: &[T],
    width: usize,
    height: usize,
    opts: &HeatmapOptions,
) -> Result<(f64, f64)> {
    let values: Vec<f64> = data.iter().map(|&v| v.into()).collect();
    let fig = FieldFigure::new(&values, width, height, opts)?;
    write_figure("heat map", path.as_ref(), &fig)?;
    Ok(fig.range)
}

/// Checks grid sizes against the data length.
pub(crate) fn check_grid(name: &str, len: usize, width: usize, height: usize) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::invalid(
            "grid size",
            format!("{width} x {height}"),
            "width and height must both be >= 1",
        ));
    }
    let expected = width
        .checked_mul(height)
        .ok_or_else(|| Error::invalid("grid size", format!("{width} x {height}"), "too large"))?;
    if len != expected {
        return Err(Error::invalid(
            format!("{name}.len()"),
            len,
            format!(
                "expected width * height = {width} * {height} = {expected}; data is row-major \
                 with rows of `width` values"
            ),
        ));
    }
    Ok(())
}

/// The value range for `values` under `opts`.
pub(crate) fn resolve_range(values: &[f64], opts: &HeatmapOptions) -> Result<(f64, f64)> {
    if let Some((min, max)) = opts.range {
        if !(min.is_finite() && max.is_finite()) {
            return Err(Error::invalid(
                "range",
                format!("({min}, {max})"),
                "both ends must be finite numbers",
            ));
        }
        if min >= max {
            return Err(Error::invalid(
                "range",
                format!("({min}, {max})"),
                "min must be < max; swap them or widen the range",
            ));
        }
        return Ok((min, max));
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &v in values.iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return Err(Error::invalid(
            "data",
            "no finite value",
            "every value is NaN or infinite; check the simulation for a blow-up, or pass a \
             fixed range to draw it anyway",
        ));
    }
    if opts.symmetric {
        let m = lo.abs().max(hi.abs());
        (lo, hi) = (-m, m);
    }
    if lo == hi {
        // 10 % either side, at least the smallest normal number (a subnormal value's 10 %
        // rounds to nothing), and clamped: padding a value near f64::MAX must stay finite.
        let d = if lo == 0.0 {
            1.0
        } else {
            (lo.abs() * 0.1).max(f64::MIN_POSITIVE)
        };
        (lo, hi) = ((lo - d).max(f64::MIN), (hi + d).min(f64::MAX));
    }
    Ok((lo, hi))
}

/// A polyline drawn over a field (the arrows of a vector field), in axis coordinates.
#[derive(Debug, Clone)]
pub(crate) struct Stroke {
    pub(crate) points: Vec<(f64, f64)>,
    pub(crate) color: [u8; 3],
    pub(crate) width: u32,
}

/// A validated field with its layout, ready to draw.
pub(crate) struct FieldFigure<'a> {
    values: &'a [f64],
    width: usize,
    height: usize,
    opts: &'a HeatmapOptions,
    pub(crate) range: (f64, f64),
    x: Axis,
    y: Axis,
    /// Pixels of the field: width, height.
    field_px: (u32, u32),
    pub(crate) strokes: Vec<Stroke>,
}

/// Left margin (tick labels and y title), bottom margin (tick labels and x title), gap
/// above the field and right margin without a colour bar, in pixels.
const LEFT: u32 = 92;
const BOTTOM: u32 = 54;
const GAP: u32 = 8;
const RIGHT: u32 = 24;

impl<'a> FieldFigure<'a> {
    pub(crate) fn new(
        values: &'a [f64],
        width: usize,
        height: usize,
        opts: &'a HeatmapOptions,
    ) -> Result<Self> {
        check_grid("data", values.len(), width, height)?;
        if opts.upscale == 0 {
            return Err(Error::invalid(
                "upscale",
                0,
                "must be >= 1 (1 = one pixel per cell)",
            ));
        }
        let s = opts.upscale as usize;
        let (mut fw, mut fh) = (width.saturating_mul(s), height.saturating_mul(s));
        if fw > MAX_SIDE || fh > MAX_SIDE {
            return Err(Error::invalid(
                "upscale",
                opts.upscale,
                format!(
                    "the field would be {fw} x {fh} pixels, over the limit of {MAX_SIDE}; use \
                     a smaller upscale"
                ),
            ));
        }
        let longer = fw.max(fh);
        if longer < MIN_FIELD_PX {
            let k = MIN_FIELD_PX.div_ceil(longer);
            (fw, fh) = (fw * k, fh * k);
        }
        let range = resolve_range(values, opts)?;
        let (x0, x1, y0, y1) = opts
            .extent
            .unwrap_or((0.0, width as f64, 0.0, height as f64));
        let x = spatial_axis("extent x", (x0, x1))?;
        let y = spatial_axis("extent y", (y0, y1))?;
        let fig = Self {
            values,
            width,
            height,
            opts,
            range,
            x,
            y,
            field_px: (fw as u32, fh as u32),
            strokes: Vec::new(),
        };
        let (cw, ch) = fig.canvas();
        if cw as usize > MAX_SIDE
            || ch as usize > MAX_SIDE
            || cw as usize * ch as usize > MAX_PIXELS
        {
            return Err(Error::invalid(
                "upscale",
                opts.upscale,
                format!(
                    "the image would be {cw} x {ch} pixels (field plus axes and colour bar), \
                     over the limit of {MAX_SIDE} pixels per side and {MAX_PIXELS} pixels in all; use \
                     a smaller upscale or downsample the field"
                ),
            ));
        }
        Ok(fig)
    }

    fn header(&self) -> u32 {
        header_height(
            self.opts.title.as_deref().unwrap_or(""),
            self.opts.subtitle.as_deref().unwrap_or(""),
        )
    }

    fn canvas(&self) -> (u32, u32) {
        let (fw, fh) = self.field_px;
        let right = if self.opts.colorbar {
            COLORBAR_W
        } else {
            RIGHT
        };
        (LEFT + fw + right, self.header() + GAP + fh + BOTTOM)
    }

    /// The axis coordinates of grid position `(row, col)`, in cells from the field's edge:
    /// `(0, 0)` is the outer corner of the first cell, `(0.5, 0.5)` its centre.
    pub(crate) fn grid_point(&self, row: f64, col: f64) -> (f64, f64) {
        let (x0, x1, y0, y1) = (self.x.lo, self.x.hi, self.y.lo, self.y.hi);
        let x = x0 + (col / self.width as f64) * (x1 - x0);
        let fy = row / self.height as f64;
        let y = if self.opts.row0_at_top {
            y1 - fy * (y1 - y0)
        } else {
            y0 + fy * (y1 - y0)
        };
        (x, y)
    }

    /// Axis units per grid cell along x and y (y positive up the image).
    pub(crate) fn cell_size(&self) -> (f64, f64) {
        let dx = (self.x.hi - self.x.lo) / self.width as f64;
        let dy = (self.y.hi - self.y.lo) / self.height as f64;
        (dx, if self.opts.row0_at_top { -dy } else { dy })
    }

    /// Pixels per axis unit along x.
    pub(crate) fn px_per_unit(&self) -> f64 {
        f64::from(self.field_px.0) / (self.x.hi - self.x.lo)
    }

    /// The colour of the cell at `(row, col)`.
    pub(crate) fn color_at(&self, row: usize, col: usize) -> [u8; 3] {
        self.opts.colormap.map_range(
            self.values[row * self.width + col],
            self.range.0,
            self.range.1,
        )
    }
}

impl Figure for FieldFigure<'_> {
    fn size(&self) -> (u32, u32) {
        self.canvas()
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let o = self.opts;
        root.fill(&WHITE).map_err(draw_err)?;
        let body = draw_header(
            root,
            o.title.as_deref().unwrap_or(""),
            o.subtitle.as_deref().unwrap_or(""),
        )?;
        let (main, bar) = body.split_horizontally(LEFT + self.field_px.0 + RIGHT);
        let mut chart = ChartBuilder::on(&main)
            .margin_top(GAP)
            .margin_right(RIGHT)
            .x_label_area_size(BOTTOM)
            .y_label_area_size(LEFT)
            .build_cartesian_2d(self.x.clone(), self.y.clone())
            .map_err(draw_err)?;
        // Cells, as horizontal runs of one colour (few elements in SVG files).
        let (dx, dy) = self.cell_size();
        for r in 0..self.height {
            let mut c = 0;
            while c < self.width {
                let color = self.color_at(r, c);
                let mut end = c + 1;
                while end < self.width && self.color_at(r, end) == color {
                    end += 1;
                }
                let (xa, ya) = self.grid_point(r as f64, c as f64);
                let corner = (xa + (end - c) as f64 * dx, ya + dy);
                chart
                    .plotting_area()
                    .draw(&Rectangle::new([(xa, ya), corner], rgb(color).filled()))
                    .map_err(draw_err)?;
                c = end;
            }
        }
        for s in &self.strokes {
            chart
                .plotting_area()
                .draw(&PathElement::new(
                    s.points.clone(),
                    rgb(s.color).stroke_width(s.width),
                ))
                .map_err(draw_err)?;
        }
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(o.x_label.as_deref().unwrap_or(""))
            .label_style(font(TICK_PX))
            .axis_desc_style(font(LABEL_PX))
            .x_labels(7)
            .y_labels(7)
            .draw()
            .map_err(draw_err)?;
        let (_, rows) = chart.plotting_area().get_pixel_range();
        draw_y_title(
            root,
            o.y_label.as_deref().unwrap_or(""),
            (30, (rows.start + rows.end) / 2),
        )?;
        if o.colorbar {
            draw_colorbar(
                &bar,
                o.colormap,
                self.range,
                o.quantity.as_deref().unwrap_or(""),
                GAP,
                BOTTOM,
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_rules() {
        let o = HeatmapOptions::new();
        assert_eq!(
            resolve_range(&[1.0, f64::NAN, 3.0], &o).unwrap(),
            (1.0, 3.0)
        );
        assert_eq!(resolve_range(&[2.0, 2.0], &o).unwrap(), (1.8, 2.2));
        assert_eq!(
            resolve_range(&[-1.0, 3.0], &o.clone().symmetric(true)).unwrap(),
            (-3.0, 3.0)
        );
        assert!(resolve_range(&[f64::NAN], &o).is_err());
        // One value at the ends of f64: a finite range around it (it used to reach inf, or
        // stay empty for a subnormal value).
        assert_eq!(
            resolve_range(&[f64::MAX], &o).unwrap(),
            (f64::MAX - f64::MAX * 0.1, f64::MAX)
        );
        let (lo, hi) = resolve_range(&[5e-324], &o).unwrap();
        assert!(lo < 5e-324 && hi > 5e-324, "{lo} {hi}");
        assert!(resolve_range(&[1.0], &o.clone().range(1.0, 1.0)).is_err());
        assert!(resolve_range(&[1.0], &o.clone().range(0.0, f64::INFINITY)).is_err());
    }

    #[test]
    fn small_grids_are_enlarged_and_extent_checked() {
        let o = HeatmapOptions::new();
        let f = FieldFigure::new(&[0.0, 1.0], 1, 2, &o).unwrap();
        assert_eq!(f.field_px, (160, 320));
        let bad = o.clone().extent(1.0, 1.0, 0.0, 1.0);
        let e = FieldFigure::new(&[0.0, 1.0], 1, 2, &bad)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("extent x"), "{e}");
    }
}
