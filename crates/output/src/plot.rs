//! Line and scatter plots, PNG or SVG (from the file extension): several named series,
//! linear or log10 axes, numeric ticks, axis titles (write the unit in them: `"t (ps)"`),
//! legend and a title that shrinks to fit. Enough for convergence plots and
//! radius-vs-time curves.
//!
//! ```
//! use simkit_output::plot::{Plot, Scale, Series};
//! # fn main() -> simkit_backend::Result<()> {
//! let h = [0.1, 0.05, 0.025, 0.0125];
//! let err: Vec<f64> = h.iter().map(|h| 0.3 * h * h).collect();
//! let path = std::env::temp_dir().join("simkit-doc-plot").join("convergence.png");
//! Plot::new("convergence")
//!     .x_label("h (grid spacing)")
//!     .y_label("L2 error")
//!     .x_scale(Scale::Log10)
//!     .y_scale(Scale::Log10)
//!     .series(Series::line("measured", &h, &err))
//!     .series(Series::points("h²", &h, &h.map(|h| h * h)))
//!     .write(&path)?;
//! # Ok(())
//! # }
//! ```

use std::path::Path;

use image::RgbImage;
use plotters::coord::Shift;
use plotters::prelude::*;

pub use crate::figure::Scale;
use crate::figure::{
    Axis, Figure, LABEL_PX, MAX_PIXELS, MAX_SIDE, TICK_PX, draw_err, draw_header, draw_y_title,
    font, render_rgb, rgb, write_figure,
};
use simkit_backend::{Error, Result};

/// Default series colours, in order.
pub const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [23, 190, 207],
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Style {
    /// Connected line (default).
    #[default]
    Line,
    /// Markers only (scatter).
    Points,
    /// Line with markers.
    LinePoints,
}

/// One named data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend name (empty: not listed in the legend).
    pub name: String,
    /// x values.
    pub x: Vec<f64>,
    /// y values, one per x.
    pub y: Vec<f64>,
    /// Colour; `None` takes the next [`PALETTE`] colour.
    pub color: Option<[u8; 3]>,
    /// Line, points or both.
    pub style: Style,
}

impl Series {
    /// A line series. Lengths and values are checked when the plot is rendered.
    pub fn line<X: Copy + Into<f64>, Y: Copy + Into<f64>>(
        name: impl Into<String>,
        x: &[X],
        y: &[Y],
    ) -> Self {
        Self {
            name: name.into(),
            x: x.iter().map(|&v| v.into()).collect(),
            y: y.iter().map(|&v| v.into()).collect(),
            color: None,
            style: Style::Line,
        }
    }

    /// A scatter series (markers only).
    pub fn points<X: Copy + Into<f64>, Y: Copy + Into<f64>>(
        name: impl Into<String>,
        x: &[X],
        y: &[Y],
    ) -> Self {
        Self::line(name, x, y).style(Style::Points)
    }

    /// Sets the drawing style.
    pub fn style(mut self, style: Style) -> Self {
        self.style = style;
        self
    }

    /// Sets the colour.
    pub fn color(mut self, color: [u8; 3]) -> Self {
        self.color = Some(color);
        self
    }
}

/// A plot; build with [`Plot::new`] and the chained setters, then [`render`](Self::render)
/// or [`write`](Self::write).
#[derive(Debug, Clone, PartialEq)]
pub struct Plot {
    /// Title above the plot (empty: none).
    pub title: String,
    /// x-axis title (empty: none).
    pub x_label: String,
    /// y-axis title (empty: none).
    pub y_label: String,
    /// x-axis scale.
    pub x_scale: Scale,
    /// y-axis scale.
    pub y_scale: Scale,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data.
    pub y_range: Option<(f64, f64)>,
    /// Image width in pixels (default 800).
    pub width: u32,
    /// Image height in pixels (default 500).
    pub height: u32,
    /// Draw a legend of the named series (default true).
    pub legend: bool,
    /// The data.
    pub series: Vec<Series>,
}

impl Plot {
    /// An empty 800 x 500 plot with linear axes.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: String::new(),
            y_label: String::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            x_range: None,
            y_range: None,
            width: 800,
            height: 500,
            legend: true,
            series: Vec::new(),
        }
    }
    /// Sets the image size in pixels.
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }
    /// Sets the x-axis title.
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = label.into();
        self
    }
    /// Sets the y-axis title.
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = label.into();
        self
    }
    /// Sets the x-axis scale.
    pub fn x_scale(mut self, scale: Scale) -> Self {
        self.x_scale = scale;
        self
    }
    /// Sets the y-axis scale.
    pub fn y_scale(mut self, scale: Scale) -> Self {
        self.y_scale = scale;
        self
    }
    /// Fixes the x range.
    pub fn x_range(mut self, min: f64, max: f64) -> Self {
        self.x_range = Some((min, max));
        self
    }
    /// Fixes the y range.
    pub fn y_range(mut self, min: f64, max: f64) -> Self {
        self.y_range = Some((min, max));
        self
    }
    /// Turns the legend on or off.
    pub fn legend(mut self, yes: bool) -> Self {
        self.legend = yes;
        self
    }
    /// Adds a series (builder style).
    pub fn series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }
    /// Adds a series (in place).
    pub fn push(&mut self, series: Series) {
        self.series.push(series);
    }

    fn validate(&self) -> Result<()> {
        if self.series.is_empty() {
            return Err(Error::invalid(
                "plot series",
                "none",
                "add at least one series with Plot::series",
            ));
        }
        for (si, s) in self.series.iter().enumerate() {
            let label = format!("series {si} '{}'", s.name);
            if s.x.is_empty() {
                return Err(Error::invalid(
                    label,
                    "0 points",
                    "a series needs at least one (x, y) point; drop empty series",
                ));
            }
            if s.x.len() != s.y.len() {
                return Err(Error::invalid(
                    label,
                    format!("{} x values, {} y values", s.x.len(), s.y.len()),
                    "x and y must have the same length",
                ));
            }
            for (axis, vals, scale) in [("x", &s.x, self.x_scale), ("y", &s.y, self.y_scale)] {
                for (k, &v) in vals.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(Error::invalid(
                            format!("{label} {axis}[{k}]"),
                            v,
                            "plot values must be finite; remove or fix NaN/inf points",
                        ));
                    }
                    if scale == Scale::Log10 && v <= 0.0 {
                        return Err(Error::invalid(
                            format!("{label} {axis}[{k}]"),
                            v,
                            format!(
                                "a log10 {axis} axis needs values > 0; use a linear {axis} \
                                 axis, plot the absolute value, or drop the point"
                            ),
                        ));
                    }
                }
            }
        }
        if self.width < 100 || self.height < 80 {
            return Err(Error::invalid(
                "plot size",
                format!("{} x {}", self.width, self.height),
                "use at least 100 x 80 pixels (800 x 500 is typical)",
            ));
        }
        let (w, h) = (self.width as usize, self.height as usize);
        if w > MAX_SIDE || h > MAX_SIDE || w * h > MAX_PIXELS {
            return Err(Error::invalid(
                "plot size",
                format!("{w} x {h}"),
                format!("at most {MAX_SIDE} pixels per side and {MAX_PIXELS} pixels in all"),
            ));
        }
        Ok(())
    }

    /// Renders the plot to an RGB image.
    ///
    /// Errors when there is no series, a series is empty or has `x.len() != y.len()`, a value
    /// is non-finite or not positive on a log axis, a fixed range is invalid, or the image is
    /// smaller than 100 x 80 or larger than [`MAX_SIDE`] pixels per side or [`MAX_PIXELS`]
    /// in all.
    pub fn render(&self) -> Result<RgbImage> {
        render_rgb("plot", &self.prepare()?)
    }

    /// Renders and writes the plot atomically: PNG for a `.png` path, SVG for `.svg`.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        write_figure("plot", path.as_ref(), &self.prepare()?)
    }

    fn prepare(&self) -> Result<Prepared<'_>> {
        self.validate()?;
        let xs = self.series.iter().flat_map(|s| s.x.iter().copied());
        let ys = self.series.iter().flat_map(|s| s.y.iter().copied());
        let x = Axis::build("x", self.x_scale, self.x_range, xs, 7, false)?;
        let y = Axis::build("y", self.y_scale, self.y_range, ys, 6, false)?;
        Ok(Prepared { plot: self, x, y })
    }
}

/// A validated plot with its axes.
struct Prepared<'a> {
    plot: &'a Plot,
    x: Axis,
    y: Axis,
}

impl Figure for Prepared<'_> {
    fn size(&self) -> (u32, u32) {
        (self.plot.width, self.plot.height)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let p = self.plot;
        root.fill(&WHITE).map_err(draw_err)?;
        let body = draw_header(root, &p.title, "")?;
        let mut chart = ChartBuilder::on(&body)
            .margin(10)
            .margin_right(24)
            .x_label_area_size(if p.x_label.is_empty() { 28 } else { 50 })
            .y_label_area_size(if p.y_label.is_empty() { 64 } else { 86 })
            .build_cartesian_2d(self.x.clone(), self.y.clone())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(p.x_label.as_str())
            .label_style(font(TICK_PX))
            .axis_desc_style(font(LABEL_PX))
            .bold_line_style(RGBColor(225, 225, 225))
            .light_line_style(TRANSPARENT)
            .x_labels(8)
            .y_labels(7)
            .draw()
            .map_err(draw_err)?;
        let (_, rows) = chart.plotting_area().get_pixel_range();
        draw_y_title(root, p.y_label.as_str(), (18, (rows.start + rows.end) / 2))?;
        let mut any_named = false;
        for (si, s) in p.series.iter().enumerate() {
            let color = rgb(s.color.unwrap_or(PALETTE[si % PALETTE.len()]));
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(&x, &y)| (self.x.tf(x), self.y.tf(y)))
                    .collect();
            let line = matches!(s.style, Style::Line | Style::LinePoints);
            let marks = matches!(s.style, Style::Points | Style::LinePoints);
            if line {
                let anno = chart
                    .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                    .map_err(draw_err)?;
                if !s.name.is_empty() {
                    anno.label(s.name.as_str()).legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                    });
                }
            }
            if marks {
                let anno = chart
                    .draw_series(
                        pts.iter()
                            .map(|&(x, y)| Circle::new((x, y), 4, color.filled())),
                    )
                    .map_err(draw_err)?;
                if !s.name.is_empty() && !line {
                    anno.label(s.name.as_str())
                        .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
                }
            }
            any_named |= !s.name.is_empty();
        }
        if p.legend && any_named {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .label_font(font(TICK_PX))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .draw()
                .map_err(draw_err)?;
        }
        Ok(())
    }
}
