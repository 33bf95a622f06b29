//! Line and scatter plots to PNG: several named series, linear or log10 axes, numeric ticks,
//! axis titles, legend and title. Enough for convergence plots and radius-vs-time curves.
//!
//! ```
//! use simkit_output::plot::{Plot, Scale, Series};
//! # fn main() -> simkit_backend::Result<()> {
//! let h = [0.1, 0.05, 0.025, 0.0125];
//! let err: Vec<f64> = h.iter().map(|h| 0.3 * h * h).collect();
//! let path = std::env::temp_dir().join("simkit-doc-plot").join("convergence.png");
//! Plot::new("convergence")
//!     .x_label("h")
//!     .y_label("L2 error")
//!     .x_scale(Scale::Log10)
//!     .y_scale(Scale::Log10)
//!     .series(Series::line("measured", &h, &err))
//!     .series(Series::points("h^2", &h, &h.map(|h| h * h)))
//!     .write(&path)?;
//! # Ok(())
//! # }
//! ```

use std::path::Path;

use image::{Rgb, RgbImage};

use crate::heatmap::{MAX_PIXELS, MAX_SIDE};
use crate::{font, numfmt, png, raster};
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

const BLACK: [u8; 3] = [0, 0, 0];
const GRID: [u8; 3] = [225, 225, 225];
const WHITE: [u8; 3] = [255, 255, 255];

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Linear axis (default).
    #[default]
    Linear,
    /// Base-10 logarithmic axis; every value on it must be > 0.
    Log10,
}

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

    /// Renders the plot.
    ///
    /// Errors when there is no series, a series is empty or has `x.len() != y.len()`, a value
    /// is non-finite or not positive on a log axis, a fixed range is invalid, or the image is
    /// too small for the axes or larger than [`MAX_SIDE`] pixels per side or [`MAX_PIXELS`]
    /// in all.
    pub fn render(&self) -> Result<RgbImage> {
        self.validate()?;
        let xs = self.series.iter().flat_map(|s| s.x.iter().copied());
        let ys = self.series.iter().flat_map(|s| s.y.iter().copied());
        let xa = Axis::build("x", self.x_scale, self.x_range, xs, 7)?;
        let ya = Axis::build("y", self.y_scale, self.y_range, ys, 6)?;

        let (w, h) = (self.width, self.height);
        let ts: u32 = if w.min(h) >= 400 { 2 } else { 1 };
        let title_ts = if w >= 600 { ts + 1 } else { ts };
        let th = font::text_height(ts) as i64;
        let m = 6 * ts as i64;
        let tick_len = 3 * ts as i64;
        let ytick_w = ya
            .ticks
            .iter()
            .map(|t| font::text_width(&t.1, ts))
            .max()
            .unwrap_or(0) as i64;
        let xtick_last = xa
            .ticks
            .last()
            .map(|t| font::text_width(&t.1, ts))
            .unwrap_or(0) as i64;
        let left = m
            + if self.y_label.is_empty() { 0 } else { th + m }
            + ytick_w
            + 3 * ts as i64
            + tick_len;
        let bottom =
            tick_len + 3 * ts as i64 + th + if self.x_label.is_empty() { 0 } else { m + th } + m;
        let top =
            m + if self.title.is_empty() {
                0
            } else {
                font::text_height(title_ts) as i64 + m
            } + th / 2;
        let right = m + xtick_last / 2;
        let (pw, ph) = (w as i64 - left - right, h as i64 - top - bottom);
        if pw < 40 || ph < 30 {
            return Err(Error::invalid(
                "plot size",
                format!("{w} x {h}"),
                "too small for the axes and labels; make the image larger",
            ));
        }

        let mut img = RgbImage::from_pixel(w, h, Rgb(WHITE));
        let px = |t: f64| left as f64 + xa.frac(t) * (pw - 1) as f64;
        let py = |t: f64| top as f64 + (1.0 - ya.frac(t)) * (ph - 1) as f64;

        // Grid, ticks and tick labels.
        let xkeep = thin(&xa, pw, |l| font::text_width(l, ts) as i64 + 4 * ts as i64);
        for (i, (t, label)) in xa.ticks.iter().enumerate() {
            let x = px(*t).round() as i64;
            raster::fill_rect(&mut img, x, top, 1, ph, GRID);
            raster::fill_rect(&mut img, x, top + ph, 1, tick_len, BLACK);
            if i % xkeep == 0 {
                let lw = font::text_width(label, ts) as i64;
                let ly = top + ph + tick_len + 3 * ts as i64;
                font::draw_text(&mut img, x - lw / 2, ly, label, ts, BLACK);
            }
        }
        let ykeep = thin(&ya, ph, |_| th + 3 * ts as i64);
        for (i, (t, label)) in ya.ticks.iter().enumerate() {
            let y = py(*t).round() as i64;
            raster::fill_rect(&mut img, left, y, pw, 1, GRID);
            raster::fill_rect(&mut img, left - tick_len, y, tick_len, 1, BLACK);
            if i % ykeep == 0 {
                let lw = font::text_width(label, ts) as i64;
                let lx = left - tick_len - 3 * ts as i64 - lw;
                font::draw_text(&mut img, lx, y - th / 2, label, ts, BLACK);
            }
        }
        raster::stroke_rect(&mut img, left - 1, top - 1, pw + 2, ph + 2, BLACK);

        // Data.
        let clip = [left, top, left + pw - 1, top + ph - 1];
        let pen = ts;
        let radius = 1.5 * ts as f64 + 0.5;
        let mut drawn: Vec<(f64, f64)> = Vec::new(); // samples of what was drawn, for the legend
        for (si, s) in self.series.iter().enumerate() {
            let color = s.color.unwrap_or(PALETTE[si % PALETTE.len()]);
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(&x, &y)| (px(xa.tf(x)), py(ya.tf(y))))
                    .collect();
            drawn.extend_from_slice(&pts);
            if matches!(s.style, Style::Line | Style::LinePoints) {
                for seg in pts.windows(2) {
                    let ((x0, y0), (x1, y1)) = (seg[0], seg[1]);
                    raster::line_clipped(&mut img, x0, y0, x1, y1, pen, color, clip);
                    for k in 1..8 {
                        let f = k as f64 / 8.0;
                        drawn.push((x0 + f * (x1 - x0), y0 + f * (y1 - y0)));
                    }
                }
                if pts.len() == 1 {
                    let (x, y) = pts[0];
                    raster::line_clipped(&mut img, x, y, x, y, pen, color, clip);
                }
            }
            if matches!(s.style, Style::Points | Style::LinePoints) {
                for &(x, y) in &pts {
                    if x >= clip[0] as f64 - 0.5
                        && x <= clip[2] as f64 + 0.5
                        && y >= clip[1] as f64 - 0.5
                        && y <= clip[3] as f64 + 0.5
                    {
                        raster::fill_disc(&mut img, x, y, radius, color);
                    }
                }
            }
        }

        // Legend.
        let named: Vec<(usize, &Series)> = self
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.name.is_empty())
            .collect();
        if self.legend && !named.is_empty() {
            let swatch = 16 * ts as i64;
            let pad = 4 * ts as i64;
            let row_h = th + 3 * ts as i64;
            let name_w = named
                .iter()
                .map(|(_, s)| font::text_width(&s.name, ts))
                .max()
                .unwrap_or(0) as i64;
            let lw = pad + swatch + pad + name_w + pad;
            let lh = pad + row_h * named.len() as i64 - 3 * ts as i64 + pad;
            // The corner covering the least data, preferring top right.
            let (x_r, x_l) = (left + pw - lw - pad, left + pad);
            let (y_t, y_b) = (top + pad, top + ph - lh - pad);
            let covered = |&(cx, cy): &(i64, i64)| {
                let (x0, y0) = (cx as f64 - radius, cy as f64 - radius);
                let (x1, y1) = ((cx + lw) as f64 + radius, (cy + lh) as f64 + radius);
                drawn
                    .iter()
                    .filter(|(x, y)| *x >= x0 && *x <= x1 && *y >= y0 && *y <= y1)
                    .count()
            };
            let corners = [(x_r, y_t), (x_l, y_t), (x_r, y_b), (x_l, y_b)];
            let (lx, ly) = corners
                .into_iter()
                .min_by_key(covered)
                .unwrap_or((x_r, y_t));
            raster::fill_rect(&mut img, lx, ly, lw, lh, WHITE);
            raster::stroke_rect(&mut img, lx, ly, lw, lh, [160, 160, 160]);
            for (row, (si, s)) in named.iter().enumerate() {
                let color = s.color.unwrap_or(PALETTE[si % PALETTE.len()]);
                let y = ly + pad + row as i64 * row_h;
                let cy = (y + th / 2) as f64;
                let (x0, x1) = ((lx + pad) as f64, (lx + pad + swatch) as f64);
                if matches!(s.style, Style::Line | Style::LinePoints) {
                    raster::line(&mut img, x0, cy, x1, cy, pen, color);
                }
                if matches!(s.style, Style::Points | Style::LinePoints) {
                    raster::fill_disc(&mut img, (x0 + x1) / 2.0, cy, radius, color);
                }
                font::draw_text(&mut img, lx + 2 * pad + swatch, y, &s.name, ts, BLACK);
            }
        }

        // Titles.
        if !self.title.is_empty() {
            let tw = font::text_width(&self.title, title_ts) as i64;
            font::draw_text(
                &mut img,
                (w as i64 - tw) / 2,
                m,
                &self.title,
                title_ts,
                BLACK,
            );
        }
        if !self.x_label.is_empty() {
            let tw = font::text_width(&self.x_label, ts) as i64;
            let y = h as i64 - m - th;
            font::draw_text(&mut img, left + (pw - tw) / 2, y, &self.x_label, ts, BLACK);
        }
        if !self.y_label.is_empty() {
            let tw = font::text_width(&self.y_label, ts) as i64;
            let y = top + (ph + tw) / 2;
            font::draw_text_up(&mut img, m, y, &self.y_label, ts, BLACK);
        }
        Ok(img)
    }

    /// Renders and writes the PNG atomically.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let img = self.render()?;
        png::write_png(path, &img)
    }
}

/// Keep every k-th tick label so that labels do not overlap.
fn thin(axis: &Axis, len_px: i64, size: impl Fn(&str) -> i64) -> usize {
    let n = axis.ticks.len();
    if n < 2 {
        return 1;
    }
    let need = axis.ticks.iter().map(|t| size(&t.1)).max().unwrap_or(1);
    let span = (axis.frac(axis.ticks[n - 1].0) - axis.frac(axis.ticks[0].0)).abs();
    let gap = span * len_px as f64 / (n - 1) as f64;
    if gap <= 0.0 {
        return 1;
    }
    ((need as f64 / gap).ceil() as usize).max(1)
}

/// An axis in transformed coordinates (log10 of the values on a log axis).
struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
    ticks: Vec<(f64, String)>,
}

impl Axis {
    fn tf(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v,
            Scale::Log10 => v.log10(),
        }
    }

    fn frac(&self, t: f64) -> f64 {
        let span = self.hi - self.lo;
        if span.is_finite() {
            (t - self.lo) / span
        } else {
            // The span passes f64::MAX (data near ±1e308): halving is exact and keeps it finite.
            (t / 2.0 - self.lo / 2.0) / (self.hi / 2.0 - self.lo / 2.0)
        }
    }

    fn build(
        name: &str,
        scale: Scale,
        fixed: Option<(f64, f64)>,
        values: impl Iterator<Item = f64>,
        target: usize,
    ) -> Result<Axis> {
        let (mut min, mut max) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if let Some((a, b)) = fixed {
            if !(a.is_finite() && b.is_finite() && a < b) {
                return Err(Error::invalid(
                    format!("{name} range"),
                    format!("({a}, {b})"),
                    "must be finite with min < max",
                ));
            }
            if scale == Scale::Log10 && a <= 0.0 {
                return Err(Error::invalid(
                    format!("{name} range"),
                    format!("({a}, {b})"),
                    format!("a log10 {name} axis needs min > 0"),
                ));
            }
            (min, max) = (a, b);
        }
        match scale {
            Scale::Linear => {
                if min == max {
                    let d = if min == 0.0 { 1.0 } else { min.abs() * 0.1 };
                    // Clamped: padding a value near ±f64::MAX must not reach infinity.
                    (min, max) = ((min - d).max(f64::MIN), (max + d).min(f64::MAX));
                }
                let span = max - min;
                let raw = if span.is_finite() {
                    span / target as f64
                } else {
                    // The span passes f64::MAX (e.g. data from -1e308 to 1e308): halve first.
                    (max / 2.0 - min / 2.0) / target as f64 * 2.0
                };
                let step = nice_step(raw);
                let (lo, hi) = if fixed.is_some() {
                    (min, max)
                } else {
                    // Rounding outward to a tick can pass f64::MAX; keep the data's end then.
                    let (lo, hi) = ((min / step).floor() * step, (max / step).ceil() * step);
                    (
                        if lo.is_finite() { lo } else { min },
                        if hi.is_finite() { hi } else { max },
                    )
                };
                let ticks = linear_ticks(lo, hi, step)
                    .into_iter()
                    .map(|v| (v, numfmt::tick(v, step)))
                    .collect();
                Ok(Axis {
                    scale,
                    lo,
                    hi,
                    ticks,
                })
            }
            Scale::Log10 => {
                let (mut lo, mut hi) = (min.log10(), max.log10());
                if lo == hi {
                    (lo, hi) = (lo - 0.5, hi + 0.5);
                } else if fixed.is_none() {
                    if hi - lo >= 2.0 {
                        (lo, hi) = ((lo + 1e-9).floor(), (hi - 1e-9).ceil());
                    } else {
                        let pad = 0.05 * (hi - lo);
                        (lo, hi) = (lo - pad, hi + pad);
                    }
                }
                let ticks = log_ticks(lo, hi, target);
                Ok(Axis {
                    scale,
                    lo,
                    hi,
                    ticks,
                })
            }
        }
    }
}

/// 1, 2 or 5 times a power of ten, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let e = raw.log10().floor();
    let p = 10f64.powf(e);
    let f = raw / p;
    let nf = if f <= 1.0 {
        1.0
    } else if f <= 2.0 {
        2.0
    } else if f <= 5.0 {
        5.0
    } else {
        10.0
    };
    nf * p
}

/// Multiples of `step` in `[lo, hi]`; just `[lo, hi]` when there would be none or more than
/// 1001, or when the tick indices are not exact integers (checked in f64 before any integer
/// conversion, so ranges near ±f64::MAX or infinite bounds cannot overflow).
fn linear_ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    const EXACT: f64 = (1u64 << 53) as f64;
    let eps = step * 1e-9;
    let k0 = ((lo - eps) / step).ceil();
    let k1 = ((hi + eps) / step).floor();
    if !(k0.abs() <= EXACT && k1.abs() <= EXACT) || k1 < k0 || k1 - k0 > 1000.0 {
        return vec![lo, hi];
    }
    (k0 as i64..=k1 as i64)
        .map(|k| {
            let v = k as f64 * step;
            if v.abs() < eps { 0.0 } else { v }
        })
        .collect()
}

/// Ticks for a log axis spanning `[lo, hi]` decades (log10 space): labels are the values.
fn log_ticks(lo: f64, hi: f64, target: usize) -> Vec<(f64, String)> {
    let eps = 1e-9;
    // Whole decades, thinned to about `target`.
    let d0 = (lo - eps).ceil() as i64;
    let d1 = (hi + eps).floor() as i64;
    if d1 - d0 + 1 >= 3 {
        let stride = ((d1 - d0 + 1) as usize).div_ceil(target.max(1) + 2).max(1) as i64;
        return (d0..=d1)
            .filter(|d| (d - d0) % stride == 0)
            .map(|d| (d as f64, numfmt::short(10f64.powi(d as i32))))
            .collect();
    }
    // 1-2-5, then every digit.
    for mantissas in [
        &[1.0, 2.0, 5.0][..],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ] {
        let mut ticks = Vec::new();
        for d in (lo.floor() as i64)..=(hi.ceil() as i64) {
            for m in mantissas {
                let v = m * 10f64.powi(d as i32);
                let t = v.log10();
                if t >= lo - eps && t <= hi + eps {
                    ticks.push((t, numfmt::short(v)));
                }
            }
        }
        if ticks.len() >= 3 {
            return ticks;
        }
    }
    // Narrow range: linear ticks in value space.
    let (a, b) = (10f64.powf(lo), 10f64.powf(hi));
    let step = nice_step((b - a) / target as f64);
    linear_ticks(a, b, step)
        .into_iter()
        .filter(|v| *v > 0.0 && v.log10() >= lo - eps && v.log10() <= hi + eps)
        .map(|v| (v.log10(), numfmt::tick(v, step)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_ticks() {
        assert_eq!(nice_step(0.13), 0.2);
        assert_eq!(nice_step(3.0), 5.0);
        assert_eq!(nice_step(7.0), 10.0);
        assert_eq!(linear_ticks(0.0, 1.0, 0.2).len(), 6);
        let t = log_ticks(-4.0, 0.0, 6);
        assert_eq!(t.len(), 5);
        assert_eq!(t[0].1, "1e-4");
        assert_eq!(t[4].1, "1");
        let t = log_ticks(0.0, 0.5, 6); // 1 .. 3.16
        assert!(t.len() >= 3, "{t:?}");
        let t = log_ticks(0.0, 0.01, 6); // 1 .. 1.023
        assert!(t.len() >= 2, "{t:?}");
    }

    #[test]
    fn ranges_near_f64_max_give_finite_ticks() {
        // A span of 2e308 is past f64::MAX: it used to give i64-saturated tick indices whose
        // difference overflowed ("capacity overflow").
        let ys = [-1e308, 1e308];
        let a = Axis::build("y", Scale::Linear, None, ys.into_iter(), 6).unwrap();
        assert_eq!((a.lo, a.hi), (-1e308, 1e308));
        let ticks: Vec<f64> = a.ticks.iter().map(|t| t.0).collect();
        assert_eq!(ticks, [-1e308, -5e307, 0.0, 5e307, 1e308]);
        assert_eq!(a.frac(0.0), 0.5);
        assert_eq!(a.frac(1e308), 1.0);
        for (values, fixed) in [
            ([f64::MIN, f64::MAX], None),
            ([1.7e308, 1.7e308], None),
            ([0.0, 1.0], Some((f64::MIN, f64::MAX))),
        ] {
            let a = Axis::build("y", Scale::Linear, fixed, values.into_iter(), 6).unwrap();
            assert!(a.lo.is_finite() && a.hi.is_finite() && a.lo < a.hi);
            assert!(a.ticks.len() >= 2, "{:?}", a.ticks);
            for (t, label) in &a.ticks {
                assert!(t.is_finite() && (a.lo..=a.hi).contains(t), "{t} {label}");
                assert!((0.0..=1.0).contains(&a.frac(*t)), "{t}");
            }
        }
        assert_eq!(linear_ticks(0.0, f64::INFINITY, 1.0), [0.0, f64::INFINITY]);
        assert_eq!(linear_ticks(-1e300, 1e300, 1.0), [-1e300, 1e300]);
    }
}
