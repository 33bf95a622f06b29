//! Frames of 2D particle systems (granular beds, molecular dynamics slices, plasma clouds),
//! PNG or SVG (from the file extension): discs of their true radii on spatial axes, coloured
//! by a value (with a labelled colour bar) or by species (with a legend), optional wall
//! lines and circles, a title and a subtitle for the time.
//!
//! ```
//! use simkit_output::particles::ParticleFrame;
//! # fn main() -> simkit_backend::Result<()> {
//! let pos = [[1.0, 1.0], [2.0, 1.2], [3.0, 2.5]];
//! let speed = [0.1, 0.4, 0.9];
//! let dir = std::env::temp_dir().join("simkit-doc-particles");
//! ParticleFrame::new(&pos, &[0.5; 3])
//!     .bounds(0.0, 4.0, 0.0, 3.0)
//!     .by_value(&speed, "|v| (d/τ)")
//!     .title("bed")
//!     .subtitle("t = 1.5 τ")
//!     .x_label("x (d)")
//!     .y_label("y (d)")
//!     .line((0.0, 0.0), (4.0, 0.0))
//!     .write(dir.join("bed.png"))?;
//! ParticleFrame::new(&pos, &[0.5; 3])
//!     .by_species(&[0, 1, 1], &["small", "large"])
//!     .write(dir.join("species.svg"))?;
//! # Ok(())
//! # }
//! ```

use std::path::Path;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colormap::Colormap;
use crate::figure::{
    Axis, COLORBAR_W, Figure, LABEL_PX, Scale, TICK_PX, draw_colorbar, draw_err, draw_header,
    draw_y_title, font, header_height, render_rgb, rgb, spatial_axis, write_figure,
};
use crate::plot::PALETTE;
use simkit_backend::{Error, Result};

/// How the discs are coloured.
#[derive(Debug, Clone, PartialEq)]
pub enum Coloring {
    /// One colour for all discs.
    Uniform([u8; 3]),
    /// By a value per particle through a colour map, with a colour bar.
    Value {
        /// One value per particle (NaN is drawn in
        /// [`NAN_COLOR`](crate::colormap::NAN_COLOR)).
        values: Vec<f64>,
        /// The quantity with its unit, written along the colour bar.
        quantity: String,
        /// Colour map.
        colormap: Colormap,
        /// Fixed `(min, max)`; `None` uses the finite min and max of the values.
        range: Option<(f64, f64)>,
    },
    /// By species index, with a legend of the names.
    Species {
        /// Species index per particle, `< names.len()`.
        ids: Vec<usize>,
        /// Legend name per species.
        names: Vec<String>,
        /// Colour per species; empty uses [`PALETTE`].
        colors: Vec<[u8; 3]>,
    },
}

/// A line or circle drawn over the particles (walls, plates, containers), in grey.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outline {
    /// Straight segment between two points.
    Line((f64, f64), (f64, f64)),
    /// Circle with centre and radius.
    Circle((f64, f64), f64),
}

/// A particle frame; build with [`ParticleFrame::new`] and the chained setters, then
/// [`render`](Self::render) or [`write`](Self::write).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleFrame {
    /// Centres `(x, y)`.
    pub positions: Vec<[f64; 2]>,
    /// Radii, one per particle, in the units of the positions.
    pub radii: Vec<f64>,
    /// Colouring (default: uniform blue).
    pub coloring: Coloring,
    /// Region shown `(x0, x1, y0, y1)`; `None` fits the discs.
    pub bounds: Option<(f64, f64, f64, f64)>,
    /// Walls and containers.
    pub outlines: Vec<Outline>,
    /// Title (empty: none).
    pub title: String,
    /// Subtitle, for example the time (empty: none).
    pub subtitle: String,
    /// x-axis title with its unit.
    pub x_label: String,
    /// y-axis title with its unit.
    pub y_label: String,
    /// Pixels along the longer side of the region (default 560).
    pub size_px: u32,
}

const LEFT: u32 = 86;
const BOTTOM: u32 = 54;
const GAP: u32 = 8;
const RIGHT: u32 = 24;
const LEGEND_W: u32 = 150;
const OUTLINE: RGBColor = RGBColor(90, 90, 90);

impl ParticleFrame {
    /// A frame of discs at `positions` with `radii` (lengths are checked when rendering).
    pub fn new(positions: &[[f64; 2]], radii: &[f64]) -> Self {
        Self {
            positions: positions.to_vec(),
            radii: radii.to_vec(),
            coloring: Coloring::Uniform(PALETTE[0]),
            bounds: None,
            outlines: Vec::new(),
            title: String::new(),
            subtitle: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            size_px: 560,
        }
    }
    /// Colours the discs by `values` (viridis, automatic range); `quantity` names them on
    /// the colour bar, with the unit.
    pub fn by_value(mut self, values: &[f64], quantity: impl Into<String>) -> Self {
        self.coloring = Coloring::Value {
            values: values.to_vec(),
            quantity: quantity.into(),
            colormap: Colormap::Viridis,
            range: None,
        };
        self
    }
    /// Fixes the value range of [`by_value`](Self::by_value) (same colours in every frame).
    pub fn range(mut self, min: f64, max: f64) -> Self {
        if let Coloring::Value { range, .. } = &mut self.coloring {
            *range = Some((min, max));
        }
        self
    }
    /// Sets the colour map of [`by_value`](Self::by_value).
    pub fn colormap(mut self, map: Colormap) -> Self {
        if let Coloring::Value { colormap, .. } = &mut self.coloring {
            *colormap = map;
        }
        self
    }
    /// Colours the discs by species `ids` (indices into `names`), with a legend.
    pub fn by_species(mut self, ids: &[usize], names: &[&str]) -> Self {
        self.coloring = Coloring::Species {
            ids: ids.to_vec(),
            names: names.iter().map(|n| n.to_string()).collect(),
            colors: Vec::new(),
        };
        self
    }
    /// Sets the species colours of [`by_species`](Self::by_species) (one per name).
    pub fn species_colors(mut self, list: &[[u8; 3]]) -> Self {
        if let Coloring::Species { colors, .. } = &mut self.coloring {
            *colors = list.to_vec();
        }
        self
    }
    /// Sets the region shown.
    pub fn bounds(mut self, x0: f64, x1: f64, y0: f64, y1: f64) -> Self {
        self.bounds = Some((x0, x1, y0, y1));
        self
    }
    /// Adds a wall segment.
    pub fn line(mut self, a: (f64, f64), b: (f64, f64)) -> Self {
        self.outlines.push(Outline::Line(a, b));
        self
    }
    /// Adds a circular wall.
    pub fn circle(mut self, centre: (f64, f64), radius: f64) -> Self {
        self.outlines.push(Outline::Circle(centre, radius));
        self
    }
    /// Sets the title.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = title.into();
        self
    }
    /// Sets the subtitle (e.g. the time).
    pub fn subtitle(mut self, subtitle: impl Into<String>) -> Self {
        self.subtitle = subtitle.into();
        self
    }
    /// Sets the x-axis title (write the unit in it).
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = label.into();
        self
    }
    /// Sets the y-axis title (write the unit in it).
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = label.into();
        self
    }
    /// Sets the pixels along the longer side of the region (100 to 8192).
    pub fn size_px(mut self, px: u32) -> Self {
        self.size_px = px;
        self
    }

    /// Renders the frame to an RGB image (frames with the same options have the same size:
    /// use them for [`crate::gif`]).
    ///
    /// Errors when lengths differ, a position or radius is not finite (or a radius is
    /// negative), a species index has no name, the bounds are not finite or empty, the
    /// value range is invalid or no value is finite, or the size is outside 100 to 8192.
    pub fn render(&self) -> Result<RgbImage> {
        render_rgb("particle frame", &self.prepare()?)
    }

    /// Renders and writes atomically: PNG for a `.png` path, SVG for `.svg`.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        write_figure("particle frame", path.as_ref(), &self.prepare()?)
    }

    fn prepare(&self) -> Result<Prepared<'_>> {
        let n = self.positions.len();
        if self.radii.len() != n {
            return Err(Error::invalid(
                "radii.len()",
                self.radii.len(),
                format!("give one radius per particle ({n} positions)"),
            ));
        }
        for (i, (p, &r)) in self.positions.iter().zip(&self.radii).enumerate() {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(Error::invalid(
                    format!("position[{i}]"),
                    format!("({}, {})", p[0], p[1]),
                    "positions must be finite; check the simulation for a blow-up",
                ));
            }
            if !(r.is_finite() && r >= 0.0) {
                return Err(Error::invalid(
                    format!("radius[{i}]"),
                    r,
                    "radii must be finite and >= 0",
                ));
            }
        }
        if !(100..=8192).contains(&self.size_px) {
            return Err(Error::invalid(
                "size_px",
                self.size_px,
                "use 100 to 8192 pixels along the longer side",
            ));
        }
        let range = match &self.coloring {
            Coloring::Uniform(_) => None,
            Coloring::Value { values, range, .. } => {
                if values.len() != n {
                    return Err(Error::invalid(
                        "values.len()",
                        values.len(),
                        format!("give one value per particle ({n} positions)"),
                    ));
                }
                let a = Axis::build("value", Scale::Linear, *range, finite(values), 5, true)?;
                Some((a.lo, a.hi))
            }
            Coloring::Species { ids, names, colors } => {
                if ids.len() != n {
                    return Err(Error::invalid(
                        "species ids.len()",
                        ids.len(),
                        format!("give one species index per particle ({n} positions)"),
                    ));
                }
                if let Some((i, &id)) = ids.iter().enumerate().find(|(_, id)| **id >= names.len()) {
                    return Err(Error::invalid(
                        format!("species id[{i}]"),
                        id,
                        format!("only {} species names were given", names.len()),
                    ));
                }
                if !colors.is_empty() && colors.len() < names.len() {
                    return Err(Error::invalid(
                        "species colours",
                        colors.len(),
                        format!("give one colour per species ({})", names.len()),
                    ));
                }
                None
            }
        };
        let (x0, x1, y0, y1) = match self.bounds {
            Some(b) => b,
            None if n == 0 => (0.0, 1.0, 0.0, 1.0),
            None => {
                let mut b = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                for (p, r) in self.positions.iter().zip(&self.radii) {
                    b = (
                        b.0.min(p[0] - r),
                        b.1.max(p[0] + r),
                        b.2.min(p[1] - r),
                        b.3.max(p[1] + r),
                    );
                }
                b
            }
        };
        let x = spatial_axis("bounds x", (x0, x1))?;
        let y = spatial_axis("bounds y", (y0, y1))?;
        let (w, h) = (x1 - x0, y1 - y0);
        let s = f64::from(self.size_px);
        let (pw, ph) = if w >= h {
            (s, (s * h / w).max(40.0))
        } else {
            ((s * w / h).max(40.0), s)
        };
        Ok(Prepared {
            frame: self,
            x,
            y,
            range,
            plot_px: (pw.round() as u32, ph.round() as u32),
            px_per_unit: pw.round() / w,
        })
    }
}

fn finite(values: &[f64]) -> impl Iterator<Item = f64> + '_ {
    values.iter().copied().filter(|v| v.is_finite())
}

struct Prepared<'a> {
    frame: &'a ParticleFrame,
    x: Axis,
    y: Axis,
    range: Option<(f64, f64)>,
    plot_px: (u32, u32),
    px_per_unit: f64,
}

impl Prepared<'_> {
    fn right(&self) -> u32 {
        match self.frame.coloring {
            Coloring::Uniform(_) => RIGHT,
            Coloring::Value { .. } => COLORBAR_W,
            Coloring::Species { .. } => LEGEND_W,
        }
    }
}

impl Figure for Prepared<'_> {
    fn size(&self) -> (u32, u32) {
        let f = self.frame;
        (
            LEFT + self.plot_px.0 + RIGHT + self.right(),
            header_height(&f.title, &f.subtitle) + GAP + self.plot_px.1 + BOTTOM,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let f = self.frame;
        root.fill(&WHITE).map_err(draw_err)?;
        let body = draw_header(root, &f.title, &f.subtitle)?;
        let (main, side) = body.split_horizontally(LEFT + self.plot_px.0 + RIGHT);
        let mut chart = ChartBuilder::on(&main)
            .margin_top(GAP)
            .margin_right(RIGHT)
            .x_label_area_size(BOTTOM)
            .y_label_area_size(LEFT)
            .build_cartesian_2d(self.x.clone(), self.y.clone())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(f.x_label.as_str())
            .label_style(font(TICK_PX))
            .axis_desc_style(font(LABEL_PX))
            .x_labels(7)
            .y_labels(7)
            .draw()
            .map_err(draw_err)?;
        let (_, rows) = chart.plotting_area().get_pixel_range();
        draw_y_title(root, f.y_label.as_str(), (30, (rows.start + rows.end) / 2))?;
        let area = chart.plotting_area();
        for o in &f.outlines {
            match *o {
                Outline::Line(a, b) => {
                    area.draw(&PathElement::new([a, b], OUTLINE.stroke_width(3)))
                }
                Outline::Circle(c, r) => area.draw(&Circle::new(
                    c,
                    r * self.px_per_unit,
                    OUTLINE.stroke_width(2),
                )),
            }
            .map_err(draw_err)?;
        }
        let color_of = |i: usize| -> [u8; 3] {
            match &f.coloring {
                Coloring::Uniform(c) => *c,
                Coloring::Value {
                    values, colormap, ..
                } => {
                    let (lo, hi) = self.range.unwrap_or((0.0, 1.0));
                    colormap.map_range(values[i], lo, hi)
                }
                Coloring::Species { ids, colors, .. } => species_color(colors, ids[i]),
            }
        };
        for (i, (p, r)) in f.positions.iter().zip(&f.radii).enumerate() {
            let rp = (r * self.px_per_unit).max(1.0);
            area.draw(&Circle::new((p[0], p[1]), rp, rgb(color_of(i)).filled()))
                .map_err(draw_err)?;
        }
        // The frame around the region.
        area.draw(&Rectangle::new(
            [(self.x.lo, self.y.lo), (self.x.hi, self.y.hi)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;
        match &f.coloring {
            Coloring::Uniform(_) => {}
            Coloring::Value {
                quantity, colormap, ..
            } => {
                let range = self.range.unwrap_or((0.0, 1.0));
                draw_colorbar(&side, *colormap, range, quantity, GAP, BOTTOM)?;
            }
            Coloring::Species { names, colors, .. } => {
                let x = 6;
                for (k, name) in names.iter().enumerate() {
                    let y = GAP as i32 + 8 + k as i32 * 28;
                    side.draw(&Circle::new(
                        (x + 8, y + 9),
                        8,
                        rgb(species_color(colors, k)).filled(),
                    ))
                    .map_err(draw_err)?;
                    side.draw_text(name, &font(LABEL_PX), (x + 24, y))
                        .map_err(draw_err)?;
                }
            }
        }
        Ok(())
    }
}

fn species_color(colors: &[[u8; 3]], k: usize) -> [u8; 3] {
    colors.get(k).copied().unwrap_or(PALETTE[k % PALETTE.len()])
}
